r"""Plots used by the course notebooks.

Every function draws on a matplotlib ``Axes`` it is given and returns it, so
a notebook keeps control of the figure layout::

    import matplotlib.pyplot as plt
    import bayesfilt as bf
    fig, ax = plt.subplots()
    bf.plotting.plot_error(ax, t, xs[:, 0] - res.means[:, 0], np.sqrt(res.covs[:, 0, 0]), unit="m")

The filters never plot; the plots never filter.
"""

from __future__ import annotations

import numpy as np
from matplotlib.patches import Ellipse

from ._checks import as_array, as_covariance, as_int, as_positive_float, as_vector

__all__ = [
    "use_course_style",
    "covariance_ellipse",
    "plot_track",
    "plot_estimate",
    "plot_error",
    "plot_consistency",
    "plot_belief_step",
    "belief_image",
]


#: The look shared by every chapter (applied by :func:`use_course_style`).
COURSE_STYLE = {
    "figure.dpi": 90,
    "figure.figsize": (8.0, 3.2),
    "font.size": 10,
    "axes.titlesize": "medium",
    "axes.grid": True,
    "grid.alpha": 0.3,
    "legend.fontsize": "small",
    "legend.framealpha": 0.85,
}


def use_course_style() -> None:
    """Apply the course's matplotlib settings (size, resolution, grid, fonts).

    Every notebook calls this once in its first cell, so that all chapters
    look alike and their stored figures stay small.
    """
    import matplotlib as mpl

    mpl.rcParams.update(COURSE_STYLE)


def _as_std(std, size: int) -> np.ndarray:
    std = as_vector("std", std, size)
    if np.any(std < 0):
        raise ValueError(f"std must be non-negative (standard deviations), got min {std.min():.3g}")
    return std


def _label(name: str, unit: str) -> str:
    return f"{name} ({unit})" if unit else name


def covariance_ellipse(ax, mean, cov, n_std: float = 2.0, **kwargs):
    r"""Draw the ellipse :math:`(x - m)^T P^{-1} (x - m) = n_{std}^2` of a 2-D Gaussian.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
    mean : array_like, shape (2,)
    cov : array_like, shape (2, 2)
        Symmetric positive semi-definite.
    n_std : float
        Radius in standard deviations (2: about 86 % of the mass in 2-D).
    **kwargs
        Passed to :class:`matplotlib.patches.Ellipse` (default: unfilled).

    Returns
    -------
    matplotlib.patches.Ellipse
    """
    mean = as_vector("mean", mean, 2)
    cov = as_covariance("cov", cov, 2)
    n_std = as_positive_float("n_std", n_std)
    vals, vecs = np.linalg.eigh(cov)
    vals = np.clip(vals, 0.0, None)
    # The major axis is the eigenvector of the largest eigenvalue (eigh sorts ascending).
    angle = np.degrees(np.arctan2(vecs[1, 1], vecs[0, 1]))
    width, height = 2.0 * n_std * np.sqrt(vals[::-1])
    kwargs.setdefault("fill", False)
    ellipse = Ellipse(xy=tuple(mean), width=width, height=height, angle=angle, **kwargs)
    ax.add_patch(ellipse)
    return ellipse


