"""Checks of chapter 03's exercises (the damped particle; references by bf.models,
bf.kalman, bf.gaussian). One line per exercise (the notebook variables each reads with
``given``, in brackets)::

    exercise_1(stabilising_1, std_1, radius_1): the steady state of
        damped_particle(damping=1.0) [model_1];
    exercise_2(GQGt_2, nees_2, nees_old_2): G Q G^T designed for a half step, and the
        mean NEES of that design and of section 6's design for one step, on the
        simulated runs [dt_2, sigma_a_2, A_2, xs_2, ys_2];
    exercise_3(normalised_squared): the NEES / NIS d_t^T P_t^{-1} d_t, on six inputs;
    exercise_4(end_of_gap_variance, slope_4): the variance at the end of a gap in the
        data, and its log-log slope (and section 1's ys, put back if an answer wrote NaN
        into it) [ys, short_4, long_4];
    exercise_5(lag1_5, sees_5): the lag-1 autocorrelations of r̃_t under three mistuned
        models [models_5, ys_long].
"""

from __future__ import annotations

import functools

import numpy as np

from . import (INCORRECT, Feedback, _Stop, _as_numbers, _combine, _each_case, _forbidden, _frozen, _hinted, _named,
               _wrong, compare_choice, compare_number, given, register as _register)
from .. import gaussian, kalman, models

# the statements' numbers (ex 4 tries length 10 first: at length 1, zeros for NaN and one step early agree; ex 5:
# Q ×10 and R ×0.1 share Q / R, so the gain and r̃_t); 5 spreads of a lag-1 value between runs of 1000 steps
SECTION_1_SEED, T, DAMPING_1, ATOL_1, YES_NO = 2024, 100, 1.0, 2e-4, ("yes", "no")
DT_2, SIGMA_A_2, M_2, T_2, SEED_2, DAMPING, RTOL_2 = 0.5, 0.1, 200, 200, 22, 0.98, 1e-6
CORRELATED_3, ERRORS_3, SEED_3 = _frozen([[1.0, 0.95], [0.95, 1.0]]), _frozen([[1.0, -1.0], [1.0, 1.0]]), 3033
GAP_START, GAP_LENGTHS, SLOPE_LENGTHS, ATOL_SLOPE = 40, (10, 20, 1, 2, 5, 33, 60), (10, 20), 0.006
MODELS_5 = (("Q ×10", dict(force_var=0.1)), ("R ×0.1", dict(meas_var=0.1)), ("R ×10", dict(meas_var=10.0)))
OTHER_MODELS_5 = (("the correct model", {}), ("Q ×0.1 (section 13)", dict(force_var=0.001)))
LONG_SEED, N_LONG, ATOL_5, OTHER_RUN_5, OPTIONS_5 = 5, 1000, 2e-3, 5 / np.sqrt(1000), ("ratio", "scale", "neither")
SEES_5 = "sha256:ch03-ex5:7253dfb99bf17a340b58"          # the right option of sees_5, as a digest
_X1, _V1 = models.damped_particle().index_of("x1", "x1_dot")          # the components of the gap's mistakes


def _number(answer, expected, what, mistakes=(), rtol=0.0, atol=0.0, fallback="", label=None) -> Feedback:
    """compare_number; a wrong number that a named mistake (a value or a predicate) explains gets its message."""
    fb = compare_number(answer, expected, what, rtol=rtol, atol=atol)
    if fb.status != INCORRECT or f"{what} must be" in fb.message or f"{what} is NaN" in fb.message:
        return fb                                          # right, or not a finite number
    v = float(np.ravel(answer)[0])
    for wrong, message in mistakes:
        if wrong is not None and (wrong(v) if callable(wrong) else np.isclose(v, wrong, rtol=rtol, atol=atol)):
            return _wrong(f"{label or what}: {message}")
    return _wrong(f"{what}: {fallback}") if fallback else fb


