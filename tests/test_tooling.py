"""Tests of the course tooling: pytest set-up, the notebook runner, the declared dependencies.

These guard the promise of the README that ``pytest`` and the notebooks give
the same result on a student's machine as in CI: from any working folder,
with pytest-xdist, and that re-running the notebooks on unchanged code
changes no byte.
"""

from __future__ import annotations

import asyncio
import configparser
import importlib.util
import json
import os
import re
import subprocess
import sys
import textwrap
import time
import tomllib
from pathlib import Path
from queue import Empty
from types import SimpleNamespace

import nbformat
import pytest
from packaging.requirements import Requirement
from packaging.version import Version

ROOT = Path(__file__).resolve().parents[1]


def _load(name: str, path: Path):
    """Import a file that is not in a package (the root conftest, a tool) under its own name."""
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


course_conftest = _load("_course_conftest", ROOT / "conftest.py")
runner = _load("_run_notebooks", ROOT / "tools" / "run_notebooks.py")

class _Probe:
    """A pytest plugin for the runs below: after collection it does what nbval does when a
    notebook starts (open the sanitiser named by the option, from the working directory) and
    records what it found, plus xdist's mode, the collected items and any collection error."""

    def __init__(self):
        self.found: dict = {}
        self.items: list[str] = []
        self.errors: list[str] = []

    def pytest_collectreport(self, report):
        if report.failed:
            self.errors.append(f"{report.nodeid}: {report.longreprtext[-2000:]}")

    def pytest_collection_finish(self, session):
        from nbval.plugin import IPyNbFile

        option = session.config.option
        files = {item.parent for item in session.items if isinstance(item.parent, IPyNbFile)}
        patterns = {}
        for nb_file in files:
            nb_file.setup_sanitize_files()  # what nbval's IPyNbFile.setup does, without a kernel
            patterns.update(nb_file.sanitize_patterns)
        self.items = [item.nodeid for item in session.items]
        self.found = {
            "sanitize_with": option.nbval_sanitize_with,
            "notebooks": len(files),
            "patterns": sorted(patterns.values()),
            "dist": getattr(option, "dist", None),
            "xdist": session.config.pluginmanager.has_plugin("xdist"),
        }


def _smallest_notebook() -> Path:
    notebooks = sorted((ROOT / "notebooks").glob("[0-9][0-9]_*.ipynb"), key=lambda p: p.stat().st_size)
    assert notebooks, "no notebooks/NN_*.ipynb found"
    return notebooks[0]


def _run_pytest(args, cwd: Path, monkeypatch) -> tuple[int, _Probe]:
    """``pytest *args`` started in ``cwd``, run in this process (pytest.main).

    A fresh Python would prove nothing more: pytest.main builds a new
    configuration from the command line and the working directory (rootdir,
    pyproject.toml's addopts, the root conftest), as the ``pytest`` command
    does, and collection imports nothing that is not already imported here.
    It saves the 3-8 s a fresh interpreter takes to start and import nbval.
    """
    probe = _Probe()
    monkeypatch.chdir(cwd)
    code = pytest.main(list(args), plugins=[probe])
    return int(code), probe


def _sanitize_replacements() -> list[str]:
    """The replacement strings of notebooks/sanitize.cfg, read independently of nbval."""
    cfg = configparser.RawConfigParser()
    cfg.read(ROOT / "notebooks" / "sanitize.cfg", encoding="utf-8")
    return sorted(cfg[section]["replace"] for section in cfg.sections())


# --------------------------------------------------------------------------
# Issue 8, item 1: pytest from any folder
# --------------------------------------------------------------------------