def plot_track(ax, truth_xy, meas_xy=None, est_xy=None, covs_xy=None, every: int = 10,
               n_std: float = 2.0, unit: str = "m"):
    """Plane trajectory: truth, measurements, estimate and covariance ellipses.

    Parameters
    ----------
    truth_xy : array_like, shape (T, 2)
    meas_xy, est_xy : array_like, shape (T, 2), optional
    covs_xy : array_like, shape (T, 2, 2), optional
        Position covariances; an ellipse is drawn every ``every`` steps.
    """
    truth = as_array("truth_xy", truth_xy, ndim=2)
    if truth.shape[1] != 2:
        raise ValueError(f"truth_xy must have shape (T, 2), got shape {truth.shape}")
    every = as_int("every", every, minimum=1)
    if covs_xy is not None and est_xy is None:
        raise ValueError("covs_xy needs est_xy: the ellipses are centred on the estimates")
    ax.plot(truth[:, 0], truth[:, 1], "k-", lw=1.5, label="truth")
    if meas_xy is not None:
        meas = as_array("meas_xy", meas_xy, ndim=2, finite=False)
        if meas.shape[1] != 2:
            raise ValueError(f"meas_xy must have shape (T, 2), got shape {meas.shape}")
        ax.plot(meas[:, 0], meas[:, 1], ".", color="tab:gray", ms=3, alpha=0.7, label="measurements")
    if est_xy is not None:
        est = as_array("est_xy", est_xy, ndim=2)
        if est.shape != truth.shape:
            raise ValueError(f"est_xy must have shape {truth.shape}, got shape {est.shape}")
        ax.plot(est[:, 0], est[:, 1], "-", color="tab:blue", lw=1.2, label="estimate")
        if covs_xy is not None:
            covs = as_array("covs_xy", covs_xy, ndim=3)
            if covs.shape != (truth.shape[0], 2, 2):
                raise ValueError(f"covs_xy must have shape ({truth.shape[0]}, 2, 2), "
                                 f"got shape {covs.shape}")
            for t in range(0, truth.shape[0], every):
                try:
                    covariance_ellipse(ax, est[t], covs[t], n_std, color="tab:blue", alpha=0.6, lw=0.8)
                except ValueError as exc:
                    raise ValueError(f"covs_xy[{t}]: {exc}") from None
    ax.set_xlabel(_label("position $x^1$", unit))
    ax.set_ylabel(_label("position $x^2$", unit))
    ax.set_aspect("equal", adjustable="datalim")
    ax.legend(loc="best", fontsize="small")
    return ax


def plot_estimate(ax, t, truth, mean, std, n_std: float = 2.0, label: str = "", unit: str = ""):
    """One state component over time: truth, estimate and a +-n_std band.

    Parameters
    ----------
    t : array_like, shape (T,)
    truth, mean, std : array_like, shape (T,)
    """
    t = as_vector("t", t)
    truth = as_vector("truth", truth, t.shape[0])
    mean = as_vector("mean", mean, t.shape[0])
    std = _as_std(std, t.shape[0])
    n_std = as_positive_float("n_std", n_std)
    ax.plot(t, truth, "k-", lw=1.2, label="truth")
    ax.plot(t, mean, "-", color="tab:blue", lw=1.2, label="estimate")
    ax.fill_between(t, mean - n_std * std, mean + n_std * std, color="tab:blue", alpha=0.2,
                    label=f"$\\pm{n_std:g}\\sigma$")
    ax.set_xlabel("time step $t$")
    ax.set_ylabel(_label(label or "state", unit))
    ax.legend(loc="best", fontsize="small")
    return ax


def plot_error(ax, t, error, std, n_std: float = 2.0, label: str = "error", unit: str = ""):
    """Estimation error over time with the filter's own +-n_std band.

    A consistent filter keeps about 95 % of the errors inside +-2 sigma.
    """
    t = as_vector("t", t)
    error = as_vector("error", error, t.shape[0])
    std = _as_std(std, t.shape[0])
    n_std = as_positive_float("n_std", n_std)
    ax.plot(t, error, "-", color="tab:red", lw=1.0, label=label)
    ax.fill_between(t, -n_std * std, n_std * std, color="tab:blue", alpha=0.2,
                    label=f"$\\pm{n_std:g}\\sigma$ (filter)")
    ax.axhline(0.0, color="k", lw=0.5)
    ax.set_xlabel("time step $t$")
    ax.set_ylabel(_label(label, unit))
    ax.legend(loc="best", fontsize="small")
    return ax


