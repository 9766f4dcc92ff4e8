"""The code examples of the README run as written, and the quick-start result is right.

Reference for the quick start: filterpy 2.0.0's KalmanFilter on the same model
and measurements (seed 000's time convention: update with ys[0] first, then
predict/update; filterpy has no noise gain, so its Q is G Q G^T).
"""

from __future__ import annotations

import re
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import numpy as np  # noqa: E402
from filterpy.kalman import KalmanFilter  # noqa: E402

README = Path(__file__).resolve().parents[1] / "README.md"


def test_readme_python_examples_run():
    blocks = re.findall(r"```python\n(.*?)```", README.read_text(encoding="utf-8"), re.S)
    assert blocks, "the README has no python example"
    for block in blocks:
        namespace: dict = {}
        exec(compile(block, str(README), "exec"), namespace)  # noqa: S102 - our own README
    model, ys, result = namespace["model"], namespace["ys"], namespace["result"]
    assert result.means.shape == (200, 4) and result.covs.shape == (200, 4, 4)

    kf = KalmanFilter(dim_x=model.state_dim, dim_z=model.obs_dim)
    kf.F, kf.H, kf.R = np.array(model.A), np.array(model.C), np.array(model.R)
    kf.Q = model.G @ model.Q @ model.G.T
    kf.x, kf.P = np.array(model.m0), np.array(model.P0)
    means, covs, loglik = [], [], 0.0
    for t, y in enumerate(ys):
        if t > 0:
            kf.predict()
        kf.update(y)
        means.append(kf.x.copy())
        covs.append(kf.P.copy())
        loglik += kf.log_likelihood
    # Tolerance: both compute the same recursion in double precision, in different orders
    # (Cholesky solve vs explicit inverse); 200 steps of a stable filter stay far below 1e-9.
    np.testing.assert_allclose(result.means, means, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(result.covs, covs, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(result.loglik, loglik, rtol=1e-9)