@pytest.mark.parametrize("where", ["outside", "tests"])
def test_pytest_finds_the_sanitiser_from_any_folder(tmp_path, monkeypatch, where):
    """From a folder that is not the root, collection works and nbval can open sanitize.cfg."""
    notebook = _smallest_notebook()
    if where == "outside":
        cwd, args = tmp_path, [str(ROOT / "tests" / "test_plotting.py"), str(notebook)]
    else:
        cwd, args = ROOT / "tests", ["test_plotting.py", os.path.relpath(notebook, ROOT / "tests")]
    code, probe = _run_pytest([*args, "--collect-only", "-q"], cwd, monkeypatch)
    assert code == 0 and not probe.errors, probe.errors
    assert probe.found, "the probe plugin did not run"
    assert probe.found["notebooks"] == 1, probe.found
    assert Path(probe.found["sanitize_with"]).is_absolute(), probe.found
    # Each rule of sanitize.cfg was loaded, exactly as nbval loads them.
    assert probe.found["patterns"] == _sanitize_replacements() != []
    # Some unit tests and some cells were collected.
    assert any("test_plotting.py::" in i for i in probe.items), probe.items
    assert any(i.endswith(".ipynb::Cell 0") for i in probe.items), probe.items


def test_sanitiser_is_not_a_relative_path_in_addopts():
    """nbval opens --nbval-sanitize-with from the working directory: addopts must not name it."""
    ini = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["pytest"]["ini_options"]
    assert "sanitize" not in ini["addopts"]
    assert "--nbval" in ini["addopts"].split()


def test_default_sanitiser_respects_the_command_line():
    option = SimpleNamespace(nbval_sanitize_with=None, sanitize_with=None)
    course_conftest.set_default_sanitizer(option)
    assert option.nbval_sanitize_with == str(ROOT / "notebooks" / "sanitize.cfg")
    assert Path(option.nbval_sanitize_with).is_file()

    option = SimpleNamespace(nbval_sanitize_with="mine.cfg", sanitize_with=None)
    course_conftest.set_default_sanitizer(option)
    assert option.nbval_sanitize_with == "mine.cfg"

    # nbval's deprecated alias is copied over by nbval itself; setting both would be an error.
    option = SimpleNamespace(nbval_sanitize_with=None, sanitize_with="old.cfg")
    course_conftest.set_default_sanitizer(option)
    assert option.nbval_sanitize_with is None

    option = SimpleNamespace()  # nbval not loaded (-p no:nbval): nothing to set
    course_conftest.set_default_sanitizer(option)
    assert not hasattr(option, "nbval_sanitize_with")


# --------------------------------------------------------------------------
# Issue 8, item 3: pytest-xdist keeps each notebook in one kernel
# --------------------------------------------------------------------------

@pytest.mark.parametrize("given,want", [
    (dict(numprocesses=2, dist="no", distload=False), "loadfile"),    # pytest -n 2
    (dict(numprocesses="auto", dist="no", distload=False), "loadfile"),
    (dict(numprocesses=2, dist="load", distload=False), "load"),      # explicit --dist load
    (dict(numprocesses=2, dist="loadscope", distload=False), "loadscope"),
    (dict(numprocesses=2, dist="no", distload=True), "no"),           # --distload: xdist sets load
    (dict(numprocesses=None, dist="no", distload=False), "no"),       # no -n
    (dict(numprocesses=0, dist="no", distload=False), "no"),          # -n 0
])
def test_xdist_default_mode_becomes_loadfile(given, want):
    option = SimpleNamespace(**given)
    course_conftest.keep_notebooks_whole(option)
    assert option.dist == want


def test_no_xdist_no_change():
    option = SimpleNamespace(nbval_sanitize_with=None)
    course_conftest.keep_notebooks_whole(option)
    assert vars(option) == {"nbval_sanitize_with": None}


@pytest.mark.parametrize("args", [
    [],                                 # plain pytest: addopts asks for -n auto --dist loadfile
    ["-n", "2", "-o", "addopts=--nbval -p no:cacheprovider"],  # -n alone: conftest picks loadfile
])
def test_xdist_run_uses_loadfile(tmp_path, monkeypatch, args):
    pytest.importorskip("xdist", reason="pytest-xdist is not installed")
    code, probe = _run_pytest([str(_smallest_notebook()), *args, "--collect-only", "-q"],
                              tmp_path, monkeypatch)
    assert code == 0 and not probe.errors, probe.errors
    assert probe.found["dist"] == "loadfile"


