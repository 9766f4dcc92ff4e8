"""Kalman filter (seed 000, section 2). WORK IN PROGRESS: result types only so far."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np


class Prediction(NamedTuple):
    """Predicted Gaussian: ``mean`` (n,) and ``cov`` (n, n). Unpacks as ``x, P``."""

    mean: np.ndarray
    cov: np.ndarray


class Update(NamedTuple):
    """Result of a measurement update.

    mean : (n,) posterior mean; cov : (n, n) posterior covariance;
    gain : (n, m) Kalman gain K; innovation : (m,) y - C x (or residual(y, h(x)));
    innovation_cov : (m, m) S = C P C^T + R; loglik : float, log N(innovation; 0, S).
    """

    mean: np.ndarray
    cov: np.ndarray
    gain: np.ndarray
    innovation: np.ndarray
    innovation_cov: np.ndarray
    loglik: float


class FilterResult(NamedTuple):
    """Output of a filter run over T steps (a leading batch axis M when batched).

    means (T, n) = E[x_t | y_0..y_t]; covs (T, n, n);
    pred_means (T, n) = E[x_t | y_0..y_{t-1}] (pred_means[0] = m0); pred_covs (T, n, n);
    innovations (T, m) and innovation_covs (T, m, m), NaN on rows whose
    measurement is missing (see ``observed``); gains (T, n, m), zero on missing rows;
    step_logliks (T,), 0 on missing rows; loglik: their sum, log p(y_0..y_{T-1});
    observed (T,) bool, False where the row of ys was all NaN.
    """

    means: np.ndarray
    covs: np.ndarray
    pred_means: np.ndarray
    pred_covs: np.ndarray
    innovations: np.ndarray
    innovation_covs: np.ndarray
    gains: np.ndarray
    step_logliks: np.ndarray
    loglik: float | np.ndarray
    observed: np.ndarray
