"""Tests of bf.models against independent references.

References: the matrices typed from seed 000 (damped particle), Monte Carlo
moments against the model formulas, scipy.stats.multivariate_normal, and
hand-computed angles.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import multivariate_normal

import bayesfilt as bf

LG = bf.models.LinearGaussian


def small_model(**kw):
    args = dict(A=[[0.9, 0.2], [0.0, 0.7]], C=[[1.0, 0.5]], Q=[[0.3]], R=[[0.2]],
                m0=[1.0, -1.0], P0=[[1.0, 0.2], [0.2, 0.5]], G=[[0.5], [1.0]],
                B=[[1.0], [0.0]])
    args.update(kw)
    return LG(**args)


# --------------------------------------------------------------------------
# The seed's example
# --------------------------------------------------------------------------

def test_damped_particle_matrices_are_the_seeds():
    # Typed from seed 000, section 2 ("Ex) particle ... random forces and damping").
    A = np.array([[1, 1, 0, 0],
                  [0, 0.98, 0, 0],
                  [0, 0, 1, 1],
                  [0, 0, 0, 0.98]])
    G = np.array([[0, 0],
                  [1, 0],
                  [0, 0],
                  [0, 1]])
    C = np.array([[1, 0, 0, 0],
                  [0, 0, 1, 0]])
    model = bf.models.damped_particle()
    np.testing.assert_array_equal(model.A, A)
    np.testing.assert_array_equal(model.G, G)
    np.testing.assert_array_equal(model.C, C)
    np.testing.assert_array_equal(model.m0, np.zeros(4))  # the seed's mu_0 = 0
    assert (model.state_dim, model.obs_dim, model.noise_dim) == (4, 2, 2)
    assert model.B is None and model.control_dim == 0


def test_model_arrays_are_read_only():
    model = bf.models.damped_particle()
    with pytest.raises(ValueError):
        model.A[0, 0] = 2.0


# --------------------------------------------------------------------------
# Validation
# --------------------------------------------------------------------------

def test_linear_gaussian_validation():
    for key, bad, match in [
        ("A", np.ones((2, 3)), r"A must be square \(n, n\), got shape \(2, 3\)"),
        ("A", [[np.inf, 0.0], [0.0, 1.0]], "A must be finite"),
        ("C", np.ones((1, 3)), r"C must have shape \(\?, 2\), got shape \(1, 3\)"),
        ("Q", [[1.0, 0.0], [0.0, 1.0]], "G must have shape"),
        ("Q", [[-0.1]], "Q must be positive semi-definite"),
        ("R", [[0.2, 0.0], [0.0, 0.2]], "R must have shape"),
        ("R", [[-0.2]], "R must be positive semi-definite"),
        ("m0", [1.0], "m0 must have shape"),
        ("P0", [[1.0, 0.3], [0.2, 0.5]], "P0 must be symmetric"),
        ("P0", [[1.0, 2.0], [2.0, 0.5]], "P0 must be positive semi-definite"),
        ("G", [[1.0], [0.0], [0.0]], "G must have shape"),
        ("B", [[1.0]], "B must have shape"),
    ]:
        with pytest.raises(ValueError, match=match):
            small_model(**{key: bad})
    with pytest.raises(ValueError, match="Q must have shape"):
        LG(A=np.eye(2), C=[[1.0, 0.0]], Q=[[1.0]], R=[[1.0]], m0=[0.0, 0.0], P0=np.eye(2))
    with pytest.raises(TypeError, match="A must be an array of numbers, got None"):
        small_model(A=None)


def _pendulum_parts():
    def f(x):
        x = np.asarray(x, float)
        return np.stack([x[..., 0] + 0.1 * x[..., 1], x[..., 1] - 0.1 * np.sin(x[..., 0])], -1)

    def F(x):
        return np.array([[1.0, 0.1], [-0.1 * np.cos(x[0]), 1.0]])

    def h(x):
        return np.sin(np.asarray(x, float)[..., :1])

    def H(x):
        return np.array([[np.cos(x[0]), 0.0]])

    return dict(f=f, F=F, h=h, H=H, Q=[[0.01]], R=[[0.1]], m0=[0.5, 0.0], P0=np.eye(2),
                G=[[0.0], [1.0]])


def test_nonlinear_gaussian_validation():
    ok = _pendulum_parts()
    bf.models.NonlinearGaussian(**ok)
    with pytest.raises(TypeError, match="f must be callable"):
        bf.models.NonlinearGaussian(**{**ok, "f": 3.0})
    with pytest.raises(TypeError, match="residual_fn must be callable"):
        bf.models.NonlinearGaussian(**ok, residual_fn="wrap")
    with pytest.raises(ValueError, match="f must map shape"):
        bf.models.NonlinearGaussian(**{**ok, "f": lambda x: np.zeros(3)})
    with pytest.raises(ValueError, match="row-wise"):
        # works on one state only: returns (2,) for a batch
        bf.models.NonlinearGaussian(**{**ok, "f": lambda x: np.asarray(x, float).ravel()[:2]})
    with pytest.raises(ValueError, match="values h returns|h must map shape"):
        bf.models.NonlinearGaussian(**{**ok, "h": lambda x: np.asarray(x, float)})
    with pytest.raises(ValueError, match="Jacobian F"):
        bf.models.NonlinearGaussian(**{**ok, "F": lambda x: np.eye(3)})
    with pytest.raises(ValueError, match="Jacobian H"):
        bf.models.NonlinearGaussian(**{**ok, "H": lambda x: np.eye(2)})
    with pytest.raises(ValueError, match="R must be positive semi-definite"):
        bf.models.NonlinearGaussian(**{**ok, "R": [[-1.0]]})
    with pytest.raises(ValueError, match="takes no control input"):
        bf.models.NonlinearGaussian(**ok).transition_mean([0.0, 0.0], u=[1.0])


# --------------------------------------------------------------------------
# Simulation
# --------------------------------------------------------------------------

def test_simulate_shapes_and_time_convention():
    # Noise-free dynamics and (nearly) noise-free measurements make the convention visible.
    model = small_model(Q=[[0.0]], R=[[1e-20]], P0=np.zeros((2, 2)))
    us = np.arange(4.0)[:, None]
    xs, ys = bf.models.simulate(model, 5, np.random.default_rng(0), us=us)
    assert xs.shape == (5, 2) and ys.shape == (5, 1)
    np.testing.assert_allclose(xs[0], model.m0)  # x_0 ~ N(m0, 0)
    for t in range(4):  # row t of us drives x_t -> x_{t+1}
        np.testing.assert_allclose(xs[t + 1], model.A @ xs[t] + model.B @ us[t])
    np.testing.assert_allclose(ys, xs @ model.C.T, atol=1e-8)  # ys[0] measures x_0
    sim = bf.models.simulate(model, 3, np.random.default_rng(0), x0=[2.0, 3.0])
    np.testing.assert_allclose(sim.xs[0], [2.0, 3.0])


def test_simulate_bad_arguments():
    model = small_model()
    rng = np.random.default_rng(0)
    with pytest.raises(TypeError, match="rng must be a numpy.random.Generator"):
        bf.models.simulate(model, 5, 0)
    with pytest.raises(ValueError, match="T must be >= 1"):
        bf.models.simulate(model, 0, rng)
    with pytest.raises(TypeError, match="T must be an integer"):
        bf.models.simulate(model, 5.0, rng)
    with pytest.raises(ValueError, match="us must have T - 1"):
        bf.models.simulate(model, 5, rng, us=np.zeros((2, 1)))
    with pytest.raises(ValueError, match="no control matrix B"):
        bf.models.simulate(bf.models.damped_particle(), 5, rng, us=np.zeros((4, 2)))
    with pytest.raises(TypeError, match="model must be a LinearGaussian or NonlinearGaussian"):
        bf.models.simulate("model", 5, rng)
    with pytest.raises(ValueError, match=r"x0 must have shape \(2,\), got shape \(3,\)"):
        bf.models.simulate(model, 5, rng, x0=[1.0, 2.0, 3.0])


# --------------------------------------------------------------------------
# Sampling: Monte Carlo moments against the formulas
# --------------------------------------------------------------------------

N = 200_000


def test_sample_initial_moments():
    model = small_model()
    xs = model.sample_initial(np.random.default_rng(1), N)
    assert xs.shape == (N, 2)
    np.testing.assert_allclose(xs.mean(axis=0), model.m0, atol=0.01)
    np.testing.assert_allclose(np.cov(xs.T), model.P0, atol=0.01)


def test_sample_transition_moments():
    model = small_model()
    x, u = np.array([1.0, 2.0]), np.array([0.5])
    draws = model.sample_transition(np.random.default_rng(2), np.tile(x, (N, 1)), u)
    np.testing.assert_allclose(draws.mean(axis=0), model.A @ x + model.B @ u, atol=0.01)
    # G Q G^T = 0.3 [[0.25, 0.5], [0.5, 1]] (singular: one noise drives both components)
    np.testing.assert_allclose(np.cov(draws.T), 0.3 * np.array([[0.25, 0.5], [0.5, 1.0]]),
                               atol=0.01)
    one = model.sample_transition(np.random.default_rng(2), x, u)
    assert one.shape == (2,)


def test_sample_measurement_moments():
    model = bf.models.damped_particle(meas_var=0.5)
    x = np.array([1.0, 2.0, 3.0, 4.0])
    draws = model.sample_measurement(np.random.default_rng(3), np.tile(x, (N, 1)))
    np.testing.assert_allclose(draws.mean(axis=0), [1.0, 3.0], atol=0.01)
    np.testing.assert_allclose(np.cov(draws.T), 0.5 * np.eye(2), atol=0.01)


def test_sampling_rejects_bad_rng_and_shapes():
    model = small_model()
    with pytest.raises(TypeError, match="rng must be a numpy.random.Generator"):
        model.sample_initial(np.random.RandomState(0), 3)
    with pytest.raises(ValueError, match="xs must have shape"):
        model.sample_transition(np.random.default_rng(0), np.zeros((3, 3)))
    with pytest.raises(ValueError, match=r"u must have shape \(1,\), got shape \(2,\)"):
        model.sample_transition(np.random.default_rng(0), np.zeros(2), u=[1.0, 2.0])


# --------------------------------------------------------------------------
# Densities
# --------------------------------------------------------------------------

def test_measurement_logpdf_equals_scipy():
    model = bf.models.damped_particle(meas_var=0.7)
    xs = np.random.default_rng(4).standard_normal((6, 4))
    y = np.array([0.3, -0.2])
    ref = [multivariate_normal(model.C @ x, model.R).logpdf(y) for x in xs]
    np.testing.assert_allclose(model.measurement_logpdf(y, xs), ref, rtol=1e-12)
    one = model.measurement_logpdf(y, xs[0])
    assert isinstance(one, float)
    np.testing.assert_allclose(one, ref[0], rtol=1e-12)


def test_transition_logpdf_equals_scipy_and_raises_when_singular():
    model = small_model(G=None, Q=[[0.3, 0.1], [0.1, 0.2]])
    xs = np.random.default_rng(5).standard_normal((4, 2))
    x_next = np.array([0.1, 0.4])
    ref = [multivariate_normal(model.A @ x, model.Q).logpdf(x_next) for x in xs]
    np.testing.assert_allclose(model.transition_logpdf(x_next, xs), ref, rtol=1e-12)
    # The damped particle's G Q G^T has rank 2 in 4-D: no density.
    with pytest.raises(ValueError, match=r"G Q G\^T must be positive definite"):
        bf.models.damped_particle().transition_logpdf(np.zeros(4), np.zeros((3, 4)))


# --------------------------------------------------------------------------
# Range and bearing (seed 000, section 3)
# --------------------------------------------------------------------------

def test_wrap_angle():
    np.testing.assert_allclose(bf.models.wrap_angle([0.0, np.pi, -np.pi, 3 * np.pi / 2, 7.0]),
                               [0.0, np.pi, np.pi, -np.pi / 2, 7.0 - 2 * np.pi], atol=1e-12)


def test_range_bearing_residual_wraps_the_bearing_only():
    y = np.array([10.0, 3.1])
    y_pred = np.array([4.0, -3.1])
    r = bf.models.range_bearing_residual(y, y_pred)
    np.testing.assert_allclose(r, [6.0, 6.2 - 2 * np.pi], atol=1e-12)
    model = bf.models.range_bearing()
    np.testing.assert_allclose(model.residual(y, y_pred), r)
    # batch of rows
    rs = bf.models.range_bearing_residual(np.tile(y, (3, 1)), np.tile(y_pred, (3, 1)))
    np.testing.assert_allclose(rs, np.tile(r, (3, 1)), atol=1e-12)


def test_range_bearing_measurement_uses_atan2():
    model = bf.models.range_bearing()
    # A point in the third quadrant: arctan(xi_y / xi_x) would give +pi/4.
    y = model.measurement_mean(np.array([-3.0, -3.0, 0.0, 0.0]))
    np.testing.assert_allclose(y, [np.sqrt(18.0), -3 * np.pi / 4], atol=1e-12)
    np.testing.assert_allclose(bf.models.RANGE_BEARING_TRUE_START, [10.0, -5.0, -0.2, 0.2])


# --------------------------------------------------------------------------
# Bad input found by the API review: each must raise a clear error, not NaN
# --------------------------------------------------------------------------

def test_a_negative_variance_is_refused_next_to_a_large_one():
    with pytest.raises(ValueError, match=r"R must be positive semi-definite, got a negative variance"):
        bf.models.LinearGaussian(A=np.eye(2), C=np.eye(2), Q=np.eye(2), R=np.diag([1e9, -0.5]),
                                 m0=np.zeros(2), P0=np.eye(2))


@pytest.mark.parametrize("method", ["transition_mean", "measurement_mean"])
def test_a_nan_state_is_refused(method):
    model = bf.models.damped_particle()
    with pytest.raises(ValueError, match="xs must be finite"):
        getattr(model, method)([np.nan, 0.0, 0.0, 0.0])


def test_user_functions_returning_nan_are_named():
    ok = _pendulum_parts()
    # fine near m0 (where the constructor probes it), NaN far away
    model = bf.models.NonlinearGaussian(**{**ok, "f": lambda x: np.where(
        np.abs(np.asarray(x, float)) > 100, np.nan, np.asarray(x, float))})
    with pytest.raises(ValueError, match="f returned non-finite"):
        model.sample_transition(np.random.default_rng(0), np.full((5, 2), 1e3))


def test_one_state_against_many_next_states():
    model = small_model(Q=[[0.5]])
    nxt = np.random.default_rng(0).standard_normal((4, 2))
    many = model.transition_logpdf(nxt, np.zeros(2))
    one_by_one = [model.transition_logpdf(row, np.zeros(2)) for row in nxt]
    np.testing.assert_allclose(many, one_by_one, rtol=1e-13)


def test_example_builders_check_their_arguments():
    with pytest.raises(ValueError, match="force_var must be finite and > 0"):
        bf.models.damped_particle(force_var=-1.0)
    with pytest.raises(ValueError, match="damping must be finite"):
        bf.models.damped_particle(damping=np.nan)
    with pytest.raises(TypeError, match="damping must be a real number"):
        bf.models.damped_particle(damping="0.9")
    with pytest.raises(ValueError, match=r"m0 must have shape \(4,\)"):
        bf.models.range_bearing(m0=(1.0, 2.0, 3.0))
    with pytest.raises(ValueError, match="range_var must be finite and > 0"):
        bf.models.range_bearing(range_var=0.0)


def test_angle_helpers_check_their_arguments():
    with pytest.raises(TypeError, match="angle must be an array of numbers, got None"):
        bf.models.wrap_angle(None)
    with pytest.raises(ValueError, match="angle must be finite"):
        bf.models.wrap_angle(np.nan)
    with pytest.raises(ValueError, match=r"y must have shape \(\.\.\., 2\)"):
        bf.models.range_bearing_residual([1.0], [0.0])


def test_to_nonlinear_refuses_a_control_matrix():
    with pytest.raises(ValueError, match="control matrix B"):
        bf.models.to_nonlinear(bf.models.damped_particle(B=np.eye(4)))


def test_scalar_one_dimensional_model():
    model = bf.models.LinearGaussian(A=0.9, C=1.0, Q=0.1, R=1.0, m0=0.0, P0=1.0)
    assert model.A.shape == (1, 1) and model.m0.shape == (1,)
    xs, ys = bf.models.simulate(model, 5, np.random.default_rng(0))
    assert xs.shape == (5, 1) and ys.shape == (5, 1)


def test_a_diverging_simulation_is_reported():
    model = bf.models.LinearGaussian(A=[[1e200]], C=[[1.0]], Q=[[1.0]], R=[[1.0]], m0=[1.0], P0=[[1.0]])
    with pytest.raises(ValueError, match=r"the simulated state diverged \(non-finite\) at step t = "):
        bf.models.simulate(model, 5, np.random.default_rng(0))


@pytest.mark.parametrize("bad", [[True, False], ["1.0", "2.0"], [1j, 2.0], [[1.0, 2.0], [3.0]]])
def test_non_numbers_are_refused_with_the_argument_name(bad):
    with pytest.raises(TypeError, match="m0 must be an? (rectangular )?array of (real )?numbers"):
        bf.models.LinearGaussian(A=np.eye(2), C=np.eye(2), Q=np.eye(2), R=np.eye(2), m0=bad, P0=np.eye(2))


def test_simulate_many_equals_repeated_simulate():
    model = bf.models.damped_particle()
    many = bf.models.simulate_many(model, 4, 6, np.random.default_rng(3))
    rng = np.random.default_rng(3)
    runs = [bf.models.simulate(model, 6, rng) for _ in range(4)]
    np.testing.assert_array_equal(many.xs, np.stack([r.xs for r in runs]))
    np.testing.assert_array_equal(many.ys, np.stack([r.ys for r in runs]))
    assert many.xs.shape == (4, 6, 4) and many.ys.shape == (4, 6, 2)
    with pytest.raises(ValueError, match="M must be >= 1"):
        bf.models.simulate_many(model, 0, 6, np.random.default_rng(3))


# --- issue 8: row-wise check, state names; issue 7: time-varying models, UNGM ---

def test_row_wise_check_is_not_fooled_when_n_is_2():
    # x[0], x[1] index rows of a (2, 2) batch, yet return the right shape (2, 2):
    # two copies of m0 could not tell; two distinct states do.
    ok = _pendulum_parts()
    wrong = lambda x: np.stack([np.asarray(x, float)[1], np.asarray(x, float)[0]])  # noqa: E731
    with pytest.raises(ValueError, match="f must act row-wise"):
        bf.models.NonlinearGaussian(**{**ok, "f": wrong})
    with pytest.raises(ValueError, match="h must act row-wise"):
        # right for one state, rows swapped for a batch
        bf.models.NonlinearGaussian(**{**ok, "h": lambda x: np.sin(np.asarray(x, float)[..., :1])
                                       if np.ndim(x) == 1 else np.sin(np.asarray(x, float)[::-1, :1])})


def test_state_names_and_positions_select_by_name():
    dp, rb = bf.models.damped_particle(), bf.models.range_bearing()
    xs = np.arange(12.0).reshape(3, 4)
    # independent reference: the documented column orders of the two seeds
    np.testing.assert_array_equal(bf.models.positions(dp, xs), xs[:, [0, 2]])
    np.testing.assert_array_equal(bf.models.positions(rb, xs), xs[:, [0, 1]])
    assert dp.index_of("x2_dot") == [3] and rb.index_of("xi_x_dot") == [2]
    with pytest.raises(ValueError, match="unknown state component"):
        dp.index_of("xi_x")
    with pytest.raises(ValueError, match=r"xs must have shape \(\.\.\., 4\)"):
        bf.models.positions(dp, xs[:, :2])
    with pytest.raises(ValueError, match="state_names must be 2 distinct strings"):
        small_model(state_names=("a",))
    with pytest.raises(ValueError, match="position_names must be two of state_names"):
        small_model(state_names=("a", "b"), position_names=("a", "c"))
    assert bf.models.to_nonlinear(dp).position_names == ("x1", "x2")


def _ungm_step(x, t):
    # Arulampalam et al. (2002), eq. for x_k with k = t + 1, written out independently
    return x / 2 + 25 * x / (1 + x ** 2) + 8 * np.cos(1.2 * (t + 1))


def test_ungm_transition_uses_the_time_index():
    model = bf.models.ungm()
    xs = np.array([[-3.0], [0.0], [0.5], [7.0]])
    for t in (0, 1, 5):
        np.testing.assert_allclose(model.transition_mean(xs, t=t), _ungm_step(xs, t), rtol=1e-14)
    # f's Jacobian against central differences
    for x in (-3.0, 0.2, 4.0):
        num = bf.ekf.numerical_jacobian(lambda z: model.transition_functions(3)[0](z), [x])
        np.testing.assert_allclose(model.transition_functions(3)[1]([x]), num, rtol=1e-7)
        np.testing.assert_allclose(model.H([x]), bf.ekf.numerical_jacobian(model.h, [x]), rtol=1e-7)
    # the transition density is N(f(x, t), 10) with the right t
    ref = -0.5 * (np.log(2 * np.pi * 10) + (2.0 - _ungm_step(xs[:, 0], 4)) ** 2 / 10)
    np.testing.assert_allclose(model.transition_logpdf([2.0], xs, t=4), ref, rtol=1e-12)


def test_ungm_simulation_follows_the_equations():
    model = bf.models.ungm()
    T, M = 6, 4000
    sims = bf.models.simulate_many(model, M, T, np.random.default_rng(5))
    # x_{t+1} - f(x_t, t) must be N(0, 10): mean within 5 SE, variance within 5 SE
    w = sims.xs[:, 1:, 0] - _ungm_step(sims.xs[:, :-1, 0], np.arange(T - 1))
    se_mean, se_var = np.sqrt(10 / w.size), 10 * np.sqrt(2 / w.size)
    assert abs(w.mean()) < 5 * se_mean, f"process noise mean {w.mean():.3f} is not 0"
    assert abs(w.var() - 10) < 5 * se_var, f"process noise variance {w.var():.3f} is not 10"
    v = sims.ys[..., 0] - sims.xs[..., 0] ** 2 / 20
    assert abs(v.var() - 1) < 5 * np.sqrt(2 / v.size), f"measurement noise variance {v.var():.3f} is not 1"
    x0 = sims.xs[:, 0, 0]
    assert abs(x0.var() - 5) < 5 * 5 * np.sqrt(2 / M), f"prior variance {x0.var():.3f} is not 5"


def test_time_varying_flag_is_checked():
    ok = _pendulum_parts()
    with pytest.raises(TypeError, match="time_varying must be True or False"):
        bf.models.NonlinearGaussian(**{**ok, "time_varying": "yes"})


def test_state_names_given_as_a_string_are_refused():
    with pytest.raises(TypeError, match="state_names must be a tuple of strings"):
        small_model(state_names="ab")


# --------------------------------------------------------------------------
# Noise factors held by the model (computed once, when it is built)
# --------------------------------------------------------------------------

def test_a_model_cannot_change_so_its_held_factors_stay_valid():
    import dataclasses

    model = small_model()
    with pytest.raises(dataclasses.FrozenInstanceError):
        model.R = [[5.0]]
    for name in ("Q", "R", "P0", "G"):
        with pytest.raises(ValueError, match="read-only"):
            getattr(model, name)[0, 0] = 5.0
    # a changed model is a new model, with its own factors: its densities use the new R
    bigger = dataclasses.replace(model, R=[[5.0]])
    x, y = np.array([[0.3, -0.2]]), np.array([1.0])
    want = multivariate_normal(mean=bigger.C @ x[0], cov=5.0).logpdf(y)
    np.testing.assert_allclose(bigger.measurement_logpdf(y, x), [want], rtol=1e-12)
    # ... and its draws have the new covariance (the same z, scaled by sqrt(5 / 0.2))
    ratio = (bigger.sample_measurement(np.random.default_rng(3), x) - bigger.C @ x[0]) / (
        model.sample_measurement(np.random.default_rng(3), x) - model.C @ x[0])
    np.testing.assert_allclose(ratio, np.sqrt(5.0 / 0.2), rtol=1e-12)


def test_held_factors_give_the_model_covariances():
    model = small_model()
    GL = model._noise_gain_factor
    np.testing.assert_allclose(GL @ GL.T, model.G @ model.Q @ model.G.T, rtol=1e-14, atol=1e-15)
    np.testing.assert_allclose(model._P0_factor @ model._P0_factor.T, model.P0, rtol=1e-14)
    np.testing.assert_allclose(model._R_cholesky_inv @ model._R_cholesky, np.eye(1), rtol=1e-14)
    # a singular G Q G^T (the damped particle's positions have no noise) has no Cholesky factor
    assert bf.models.damped_particle()._GQGt_cholesky is None


def test_densities_with_a_singular_noise_still_raise_a_clear_error():
    # R singular: the model can be built and sampled, but p(y | x) has no density
    model = LG(A=np.eye(2), C=np.eye(2), Q=np.eye(2), R=[[1.0, 1.0], [1.0, 1.0]],
               m0=np.zeros(2), P0=np.eye(2))
    assert model.sample_measurement(np.random.default_rng(0), np.zeros((3, 2))).shape == (3, 2)
    with pytest.raises(ValueError, match=r"R must be positive definite, got smallest eigenvalue"):
        model.measurement_logpdf([0.0, 0.0], np.zeros((3, 2)))
    with pytest.raises(ValueError, match=r"G Q G\^T must be positive definite"):
        bf.models.damped_particle().transition_logpdf(np.zeros((2, 4)), np.zeros((2, 4)))


def test_transition_draws_of_a_scalar_model_are_the_mean_plus_sigma_z():
    # np.dot with a 1 x 1 factor: the draw is f(x) + sqrt(Q) z, z the generator's normals in order
    model = bf.models.ungm(process_var=10.0)
    xs = np.linspace(-3.0, 3.0, 7)[:, None]
    got = model.sample_transition(np.random.default_rng(5), xs, t=2)
    z = np.random.default_rng(5).standard_normal((7, 1))
    np.testing.assert_allclose(got, model.transition_mean(xs, t=2) + np.sqrt(10.0) * z, rtol=1e-14)


def test_range_bearing_model_residual_wraps_the_bearing_and_checks_shapes():
    # independent reference: the range difference as it is, the bearing difference brought
    # into (-pi, pi] by adding or subtracting 2 pi
    model = bf.models.range_bearing()
    rng = np.random.default_rng(3)
    y = np.column_stack([rng.uniform(0, 20, 50), rng.uniform(-np.pi, np.pi, 50)])
    y_pred = np.column_stack([rng.uniform(0, 20, 50), rng.uniform(-np.pi, np.pi, 50)])
    d = y[:, 1] - y_pred[:, 1]
    expected = np.column_stack([y[:, 0] - y_pred[:, 0],
                                np.where(d > np.pi, d - 2 * np.pi, np.where(d <= -np.pi, d + 2 * np.pi, d))])
    np.testing.assert_allclose(model.residual(y, y_pred), expected, rtol=0, atol=1e-12)
    np.testing.assert_allclose(bf.models.range_bearing_residual(y, y_pred), expected, rtol=0, atol=1e-12)
    y_before = y.copy()
    model.residual(y, y_pred)
    np.testing.assert_array_equal(y, y_before)          # the caller's arrays are not changed
    with pytest.raises(ValueError, match=r"y must have shape \(\.\.\., 2\), got shape \(3,\)"):
        model.residual(np.zeros(3), np.zeros(3))
    with pytest.raises(ValueError, match=r"y_pred must have shape \(\.\.\., 2\)"):
        model.residual(np.zeros(2), np.zeros((4, 1)))


# --------------------------------------------------------------------------
# wrap_angle at the ends of (-pi, pi]; the likelihood of observed components
# --------------------------------------------------------------------------

def test_wrap_angle_stays_in_the_half_open_interval_next_to_pi():
    """One ulp above pi, pi - ((pi - a) mod 2 pi) rounds to -pi, outside (-pi, pi]."""
    above = np.nextafter(np.pi, 4.0)
    assert np.pi - np.mod(np.pi - above, 2 * np.pi) == -np.pi   # the naive formula fails
    got = bf.models.wrap_angle(above)
    assert -np.pi < got <= np.pi and got == np.pi   # pi + 1 ulp is the angle pi, to rounding
    assert isinstance(got, np.floating)
    # around every odd multiple of pi, at and one ulp either side, and a few wide angles
    odd = np.array([k * np.pi for k in range(-9, 10, 2)])
    a = np.concatenate([odd, np.nextafter(odd, -np.inf), np.nextafter(odd, np.inf),
                        np.linspace(-50, 50, 2001)])
    w = bf.models.wrap_angle(a)
    assert (w > -np.pi).all() and (w <= np.pi).all()
    # the same angle: w - a is a multiple of 2 pi (to the rounding of a)
    k = (w - a) / (2 * np.pi)
    np.testing.assert_allclose(k, np.round(k), atol=1e-13)
    r = bf.models.range_bearing_residual([1.0, above], [0.0, 0.0])
    assert -np.pi < r[1] <= np.pi


def test_measurement_logpdf_of_the_observed_components_equals_scipy():
    """log p(y_o | x) is N(y_o; C_o x, R_oo), the marginal: scipy on the sub-block."""
    R = np.array([[0.5, 0.2, 0.1], [0.2, 0.4, 0.05], [0.1, 0.05, 0.3]])
    model = LG(A=np.eye(2), C=[[1.0, 0.0], [0.0, 1.0], [1.0, 1.0]], Q=np.eye(2), R=R,
               m0=np.zeros(2), P0=np.eye(2))
    xs = np.random.default_rng(6).standard_normal((5, 2))
    y = np.array([0.3, np.nan, -0.4])
    o = ~np.isnan(y)
    ref = [multivariate_normal(model.C[o] @ x, R[np.ix_(o, o)]).logpdf(y[o]) for x in xs]
    np.testing.assert_allclose(model.measurement_logpdf(y, xs, observed=o), ref, rtol=1e-12)
    one = model.measurement_logpdf(y, xs[0], observed=o)
    assert isinstance(one, float) and one == pytest.approx(ref[0], rel=1e-12)
    # the unobserved entry is not read; all observed is the plain density
    np.testing.assert_array_equal(model.measurement_logpdf(np.where(o, y, 1e9), xs, observed=o),
                                  model.measurement_logpdf(y, xs, observed=o))
    full = np.array([0.3, 0.1, -0.4])
    np.testing.assert_array_equal(model.measurement_logpdf(full, xs, observed=np.ones(3, bool)),
                                  model.measurement_logpdf(full, xs))
    np.testing.assert_array_equal(model.measurement_logpdf(y, xs, observed=np.zeros(3, bool)),
                                  np.zeros(5))


def test_measurement_logpdf_of_the_bearing_alone_is_wrapped():
    model = bf.models.range_bearing()
    xs = np.array([[-5.0, 0.01, 0.0, 0.0], [-5.0, -0.01, 0.0, 0.0]])   # bearing ~ +-pi
    y = np.array([np.nan, -np.pi + 0.001])
    o = np.array([False, True])
    pred = np.arctan2(xs[:, 1], xs[:, 0])
    d = np.angle(np.exp(1j * (y[1] - pred)))          # an independent wrap
    ref = -0.5 * (d ** 2 / model.R[1, 1] + np.log(2 * np.pi * model.R[1, 1]))
    np.testing.assert_allclose(model.measurement_logpdf(y, xs, observed=o), ref, rtol=1e-12)


def test_measurement_logpdf_observed_errors():
    model = bf.models.damped_particle()
    xs = np.zeros((3, 4))
    with pytest.raises(ValueError, match=r"observed must be a boolean mask of shape \(2,\)"):
        model.measurement_logpdf([0.0, 1.0], xs, observed=[0, 1])
    with pytest.raises(ValueError, match=r"observed must be a boolean mask of shape \(2,\)"):
        model.measurement_logpdf([0.0, 1.0], xs, observed=[True])
    with pytest.raises(ValueError,
                       match=r"y must be finite in the observed components, got y\[1\]"):
        model.measurement_logpdf([0.0, np.nan], xs, observed=[True, True])
    singular = LG(A=np.eye(2), C=np.eye(2), Q=np.eye(2), R=[[1.0, 0.0], [0.0, 0.0]],
                  m0=np.zeros(2), P0=np.eye(2))
    with pytest.raises(ValueError, match="R_oo .* must be positive definite"):
        singular.measurement_logpdf([np.nan, 1.0], xs[:, :2], observed=[False, True])
    # the block of the observed components can be definite when R is not
    assert np.isfinite(singular.measurement_logpdf([1.0, np.nan], xs[:, :2],
                                                   observed=np.array([True, False]))).all()
