"""Tests of bf.plotting: geometry checked against the defining equation, and bad input."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

import bayesfilt as bf  # noqa: E402


@pytest.fixture
def ax():
    fig, ax = plt.subplots()
    yield ax
    plt.close(fig)


@pytest.mark.parametrize("cov", [np.array([[4.0, 1.5], [1.5, 1.0]]),
                                 np.array([[1.0, -0.9], [-0.9, 1.0]]),
                                 np.diag([0.25, 9.0])])
def test_covariance_ellipse_points_have_mahalanobis_radius_n_std(ax, cov):
    mean = np.array([1.0, -2.0])
    ellipse = bf.plotting.covariance_ellipse(ax, mean, cov, n_std=2.0)
    # The patch is the unit circle mapped by its patch transform: map points of the circle.
    theta = np.linspace(0.0, 2.0 * np.pi, 37)
    outline = ellipse.get_patch_transform().transform(np.c_[np.cos(theta), np.sin(theta)])
    d = outline - mean
    maha = np.einsum("ij,jk,ik->i", d, np.linalg.inv(cov), d)
    np.testing.assert_allclose(np.sqrt(maha), 2.0, rtol=1e-6)


def test_consistency_band_is_the_chi2_interval_of_the_average(ax):
    from scipy.stats import chi2
    values = np.full((50, 10), 4.0)
    bf.plotting.plot_consistency(ax, np.arange(10), values, dof=4)
    (band,) = ax.patches
    low, high = chi2.ppf([0.025, 0.975], 50 * 4) / 50
    np.testing.assert_allclose([band.get_y(), band.get_y() + band.get_height()], [low, high],
                               rtol=1e-12)


def test_plot_helpers_run_on_valid_input(ax):
    t = np.arange(5.0)
    bf.plotting.plot_estimate(ax, t, t, t + 0.1, np.ones(5), label="position", unit="m")
    bf.plotting.plot_error(ax, t, 0.1 * t, np.ones(5), unit="m")
    bf.plotting.plot_track(ax, np.c_[t, t], np.c_[t, t], np.c_[t, t], np.tile(np.eye(2), (5, 1, 1)), every=2)
    bf.plotting.plot_belief_step(ax, t, np.full(5, 0.2), np.ones(5), np.full(5, 0.2), truth=2)
    bf.plotting.belief_image(ax, t, np.full((3, 5), 0.2), truth=[0, 1, 2])
    assert ax.get_xlabel()  # every helper labels its axes


@pytest.mark.parametrize("call,match", [
    (lambda ax: bf.plotting.covariance_ellipse(ax, [0, 0, 0], np.eye(2)), r"mean must have shape \(2,\)"),
    (lambda ax: bf.plotting.covariance_ellipse(ax, [0, 0], [[1, 2], [2, 1]]), "cov must be positive semi-definite"),
    (lambda ax: bf.plotting.covariance_ellipse(ax, [0, 0], np.eye(2), n_std=-1), "n_std must be finite and > 0"),
    (lambda ax: bf.plotting.plot_track(ax, np.zeros((5, 3))), r"truth_xy must have shape \(T, 2\)"),
    (lambda ax: bf.plotting.plot_track(ax, np.zeros((5, 2)), est_xy=np.zeros((4, 2))), "est_xy must have shape"),
    (lambda ax: bf.plotting.plot_error(ax, np.arange(5), np.zeros(4), np.ones(5)), r"error must have shape \(5,\)"),
    (lambda ax: bf.plotting.plot_consistency(ax, np.arange(5), np.ones((3, 4)), dof=2), "values must have shape"),
    (lambda ax: bf.plotting.belief_image(ax, np.arange(5), np.ones((3, 4))), r"beliefs must have shape \(T, 5\)"),
])
def test_bad_input_names_the_argument(ax, call, match):
    with pytest.raises(ValueError, match=match):
        call(ax)


@pytest.mark.parametrize("call,match", [
    (lambda ax: bf.plotting.plot_error(ax, np.arange(3), np.zeros(3), -np.ones(3)), "std must be non-negative"),
    (lambda ax: bf.plotting.plot_estimate(ax, np.arange(3), np.zeros(3), np.zeros(3), np.ones(3), n_std=0),
     "n_std must be finite and > 0"),
    (lambda ax: bf.plotting.plot_track(ax, np.zeros((3, 2)), meas_xy=np.zeros((3, 3))), "meas_xy must have shape"),
    (lambda ax: bf.plotting.plot_track(ax, np.zeros((3, 2)), covs_xy=np.zeros((3, 2, 2))), "covs_xy needs est_xy"),
    (lambda ax: bf.plotting.plot_belief_step(ax, [2.0, 1.0], [0.5, 0.5], [1, 1], [0.5, 0.5]), "grid must be"),
])
def test_more_bad_input(ax, call, match):
    with pytest.raises(ValueError, match=match):
        call(ax)


def test_plot_track_names_the_bad_covariance(ax):
    covs = np.tile(np.eye(2), (3, 1, 1))
    covs[2] = [[1.0, 2.0], [2.0, 1.0]]
    with pytest.raises(ValueError, match=r"covs_xy\[2\]"):
        bf.plotting.plot_track(ax, np.zeros((3, 2)), est_xy=np.zeros((3, 2)), covs_xy=covs, every=1)