def _steady_of(model) -> dict:                         # std of ξ_1, ..., the spectral radius and its mistakes
    ss, (x1, v1), pos = kalman.steady_state(model), model.index_of("x1", "x1_dot"), model.index_of("x1", "x2")
    eig = np.linalg.eigvals(model.A @ (np.eye(model.state_dim) - ss.gain @ model.C))    # Psi = A (I - K C)
    return dict(std=np.sqrt(ss.cov[x1, x1]), var=ss.cov[x1, x1], pred_std=np.sqrt(ss.pred_cov[x1, x1]),
                vel_std=np.sqrt(ss.cov[v1, v1]), both=np.sqrt(np.trace(ss.cov[np.ix_(pos, pos)])),
                radius=np.abs(eig).max(), real=np.abs(eig.real).max(),
                a_minus_kc=np.abs(np.linalg.eigvals(model.A - ss.gain @ model.C)).max())


@functools.lru_cache(maxsize=None)
def _steady(damping: float) -> dict:
    return _steady_of(models.damped_particle(damping=damping))


def _yes_no(flag: bool) -> str:
    return YES_NO[0] if flag else YES_NO[1]


def exercise_1(stabilising, std, radius) -> Feedback:
    """stabilising_1, std_1 and radius_1 of the steady state of model_1 (damped_particle(damping=1.0))."""
    model = given("model_1", None)
    try:
        u = _steady(DAMPING_1) if model is None else _steady_of(model)
    except ValueError:                     # a teacher's model_1 without a stabilising solution
        return _combine([("stabilising_1", compare_choice(stabilising, _yes_no(False), YES_NO, "stabilising_1",
                                                          _HINT_1))])
    d = _steady(0.98)
    damped = "this is section 7's value, for the damped particle (0.98); use model_1, without damping."
    return _combine([
        ("stabilising_1", compare_choice(stabilising, _yes_no(True), YES_NO, "stabilising_1", _HINT_1)),
        ("std_1", _number(std, u["std"], "std_1", atol=ATOL_1, mistakes=[
            (d["std"], damped), (u["var"], "this is the variance (m²); the standard deviation is its square root."),
            (u["pred_std"], "this is the standard deviation of the prediction P_{t|t-1} (steady_state(...).pred_cov); "
             "the exercise asks for the filtered one, after the measurement update (.cov)."),
            (d["pred_std"], "this is the prediction's standard deviation, and of the damped model: use the filtered "
             "covariance (.cov) of damped_particle(damping=1.0)."),
            (u["vel_std"], "this is the velocity x1_dot (ξ̇_1, m/step); the position ξ_1 is model.index_of('x1')."),
            (u["both"], "this takes both positions together (the trace of the position block); give the standard "
             "deviation of ξ_1 (position along axis 1) alone."),
            (1.0, "1 m is the standard deviation of one measurement; the filter, which averages many, does better.")])),
        ("radius_1", _number(radius, u["radius"], "radius_1", atol=ATOL_1, mistakes=[
            (d["radius"], damped), (u["radius"] ** 2, "this is |lambda|_max², the rate at which P_{t|t-1} approaches "
                                    "P_inf (section 12); the spectral radius is |lambda|_max itself."),
            (1.0, "1 is the spectral radius of A (and, to 4 decimals, of I - K_inf C); errors move by A (I - K_inf "
                  "C) (optional section 12)."),
            (u["real"], "this is the largest real part; the eigenvalues of A (I - K_inf C) are complex: take their "
             "modulus (np.abs), not .real."),
            (u["a_minus_kc"], "this is the spectral radius of A - K_inf C; the update comes before the prediction, "
             "so the error moves by A (I - K_inf C).")])),
    ])


_HINT_1 = ("try bf.kalman.steady_state on model_1, and reread optional section 12's two conditions "
           "(detectable, stabilisable): which mode of A would each need?")


@functools.lru_cache(maxsize=1)
def _section_1():
    return models.simulate(models.damped_particle(), T, np.random.default_rng(SECTION_1_SEED))


def _block(dt: float, sigma_a: float) -> np.ndarray:
    """The per-axis block of G Q G^T, piecewise-constant acceleration: sigma_a^2 g g^T, g = [dt^2/2, dt]."""
    g = np.array([dt ** 2 / 2, dt])
    return sigma_a ** 2 * np.outer(g, g)


def _both_axes(block) -> np.ndarray:                   # state order (xi_1, xi_1 dot, xi_2, xi_2 dot)
    return np.kron(np.eye(2), block)


def _half_step_A(dt: float) -> np.ndarray:
    return _both_axes(np.array([[1.0, dt], [0.0, DAMPING ** dt]]))


