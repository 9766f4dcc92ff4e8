"""Tests of bayesfilt._checks, the argument checks every public function shares.

References: hand-built matrices whose properties are known in closed form
(a negative diagonal entry, a rank-one matrix whose rounding leaves an
eigenvalue a few ulp below zero).
"""

from __future__ import annotations

import numpy as np
import pytest

from bayesfilt._checks import as_covariance


def test_a_small_negative_variance_next_to_a_large_one_is_refused():
    """diag(1e6, -1e-7) is within the rounding tolerance of the largest entry (1e-12 * 1e6 * 2),
    but a variance cannot be negative at all."""
    with pytest.raises(ValueError, match=r"P must be positive semi-definite, got a negative "
                                         r"variance P\[1, 1\] = -1e-07"):
        as_covariance("P", np.diag([1e6, -1e-7]))
    with pytest.raises(ValueError, match=r"Q\[0, 0\] = -1e-300"):
        as_covariance("Q", np.diag([-1e-300, 1.0]))


def test_rounding_below_zero_in_an_eigenvalue_is_still_accepted():
    """v v^T with v = (1, 1/3, 1e8) is rank one: its two zero eigenvalues come out of eigvalsh
    as about -4e-8 and +4e-8 (rounding relative to the largest entry 1e16), while every
    variance on the diagonal is positive. It must pass."""
    v = np.array([1.0, 1.0 / 3.0, 1e8])
    P = np.outer(v, v)
    assert np.all(np.diag(P) > 0) and np.linalg.eigvalsh(P).min() < 0
    got = as_covariance("P", P)
    np.testing.assert_array_equal(got, P)
    # and a zero variance is a valid (degenerate) variance
    as_covariance("P", np.diag([1.0, 0.0]))


def test_a_negative_eigenvalue_without_negative_variance_is_refused():
    with pytest.raises(ValueError,
                       match="P must be positive semi-definite, got smallest eigenvalue"):
        as_covariance("P", [[1.0, 2.0], [2.0, 1.0]])
