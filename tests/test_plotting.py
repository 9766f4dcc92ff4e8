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
    # A Rectangle since matplotlib 3.9, a Polygon before: read its corners either way.
    corners = band.get_patch_transform().transform(band.get_path().vertices)
    low, high = chi2.ppf([0.025, 0.975], 50 * 4) / 50
    np.testing.assert_allclose([corners[:, 1].min(), corners[:, 1].max()], [low, high], rtol=1e-12)


def _band(collection, t):
    """Lower and upper edge of a fill_between band at each time in t, from its vertices."""
    xy = collection.get_paths()[0].vertices
    low = np.array([xy[xy[:, 0] == ti, 1].min() for ti in t])
    high = np.array([xy[xy[:, 0] == ti, 1].max() for ti in t])
    return low, high


def test_plot_helpers_draw_their_data():
    """Each helper draws the numbers it is given: bands at +-n_std std, lines at the data."""
    t = np.arange(5.0)
    std = np.array([0.5, 1.0, 1.5, 2.0, 0.25])
    truth, mean, error = np.sin(t), np.sin(t) + 0.1, 0.3 * np.cos(t)
    fig, axes = plt.subplots(2, 3)
    try:
        ax = axes[0, 0]
        bf.plotting.plot_estimate(ax, t, truth, mean, std, n_std=1.5, label="position", unit="m")
        (band,) = ax.collections
        np.testing.assert_allclose(_band(band, t), (mean - 1.5 * std, mean + 1.5 * std), rtol=1e-12)
        np.testing.assert_allclose(ax.lines[0].get_xydata(), np.c_[t, truth])
        np.testing.assert_allclose(ax.lines[1].get_xydata(), np.c_[t, mean])
        assert ax.get_xlabel() and ax.get_ylabel().startswith("position")

        ax = axes[0, 1]
        bf.plotting.plot_error(ax, t, error, std, unit="m")  # default n_std = 2
        (band,) = ax.collections
        np.testing.assert_allclose(_band(band, t), (-2.0 * std, 2.0 * std), rtol=1e-12)
        np.testing.assert_allclose(ax.lines[0].get_xydata(), np.c_[t, error])
        assert ax.get_xlabel() and ax.get_ylabel()

        ax = axes[0, 2]
        truth_xy, meas_xy, est_xy = np.c_[t, t**2], np.c_[t + 0.2, t**2 - 0.3], np.c_[t, t**2 + 0.1]
        covs_xy = np.tile(np.eye(2), (5, 1, 1))
        bf.plotting.plot_track(ax, truth_xy, meas_xy, est_xy, covs_xy, every=2)
        for line, want in zip(ax.lines, (truth_xy, meas_xy, est_xy)):
            np.testing.assert_allclose(line.get_xydata(), want)
        assert len(ax.patches) == 3  # ellipses at t = 0, 2, 4
        np.testing.assert_allclose([e.center for e in ax.patches], est_xy[::2])
        assert ax.get_xlabel() and ax.get_ylabel()

        ax = axes[1, 0]
        prior, post = np.array([0.1, 0.2, 0.4, 0.2, 0.1]), np.full(5, 0.2)
        like = np.arange(1.0, 6.0)
        bf.plotting.plot_belief_step(ax, t, prior, like, post, truth=2)
        np.testing.assert_allclose([bar.get_height() for bar in ax.containers[0]], prior)
        scaled, posterior = ax.lines[0], ax.lines[1]
        np.testing.assert_allclose(posterior.get_ydata(), post)
        np.testing.assert_allclose(scaled.get_ydata(), like * post.max() / like.max())
        assert ax.get_xlabel() and ax.get_ylabel()

        ax = axes[1, 1]
        beliefs = np.random.default_rng(0).dirichlet(np.ones(5), size=3)  # (T, n) = (3, 5)
        bf.plotting.belief_image(ax, t, beliefs, truth=[0.0, 1.0, 2.0])
        (image,) = ax.images
        np.testing.assert_array_equal(np.asarray(image.get_array()), beliefs.T)
        np.testing.assert_allclose(ax.lines[0].get_xydata(), [[0, 0], [1, 1], [2, 2]])
        assert ax.get_xlabel() and ax.get_ylabel()
    finally:
        plt.close(fig)


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
    with pytest.raises(ValueError, match=r"covs_xy\[2\] must be positive semi-definite"):
        bf.plotting.plot_track(ax, np.zeros((3, 2)), est_xy=np.zeros((3, 2)), covs_xy=covs, every=1)
    assert not ax.lines and not ax.patches  # checked before anything is drawn


# --------------------------------------------------------------------------
# Planar positions are checked, never guessed (issue 8: the damped particle's
# state is [x1, x1_dot, x2, x2_dot], the vehicle's [xi_x, xi_y, xi_x_dot, xi_y_dot]).
# --------------------------------------------------------------------------

def _states(T=6, n=4, seed=1):
    rng = np.random.default_rng(seed)
    xs = rng.normal(size=(T, n))
    L = rng.normal(size=(T, n, n))
    covs = L @ np.swapaxes(L, 1, 2) + 0.1 * np.eye(n)
    return xs, xs + 0.1 * rng.normal(size=(T, n)), covs


def _ellipse_axes(cov):
    """Full width and height of the 2-sigma ellipse of a 2 x 2 covariance, larger first."""
    vals = np.linalg.eigvalsh(cov)[::-1]
    return 4.0 * np.sqrt(vals)


@pytest.mark.parametrize("make,cols", [(bf.models.damped_particle, [0, 2]),
                                       (bf.models.range_bearing, [0, 1])])