def plot_consistency(ax, t, values, dof: int, confidence: float = 0.95, label: str = "NEES"):
    r"""NEES or NIS over time against its chi-square interval.

    Parameters
    ----------
    t : array_like, shape (T,)
    values : array_like, shape (T,) or (M, T)
        Squared Mahalanobis distances (one run, or M Monte Carlo runs).
        With M runs the average over runs is drawn, and the interval is the
        one of the average of M independent :math:`\chi^2_{dof}` values.
    dof : int
        Degrees of freedom: the state dimension for NEES, the measurement
        dimension for NIS.
    confidence : float
        Two-sided probability of the interval.
    """
    from .gaussian import chi2_interval  # the interval is maths, not plotting

    t = as_vector("t", t)
    v = as_array("values", values)
    if v.ndim == 1:
        v = v[None, :]
    if v.ndim != 2 or v.shape[1] != t.shape[0]:
        raise ValueError(f"values must have shape ({t.shape[0]},) or (M, {t.shape[0]}), "
                         f"got shape {np.shape(values)}")
    n_runs = v.shape[0]
    low, high = chi2_interval(dof, n_runs=n_runs, confidence=confidence)
    ax.plot(t, v.mean(axis=0), "-", color="tab:blue", lw=1.0,
            label=f"{label}" + (f" (mean of {n_runs} runs)" if n_runs > 1 else ""))
    ax.axhline(dof, color="k", lw=0.8, ls="--", label=f"expected value {dof}")
    ax.axhspan(low, high, color="tab:green", alpha=0.15,
               label=f"{100 * confidence:g} % $\\chi^2$ interval")
    ax.set_xlabel("time step $t$")
    ax.set_ylabel(label)
    ax.legend(loc="best", fontsize="small")
    return ax


def plot_belief_step(ax, grid, prior, likelihood, posterior, truth=None, unit: str = ""):
    """One Bayes-filter step on a grid: prior, likelihood (rescaled) and posterior.

    The likelihood is a function of the state, not a distribution; it is
    scaled to the posterior's maximum so that its shape can be compared.
    """
    grid = as_vector("grid", grid)
    n = grid.shape[0]
    if n > 1 and np.any(np.diff(grid) <= 0):
        raise ValueError("grid must be strictly increasing")
    prior = as_vector("prior", prior, n)
    likelihood = as_vector("likelihood", likelihood, n)
    posterior = as_vector("posterior", posterior, n)
    width = float(np.min(np.diff(grid))) if n > 1 else 1.0
    ax.bar(grid, prior, width=width, color="tab:orange", alpha=0.5, label="prior")
    scale = posterior.max() / likelihood.max() if likelihood.max() > 0 else 0.0
    # A likelihood on a grid is constant over each cell: draw it as steps, like the beliefs.
    ax.step(grid, likelihood * scale, where="mid", color="tab:green", lw=1.2, label="likelihood (scaled)")
    ax.step(grid, posterior, where="mid", color="tab:blue", lw=1.5, label="posterior")
    if truth is not None:
        truth = float(as_vector("truth", truth, 1)[0])
        ax.axvline(truth, color="k", ls="--", lw=1.0, label="true state")
    ax.set_xlabel(_label("state $x$", unit))
    ax.set_ylabel("probability")
    ax.legend(loc="best", fontsize="small")
    return ax


def belief_image(ax, grid, beliefs, truth=None, title: str = "", unit: str = ""):
    """Beliefs over time as an image: time on the horizontal axis, state vertically.

    Parameters
    ----------
    grid : array_like, shape (n,)
    beliefs : array_like, shape (T, n)
    truth : array_like, shape (T,), optional
        True states, drawn on top.
    """
    grid = as_vector("grid", grid)
    b = as_array("beliefs", beliefs, ndim=2)
    if b.shape[1] != grid.shape[0]:
        raise ValueError(f"beliefs must have shape (T, {grid.shape[0]}), got shape {b.shape}")
    T = b.shape[0]
    half = 0.5 * (grid[1] - grid[0]) if grid.shape[0] > 1 else 0.5
    ax.grid(False)  # grid lines would hide faint cells of the image
    image = ax.imshow(b.T, origin="lower", aspect="auto", cmap="Blues",
                      extent=(-0.5, T - 0.5, grid[0] - half, grid[-1] + half))
    if truth is not None:
        truth = as_vector("truth", truth, T)
        ax.plot(np.arange(T), truth, "r.", ms=4, label="true state")
        ax.legend(loc="upper left", fontsize="small")
    ax.set_xlabel("time step $t$")
    ax.set_ylabel(_label("state $x$", unit))
    if title:
        ax.set_title(title)
    ax.figure.colorbar(image, ax=ax, label="probability")
    return ax
