"""pytest set-up for the course, valid from whatever folder pytest is started in.

``pytest`` (configured in ``pyproject.toml``) runs the unit tests and
re-executes every notebook under strict nbval. Two settings cannot live in
``addopts`` and are made here instead:

* the nbval sanitiser ``notebooks/sanitize.cfg``. nbval opens the file given
  to ``--nbval-sanitize-with`` relative to the *working directory*, so a
  relative path in ``addopts`` breaks ``pytest`` started in ``notebooks/``
  or ``pytest /path/to/course`` started elsewhere. It is set here as an
  absolute path, unless the command line names another sanitiser;
* with pytest-xdist, ``pytest -n 2`` would deal the cells of one notebook
  out to several workers, each with its own kernel, so a cell would run
  without the variables of the cells before it. When ``-n`` is given
  without a ``--dist`` mode (e.g. with ``-o addopts=""``), ``--dist
  loadfile`` is chosen: every notebook (and every test file) stays on one
  worker.

``addopts`` asks for ``--numprocesses=auto --dist=loadfile`` (``-n auto``:
every CPU, one worker each; see ``pyproject.toml``). With xdist switched off (``pytest -p
no:xdist``, or not installed) those two options would be unknown and
pytest would stop; :func:`pytest_addoption` then accepts them and nothing
is distributed.

Under xdist every worker is a pytest process of its own, configured from
the controller's options: the controller sets the sanitiser's absolute path
before the workers start, and each worker's ``pytest_configure`` leaves a
path it was given alone.
"""

from __future__ import annotations

from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent
SANITIZE_CFG = ROOT / "notebooks" / "sanitize.cfg"


def set_default_sanitizer(option) -> None:
    """Point nbval at ``notebooks/sanitize.cfg`` by absolute path, unless one was given.

    ``option`` is ``config.option``. A sanitiser named on the command line
    (``--nbval-sanitize-with``, or nbval's deprecated ``--sanitize-with``)
    is left alone.
    """
    if not hasattr(option, "nbval_sanitize_with"):
        return  # nbval is not installed or was disabled (-p no:nbval)
    if option.nbval_sanitize_with is None and not getattr(option, "sanitize_with", None):
        option.nbval_sanitize_with = str(SANITIZE_CFG)


def keep_notebooks_whole(option) -> None:
    """With pytest-xdist's ``-n N`` and no ``--dist`` mode, choose ``--dist loadfile``.

    ``option`` is ``config.option``. xdist's default mode (``load``) sends
    single cells of one notebook to different workers; ``loadfile`` keeps
    each file, so each notebook, in one worker and one kernel. An explicit
    ``--dist`` is left alone. Without xdist there is no ``numprocesses``
    option and nothing changes.
    """
    if (getattr(option, "numprocesses", None) and getattr(option, "dist", None) == "no"
            and not getattr(option, "distload", False)):
        option.dist = "loadfile"


def pytest_addoption(parser, pluginmanager):
    """Accept xdist's ``-n`` and ``--dist`` of ``addopts`` when xdist is not loaded."""
    if pluginmanager.has_plugin("xdist"):
        return
    group = parser.getgroup("xdist-absent", "pytest-xdist is not loaded (-p no:xdist)")
    # (addopts spells -n as --numprocesses: pytest reserves one-letter options for itself)
    group.addoption("--numprocesses", dest="numprocesses", default=None,
                    help="ignored: pytest-xdist is not loaded, the tests run in this process")
    group.addoption("--dist", dest="dist", default="no",
                    help="ignored: pytest-xdist is not loaded")


@pytest.hookimpl(wrapper=True)
def pytest_cmdline_main(config):
    # A wrapper runs before xdist's own hook, which would turn "no" into "load".
    keep_notebooks_whole(config.option)
    return (yield)


def pytest_configure(config):
    set_default_sanitizer(config.option)