def test_without_xdist_the_addopts_still_parse(tmp_path, monkeypatch):
    """``pytest -p no:xdist`` (or pytest-xdist absent): -n/--dist of addopts are accepted, unused."""
    code, probe = _run_pytest([str(_smallest_notebook()), "-p", "no:xdist", "--collect-only", "-q"],
                              tmp_path, monkeypatch)
    assert code == 0 and not probe.errors, probe.errors
    assert probe.found["notebooks"] == 1 and probe.found["xdist"] is False, probe.found


# --------------------------------------------------------------------------
# Issue 8, item 2: a student's matplotlibrc does not change the figures
# --------------------------------------------------------------------------

STYLE_PROBE = textwrap.dedent('''
    import json
    import matplotlib
    matplotlib.use("module://matplotlib_inline.backend_inline")  # what %matplotlib inline selects
    import matplotlib.pyplot as plt
    import bayesfilt as bf

    before = {k: matplotlib.rcParams[k] for k in ("figure.constrained_layout.use", "lines.linewidth")}
    bf.plotting.use_course_style()
    rc = matplotlib.rcParams
    fig = plt.figure()
    print(json.dumps({
        "before": before,
        "constrained": rc["figure.constrained_layout.use"],
        "linewidth": rc["lines.linewidth"],
        "figsize": list(rc["figure.figsize"]),
        "grid": rc["axes.grid"],
        "backend": matplotlib.get_backend(),
        "figure": [fig.get_figwidth(), fig.get_figheight(), fig.dpi],
    }))
''')


