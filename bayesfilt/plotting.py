r"""Plots used by the course notebooks.

Every function draws on a matplotlib ``Axes`` it is given and returns it, so
a notebook keeps control of the figure layout::

    import matplotlib.pyplot as plt
    import bayesfilt as bf
    fig, ax = plt.subplots()
    bf.plotting.plot_error(ax, t, xs[:, 0] - res.means[:, 0], np.sqrt(res.covs[:, 0, 0]),
                           unit="m")

Plots in the plane (:func:`plot_track`, :func:`covariance_ellipse`) take
positions of width 2, or full states together with the model, whose
``position_names`` select the columns; they never guess which columns are
positions, because that differs between models::

    bf.plotting.plot_track(ax, sim.xs, sim.ys, res.means, res.covs, model=model)

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
    """Reset matplotlib to its defaults, then apply the course's settings.

    Every notebook calls this once in its first cell, so that all chapters
    look alike and their stored figures stay small. The reset comes first so
    that what a learner sees is what CI checked: a personal ``matplotlibrc``
    or an earlier ``plt.rcParams`` change (``figure.constrained_layout.use``,
    ``text.usetex``, another figure size, ...) would otherwise change the
    figures, the printed figure sizes and the warnings of a cell.

    The reset is ``matplotlib.style.use("default")``, which leaves alone the
    settings that are not about style: the backend chosen by
    ``%matplotlib inline`` and interactive mode are kept.
    """
    import matplotlib.style

    matplotlib.style.use(["default", COURSE_STYLE])


def _as_std(std, size: int) -> np.ndarray:
    std = as_vector("std", std, size)
    if np.any(std < 0):
        raise ValueError(f"std must be non-negative (standard deviations), got min {std.min():.3g}")
    return std


def _label(name: str, unit: str) -> str:
    return f"{name} ({unit})" if unit else name


def _position_columns(model) -> list[int] | None:
    """Indices of ``model.position_names`` in its state, or None without a model."""
    if model is None:
        return None
    if not all(hasattr(model, a) for a in ("state_dim", "state_names", "position_names")):
        raise TypeError("model must be a bayesfilt model with state_names and position_names "
                        f"(e.g. bf.models.damped_particle()), got {type(model).__name__}")
    if model.position_names is None or model.state_names is None:
        raise ValueError(f"model ({type(model).__name__}) has no position_names, so its planar "
                         "positions are unknown: give the model state_names and position_names, "
                         "or pass the two position columns yourself (shape (..., 2))")
    names = list(model.state_names)
    return [names.index(a) for a in model.position_names]


def _planar(name: str, a: np.ndarray, model, want: str, *, square: bool = False) -> np.ndarray:
    """Planar positions (last axis of width 2) from positions or, with a model, full states.

    ``a`` has its shape checked already except for the last axis (the last
    two if ``square``, for covariances). Width 2 is taken as the positions
    themselves; the full state width of ``model`` is reduced to the columns
    ``model.position_names``; anything else is an error. A full-state array
    without a model is refused: which two columns are positions differs
    between models (``[x1, x1_dot, x2, x2_dot]`` against ``[xi_x, xi_y, xi_x_dot, xi_y_dot]``).
    """
    width = a.shape[-1]
    if square and a.shape[-2] != width:
        raise ValueError(f"{name} must have shape {want}, got shape {a.shape} (not square)")
    if width == 2:
        return a
    cols = _position_columns(model)
    if cols is None:
        raise ValueError(f"{name} must have shape {want} (planar positions), got shape {a.shape}. "
                         f"For full states of width {width}, pass model= so that the positions are "
                         "selected by model.position_names, or select the two position columns "
                         "yourself")
    n = model.state_dim
    if width != n:
        full = want.replace("2", str(n))
        raise ValueError(f"{name} must have shape {want} (planar positions) or {full} (full states "
                         f"{list(model.state_names)} of the model), got shape {a.shape}")
    if square:
        return a[..., cols, :][..., cols]
    return a[..., cols]


def covariance_ellipse(ax, mean, cov, n_std: float = 2.0, *, model=None, **kwargs):
    r"""Draw the ellipse :math:`(x - m)^T P^{-1} (x - m) = n_{std}^2` of a 2-D Gaussian.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
    mean : array_like, shape (2,) or (n,)
        A mean in the plane; a full state of length n only with ``model``.
    cov : array_like, shape (2, 2) or (n, n)
        Symmetric positive semi-definite; a full state covariance only with
        ``model``, whose position block is drawn.
    n_std : float
        Radius in standard deviations (2: about 86 % of the mass in 2-D).
    model : LinearGaussian or NonlinearGaussian, optional
        Selects the planar positions of full-state arguments by
        ``model.position_names``. Arguments of size 2 are used as given.
    **kwargs
        Passed to :class:`matplotlib.patches.Ellipse` (default: unfilled).

    Returns
    -------
    matplotlib.patches.Ellipse

    Raises
    ------
    ValueError
        If ``mean`` or ``cov`` is neither planar nor, with ``model``, of the
        model's state size, or ``cov`` is not a covariance.
    """
    mean = _planar("mean", as_array("mean", mean, ndim=1), model, "(2,)")
    cov = _planar("cov", as_array("cov", cov, ndim=2), model, "(2, 2)", square=True)
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
               n_std: float = 2.0, unit: str = "m", *, model=None):
    """Plane trajectory: truth, measurements, estimate and covariance ellipses.

    The positions are checked, never guessed: a state vector holds the
    positions in different columns from model to model (``[x1, x1_dot, x2,
    x2_dot]`` for ``bf.models.damped_particle()``, ``[xi_x, xi_y, xi_x_dot, xi_y_dot]``
    for ``bf.models.range_bearing()``). Pass either the two position columns
    (width 2) or full states together with ``model=``; full states without a
    model are refused::

        bf.plotting.plot_track(ax, sim.xs, ys, res.means, res.covs, model=model)

    Parameters
    ----------
    ax : matplotlib.axes.Axes
    truth_xy : array_like, shape (T, 2) or (T, n)
        True positions; full states (n = ``model.state_dim``) only with ``model``.
    meas_xy : array_like, shape (M, 2), optional
        Measurements converted to positions in the plane (NaN for a gap).
    est_xy : array_like, shape (T, 2) or (T, n), optional
        Estimated positions (filter means); full states only with ``model``.
    covs_xy : array_like, shape (T, 2, 2) or (T, n, n), optional
        Position covariances, or full state covariances with ``model``; an
        ellipse is drawn every ``every`` steps. Needs ``est_xy``.
    every : int
        Steps between two ellipses (>= 1).
    n_std : float
        Ellipse radius in standard deviations.
    unit : str
        Unit of the positions, for the axis labels ("" for none).
    model : LinearGaussian or NonlinearGaussian, optional
        The model of the states; its ``position_names`` select the position
        columns of full-state arguments and label the axes.

    Returns
    -------
    matplotlib.axes.Axes

    Raises
    ------
    ValueError
        If an array is neither planar (width 2) nor, with ``model``, of the
        model's state width; if a full-state array comes without ``model``;
        if the lengths differ or a covariance is not positive semi-definite.
    TypeError
        If ``model`` is not a bayesfilt model.
    """
    # Every argument is checked before anything is drawn: no half-drawn axes on an error.
    cols = _position_columns(model)  # checks the model first, even for planar arrays
    truth = _planar("truth_xy", as_array("truth_xy", truth_xy, ndim=2), model, "(T, 2)")
    every = as_int("every", every, minimum=1)
    n_std = as_positive_float("n_std", n_std)
    if covs_xy is not None and est_xy is None:
        raise ValueError("covs_xy needs est_xy: the ellipses are centred on the estimates")
    meas = est = covs = None
    if meas_xy is not None:
        meas = as_array("meas_xy", meas_xy, ndim=2, finite=False)
        if meas.shape[1] != 2:
            raise ValueError(f"meas_xy must have shape (M, 2) (measured positions in the plane; "
                             f"measurements are not states, so model= does not apply), "
                             f"got shape {meas.shape}")
    if est_xy is not None:
        est = _planar("est_xy", as_array("est_xy", est_xy, ndim=2), model, "(T, 2)")
        if est.shape != truth.shape:
            raise ValueError(f"est_xy must have shape {truth.shape}, got shape {est.shape}")
    if covs_xy is not None:
        covs = _planar("covs_xy", as_array("covs_xy", covs_xy, ndim=3), model, "(T, 2, 2)",
                       square=True)
        if covs.shape != (truth.shape[0], 2, 2):
            raise ValueError(f"covs_xy must have shape ({truth.shape[0]}, 2, 2), "
                             f"got shape {covs.shape}")
        for t in range(0, truth.shape[0], every):
            as_covariance(f"covs_xy[{t}]", covs[t], 2)
    ax.plot(truth[:, 0], truth[:, 1], "k-", lw=1.5, label="truth")
    if meas is not None:
        ax.plot(meas[:, 0], meas[:, 1], ".", color="tab:gray", ms=3, alpha=0.7, label="measurements")
    if est is not None:
        ax.plot(est[:, 0], est[:, 1], "-", color="tab:blue", lw=1.2, label="estimate")
    if covs is not None:
        for t in range(0, truth.shape[0], every):
            covariance_ellipse(ax, est[t], covs[t], n_std, color="tab:blue", alpha=0.6, lw=0.8)
    if cols is None:
        xname, yname = "position $x^1$", "position $x^2$"
    else:
        xname, yname = (f"position {a}" for a in model.position_names)
    ax.set_xlabel(_label(xname, unit))
    ax.set_ylabel(_label(yname, unit))
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

    Parameters
    ----------
    ax : matplotlib.axes.Axes
    t : array_like, shape (T,)
        Time steps.
    error : array_like, shape (T,)
        Estimate minus truth of one state component.
    std : array_like, shape (T,)
        The filter's standard deviation of that component (square root of a diagonal entry
        of its covariance), non-negative.
    n_std : float
        Half-width of the band in standard deviations (default 2).
    label, unit : str
        Legend label and unit of the error, for the y-axis label.
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

    Parameters
    ----------
    ax : matplotlib.axes.Axes
    grid : array_like, shape (n,)
        Cell centres, strictly increasing.
    prior, likelihood, posterior : array_like, shape (n,)
        Probabilities of the cells before and after the measurement, and the likelihood of
        the measurement at each cell.
    truth : float, optional
        The true state, drawn as a vertical line.
    unit : str
        Unit of the state, for the x-axis label.
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