@functools.lru_cache(maxsize=4)
def _runs_2(dt: float, sigma_a: float) -> tuple[np.ndarray, np.ndarray]:
    """The statement's runs (xs_2, ys_2), as the answer cell simulates them (for a check without a notebook)."""
    A, rng, xs = _half_step_A(dt), np.random.default_rng(SEED_2), np.zeros((M_2, T_2, 4))
    xs[:, 0] = rng.normal(size=(M_2, 4))
    for t in range(1, T_2):
        a = rng.normal(0.0, sigma_a, size=(M_2, 2))
        xs[:, t] = xs[:, t - 1] @ A.T + np.kron(a, [dt ** 2 / 2, dt])
    return xs, xs[..., [0, 2]] + rng.normal(size=(M_2, T_2, 2))


def _nees_of(GQGt, A, xs, ys, predicted: bool = False) -> float | None:
    """Mean NEES of the filter (A, section 2's C, GQGt, R = I, m0 = 0, P0 = I) on the runs; None if GQGt is no
    covariance (with predicted, of the predictions x_t|t-1, P_t|t-1: a named mistake)."""
    try:
        fm = models.LinearGaussian(A, models.damped_particle().C, GQGt, np.eye(2), np.zeros(4), np.eye(4))
        out = kalman.batch_kalman_filter(fm, ys)
    except (ValueError, TypeError, np.linalg.LinAlgError):
        return None
    means, covs = (out.pred_means, out.pred_covs) if predicted else (out.means, out.covs)
    return float(gaussian.squared_mahalanobis(xs - means, covs).mean())


_NEES_2: dict = {}


def _nees_2(key: str, GQGt, A, xs, ys, predicted: bool = False) -> float | None:
    """_nees_of, remembered per design and data (a check cell asks for the same few designs again)."""
    digest_ = (key, predicted, np.asarray(GQGt, float).tobytes(), A.tobytes(), xs.tobytes()[:4096], xs.shape,
               float(np.sum(xs)), float(np.sum(ys)), ys.shape)
    if digest_ not in _NEES_2:
        if len(_NEES_2) > 32:
            _NEES_2.clear()
        _NEES_2[digest_] = _nees_of(GQGt, A, xs, ys, predicted)
    return _NEES_2[digest_]


def _data_2():
    """(dt, sigma_a, A, xs, ys) of the statement: the notebook's, else the statement's own numbers."""
    dt, sigma_a = float(given("dt_2", DT_2)), float(given("sigma_a_2", SIGMA_A_2))
    A, xs, ys = given("A_2", None), given("xs_2", None), given("ys_2", None)
    A = _half_step_A(dt) if A is None else np.asarray(A, dtype=float)
    if xs is None or ys is None:
        xs, ys = _runs_2(dt, sigma_a)
    return dt, sigma_a, A, np.asarray(xs, dtype=float), np.asarray(ys, dtype=float)


