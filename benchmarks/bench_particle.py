"""Benchmark: a whole bootstrap particle filter on UNGM, bayesfilt against `particles`.

Usage, from the repository root::

    python benchmarks/bench_particle.py            # N = 10^4, 10^5, 10^6
    python benchmarks/bench_particle.py --quick    # N = 10^4, 10^5
    python benchmarks/bench_particle.py --wall     # wall-clock instead of CPU time

The peer is `particles` (N. Chopin's SMC library, numba-based; the
reference implementation of Chopin & Papaspiliopoulos, 2020). It pins
numpy below 2, so it cannot live in the course environment: build it a
virtual environment of its own once,

    python3 -m venv benchmarks/.particles-venv
    benchmarks/.particles-venv/bin/pip install particles==0.4

(or point ``PARTICLES_PYTHON`` at a Python that has it). This script runs it
there in a subprocess and skips the comparison, saying so, when it is absent.

Both filters run the same problem: the UNGM of ``bf.models.ungm()`` (same
time index in the cosine, same prior), the same T = 50 measurements, the
bootstrap proposal, systematic resampling at every step, and the weighted
mean and variance of the particles at every step (``particles``:
``collect=[Moments()]``). Each figure is the best of a few runs, the two
libraries interleaved in one session so that the ratio is measured under the
same machine load (two rounds of each at every N). The time is the CPU time
of the process (time.process_time, which counts every thread of it, OpenBLAS's
too), which the other jobs of a shared machine disturb less than wall-clock
time; ``--wall`` uses time.perf_counter.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np

import bayesfilt as bf

ROOT = Path(__file__).resolve().parents[1]
T = 50
CLOCK = time.perf_counter if "--wall" in sys.argv[1:] else time.process_time

PEER_SCRIPT = textwrap.dedent("""
    import json, sys, time
    import numpy as np
    import particles
    from particles import distributions as dists, state_space_models as ssm
    from particles.collectors import Moments

    class UNGM(ssm.StateSpaceModel):
        # particles' t in PX is the index of the new state: x_t = f(x_{t-1}) + 8 cos(1.2 t)
        def PX0(self):
            return dists.Normal(loc=0.0, scale=np.sqrt(5.0))
        def PX(self, t, xp):
            return dists.Normal(loc=0.5 * xp + 25.0 * xp / (1.0 + xp ** 2) + 8.0 * np.cos(1.2 * t),
                                scale=np.sqrt(10.0))
        def PY(self, t, xp, x):
            return dists.Normal(loc=x ** 2 / 20.0, scale=1.0)

    args = json.loads(sys.argv[1])
    data = np.array(args["ys"])
    fk = ssm.Bootstrap(ssm=UNGM(), data=data)
    clock = time.perf_counter if args["wall"] else time.process_time
    best = float("inf")
    for _ in range(args["repeat"]):
        alg = particles.SMC(fk=fk, N=args["N"], resampling="systematic", ESSrmin=1.0,
                            collect=[Moments()], store_history=False, verbose=False)
        t0 = clock()
        alg.run()
        best = min(best, clock() - t0)
    means = [m["mean"] for m in alg.summaries.moments]
    print(json.dumps({"seconds": best, "means": [float(np.ravel(m)[0]) for m in means],
                      "loglik": float(alg.summaries.logLts[-1])}))
""")


def peer_python() -> str | None:
    """The Python that has `particles`, or None."""
    candidates = [os.environ.get("PARTICLES_PYTHON"), str(ROOT / "benchmarks/.particles-venv/bin/python")]
    for exe in candidates:
        if exe and Path(exe).exists():
            ok = subprocess.run([exe, "-c", "import particles"], capture_output=True)
            if ok.returncode == 0:
                return exe
    return None


def run_peer(exe: str, ys: np.ndarray, N: int, repeat: int) -> dict:
    # a warm-up run first so that numba's compilation is not timed
    args = json.dumps({"ys": ys[:, 0].tolist(), "N": N, "repeat": repeat + 1,
                       "wall": CLOCK is time.perf_counter})
    out = subprocess.run([exe, "-c", PEER_SCRIPT, args], capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def run_bf(model, ys: np.ndarray, N: int, repeat: int) -> tuple[float, bf.particle.ParticleFilterResult]:
    best, res = float("inf"), None
    for k in range(repeat):
        rng = np.random.default_rng(k)
        t0 = CLOCK()
        res = bf.particle.particle_filter(model, ys, N, rng, resample="systematic", ess_threshold=1.0)
        best = min(best, CLOCK() - t0)
    return best, res


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="skip N = 10^6")
    parser.add_argument("--wall", action="store_true", help="time with time.perf_counter")
    args = parser.parse_args(argv)
    sizes = [10**4, 10**5] if args.quick else [10**4, 10**5, 10**6]
    model = bf.models.ungm()
    _, ys = bf.models.simulate(model, T, np.random.default_rng(2026))
    exe = peer_python()
    print(f"machine: {platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}, "
          f"numpy {np.__version__}, "
          f"OPENBLAS_NUM_THREADS={os.environ.get('OPENBLAS_NUM_THREADS', 'unset')}")
    print(f"bayesfilt imported from {os.path.dirname(bf.__file__)}")
    print("load average (1, 5, 15 min) at start: " + ", ".join(f"{x:.2f}" for x in os.getloadavg()))
    if exe is None:
        print("particles: NOT FOUND - comparison skipped. Build its venv with\n"
              "  python3 -m venv benchmarks/.particles-venv && "
              "benchmarks/.particles-venv/bin/pip install particles==0.4")
    what = "wall-clock" if CLOCK is time.perf_counter else "CPU time of the process"
    print(f"\nUNGM, T = {T}, bootstrap, systematic resampling every step; ms per step "
          f"({what}, best of k)\n")
    print("| N | bayesfilt | particles | speed-up | max abs diff of means | loglik bf / particles |")
    print("|---|---|---|---|---|---|")
    for N in sizes:
        repeat = 5 if N <= 10**5 else 3
        t_bf, res = run_bf(model, ys, N, repeat)
        if exe is None:
            print(f"| {N:.0e} | {1e3 * t_bf / T:.2f} | - | - | - | {res.loglik:.2f} / - |")
            continue
        # two rounds, the libraries in turn, so that a burst of load hits both alike
        peer = run_peer(exe, ys, N, repeat)
        t_bf = min(t_bf, run_bf(model, ys, N, repeat)[0])
        again = run_peer(exe, ys, N, repeat)
        peer["seconds"] = min(peer["seconds"], again["seconds"])
        diff = np.max(np.abs(res.means[:, 0] - np.array(peer["means"])))
        print(f"| {N:.0e} | {1e3 * t_bf / T:.2f} | {1e3 * peer['seconds'] / T:.2f} | "
              f"{peer['seconds'] / t_bf:.2f}x | {diff:.3f} | {res.loglik:.2f} / {peer['loglik']:.2f} |")
        sys.stdout.flush()
    print("\nThe means of the two filters differ by Monte Carlo error only (different random "
          "streams); the difference shrinks like 1/sqrt(N).")
    print("load average (1, 5, 15 min) at end: " + ", ".join(f"{x:.2f}" for x in os.getloadavg()))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
