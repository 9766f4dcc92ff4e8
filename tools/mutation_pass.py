"""Mutation pass over the library: does the unit-test suite catch every one-line bug?

Usage (from the repository root, in the course environment)::

    python tools/mutation_pass.py                 # every mutation, then the table
    python tools/mutation_pass.py K05 P01         # only these
    python tools/mutation_pass.py --list          # the mutations, without running

Each mutation in ``MUTATIONS`` below replaces one line (a unique piece of
text) of a library file by a wrong version: a sign flip, a transpose, an
off-by-one, ``<`` for ``<=``, a dropped symmetrisation or term, a wrong axis.
For each, the script writes the mutant over the file, runs the library's
unit tests alone (``pytest -n 0 -x`` on ``TEST_FILES``, not the notebooks),
and puts the original file back (also on Ctrl-C, and it checks at the end
that every file is byte for byte what it was). A mutant is *caught* when
the tests fail (or exceed ``--timeout``), and *survives* when they pass.
The table at the end lists every mutation, its verdict and the first
failing test; the exit status is 1 if a mutation listed in issue 20 (marked
``issue``) survives or the score is below 95 %.

The text of a mutation must occur exactly once in its file; after an edit
of the library, a mutation whose text is gone is reported as ``stale``
(fix its text here), never silently skipped. The pass runs on the files of
the working tree: commit or stash nothing, it restores what it changes.
"""

from __future__ import annotations

import argparse
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import NamedTuple

ROOT = Path(__file__).resolve().parents[1]
TEST_FILES = ["tests/test_kalman.py", "tests/test_ekf.py", "tests/test_gaussian.py",
              "tests/test_particle.py", "tests/test_resampling.py", "tests/test_models.py",
              "tests/test_bayes.py"]


class Mutation(NamedTuple):
    id: str
    file: str           # relative to the repository root
    old: str            # a piece of text that occurs exactly once in the file
    new: str            # what it becomes
    what: str           # the bug, in words
    issue: bool = False  # listed in issue 20 (must be caught)


K, E, G, P, R, M = ("bayesfilt/kalman.py", "bayesfilt/ekf.py", "bayesfilt/gaussian.py",
                    "bayesfilt/particle.py", "bayesfilt/resampling.py", "bayesfilt/models.py")