def exercise_2(GQGt, nees, nees_old) -> Feedback:
    """GQGt_2, G Q G^T for one half step (piecewise-constant acceleration), and the mean NEES nees_2 of that design
    and nees_old_2 of section 6's design for dt = 1 on the runs xs_2, ys_2."""
    dt, sigma_a, A, xs, ys = _data_2()
    right, old = _both_axes(_block(dt, sigma_a)), _both_axes(_block(1.0, sigma_a))
    g, s2 = np.array([dt ** 2 / 2, dt]), sigma_a ** 2
    continuous = lambda c: _both_axes(c * np.array([[dt ** 3 / 3, dt ** 2 / 2], [dt ** 2 / 2, dt]]))  # noqa: E731
    order = [0, 2, 1, 3]                               # (xi_1, xi_2, xi_1 dot, xi_2 dot), filterpy's other order
    pc = "the acceleration is constant within each half step, so the block is sigma_a² g g^T with g = [Δt²/2, Δt]."
    design = _named(GQGt, right, "GQGt_2", rtol=1e-6, atol=1e-12, mistakes=[
        (old, "GQGt_2: this is section 6's design for Δt = 1 (G_pc G_pc^T sigma_a²); every power of Δt must be "
              "that of dt_2 = 0.5."),
        (continuous(s2), "GQGt_2: this is the continuous white-noise model's block; " + pc),
        (continuous(s2 * dt), "GQGt_2: this is the continuous white-noise model's block (with the same velocity "
                              "variance); " + pc),
        (_both_axes(np.diag([0.0, s2 * dt ** 2])), "GQGt_2: this puts the push on the velocity only (section 2's "
         "G); within the half step the push also moves the position, by a Δt²/2: g = [Δt²/2, Δt]."),
        (_both_axes(np.diag(np.diag(_block(dt, sigma_a)))), "GQGt_2: the position-velocity entries sigma_a² Δt³/2 "
         "are missing: one push moves both, so they are correlated (G Q G^T, not its diagonal)."),
        (_both_axes(sigma_a * np.outer(g, g)), "GQGt_2: you multiplied by sigma_a; the push's variance is "
                                               "sigma_a² (sigma_a_2**2)."),
        (_both_axes(np.outer(g, g)), "GQGt_2: the block must be multiplied by the push's variance sigma_a²."),
        (_both_axes(s2 * np.outer([dt ** 2, dt], [dt ** 2, dt])), "GQGt_2: the position moves by a Δt²/2 within "
         "the half step (the 1/2 is missing)."),
        (right[np.ix_(order, order)], "GQGt_2 is in the order (ξ_1, ξ_2, ξ̇_1, ξ̇_2) (filterpy's order_by_dim="
         "False); the chapter's state is (ξ_1, ξ̇_1, ξ_2, ξ̇_2)."),
        (_block(dt, sigma_a), "GQGt_2 is the per-axis block (2 x 2); give G Q G^T for both axes, shape (4, 4): "
                              "np.kron(np.eye(2), block)."),
        (lambda a: a.shape == (4, 2) or a.shape == (2, 4), "GQGt_2 has the shape of G; give G Q G^T, shape (4, 4)."),
    ])
    ref, ref_old = _nees_2("right", right, A, xs, ys), _nees_2("old", old, A, xs, ys)
    if ref is None or ref_old is None:                 # a teacher's statement the filter cannot run
        return _combine([("GQGt_2", design)])
    own = None
    if not design.correct:                             # the student's own design, if the filter takes it
        a, bad = _as_numbers(GQGt, "GQGt_2")
        own = _nees_2("own", a, A, xs, ys) if bad is None and a.shape == (4, 4) else None
    steps = np.prod(xs.shape[:2])
    nees_mistakes = lambda this, other, name: [        # noqa: E731
        (own if this == "nees_2" else None, "this is the mean NEES of your GQGt_2, which is not yet right: fix "
                                            "GQGt_2 first."),
        (other, f"this is the value of {name}; check which design you passed to nees_2_of."),
        (ref * steps if this == "nees_2" else ref_old * steps, "this is the sum over all runs and steps; "
                                                                "the NEES asked for is their mean."),
        ((ref if this == "nees_2" else ref_old) / 4, "you divided by the dimension 4; a consistent "
                                                     "filter's mean NEES is near 4, not 1."),
        (_nees_2("pred", right if this == "nees_2" else old, A, xs, ys, predicted=True), "this uses the "
         "predictions (pred_means, pred_covs); the NEES uses the filtered x_t|t and P_t|t."),
        (4.0, "4 is what a consistent filter's mean NEES should be near; give the value measured on "
              "ys_2 with nees_2_of."),
    ]
    return _combine([
        ("GQGt_2", design),
        ("nees_2", _number(nees, ref, "nees_2", rtol=RTOL_2, mistakes=nees_mistakes("nees_2", ref_old,
                                                                                    "nees_old_2"))),
        ("nees_old_2", _number(nees_old, ref_old, "nees_old_2", rtol=RTOL_2,
                               mistakes=nees_mistakes("nees_old_2", ref, "nees_2"))),
    ])