def test_course_style_overrides_a_students_matplotlibrc(tmp_path):
    rc_dir = tmp_path / "rc"
    rc_dir.mkdir()
    (rc_dir / "matplotlibrc").write_text("figure.constrained_layout.use: True\n"
                                         "lines.linewidth: 7\n"
                                         "figure.figsize: 5, 5\n")
    env = dict(os.environ, MATPLOTLIBRC=str(rc_dir / "matplotlibrc"))
    proc = subprocess.run([sys.executable, "-c", STYLE_PROBE], cwd=tmp_path, env=env,
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    got = json.loads(proc.stdout.strip().splitlines()[-1])
    # The student's file was read, so the check below is not vacuous ...
    assert got["before"] == {"figure.constrained_layout.use": True, "lines.linewidth": 7.0}
    # ... and use_course_style undid it: matplotlib's defaults, then the course's settings.
    from matplotlib import rcParamsDefault
    assert got["constrained"] is rcParamsDefault["figure.constrained_layout.use"] is False
    assert got["linewidth"] == rcParamsDefault["lines.linewidth"]
    assert got["figsize"] == list(bf_course_style()["figure.figsize"])
    assert got["grid"] is True
    assert got["figure"] == [*bf_course_style()["figure.figsize"], bf_course_style()["figure.dpi"]]
    # The backend chosen by %matplotlib inline survives the reset.
    assert got["backend"] == "module://matplotlib_inline.backend_inline"


def bf_course_style() -> dict:
    import bayesfilt as bf
    return bf.plotting.COURSE_STYLE


# --------------------------------------------------------------------------
# Issue 8, item 4: the runner saves nothing that changes from run to run
# --------------------------------------------------------------------------

def _widget_notebook():
    nb = nbformat.v4.new_notebook()
    nb.metadata["widgets"] = {"application/vnd.jupyter.widget-state+json": {"state": {"abc": {}}}}
    view = {"model_id": "abc", "version_major": 2, "version_minor": 0}
    code = nbformat.v4.new_code_cell("slider", execution_count=1, outputs=[
        nbformat.v4.new_output("display_data", data={runner.WIDGET_VIEW: view,
                                                     "text/plain": "IntSlider(value=3)"}),
        nbformat.v4.new_output("display_data", data={runner.WIDGET_VIEW: view}),
        nbformat.v4.new_output("stream", name="stdout", text="3\n"),
    ])
    code.metadata["execution"] = {"iopub.execute_input": "2024-01-01T00:00:00.000000Z",
                                  "shell.execute_reply": "2024-01-01T00:00:06.500000Z"}
    fast = nbformat.v4.new_code_cell("1 + 1", execution_count=2)
    fast.metadata["execution"] = {"iopub.execute_input": "2024-01-01T00:00:07.000000Z",
                                  "shell.execute_reply": "2024-01-01T00:00:07.100000Z"}
    return nbformat.from_dict(dict(nb, cells=[nbformat.v4.new_markdown_cell("# t"), code, fast]))


def test_strip_volatile_keeps_the_text_fallback_of_widgets():
    nb = _widget_notebook()
    slow = runner.strip_volatile(nb)
    assert slow == [(1, 6.5)]
    assert "widgets" not in nb.metadata
    code = nb.cells[1]
    assert "execution" not in code.metadata and "execution" not in nb.cells[2].metadata
    # The view pointer is gone, its text fallback and the other outputs stay.
    assert [dict(o.get("data", {})) for o in code.outputs] == [{"text/plain": "IntSlider(value=3)"}, {}]
    assert code.outputs[1].output_type == "stream"
    nbformat.validate(nb)


def test_strip_volatile_rejects_a_non_notebook():
    with pytest.raises(TypeError, match="nb must be"):
        runner.strip_volatile({"cells": []})


def test_rerun_of_unchanged_notebook_is_byte_identical(tmp_path):
    """Two runs of the runner on a notebook with a live widget write the same bytes."""
    pytest.importorskip("ipywidgets")
    nb = nbformat.v4.new_notebook()
    nb.cells = [nbformat.v4.new_code_cell("import ipywidgets\nipywidgets.IntSlider(value=3)"),
                nbformat.v4.new_code_cell("print(2 + 2)")]
    path = tmp_path / "widget.ipynb"
    nbformat.write(nb, path)
    runner.run(path, timeout=60)
    first = path.read_bytes()
    runner.run(path, timeout=60)
    assert path.read_bytes() == first
    saved = json.loads(first)
    assert "widgets" not in saved["metadata"]
    (out,) = saved["cells"][0]["outputs"]
    assert runner.WIDGET_VIEW not in out["data"] and "IntSlider" in "".join(out["data"]["text/plain"])
    assert "".join(saved["cells"][1]["outputs"][0]["text"]) == "4\n"
    assert saved["metadata"]["kernelspec"]["name"] == "python3"


def test_runner_rejects_a_missing_file(tmp_path):
    with pytest.raises(FileNotFoundError, match="path must be an existing notebook"):
        runner.run(tmp_path / "missing.ipynb")


# --------------------------------------------------------------------------
# nbclient's kernel client: a missed wake-up must not cost the whole timeout
# --------------------------------------------------------------------------

class _DeafChannel:
    """A channel whose wake-up is lost: a waiting get_msg sleeps its whole timeout, and
    only a zero-timeout check (pyzmq's final poll) sees a message that arrived meanwhile."""

    def __init__(self, ready_at: float):
        self.ready_at, self.calls = ready_at, 0

    async def get_msg(self, timeout=None):
        self.calls += 1
        if timeout:
            await asyncio.sleep(timeout)
        if time.monotonic() >= self.ready_at:
            return {"msg": "reply"}
        raise Empty


def test_a_missed_wake_up_costs_one_slice_not_the_timeout():
    channel = _DeafChannel(ready_at=time.monotonic() + 0.3)
    get_msg = runner.sliced(type(channel).get_msg, slice_seconds=0.2)
    start = time.monotonic()
    assert asyncio.run(get_msg(channel, timeout=600)) == {"msg": "reply"}
    waited = time.monotonic() - start
    assert waited < 2.0, f"the reply waited {waited:.1f} s (a slice is 0.2 s)"
    # without the slices the same channel holds the reply for the whole timeout
    deaf = _DeafChannel(ready_at=time.monotonic() + 0.1)
    start = time.monotonic()
    assert asyncio.run(deaf.get_msg(timeout=1.0)) == {"msg": "reply"}
    assert time.monotonic() - start >= 1.0


def test_sliced_waiting_still_times_out_and_waits_forever_when_asked():
    never = _DeafChannel(ready_at=float("inf"))
    get_msg = runner.sliced(type(never).get_msg, slice_seconds=0.1)
    start = time.monotonic()
    with pytest.raises(Empty):
        asyncio.run(get_msg(never, timeout=0.35))
    assert 0.3 <= time.monotonic() - start < 1.5, "the timeout is kept"

    async def cancelled_after(seconds):
        return await asyncio.wait_for(get_msg(never, timeout=None), seconds)

    with pytest.raises(asyncio.TimeoutError):        # timeout=None: until cancelled
        asyncio.run(cancelled_after(0.35))
    assert never.calls >= 4, "waiting without a timeout goes on slice after slice"


def test_the_kernel_channels_of_the_runner_wait_in_slices():
    from jupyter_client.channels import AsyncZMQSocketChannel

    runner.wake_up_in_slices()
    runner.wake_up_in_slices()                       # idempotent: one layer of slices
    assert getattr(AsyncZMQSocketChannel.get_msg, "sliced", False)
    assert not getattr(AsyncZMQSocketChannel.get_msg.wrapped, "sliced", False)


# --------------------------------------------------------------------------
# Issue 8, item 5: declared lower bounds install together
# --------------------------------------------------------------------------

# First releases that work with numpy 2 (built against it): scipy 1.13.0
# (release notes: "first release to support numpy 2.0"), matplotlib 3.8.4
# ("released wheels are built against numpy 2"). Earlier wheels fail on import.
FIRST_FOR_NUMPY_2 = {"scipy": Version("1.13"), "matplotlib": Version("3.8.4")}


def _declared() -> dict[str, Requirement]:
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    return {Requirement(r).name: Requirement(r) for r in project["dependencies"]}


def _lower_bound(req: Requirement) -> Version:
    lows = [Version(s.version) for s in req.specifier if s.operator in (">=", "==", "~=")]
    assert lows, f"{req} has no lower bound"
    return max(lows)


def test_lower_bounds_are_compatible_with_numpy_2():
    declared = _declared()
    assert _lower_bound(declared["numpy"]) >= Version("2")
    for name, first in FIRST_FOR_NUMPY_2.items():
        assert _lower_bound(declared[name]) >= first, (
            f"{declared[name]} admits a release built for numpy 1; numpy 2 needs {name}>={first}")


def test_lock_file_satisfies_the_declared_bounds():
    pins = {}
    for line in (ROOT / "requirements.txt").read_text().splitlines():
        line = line.split("#")[0].strip()
        if line and not line.startswith("-"):
            req = Requirement(line)
            pins[req.name] = next(iter(req.specifier)).version
    for name, req in _declared().items():
        assert name in pins, f"{name} is a dependency of bayesfilt but not pinned in requirements.txt"
        assert req.specifier.contains(pins[name]), f"requirements.txt pins {name}=={pins[name]}, outside {req}"


# --- the instructor's environment and JupyterLab -------------------------------------------------

lab_check = _load("_check_lab_browser", ROOT / "tools" / "check_lab_browser.py")


def test_the_instructors_requirements_pin_nbgrader_on_top_of_the_course():
    lines = [line.split("#")[0].strip() for line in
             (ROOT / "requirements-instructor.txt").read_text().splitlines()]
    lines = [line for line in lines if line]
    assert "-r requirements.txt" in lines
    pins = [Requirement(line) for line in lines if not line.startswith("-")]
    assert [(r.name, str(r.specifier)) for r in pins] == [("nbgrader", "==0.9.6")]


def _setting_of_the_makefile() -> tuple[str, dict]:
    text = (ROOT / "Makefile").read_text()
    path = re.search(r"^LAB_SETTING := \$\(VENV\)/(\S+)$", text, flags=re.M).group(1)
    echoed = re.search(r"echo '(\{.*\})' > \$\(LAB_SETTING\)", text).group(1)
    return path, json.loads(echoed)


def test_make_lab_installs_a_setting_jupyterlab_knows():
    """The file `make lab` writes is one JupyterLab reads (an overrides.d file of the
    environment's app settings folder) and its value is allowed by the installed JupyterLab's
    own schema, so a renamed setting fails here rather than being ignored silently."""
    path, setting = _setting_of_the_makefile()
    assert path == "share/jupyter/lab/settings/overrides.d/bayesfilt.json"
    from jupyterlab_server.settings_utils import _get_overrides

    assert "overrides.d" in (_get_overrides.__doc__ or "")
    schemas = Path(sys.prefix) / "share" / "jupyter" / "lab" / "schemas"
    for plugin, values in setting.items():
        package, name = plugin.split(":")
        schema = json.loads((schemas / package / f"{name}.json").read_text())
        for key, value in values.items():
            allowed = [choice["const"] for choice in schema["properties"][key]["oneOf"]]
            assert value in allowed, (plugin, key, value, allowed)
    assert setting == {"@jupyterlab/apputils-extension:kernels-settings":
                       {"commsOverSubshells": "disabled"}}
    assert lab_check.COMMS_SETTING.replace(".jupyterlab-settings", "").replace("/kernels",
                                                                                ":kernels") in setting



def test_binder_postbuild_installs_the_same_setting_as_make_lab(tmp_path):
    """Binder runs postBuild in its environment: it must write `make lab`'s file, with the same
    setting, under that environment's prefix (here a stand-in `python` that names tmp_path)."""
    path, setting = _setting_of_the_makefile()
    stub = tmp_path / "bin" / "python"
    stub.parent.mkdir()
    stub.write_text(f"#!/bin/sh\necho {tmp_path / 'prefix'}\n")
    stub.chmod(0o755)
    env = dict(os.environ, PATH=f"{stub.parent}{os.pathsep}{os.environ['PATH']}")
    subprocess.run(["bash", str(ROOT / "postBuild")], env=env, check=True, timeout=30)
    written = tmp_path / "prefix" / path
    assert written.is_file(), f"postBuild did not write {written}"
    assert json.loads(written.read_text()) == setting, "postBuild and make lab differ"
    assert os.access(ROOT / "postBuild", os.X_OK), "postBuild must be executable (repo2docker)"

def test_the_lab_check_reads_the_tex_of_displays_in_blockquotes():
    source = "Text\n\n$$\na = b\n$$\n\n> A quote:\n>\n> $$\n> \\begin{aligned} x &= 1\\\\ y &= 2\n> \\end{aligned}\n> $$"
    assert lab_check.display_tex(source) == ["a = b", "\\begin{aligned} x &= 1\\\\ y &= 2\n\\end{aligned}"]


def test_the_lab_check_tells_errors_warnings_and_missing_figures():
    outputs = [
        {"cell": 3, "mime": "application/vnd.jupyter.stderr", "inWidget": True, "image": False,
         "text": "ValueError                                Traceback (most recent call last)\n..."
                 "\nParseException: exception raised in parse action"},
        {"cell": 4, "mime": "application/vnd.jupyter.stderr", "inWidget": False, "image": False,
         "text": "/x.py:3: UserWarning: careful"},
        {"cell": 5, "mime": "application/vnd.jupyter.stdout", "inWidget": False, "image": False,
         "text": "the library says:\nValueError: likelihood is zero wherever the prior has mass"},
        {"cell": 1, "mime": "image/png", "inWidget": False, "image": True, "text": ""},
        {"cell": 3, "mime": "image/png", "inWidget": True, "image": True, "text": ""},
    ]
    errors, warnings = lab_check.classify(outputs)
    assert [o["cell"] for o in errors] == [3] and [o["cell"] for o in warnings] == [4]
    nb = nbformat.v4.new_notebook()
    figure = nbformat.v4.new_output("display_data", data={"image/png": "iVBOR", "text/plain": "<Figure>"})
    nb.cells = [nbformat.v4.new_markdown_cell("# t"),
                nbformat.v4.new_code_cell("plt.show()", outputs=[figure]),
                nbformat.v4.new_code_cell("plt.show(); plt.show()", outputs=[figure, figure])]
    assert lab_check.missing_figures(nb, outputs) == ["cell 3: 0 of its 2 figures shown"]