MUTATIONS = [
    # --- bf.kalman ---------------------------------------------------------------
    Mutation("K01", K, "    return x, 0.5 * (P + P.mT)", "    return x, P",
             "predict: P no longer symmetrised", issue=True),
    Mutation("K02", K, "    P = A @ P @ A.T + GQGt", "    P = A @ P @ A + GQGt",
             "predict: A P A instead of A P A^T"),
    Mutation("K03", K, "        x = x + Bu", "        x = x - Bu",
             "predict: control input with the wrong sign"),
    Mutation("K04", K, "    P = A @ P @ A.T + GQGt", "    P = A @ P @ A.T",
             "predict: process noise G Q G^T dropped"),
    Mutation("K05", K, "safe = L.diagonal(0, -2, -1) ** 2 > S.shape[-1] * _EPS",
             "safe = L.diagonal(0, -2, -1) > S.shape[-1] * _EPS",
             "singularity test: pivot unsquared", issue=True),
    Mutation("K06", K, "safe = L.diagonal(0, -2, -1) ** 2 > S.shape[-1] * _EPS",
             "safe = L.diagonal(0, -2, -1) ** 2 > _EPS",
             "singularity test: threshold eps instead of m eps"),
    Mutation("K07", K, "    K = Kt.mT\n", "    K = Kt\n",
             "gain transposed (K^T for K, same shape when n = m)", issue=True),
    Mutation("K08", K, "    P_post = IKC @ P @ IKC.mT + K @ R @ Kt",
             "    P_post = IKC @ P @ IKC.mT",
             "Joseph form: the K R K^T term dropped"),
    Mutation("K09", K, "    return K, S, L, 0.5 * (P_post + P_post.mT)",
             "    return K, S, L, P_post",
             "update: P no longer symmetrised"),
    Mutation("K10", K, "    IKC = eye_n - K @ C", "    IKC = eye_n + K @ C",
             "Joseph form: I + K C"),
    Mutation("K11", K, "    x_post = x + K @ r", "    x_post = x - K @ r",
             "update: mean moves against the innovation"),
    Mutation("K12", K, "z @ z + 2.0 * np.log(L.diagonal()).sum()",
             "z @ z + np.log(L.diagonal()).sum()",
             "log-likelihood: log det S halved"),
    Mutation("K13", K, "z @ z + 2.0 * np.log(L.diagonal()).sum() + r.shape[0] * LOG_2PI",
             "z @ z + 2.0 * np.log(L.diagonal()).sum()",
             "log-likelihood: m log 2 pi dropped"),
    Mutation("K14", K, "x, P = _predict(x, P, A, GQGt, None if us is None else B @ us[t - 1])",
             "x, P = _predict(x, P, A, GQGt, None if us is None else B @ us[t])",
             "kalman_filter: input u_t instead of u_{t-1} (off by one)"),
    Mutation("K15", K, "    return C[o], R[np.ix_(o, o)]", "    return C[o], R[:o.sum(), :o.sum()]",
             "partly missing: the leading block of R instead of R_oo"),
    Mutation("K16", K, "    K_full = np.zeros(K.shape[:-1] + (m,))",
             "    K_full = np.full(K.shape[:-1] + (m,), np.nan)",
             "partly missing: NaN gain columns instead of the documented zeros"),
    Mutation("K17", K, "                x = x + r @ K[0].T", "                x = x + r @ K[0]",
             "batch: transposed gain in the mean update"),
    Mutation("K18", K, "slot = (np.cumsum(obs) - 1)[which[seq]]", "slot = which[seq]",
             "batch: a sequence's pattern index not mapped to the measuring patterns"),
    Mutation("K19", K, "                slot = np.searchsorted(pats, which[seq])",
             "                slot = which[seq] % len(pats)",
             "batch, partly missing: wrong gain slot for a sequence"),
    Mutation("K20", K, "            innovations[t] = r\n            sets, group",
             "            sets, group",
             "batch, partly missing: innovations not recorded"),
    Mutation("K21", K, "    cov = IKC @ P @ IKC.T + K @ R @ K.T", "    cov = IKC @ P @ IKC.T",
             "steady_state: K R K^T dropped from the filtered covariance"),
    Mutation("K22", K, "    return FilterResult(means, covs, pred_means, pred_covs, innovations, "
             "innovation_covs,\n                        gains, step_logliks, "
             "float(step_logliks.sum()), observed, components)",
             "    return FilterResult(means, covs, pred_means, pred_covs, innovations, "
             "innovation_covs,\n                        gains, step_logliks, "
             "float(step_logliks[1:].sum()), observed, components)",
             "kalman_filter: loglik misses step 0 (off by one)"),
    Mutation("K23", "bayesfilt/_checks.py", "    return components.any(axis=-1), components",
             "    return components.all(axis=-1), components",
             "observed: a partly-missing row counted as missing"),
    # --- bf.ekf --------------------------------------------------------------------
    Mutation("E01", E, "        P_pred = Fx @ P @ Fx.T + GQGt",
             "        P_pred = Fx @ P @ Fx + GQGt",
             "EKF predict: F P F instead of F P F^T"),
    Mutation("E02", E, "    P_pred = 0.5 * (P_pred + P_pred.T)  # remove",
             "    P_pred = P_pred  # remove",
             "EKF predict: P no longer symmetrised"),
    Mutation("E03", E, "                f, F = model.transition_functions(t - 1)",
             "                f, F = model.transition_functions(t)",
             "EKF: steps into t with f_t instead of f_{t-1}"),
    Mutation("E04", E, "lambda _: residual(y.copy(), y_pred.copy())",
             "lambda _: residual(y_pred.copy(), y.copy())",
             "EKF: residual arguments swapped"),
    Mutation("E05", E, "        innovation = y - y_pred", "        innovation = y_pred - y",
             "EKF: innovation with the wrong sign"),
    Mutation("E06", E, "        K, innovation, S = _embed(o, K, r, S)",
             "        K, _, S = _embed(o, K, r, S)",
             "EKF, partly missing: innovation recorded as 0, not NaN, where missing"),
    Mutation("E07", E, "    Fx = _call(\"ekf.predict\", \"Jacobian F\", F, x, (n, n))\n"
             "    # x_{t+1|t} = f(x_{t|t}): the mean goes through the nonlinear function itself.\n"
             "    x_pred = _call(\"ekf.predict\", \"f\", f, x, (n,))",
             "    x_pred = _call(\"ekf.predict\", \"f\", f, x, (n,))\n"
             "    Fx = _call(\"ekf.predict\", \"Jacobian F\", F, x_pred, (n, n))",
             "EKF predict: Jacobian at the predicted mean instead of the filtered one"),
    Mutation("E08", E, "(_call(where, \"fun\", g, up, f0.shape) "
             "- _call(where, \"fun\", g, down, f0.shape))",
             "(_call(where, \"fun\", g, up, f0.shape) - f0)",
             "numerical_jacobian: one-sided difference over a two-sided step"),
    # An equivalent mutant, kept to show it: a missing entry of y is given any finite
    # value before residual() is called, and its residual is dropped; for a residual that
    # acts component by component (the documented requirement) the value cannot matter.
    Mutation("E09", E, "        y = np.where(o, y, y_pred)", "        y = np.where(o, y, 0.0)",
             "EKF, partly missing: missing entries filled with 0, not the prediction "
             "(equivalent)"),
    # --- bf.gaussian --------------------------------------------------------------
    Mutation("G01", G, "    mean = mean_x + W @ (y - mean_y)",
             "    mean = mean_x - W @ (y - mean_y)",
             "condition: mean moves the wrong way"),
    Mutation("G02", G, "    cov = cov_xx - W @ cov_xy.T", "    cov = cov_xx - W @ cov_xy",
             "condition: C_xy instead of C_yx"),
    Mutation("G03", G, "    cov = 0.5 * (cov + cov.T)\n    return Gaussian(mean, cov)",
             "    return Gaussian(mean, cov)",
             "condition: covariance no longer symmetrised"),
    Mutation("G04", G, "    log_det = 2.0 * np.log(L.diagonal(0, -2, -1)).sum(axis=-1)",
             "    log_det = np.log(L.diagonal(0, -2, -1)).sum(axis=-1)",
             "logpdf: log det halved"),
    Mutation("G05", G, "    maha *= -0.5", "    maha *= 0.5", "logpdf: sign"),
    Mutation("G06", G, "    out = np.sum(z * z, axis=-1)", "    out = np.sum(z, axis=-1) ** 2",
             "squared_mahalanobis: (sum z)^2 instead of sum z^2"),
    Mutation("G07", G, "    low = stats.chi2.ppf(0.5 * alpha, total) / n_runs",
             "    low = stats.chi2.ppf(alpha, total) / n_runs",
             "chi2_interval: one-sided lower bound"),
    Mutation("G08", G, "    d = a - a.mean(axis=0)", "    d = a - a.mean()",
             "autocorrelation: mean over all columns (wrong axis)"),
    Mutation("G09", G, "    return np.linalg.solve(L, r[..., None])[..., 0]",
             "    return np.linalg.solve(L.mT, r[..., None])[..., 0]",
             "normalised_innovations: L^{-T} r instead of L^{-1} r"),
    Mutation("G10", G, "    return mean + z @ _factor(cov).T", "    return mean + z @ _factor(cov)",
             "sample: z L instead of z L^T"),
    Mutation("G11", G, "        return vecs * np.sqrt(np.clip(vals, 0.0, None))",
             "        return vecs * np.clip(vals, 0.0, None)",
             "singular factor: variances instead of standard deviations"),
    # --- bf.particle -------------------------------------------------------------
    Mutation("P01", P, "        ess_t[t] = 1.0 / np.sum(W ** 2)",
             "        ess_t[t] = 1.0 / np.max(W)",
             "particle_filter: ESS recorded as 1 / max W", issue=True),
    Mutation("P02", P, "    return shifted - log_rest, float(m + log_rest)",
             "    return shifted - log_rest, float(log_rest)",
             "log_normalize: log-sum without the max m"),
    Mutation("P03", P, "    return shifted - log_rest, float(m + log_rest)",
             "    return shifted + log_rest, float(m + log_rest)",
             "log_normalize: + log_rest"),
    Mutation("P04", P, "            log_W = np.full(N, -np.log(N))\n"
             "            resampled[t] = True",
             "            log_W = log_W[parents]\n            resampled[t] = True",
             "resampling: weights not reset to 1/N"),
    Mutation("P05", P, "        X_new = model.sample_transition(rng, X, u, t - 1)\n"
             "        return X_new, _log_likelihood",
             "        X_new = model.sample_transition(rng, X, u, t)\n"
             "        return X_new, _log_likelihood",
             "bootstrap: the transition of step t instead of t - 1"),
    Mutation("P06", P, "+ model.transition_logpdf(X_new, X, u, t - 1) - log_q)",
             "+ model.transition_logpdf(X_new, X, u, t - 1) + log_q)",
             "eq. (13): + log q"),
    Mutation("P07", P, "    Dt = Xt - mean[:, None]", "    Dt = Xt",
             "weighted covariance not centred"),
    Mutation("P08", P, "    cov = np.einsum(\"ji,ki->jk\", Dt * W, Dt)",
             "    cov = np.einsum(\"ji,ki->jk\", Dt, Dt) / W.shape[0]",
             "weighted covariance without the weights"),
    Mutation("P09", P, "* N ** (-1.0 / n)", "* N ** (1.0 / n)", "roughening: N^(1/n)"),
    Mutation("P10", P, "        Sigma = (eye_n - K @ C_o) @ Qt", "        Sigma = Qt",
             "optimal proposal: the prior covariance, not the conditional one"),
    Mutation("P11", P, "        return pred + (y[o] - pred @ C_o.T) @ K.T",
             "        return pred + (y[o] - x_prev @ C_o.T) @ K.T",
             "optimal proposal: innovation of x_{t-1} instead of A x_{t-1}"),
    Mutation("P12", P, "    if total == np.inf:\n        w = w / w.max()",
             "    if False:\n        w = w / w.max()",
             "ess / weighted_mean_cov: overflow guard dropped"),
    Mutation("P13", P, "    if not abs(log_sum) <= LOG_WEIGHTS_TOL:",
             "    if not abs(log_sum) <= 1.0:",
             "sis_step: loose normalisation check"),
    Mutation("P14", P, "            X = X[parents]\n", "            X = X\n",
             "resampling: particles not replaced by their ancestors"),
    Mutation("P15", P, "        o = None if full[t] else components[t]",
             "        o = None if full[t] else ~components[t]",
             "particle filter, partly missing: the mask inverted"),
    Mutation("P16", P, "        if threshold == 1.0 or ess_t[t] < threshold * N:",
             "        if threshold == 1.0 or ess_t[t] < threshold:",
             "resampling threshold a number of particles, not a fraction"),
    Mutation("P17", P, "        if threshold == 1.0 or ess_t[t] < threshold * N:",
             "        if threshold == 1.0 or ess_t[t] <= threshold * N:",
             "resampling also at ESS = threshold * N (<= for <)"),
    # --- bf.resampling -----------------------------------------------------------
    Mutation("R01", R, "    below += u_k < frac", "    below += u_k <= frac",
             "boundary rule <= instead of <", issue=True),
    Mutation("R02", R, "    MC /= MC[-1]", "    MC /= np.sum(w)",
             "cumulative weights divided by the pairwise sum (C_{N-1} may fall short of 1)"),
    Mutation("R03", R, "    counts = rng.multinomial(M, w / total)",
             "    counts = rng.multinomial(M, np.full(w.shape[0], 1.0 / w.shape[0]))",
             "multinomial: uniform probabilities"),
    Mutation("R04", R, "        rest = np.maximum(MW - counts, 0.0)",
             "        rest = np.maximum(w / total - counts, 0.0)",
             "residual: filterpy's residuals W - floor(M W)"),
    Mutation("R05", R, "    counts = np.floor(MW * (1.0 + 64 * np.finfo(float).eps))",
             "    counts = np.floor(MW)",
             "residual: exact floor (equal weights lose their copies)"),
    Mutation("R06", R, "    return _expand(_below(w, M, rng.random()), M)",
             "    return _expand(_below(w, M, rng.random(M)), M)",
             "systematic: one uniform per stratum (stratified)"),
    Mutation("R07", R, "    how_many = np.bincount(below, minlength=M + 1)[:M]",
             "    how_many = np.bincount(below, minlength=M + 1)[1:M + 1]",
             "_expand: off by one"),
    Mutation("R08", R, "        w = w / w.max()\n        total = float(np.sum(w))",
             "        total = float(np.sum(w))",
             "weights whose sum overflows not rescaled"),
    Mutation("R09", R, "    if not (u.min() >= 0.0 and u.max() < 1.0):",
             "    if not (u.min() >= 0.0 and u.max() <= 1.0):",
             "from_uniforms accepts u = 1"),
    # --- bf.models (the likelihood of observed components, the angle) ------------
    Mutation("M01", M, "        L = _cholesky("
             "\"R_oo (the block of R of the observed components)\", "
             "self.R[np.ix_(o, o)])",
             "        L = _cholesky(\"R_oo (the block of R of the observed components)\", "
             "np.diag(np.diag(self.R)[o]))",
             "marginal likelihood: R_oo without its correlations"),
    Mutation("M02", M, "    return np.where(out <= -np.pi, np.pi, out)[()]", "    return out",
             "wrap_angle: -pi one ulp above pi"),
]