@functools.lru_cache(maxsize=None)
def _nees_cases() -> tuple:                            # (label, diffs, covs) of the test inputs
    sim = models.simulate(model := models.damped_particle(), T, np.random.default_rng(SECTION_1_SEED))
    res, rng = kalman.kalman_filter(model, sim.ys), np.random.default_rng(SEED_3)
    spd = lambda T, n: np.round((M := rng.normal(size=(T, n, n))) @ np.swapaxes(M, 1, 2) / n + 0.3 * np.eye(n), 3)
    cov_3, cov_6 = spd(1, 3), spd(6, 3)
    return tuple((label, np.array(d, dtype=float), np.array(P, dtype=float)) for label, d, P in (
        ("section 1's errors x_t - x_t|t and P_t|t, t = 0, ..., 4", sim.xs[:5] - res.means[:5], res.covs[:5]),
        ("section 1's innovations r_t and S_t, t = 0, ..., 4", res.innovations[:5], res.innovation_covs[:5]),
        ("errors [1, -1] and [1, 1], covariance [[1, 0.95], [0.95, 1]]", ERRORS_3, np.stack([CORRELATED_3] * 2)),
        ("a single step, T = 1, n = 3", np.round(rng.normal(size=(1, 3)), 3), cov_3),
        ("n = 1: errors [2, -1, 0], variances [4, 0.25, 1]", [[2.0], [-1.0], [0.0]], [[[4.0]], [[0.25]], [[1.0]]]),
        ("six random steps, n = 3", np.round(rng.normal(size=(6, 3)), 3), cov_6)))


_QUAD, _NIS = "d_t^T P_t^{-1} d_t", gaussian.squared_mahalanobis
_NEES_MISTAKES = [
    (lambda d, P: np.einsum("ti,tij,tj->t", d, P, d), f"you multiply by P_t; the statistic uses its inverse: {_QUAD}."),
    (lambda d, P: np.sum(d ** 2 / np.diagonal(P, axis1=1, axis2=2), axis=1), f"you divide by the variances only "
     f"(the diagonal of P_t), dropping the correlations; use the whole matrix, {_QUAD}."),
    (lambda d, P: np.sqrt(_NIS(d, P)), f"you return the square root of {_QUAD}; NEES and NIS are the form itself."),
    (lambda d, P: _NIS(d, P) / d.shape[1], "you divide by the dimension n; the statistic is chi-square with n "
     "degrees of freedom, mean n (section 4 compares the average NEES with 4, not 1)."),
    (lambda d, P: np.sum(d ** 2, axis=1), f"you return d_t^T d_t, which ignores the covariance P_t: {_QUAD}."),
    *[(lambda d, P, k=k: np.einsum("ti,ij,tj->t", d, np.linalg.inv(P[k]), d), f"you use the {which} covariance for "
       f"every step; each step has its own P_t: {_QUAD}.") for k, which in ((0, "first"), (-1, "last"))],
]


def exercise_3(normalised_squared) -> Feedback:
    """normalised_squared(diffs, covs) against bf.gaussian.squared_mahalanobis on six inputs."""
    def judge(out, where, args) -> Feedback:
        (d, P), w, T = args, f"normalised_squared, {where}", len(args[0])
        return _named(out, _NIS(d, P), f"the output for {where}", [(wrong(d, P), f"{w}: {message}") for wrong, message
                                                                  in _NEES_MISTAKES] + [
            (lambda a: a.size == 1 and T > 1, f"{w}: you return a single number for {T} steps; return one value per "
             f"step, shape ({T},) (averaging them is the next step of the test)."),
            (lambda a: a.ndim >= 2 and a.shape[:2] == (T, T), lambda a: f"{w}: your array of shape {a.shape} pairs "
             f"every step with every other (a product over the time axis); pair d_t with its own P_t: shape ({T},).")])
    def hint(exc, args) -> str:
        if isinstance(exc, np.linalg.LinAlgError):
            return (" Hint: np.linalg.inv and np.linalg.solve take a stack (T, n, n) directly; "
                    "for the vectors use d[..., None].")
        return (f" Hint: diffs is (T, n) and covs (T, n, n); compute {_QUAD} for each t (a loop, "
                f"or np.einsum / np.linalg.solve on the stack)." if any(
                    w in str(exc) for w in ("matmul", "align", "broadcast", "dimension")) else "")
    fun = None if normalised_squared is Ellipsis else normalised_squared
    labels, d, P = zip(*_nees_cases())
    fb = _each_case(_hinted(fun, hint), "normalised_squared", list(zip(d, P)), labels, judge)
    return _forbidden(fb, fun, "normalised_squared", [
        ({"gaussian"}, "bf.gaussian, which the statement rules out: compute d_t^T P_t^{-1} d_t with NumPy "
                       "(a loop, or np.linalg.solve on the stack).")])


