"""Benchmark: bf.kalman against filterpy 2.0.0 on seed 000's damped particle.

Run from the repository root:

    python benchmarks/bench_kalman.py

1. One long run (T = 10^4): bf.kalman.kalman_filter against a filterpy
   KalmanFilter predict/update loop that stores the same outputs (means,
   covariances, predictions, innovations and their covariances, gains,
   per-step log-likelihoods). kalman_filter always computes the
   log-likelihood, so the like-for-like comparison reads filterpy's
   ``log_likelihood`` every step; filterpy without it is shown as well.
   Then the same with 50 % of the rows missing at random.
2. Many short runs (M = 1000 sequences of T = 100): bf.kalman.batch_kalman_filter
   against M sequential filterpy runs (the same outputs, log-likelihood
   included; also shown without). filterpy is timed on a subset of the
   sequences and scaled to M (it costs the same for every sequence). Then
   30 % of the components missing at random (partly-missing rows, which
   filterpy cannot filter): the batch against M calls of kalman_filter.

kalman_filter is one plain loop of the same kernels as bf.kalman.predict and
bf.kalman.update, so every step is computed in full, whatever the data.

Each timing is the best of a few repeats, in CPU time of the process
(time.process_time; ``--wall`` for time.perf_counter), which the other jobs
of a shared machine disturb less than wall-clock time; in part 1 the
three loops are called in turn within each repeat, so that a burst of load
on a shared machine hits them alike. Before timing, the script checks that
both libraries give the same numbers. The load average is printed at the
start and at the end, and which bayesfilt was imported (to time an older
version, put its folder first on PYTHONPATH).
"""

from __future__ import annotations

import os
import platform
import sys
import time

import numpy as np
import scipy
from filterpy.kalman import KalmanFilter

import bayesfilt as bf

CLOCK = time.perf_counter if "--wall" in sys.argv[1:] else time.process_time
T_LONG = 10_000
M, T_SHORT = 1000, 100
FILTERPY_SUBSET = 50
REPEATS = 5


def best_time(fun, repeats=REPEATS):
    best = np.inf
    for _ in range(repeats):
        start = CLOCK()
        fun()
        best = min(best, CLOCK() - start)
    return best


def best_times_interleaved(funs, repeats=REPEATS):
    """Best time of each function, calling them in turn within each repeat."""
    best = {name: np.inf for name in funs}
    for _ in range(repeats):
        for name, fun in funs.items():
            start = CLOCK()
            fun()
            best[name] = min(best[name], CLOCK() - start)
    return best


def load_average():
    return ", ".join(f"{x:.2f}" for x in os.getloadavg())


def compare(t_bf, t_other):
    """'bf is 3.9x faster' or 'bf is 1.3x slower'."""
    r = t_other / t_bf
    return f"bf is {r:.1f}x faster" if r >= 1 else f"bf is {1 / r:.1f}x slower"


def filterpy_run(model, ys, loglik=True):
    """filterpy on seed 000's time convention (update ys[0] first), storing what bf returns."""
    T, n, m = len(ys), model.state_dim, model.obs_dim
    kf = KalmanFilter(dim_x=n, dim_z=m)
    kf.F = model.A.copy()
    kf.H = model.C.copy()
    kf.Q = model.G @ model.Q @ model.G.T
    kf.R = model.R.copy()
    kf.x = model.m0.copy()
    kf.P = model.P0.copy()
    means, covs = np.empty((T, n)), np.empty((T, n, n))
    pred_means, pred_covs = np.empty((T, n)), np.empty((T, n, n))
    innovations, innovation_covs = np.empty((T, m)), np.empty((T, m, m))
    gains, step_logliks = np.empty((T, n, m)), np.zeros(T)
    for t in range(T):
        if t > 0:
            kf.predict()
        pred_means[t] = kf.x
        pred_covs[t] = kf.P
        if np.isnan(ys[t, 0]):  # missing measurement: prediction only
            means[t], covs[t] = kf.x, kf.P
            innovations[t], innovation_covs[t], gains[t] = np.nan, np.nan, 0.0
            continue
        kf.update(ys[t])
        means[t] = kf.x
        covs[t] = kf.P
        innovations[t] = kf.y
        innovation_covs[t] = kf.S
        gains[t] = kf.K
        if loglik:
            step_logliks[t] = kf.log_likelihood
    out = dict(means=means, covs=covs, pred_means=pred_means, pred_covs=pred_covs,
               innovations=innovations, innovation_covs=innovation_covs, gains=gains,
               step_logliks=step_logliks)
    if loglik:
        out["loglik"] = step_logliks.sum()
    return out


