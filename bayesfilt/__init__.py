"""bayesfilt: the small Bayesian-filtering library of the course.

Import it as ``bf`` and reach each concept through its module::

    import bayesfilt as bf
    bf.bayes      # discrete (grid) Bayes filter           -- chapter 01
    bf.gaussian   # conditioning a jointly Gaussian vector -- chapter 02
    bf.kalman     # Kalman filter                          -- chapters 02-03
    bf.ekf        # extended Kalman filter                 -- chapter 04
    bf.ukf        # unscented transform and Kalman filter  -- chapter 08
    bf.models     # state-space models and simulation      -- chapters 02-06
    bf.particle   # particle filters (SIS, bootstrap, SIR) -- chapters 05-06
    bf.resampling # resampling schemes                     -- chapter 06
    bf.smoothing  # smoothers: RTS, grid, particles        -- chapter 07
    bf.plotting   # plots used by the notebooks
    bf.verify     # the one-line checks after each derivation
    bf.checks     # exercises that answer back              -- every chapter

Modules load on first use, so ``import bayesfilt`` stays cheap and does not
pull in matplotlib until a plot is drawn.
"""

from __future__ import annotations

import importlib

__version__ = "0.1.0"

_MODULES = ("bayes", "gaussian", "kalman", "ekf", "ukf", "models", "particle", "resampling", "plotting", "verify", "checks",
            "smoothing")
__all__ = list(_MODULES)


def __getattr__(name: str):
    if name in _MODULES:
        module = importlib.import_module(f".{name}", __name__)
        globals()[name] = module
        return module
    raise AttributeError(f"module 'bayesfilt' has no attribute {name!r}")


def __dir__():
    return sorted(list(globals()) + list(_MODULES))