@functools.lru_cache(maxsize=None)
def _gap_var(length: int, offset: int = 0, k: int = _X1, t: int | None = None) -> float | None:
    """The variance of a component at t (default 39 + length + offset) with ys[40:40 + length] = NaN (ys = 0)."""
    ys, t = np.zeros((T, 2)), GAP_START + length - 1 + offset if t is None else t
    ys[GAP_START:GAP_START + length] = np.nan
    return float(kalman.kalman_filter(models.damped_particle(), ys).covs[t, k, k]) if 0 <= t < T else None


def _gap_judge(fun, out, where, args) -> Feedback:
    (length,), (a, bad) = args, _as_numbers(out, "the output")
    w, expected = f"end_of_gap_variance, {where}", _gap_var(length)
    if bad is None and a.size > 1:
        return _wrong(f"{w}: you return the whole covariance P_t|t (4 x 4); return its (x1, x1) entry, a float."
                      if a.shape == (4, 4) and np.isclose(a[_X1, _X1], expected, rtol=1e-6) else
                      f"{w}: return one number, the variance of ξ_1 at the gap's last step, not shape {a.shape}.")
    def reads_99() -> bool:      # t = 99 and "zeros for NaN" agree until the gap reaches t = 99: ask length 60
        try:
            last = np.asarray(fun(T - GAP_START), dtype=float)
            return last.size == 1 and bool(np.isclose(last.item(), _gap_var(T - GAP_START), rtol=1e-6))
        except Exception:  # noqa: BLE001 - a failure here is not the t = 99 mistake
            return False
    return _number(out, expected, f"the output for {where}", rtol=1e-6, label=w, mistakes=[
        (np.sqrt(expected), "you return the standard deviation (m); the variance is its square (m²)."),
        (_gap_var(length, 1), "this is t = 40 + length, the first step after the gap, whose measurement has already "
         "pulled the variance down; the gap's last step is t = 39 + length."),
        (_gap_var(length, -1), "this is t = 38 + length, one step before the gap's last step, t = 39 + length."),
        (_gap_var(length + 1), "this is one step after the end of the gap, before its measurement: you deleted "
         "length + 1 measurements, or read pred_covs[40 + length]."),
        (_gap_var(length, k=_V1), "this is the velocity x1_dot (ξ̇_1, (m/step)²); ξ_1 is model.index_of('x1')."),
        (_gap_var(20) if length != 20 else None, "this is section 8's gap of 20 steps whatever the length; delete "
         "`length` measurements, ys_cut[40:40 + length] = np.nan, and filter again."),
        (lambda v: np.isclose(v, _gap_var(length, t=T - 1), rtol=1e-6) and reads_99(), "this is the variance at the "
         "last step of the run, t = 99 (covs[-1]); the gap ends at t = 39 + length: read covs[39 + length, x1, x1]."),
        (_gap_var(0, t=GAP_START + length - 1), "the variance did not grow: the filter still updated during the gap. "
         "A missing measurement is a row of NaN (np.nan), not of zeros.")])


def _repair_ys() -> str:
    """Section 1's ys put back where an answer wrote NaN into the notebook's ys; what was done, or ""."""
    ys, original = given("ys", None), _section_1().ys
    if not isinstance(ys, np.ndarray) or ys.shape != original.shape or not ys.flags.writeable:
        return ""
    nan = np.isnan(ys) & ~np.isnan(original)
    if not nan.any() or not np.array_equal(ys[~nan], original[~nan]):
        return ""                                    # intact, or not section 1's ys (left alone)
    rows = np.flatnonzero(nan.any(axis=1))
    ys[nan] = original[nan]
    return (f"the chapter's ys had NaN in {len(rows)} rows ({rows[0]} to {rows[-1]}) when the check started: "
            f"a call of end_of_gap_variance in your answer cell wrote its gap into section 1's ys in place "
            f"(ys[40:40 + length] = np.nan). Work on a copy, ys_cut = ys.copy(); the check has put section "
            f"1's values back into ys.")


def exercise_4(end_of_gap_variance, slope) -> Feedback:
    """end_of_gap_variance(length) against bf.kalman.kalman_filter on GAP_LENGTHS, and slope_4; the
    notebook's ys, if an answer wrote NaN into it, is put back to section 1's values."""
    repaired = _repair_ys()
    try:
        fb = _exercise_4(end_of_gap_variance, slope)
    except _Stop as stop:                 # the guard's "Not yet", with what was done to ys
        fb = _wrong(stop.args[0])
    if repaired and fb.status != INCORRECT:
        return _wrong(repaired)
    return _wrong(f"{fb.message} (Also: {repaired})") if repaired else fb