def check_same(ours, ref, label):
    worst = 0.0
    for key, want in ref.items():
        got = np.asarray(getattr(ours, key))
        if not np.allclose(got, want, rtol=1e-9, atol=1e-10, equal_nan=True):
            raise SystemExit(f"{label}: {key} differs from filterpy "
                             f"(max abs difference {np.max(np.abs(got - want)):.3g})")
        worst = max(worst, float(np.nanmax(np.abs(got - want))))
    print(f"  check {label}: all fields equal to filterpy, max abs difference {worst:.1e}")


class FilterResultRow:
    """Sequence i of a batched FilterResult, with attribute access like FilterResult."""

    def __init__(self, result, i):
        self._result, self._i = result, i

    def __getattr__(self, key):
        return np.asarray(getattr(self._result, key))[self._i]


def per_step(seconds, T):
    return f"{seconds / T * 1e6:7.2f} us/step"


def main():
    print(f"machine: {os.cpu_count()} CPUs (nproc), {platform.machine()}, "
          f"{platform.system()} {platform.release()}")
    print(f"python {sys.version.split()[0]}, numpy {np.__version__}, scipy {scipy.__version__}, "
          f"filterpy 2.0.0, OPENBLAS_NUM_THREADS={os.environ.get('OPENBLAS_NUM_THREADS', 'unset')}")
    print(f"bayesfilt imported from {os.path.dirname(bf.__file__)}")
    print("timings: " + ("wall-clock" if CLOCK is time.perf_counter else "CPU time of the process")
          + ", best of k")
    print(f"load average (1, 5, 15 min) at start: {load_average()}")
    model = bf.models.damped_particle()
    rng = np.random.default_rng(2024)

    # 1. One long run ------------------------------------------------------
    ys = bf.models.simulate(model, T_LONG, rng).ys
    ys_gappy = ys.copy()
    ys_gappy[rng.random(T_LONG) < 0.5] = np.nan
    print(f"\n1. one run, damped particle, T = {T_LONG}")
    for label, data in (("all rows observed", ys), ("50 % of the rows missing at random",
                                                     ys_gappy)):
        print(f"  {label}:")
        check_same(bf.kalman.kalman_filter(model, data), filterpy_run(model, data),
                   "kalman_filter")
        best = best_times_interleaved({
            "bf": lambda: bf.kalman.kalman_filter(model, data),
            "fp_ll": lambda: filterpy_run(model, data, loglik=True),
            "fp": lambda: filterpy_run(model, data, loglik=False)})
        t_bf, t_fp_ll, t_fp = best["bf"], best["fp_ll"], best["fp"]
        print(f"  bf.kalman.kalman_filter (log-likelihood included): {per_step(t_bf, T_LONG)}")
        print(f"  filterpy + log_likelihood (the same outputs):      {per_step(t_fp_ll, T_LONG)}"
              f"  -> {compare(t_bf, t_fp_ll)}")
        print(f"  filterpy without log_likelihood:                   {per_step(t_fp, T_LONG)}"
              f"  -> {compare(t_bf, t_fp)}")

    # 2. Many short runs ---------------------------------------------------
    ys_many = np.stack([bf.models.simulate(model, T_SHORT, rng).ys for _ in range(M)])
    print(f"\n2. {M} runs of T = {T_SHORT}")
    batch = bf.kalman.batch_kalman_filter(model, ys_many)
    for i in (0, M // 2, M - 1):
        ref = filterpy_run(model, ys_many[i])
        check_same(FilterResultRow(batch, i), ref, f"batch_kalman_filter, sequence {i}")
    t_batch = best_time(lambda: bf.kalman.batch_kalman_filter(model, ys_many))
    t_sub_ll = best_time(lambda: [filterpy_run(model, ys_many[i], loglik=True)
                                  for i in range(FILTERPY_SUBSET)], repeats=3)
    t_sub = best_time(lambda: [filterpy_run(model, ys_many[i], loglik=False)
                               for i in range(FILTERPY_SUBSET)], repeats=3)
    t_fp_ll, t_fp = (t * M / FILTERPY_SUBSET for t in (t_sub_ll, t_sub))
    print(f"  bf.kalman.batch_kalman_filter, all {M}:               {t_batch * 1e3:8.2f} ms")
    print(f"  filterpy + log_likelihood, {FILTERPY_SUBSET} runs timed, scaled: "
          f"{t_fp_ll * 1e3:8.2f} ms"
          f"  -> bf batch is {t_fp_ll / t_batch:.0f}x faster")
    print(f"  filterpy without it, {FILTERPY_SUBSET} runs timed, scaled:     {t_fp * 1e3:8.2f} ms"
          f"  -> bf batch is {t_fp / t_batch:.0f}x faster")
    # Different missing patterns per sequence: the covariances are computed once per
    # distinct pattern, vectorised over the patterns.
    ys_mixed = ys_many.copy()
    ys_mixed[rng.random((M, T_SHORT)) < 0.02] = np.nan
    n_patterns = np.unique(~np.isnan(ys_mixed[..., 0]), axis=0).shape[0]
    check_same(FilterResultRow(bf.kalman.batch_kalman_filter(model, ys_mixed), 1),
               filterpy_run(model, ys_mixed[1]), "batch_kalman_filter, 2 % missing, sequence 1")
    t_mixed = best_time(lambda: bf.kalman.batch_kalman_filter(model, ys_mixed), repeats=3)
    print(f"  bf batch with 2 % rows missing at random ({n_patterns} distinct patterns): "
          f"{t_mixed * 1e3:8.2f} ms ({t_fp_ll / t_mixed:.0f}x faster than filterpy + "
          f"log_likelihood, {t_fp / t_mixed:.0f}x without)")
    # Partly-missing rows (a sensor drops out): filterpy cannot filter them, so the peer
    # is bf.kalman.kalman_filter called once per sequence. Every sequence has its own
    # pattern; at each step the batch groups the patterns by the set of components they
    # observe (at most 2^m - 1 groups).
    ys_partly = ys_many.copy()
    ys_partly[rng.random(ys_partly.shape) < 0.3] = np.nan
    batch = bf.kalman.batch_kalman_filter(model, ys_partly)
    worst = 0.0
    for i in (0, M // 2, M - 1):
        one = bf.kalman.kalman_filter(model, ys_partly[i])
        for key in ("means", "covs", "innovations", "gains", "step_logliks"):
            got, want = np.asarray(getattr(batch, key))[i], getattr(one, key)
            if not np.allclose(got, want, rtol=1e-9, atol=1e-10, equal_nan=True):
                raise SystemExit(f"batch_kalman_filter, 30 % components missing: {key} differs")
            worst = max(worst, float(np.nanmax(np.abs(got - want))))
    print(f"  check batch_kalman_filter, 30 % components missing: equal to kalman_filter, "
          f"max abs difference {worst:.1e}")
    t_partly = best_time(lambda: bf.kalman.batch_kalman_filter(model, ys_partly), repeats=3)
    t_loop = best_time(lambda: [bf.kalman.kalman_filter(model, ys_partly[i])
                                for i in range(FILTERPY_SUBSET)], repeats=3) * M / FILTERPY_SUBSET
    print(f"  bf batch with 30 % of the components missing at random ({M} patterns): "
          f"{t_partly * 1e3:8.2f} ms; {M} calls of kalman_filter ({FILTERPY_SUBSET} timed, "
          f"scaled): {t_loop * 1e3:8.2f} ms -> batch {t_loop / t_partly:.0f}x faster")
    print(f"\nload average (1, 5, 15 min) at end: {load_average()}")


if __name__ == "__main__":
    main()