def test_plot_track_selects_positions_by_the_models_names(ax, make, cols):
    model = make()
    xs, means, covs = _states()
    meas_xy = xs[:, cols] + 0.5
    bf.plotting.plot_track(ax, xs, meas_xy, means, covs, every=2, model=model)
    # Reference: the columns written out by hand for this model's documented state order.
    np.testing.assert_array_equal(ax.lines[0].get_xydata(), xs[:, cols])
    np.testing.assert_array_equal(ax.lines[1].get_xydata(), meas_xy)
    np.testing.assert_array_equal(ax.lines[2].get_xydata(), means[:, cols])
    np.testing.assert_allclose([e.center for e in ax.patches], means[::2][:, cols])
    for e, t in zip(ax.patches, range(0, 6, 2)):
        np.testing.assert_allclose([e.width, e.height], _ellipse_axes(covs[t][np.ix_(cols, cols)]),
                                   rtol=1e-9)
    assert ax.get_xlabel() == f"position {model.position_names[0]} (m)"
    assert ax.get_ylabel() == f"position {model.position_names[1]} (m)"


def test_plot_track_full_states_equal_the_selected_columns(ax):
    """model= with full states draws exactly what the position columns draw without it."""
    model = bf.models.damped_particle()
    xs, means, covs = _states()
    fig, ax2 = plt.subplots()
    try:
        bf.plotting.plot_track(ax, xs, est_xy=means, covs_xy=covs, every=1, model=model)
        pos = [0, 2]
        bf.plotting.plot_track(ax2, xs[:, pos], est_xy=means[:, pos],
                               covs_xy=covs[:, pos][:, :, pos], every=1)
        for a, b in zip(ax.lines, ax2.lines):
            np.testing.assert_array_equal(a.get_xydata(), b.get_xydata())
        for a, b in zip(ax.patches, ax2.patches):
            np.testing.assert_allclose([a.center, (a.width, a.height), (a.angle, 0)],
                                       [b.center, (b.width, b.height), (b.angle, 0)])
    finally:
        plt.close(fig)


def test_plot_track_takes_width_2_as_positions_even_with_a_model(ax):
    model = bf.models.damped_particle()
    truth = np.c_[np.arange(4.0), np.arange(4.0) ** 2]
    bf.plotting.plot_track(ax, truth, model=model)
    np.testing.assert_array_equal(ax.lines[0].get_xydata(), truth)


def test_covariance_ellipse_selects_the_position_block(ax):
    model = bf.models.range_bearing()
    mean, cov = np.array([3.0, -1.0, 9.0, 9.0]), np.diag([4.0, 1.0, 100.0, 100.0])
    e = bf.plotting.covariance_ellipse(ax, mean, cov, model=model)
    np.testing.assert_allclose(e.center, [3.0, -1.0])
    np.testing.assert_allclose([e.width, e.height], [8.0, 4.0])


def _unnamed_model():
    return bf.models.LinearGaussian(A=np.eye(4), C=np.eye(2, 4), Q=np.eye(4), R=np.eye(2),
                                    m0=np.zeros(4), P0=np.eye(4))


@pytest.mark.parametrize("call,match", [
    # Full states without a model: the columns would be guessed.
    (lambda ax: bf.plotting.plot_track(ax, np.zeros((5, 4))),
     r"truth_xy must have shape \(T, 2\).*got shape \(5, 4\).*pass model="),
    (lambda ax: bf.plotting.plot_track(ax, np.zeros((5, 2)), est_xy=np.zeros((5, 4))),
     r"est_xy must have shape \(T, 2\).*pass model="),
    (lambda ax: bf.plotting.plot_track(ax, np.zeros((5, 2)), est_xy=np.zeros((5, 2)),
                                       covs_xy=np.tile(np.eye(4), (5, 1, 1))),
     r"covs_xy must have shape \(T, 2, 2\).*pass model="),
    (lambda ax: bf.plotting.covariance_ellipse(ax, np.zeros(4), np.eye(4)),
     r"mean must have shape \(2,\).*pass model="),
    # A model, but the width is neither 2 nor the model's state width.
    (lambda ax: bf.plotting.plot_track(ax, np.zeros((5, 3)), model=bf.models.damped_particle()),
     r"truth_xy must have shape \(T, 2\) \(planar positions\) or \(T, 4\).*x1_dot.*got shape \(5, 3\)"),
    (lambda ax: bf.plotting.plot_track(ax, np.zeros((5, 4)), est_xy=np.zeros((5, 4)),
                                       covs_xy=np.zeros((5, 4, 3)), model=bf.models.damped_particle()),
     r"covs_xy must have shape \(T, 2, 2\), got shape \(5, 4, 3\) \(not square\)"),
    (lambda ax: bf.plotting.covariance_ellipse(ax, np.zeros(4), np.eye(3), model=bf.models.range_bearing()),
     r"cov must have shape \(2, 2\) \(planar positions\) or \(4, 4\)"),
    # A model that does not say which components are positions.
    (lambda ax: bf.plotting.plot_track(ax, np.zeros((5, 4)), model=_unnamed_model()),
     "model .LinearGaussian. has no position_names"),
    # Measurements are not states.
    (lambda ax: bf.plotting.plot_track(ax, np.zeros((5, 4)), meas_xy=np.zeros((5, 4)),
                                       model=bf.models.damped_particle()),
     r"meas_xy must have shape \(M, 2\)"),
])
def test_plot_track_refuses_ambiguous_positions(ax, call, match):
    with pytest.raises(ValueError, match=match):
        call(ax)
    assert not ax.lines and not ax.patches  # every argument is checked before drawing


@pytest.mark.parametrize("model", ["damped_particle", np.eye(4), object()])
def test_plot_track_model_must_be_a_model(ax, model):
    with pytest.raises(TypeError, match="model must be a bayesfilt model"):
        bf.plotting.plot_track(ax, np.zeros((5, 4)), model=model)