def _run_tests(timeout: float) -> tuple[bool, str, float]:
    """(passed, first failing test or reason, seconds) of the unit tests."""
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    cmd = [sys.executable, "-m", "pytest", "-n", "0", "-x", "-q", "-p", "no:cacheprovider",
           "--no-header", "-rf", *TEST_FILES]
    start = time.perf_counter()
    try:
        out = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True,
                             timeout=timeout)
    except subprocess.TimeoutExpired:
        return False, f"timeout after {timeout:.0f} s", time.perf_counter() - start
    seconds = time.perf_counter() - start
    if out.returncode == 0:
        return True, "", seconds
    failed = re.search(r"^FAILED (\S+)", out.stdout, re.M)
    error = re.search(r"^ERROR (\S+)", out.stdout, re.M)
    first = failed or error
    return False, first.group(1) if first else f"pytest exit {out.returncode}", seconds


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("ids", nargs="*", help="run only these mutations (e.g. K05 P01)")
    parser.add_argument("--list", action="store_true", help="list the mutations and exit")
    parser.add_argument("--timeout", type=float, default=600.0,
                        help="seconds per test run; a mutant that exceeds it counts as caught")
    args = parser.parse_args(argv)
    chosen = [m for m in MUTATIONS if not args.ids or m.id in args.ids]
    unknown = set(args.ids) - {m.id for m in MUTATIONS}
    if unknown:
        parser.error(f"unknown mutation id(s): {sorted(unknown)}")
    if args.list:
        for m in chosen:
            print(f"{m.id}  {m.file:24s} {'[issue] ' if m.issue else ''}{m.what}")
        return 0

    originals = {f: (ROOT / f).read_bytes() for f in {m.file for m in chosen}}

    def restore(*_):
        for f, data in originals.items():
            (ROOT / f).write_bytes(data)

    def interrupted(signum, frame):
        restore()
        raise SystemExit(f"interrupted (signal {signum}); every file restored")

    signal.signal(signal.SIGINT, interrupted)
    signal.signal(signal.SIGTERM, interrupted)

    passed, why, seconds = _run_tests(args.timeout)
    print(f"baseline: unit tests {'pass' if passed else 'FAIL (' + why + ')'} in {seconds:.1f} s")
    if not passed:
        return 2
    rows = []
    try:
        for m in chosen:
            text = originals[m.file].decode()
            count = text.count(m.old)
            if count != 1:
                rows.append((m, "stale", f"text found {count} times", 0.0))
                print(f"{m.id} stale ({count} occurrences)", flush=True)
                continue
            (ROOT / m.file).write_text(text.replace(m.old, m.new))
            try:
                passed, why, seconds = _run_tests(args.timeout)
            finally:
                restore()
            verdict = "SURVIVED" if passed else "caught"
            rows.append((m, verdict, why, seconds))
            print(f"{m.id} {verdict:8s} {seconds:5.1f} s  {why}", flush=True)
    finally:
        restore()
    for f, data in originals.items():
        assert (ROOT / f).read_bytes() == data, f"{f} was not restored"

    print("\n| id | file | mutation | verdict | first failing test |")
    print("| --- | --- | --- | --- | --- |")
    for m, verdict, why, _ in rows:
        what = m.what + (" (issue 20)" if m.issue else "")
        print(f"| {m.id} | {Path(m.file).name} | {what} | {verdict} | {why.replace('|', '/')} |")
    run = [r for r in rows if r[1] != "stale"]
    caught = sum(r[1] == "caught" for r in run)
    issue_survivors = [r[0].id for r in run if r[1] == "SURVIVED" and r[0].issue]
    stale = [r[0].id for r in rows if r[1] == "stale"]
    score = caught / len(run) if run else 0.0
    print(f"\ncaught {caught} of {len(run)} mutations ({100 * score:.1f} %); "
          f"survivors: {[r[0].id for r in run if r[1] == 'SURVIVED'] or 'none'}; "
          f"issue-20 survivors: {issue_survivors or 'none'}; stale: {stale or 'none'}")
    return 1 if issue_survivors or stale or score < 0.95 else 0


if __name__ == "__main__":
    sys.exit(main())