def _slope_lengths() -> tuple[int, int]:
    """short_4 and long_4 of the answer cell (a teacher may change them), else the statement's (10, 20)."""
    try:
        lo, hi = int(given("short_4", SLOPE_LENGTHS[0])), int(given("long_4", SLOPE_LENGTHS[1]))
    except (TypeError, ValueError):
        return SLOPE_LENGTHS
    return (lo, hi) if 1 <= lo < hi <= T - GAP_START else SLOPE_LENGTHS


def _exercise_4(end_of_gap_variance, slope) -> Feedback:
    (lo, hi), fun = _slope_lengths(), None if end_of_gap_variance is Ellipsis else end_of_gap_variance
    v_lo, v_hi, d_log_l = _gap_var(lo), _gap_var(hi), np.log(hi / lo)
    expected, mixed = np.log(v_hi / v_lo) / d_log_l, "you mixed two logarithms ({}); use the same one for both."
    return _combine([
        ("end_of_gap_variance", _each_case(_hinted(fun, lambda exc, args: (
            " Hint: the run has T = 100 steps; the gap's last step is t = 39 + length (t = 99 for "
            "length = 60)." if isinstance(exc, IndexError) else "")), "end_of_gap_variance", [(n,) for n in GAP_LENGTHS],
            [f"length = {n}" for n in GAP_LENGTHS], functools.partial(_gap_judge, fun))),
        ("slope_4", _number(slope, expected, "slope_4", atol=ATOL_SLOPE, mistakes=[
            (expected / 2, "this is the standard deviation's slope; the variance's is twice it (log of a square)."),
            (np.log(_gap_var(hi, 1) / _gap_var(lo, 1)) / d_log_l, "this uses the variances at t = 40 + length, after "
             "the gap, already updated; use those at its last step, t = 39 + length (your end_of_gap_variance)."),
            ((v_hi - v_lo) / (hi - lo), "this is the slope of the variance itself; take the logarithm of both."),
            (np.log(v_hi / v_lo) / (hi - lo), f"you took the logarithm of the variance but not of the length: divide "
             f"by log {hi} - log {lo}."),
            (np.log10(v_hi / v_lo) / d_log_l, mixed.format("log10 and ln")),
            (np.log(v_hi / v_lo) / np.log10(hi / lo), mixed.format("ln and log10")),
            (1 / expected, "you divided the other way round: the slope is d log(variance) / d log(length)."),
            (v_hi / v_lo, f"this is the ratio v({hi}) / v({lo}); the slope takes logarithms: "
                          f"log(v({hi}) / v({lo})) / log({hi} / {lo})."),
            (np.log(v_hi / v_lo), f"you did not divide by log {hi} - log {lo}: the slope is a ratio of two "
             f"logarithms.")])),
    ])


@functools.lru_cache(maxsize=1)
def _statement_ys_long() -> np.ndarray:
    return models.simulate(models.damped_particle(), N_LONG, np.random.default_rng(LONG_SEED)).ys


def _ys_long() -> np.ndarray:
    """The long run ys_long of the answer cell (a teacher may change it, or N_long), else the statement's."""
    ys = given("ys_long", None)
    try:
        ys = np.asarray(ys, dtype=float)
    except (TypeError, ValueError):
        ys = None
    ok = ys is not None and ys.ndim == 2 and ys.shape[1] == 2 and len(ys) > 5 and np.isfinite(ys).all()
    return ys if ok else _statement_ys_long()


def _lags(model, ys) -> tuple[np.ndarray, np.ndarray]:
    """(lags 1-5 of r̃_t, shape (5, 2); lag 1 of r_t, (2,)) of the filter of model on the long run ys."""
    res = kalman.kalman_filter(model, ys)
    z = gaussian.normalised_innovations(res.innovations, res.innovation_covs)
    return gaussian.autocorrelation(z, 5), gaussian.autocorrelation(res.innovations, 1)[0]


_LAGS: dict = {}


def _lags_of(label: str, ys) -> tuple[np.ndarray, np.ndarray]:
    key = (label, ys.shape, ys.tobytes()[:4096], float(ys.sum()))
    if key not in _LAGS:
        if len(_LAGS) > 32:
            _LAGS.clear()
        _LAGS[key] = _lags(models.damped_particle(**dict(MODELS_5 + OTHER_MODELS_5)[label]), ys)
    return _LAGS[key]


def exercise_5(lag1, sees) -> Feedback:
    """lag1_5 (3, 2), the lag-1 autocorrelations of r̃_t for the models of models_5 (Q ×10, R ×0.1, R ×10)
    on ys_long, and sees_5."""
    given_models, w, labels, ys = given("models_5", None), "lag1_5", [label for label, _ in MODELS_5], _ys_long()
    rows = [_lags_of(x, ys) for x in labels] if given_models is None else [_lags(m, ys) for m in given_models]
    lag = lambda k: np.array([z[k - 1] for z, _ in rows])  # noqa: E731
    close = functools.partial(np.allclose, atol=ATOL_5)
    expected, lag_is = lag(1), "autocorrelation(z, max_lag)[0] is lag 1 (row k - 1 holds lag k)."
    others = [(x, _lags_of(x, ys)[0][0]) for x, _ in OTHER_MODELS_5] + list(zip(labels, expected))

    def mixup(a) -> str | None:         # a row that holds the values of another model
        for row, label in enumerate(labels):
            for other, values in others if not close(a[row], expected[row], rtol=0.0) else ():
                if other != label and close(a[row], values, rtol=0.0):
                    return (f"{w}: row {row + 1} ({label}) holds the values of "
                            f"{'Q ×10 or R ×0.1' if other in labels[:2] else other}; check which model you filtered "
                            f"with (force_var / meas_var).")
    one = "autocorrelation(z, 2)[:, {0}] takes a column, the lags of one component; row k must hold lag 1 of both " \
          "components: autocorrelation(z, 1)[0]."
    return _combine([
        ("lag1_5", _named(lag1, expected, w, rtol=0.0, atol=ATOL_5, mistakes=[
            (lambda a: a.shape == (20, 2) or (a.ndim == 3 and a.shape[0] == 3), f"{w} must hold lag 1 only, shape "
             f"(3, 2): {lag_is}"),
            (lambda a: a.shape in ((3, 1), (1, 3)), f"{w} holds one component of r̃_t only: give both, one column per "
             f"component, shape (3, 2) (autocorrelation(z, 1)[0] for each model)."),
            (lambda a: a.shape in ((2,), (3,)), lambda a: f"{w} must have shape (3, 2): one row per model (Q ×10, "
             f"R ×0.1, R ×10), one column per component of r̃_t; got shape {a.shape}."),
            (np.ones((3, 2)), f"{w} is lag 0 (any sequence matches itself perfectly); lag 1 pairs r̃_t "
                              f"with r̃_{{t+1}}."),
            *[(np.array([z[:2, c] for z, _ in rows]), f"{w} holds lags 1 and 2 of component {c + 1} of r̃_t: "
               + one.format(c)) for c in (0, 1)],
            *[(lag(k), f"{w} is lag {k}; {lag_is}") for k in range(2, 6)],
            (np.array([raw for _, raw in rows]), f"{w} is the autocorrelation of the raw innovations r_t; the test "
             f"reads r̃_t = bf.gaussian.normalised_innovations(res.innovations, res.innovation_covs)."),
            *[(expected[list(order)], f"{w} has its rows in another order; the order is Q ×10, R ×0.1, R ×10 "
               f"(models_5).") for order in ((0, 2, 1), (1, 0, 2), (1, 2, 0), (2, 0, 1), (2, 1, 0))],
            (lambda a: a.shape == (3, 2) and mixup(a) is not None, mixup),
            (lambda a: a.shape == (3, 2) and np.all(np.abs(a - expected) < OTHER_RUN_5)
             and np.all(np.sign(a) == np.sign(expected)), f"{w} is close to the right values but not equal to 3 "
             f"decimals: another run, or another estimate of the correlation (np.corrcoef, your own formula)? "
             f"Filter ys_long of the answer cell ({len(ys)} steps), use bf.gaussian.autocorrelation(z, 1)[0].")])),
        ("sees_5", compare_choice(sees, SEES_5, OPTIONS_5, "sees_5", "compare the rows of Q ×10 and R ×0.1, two "
                                  "models with the same Q / R, and then their NIS in section 5's table.")),
    ])


_register(globals())
