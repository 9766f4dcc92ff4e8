r"""Check the chapters in JupyterLab itself, in a real browser (headless Chromium).

Usage (from the repository root, in the course environment)::

    apt-get install -y chromium              # Debian/Ubuntu: the system Chromium
    python tools/check_lab_browser.py                         # every chapter, 5 Run Alls each
    python tools/check_lab_browser.py notebooks/04_*.ipynb --runs 5
    python tools/check_lab_browser.py --runs 0                # the equations only
    python tools/check_lab_browser.py --no-equations          # the Run Alls only

It starts JupyterLab (a private server on a free port of 127.0.0.1, with its
own settings and workspace folders, in a temporary folder that holds copies
of the notebooks, so that JupyterLab's autosave never touches the
repository), opens it in headless Chromium driven by Playwright (pinned in
``requirements-site.txt``; the system Chromium, no browser download), and
checks two things that nbval cannot see, because nbval has no front end:

* **Run All, N times in a row** (``--runs``, default 5). Each run opens a
  fresh copy of the chapter in a new page with a new kernel, runs "Run All
  Cells", waits until the kernel has been idle for a while (widgets talk to
  the kernel after the last cell has run: a slider's first render calls its
  function again), then reads every output in the live page, the outputs of
  widgets included, and reports each error (a traceback, an ``...Error:`` or
  ``...Exception:`` line) with its cell, and each cell that shows fewer
  figures than the stored notebook (a figure lost). Warnings written to
  stderr are listed too, as warnings.
* **Display equations against the text column**, at a window of
  ``--width`` (default 1,024) px with the file browser open, JupyterLab's
  default layout. Every typeset display equation (MathJax's
  ``mjx-container[display]``) of every markdown cell is measured; one wider
  than the cell's text column is clipped (JupyterLab shows no scrollbar for
  it). The report lists each with its cell, both widths and the start of its
  TeX, so that it can be split over aligned lines (CONTRIBUTING.md: at most
  about 60 characters of rendered maths per line).

It prints one line per chapter, then the details, and exits 1 if a run shows
an error or an equation is clipped. Run as root (a container), JupyterLab
needs ``--allow-root``: the script passes it when it runs as root.

JupyterLab runs with the environment's settings, except its news pop-up and,
with ``--comms-over-subshells``, the setting that decides in which kernel
thread a widget's callback runs. JupyterLab's default (``perCommTarget``,
with ipykernel 7) runs a slider's callback in a second thread while Run All
goes on in the first; matplotlib is not thread-safe, so a slider's figure can
then fail (a mathtext ``ParseException``) or another cell's figure go
missing. The course's setting is ``disabled`` (``make lab`` installs it;
INSTRUCTORS.md, "JupyterLab in class"). The last line of the report says
which setting the runs had.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import secrets
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
import urllib.request
from pathlib import Path

import nbformat

sys.path.insert(0, str(Path(__file__).resolve().parent))
from check_site_browser import find_chromium  # noqa: E402  (one search for Chromium)

ROOT = Path(__file__).resolve().parents[1]
NOTEBOOKS = ROOT / "notebooks"
WIDTH, HEIGHT = 1024, 768

# Settings that make the page quiet and comparable: no news or update pop-ups.
SETTINGS = {
    "@jupyterlab/apputils-extension/notification.jupyterlab-settings":
        {"checkForUpdates": False, "fetchNews": "false"},
}

# The JupyterLab setting that decides in which kernel thread widget messages run (INSTRUCTORS.md,
# "JupyterLab in class"): JupyterLab's default, "perCommTarget", runs a slider's callback in a
# second thread, concurrently with the cells of Run All.
COMMS_SETTING = "@jupyterlab/apputils-extension/kernels-settings.jupyterlab-settings"

# The start of both page scripts below: wait for JupyterLab and the notebook's panel (`app`,
# `panel`, `sleep` are theirs to use); return an error object if either never comes.
FIND_PANEL = r"""
  const sleep = ms => new Promise(r => setTimeout(r, ms));
  for (let k = 0; k < 600 && !(window.jupyterapp && window.jupyterapp.shell); k++) await sleep(100);
  const app = window.jupyterapp;
  if (!app) return {error: 'JupyterLab did not start in the page'};
  let panel = null;
  for (let k = 0; k < 600 && !panel; k++) {
    const w = app.shell.currentWidget;
    if (w && w.content && w.sessionContext) panel = w; else await sleep(100);
  }
  if (!panel) return {error: 'no notebook panel opened'};
  await panel.context.ready;
"""

# Waits for the notebook and its kernel, then runs every cell; resolves when the run is done.
RUN_ALL = r"""
async () => {
@FIND_PANEL@
  await panel.sessionContext.ready;
  for (let k = 0; k < 600; k++) {
    const kernel = panel.sessionContext.session && panel.sessionContext.session.kernel;
    if (kernel && kernel.status === 'idle') break;
    await sleep(100);
  }
  const t0 = performance.now();
  await app.commands.execute('notebook:run-all-cells');
  // widgets call the kernel back after the last cell: wait for 3 s of continuous idleness
  let idleSince = null;
  for (let k = 0; k < 1200; k++) {
    const kernel = panel.sessionContext.session.kernel;
    if (kernel.status === 'idle') {
      idleSince = idleSince === null ? performance.now() : idleSince;
      if (performance.now() - idleSince > 3000) break;
    } else idleSince = null;
    await sleep(100);
  }
  const comms = app.serviceManager.kernels.commsOverSubshells;   // as JupyterLab applies it
  const cells = panel.content.widgets;
  const unrun = cells.filter(c => c.model.type === 'code' && c.model.sharedModel.getSource().trim()
                             && !c.model.executionCount).length;
  return {seconds: (performance.now() - t0 - 3000) / 1000, unrun: unrun, cells: cells.length,
          comms: comms};
}
"""

# Every output element of the live page: its cell, its mime type and its text.
READ_OUTPUTS = r"""
() => {
  const cells = [...document.querySelectorAll('.jp-NotebookPanel .jp-Notebook .jp-Cell')];
  const found = [];
  for (const el of document.querySelectorAll('.jp-NotebookPanel .jp-OutputArea-output')) {
    if (el.querySelector('.jp-OutputArea-output')) continue;   // a widget's outputs: read inside
    const cell = el.closest('.jp-Cell');
    // textContent, not innerText: JupyterLab skips the layout of cells off screen
    // (content-visibility), and innerText is empty for them
    found.push({cell: cells.indexOf(cell), mime: el.getAttribute('data-mime-type') || '',
                inWidget: !!el.closest('.jupyter-widgets, .jupyter-widget-Output, .widget-output'),
                image: !!el.querySelector('img'), text: el.textContent || ''});
  }
  return found;
}
"""

# The file browser open (JupyterLab's default layout), then every display equation measured.
MEASURE_EQUATIONS = r"""
async () => {
@FIND_PANEL@
  if (app.shell.leftCollapsed) await app.commands.execute('filebrowser:activate');
  await sleep(500);
  const sidebar = document.querySelector('#jp-left-stack');
  const result = {sidebar: sidebar ? Math.round(sidebar.getBoundingClientRect().width) : 0,
                  window: window.innerWidth, equations: []};
  const cells = panel.content.widgets;
  for (let i = 0; i < cells.length; i++) {
    const cell = cells[i];
    if (cell.model.type !== 'markdown' || !cell.model.sharedModel.getSource().includes('$$'))
      continue;
    panel.content.activeCellIndex = i;
    cell.node.scrollIntoView({block: 'start'});
    let rendered = null, containers = [];
    for (let k = 0; k < 100; k++) {
      rendered = cell.node.querySelector('.jp-RenderedMarkdown');
      containers = rendered ? [...rendered.querySelectorAll('mjx-container[display="true"]')] : [];
      if (containers.length && !rendered.querySelector('.jp-mod-typesetting, mjx-processing'))
        break;
      await sleep(50);
    }
    await sleep(100);
    if (!rendered) continue;
    const style = getComputedStyle(rendered);
    const column = rendered.clientWidth - parseFloat(style.paddingLeft) - parseFloat(style.paddingRight);
    containers.forEach((c, k) => {
      const inner = c.firstElementChild || c;
      const width = Math.max(inner.getBoundingClientRect().width, c.scrollWidth);
      result.equations.push({cell: i, index: k, width: Math.round(width),
                             column: Math.round(column), text: (c.innerText || '').slice(0, 60)});
    });
  }
  return result;
}
"""

# both scripts start by finding the panel
RUN_ALL, MEASURE_EQUATIONS = (script.replace("@FIND_PANEL@", FIND_PANEL.strip("\n"))
                              for script in (RUN_ALL, MEASURE_EQUATIONS))


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Lab:
    """A private JupyterLab server on 127.0.0.1 serving ``root``; stopped by :meth:`stop`."""

    def __init__(self, root: Path, home: Path, comms: str | None = None):
        self.root, self.port, self.token = root, _free_port(), secrets.token_hex(16)
        settings = home / "settings"
        chosen = dict(SETTINGS)
        if comms:
            chosen[COMMS_SETTING] = {"commsOverSubshells": comms}
        for name, values in chosen.items():
            path = settings / name
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(json.dumps(values))
        config = home / "config"
        (config / "labconfig").mkdir(parents=True, exist_ok=True)
        # a student's JupyterLab: nbgrader's instructor extensions off (if nbgrader is installed)
        (config / "labconfig" / "page_config.json").write_text(json.dumps(
            {"disabledExtensions": {"@jupyter/nbgrader": True}}))
        (config / "jupyter_server_config.json").write_text(json.dumps(
            {"ServerApp": {"jpserver_extensions": {"nbgrader": False}}}))
        env = dict(os.environ, JUPYTERLAB_SETTINGS_DIR=str(settings),
                   JUPYTERLAB_WORKSPACES_DIR=str(home / "workspaces"), JUPYTER_CONFIG_DIR=str(config),
                   PYTHONPATH=os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")])))
        args = [sys.executable, "-m", "jupyterlab", "--no-browser", f"--ServerApp.port={self.port}",
                "--ServerApp.port_retries=0", "--ServerApp.ip=127.0.0.1",
                f"--IdentityProvider.token={self.token}", f"--ServerApp.root_dir={root}",
                "--LabApp.expose_app_in_browser=True", "--ServerApp.open_browser=False"]
        if hasattr(os, "geteuid") and os.geteuid() == 0:
            args.append("--allow-root")       # JupyterLab refuses to run as root without it
        self.log = open(home / "lab.log", "w")
        self.proc = subprocess.Popen(args, cwd=root, env=env, stdout=self.log, stderr=subprocess.STDOUT,
                                     start_new_session=True)
        self.base = f"http://127.0.0.1:{self.port}"
        deadline = time.monotonic() + 120
        while True:
            try:
                urllib.request.urlopen(f"{self.base}/api/status?token={self.token}", timeout=2)
                break
            except OSError:
                if self.proc.poll() is not None or time.monotonic() > deadline:
                    raise SystemExit(f"error: JupyterLab did not start; see {home / 'lab.log'}")
                time.sleep(0.3)

    def url(self, name: str, workspace: str) -> str:
        return f"{self.base}/lab/workspaces/{workspace}/tree/{name}?reset&token={self.token}"

    def shutdown_kernels(self) -> None:
        request = urllib.request.Request(f"{self.base}/api/sessions?token={self.token}")
        for session in json.load(urllib.request.urlopen(request, timeout=10)):
            urllib.request.urlopen(urllib.request.Request(
                f"{self.base}/api/sessions/{session['id']}?token={self.token}", method="DELETE"),
                timeout=30)

    def stop(self) -> None:
        if self.proc.poll() is None:
            os.killpg(self.proc.pid, signal.SIGTERM)
            try:
                self.proc.wait(timeout=20)
            except subprocess.TimeoutExpired:
                os.killpg(self.proc.pid, signal.SIGKILL)
        self.log.close()


ERROR_LINE = re.compile(r"Traceback \(most recent call last\)|^\w*(Error|Exception)\b.*:", re.M)


STDERR = ("application/vnd.jupyter.stderr", "application/vnd.jupyter.error")


def classify(outputs: list[dict]) -> tuple[list[dict], list[dict]]:
    """(errors, warnings) among the page's outputs.

    JupyterLab renders a traceback, and anything written to stderr, with the
    stderr mime type: such an output with a traceback or an ``...Error:`` line
    is an error, any other is a warning. Printed text (stdout) is never an
    error, even when it quotes one (a chapter that shows an error message).
    """
    errors, warnings = [], []
    for out in outputs:
        if out["mime"] not in STDERR:
            continue
        (errors if ERROR_LINE.search(out["text"]) else warnings).append(out)
    return errors, warnings


def missing_figures(nb, outputs: list[dict]) -> list[str]:
    """Cells that show fewer figures outside widgets than the stored notebook (a figure lost)."""
    shown = {}
    for out in outputs:
        if out["image"] and not out["inWidget"]:
            shown[out["cell"]] = shown.get(out["cell"], 0) + 1
    problems = []
    for index, cell in enumerate(nb.cells):
        if cell.cell_type != "code":
            continue
        stored = sum(1 for o in cell.get("outputs", []) if "image/png" in o.get("data", {}))
        if shown.get(index, 0) < stored:
            problems.append(f"cell {index + 1}: {shown.get(index, 0)} of its {stored} figures shown")
    return problems


def display_tex(source: str) -> list[str]:
    """The TeX of each ``$$ ... $$`` display of a markdown source, in order."""
    source = re.sub(r"^[ \t]*>[ \t]?", "", source, flags=re.M)     # a display in a blockquote
    return [m.group(1).strip() for m in re.finditer(r"\$\$(.+?)\$\$", source, flags=re.S)]


def _snippet(tex: str, size: int = 70) -> str:
    flat = " ".join(tex.split())
    return flat if len(flat) <= size else flat[:size - 1] + "…"


def check(notebooks: list[Path], runs: int, equations: bool, chromium: str, width: int,
          keep: bool = False, comms: str | None = None) -> int:
    from playwright.sync_api import sync_playwright

    home = Path(tempfile.mkdtemp(prefix="lab-check-"))
    root = home / "root"
    root.mkdir()
    lab = Lab(root, home, comms)
    effective = set()
    failures = 0
    summary, details = [], []
    try:
        with sync_playwright() as p:
            browser = p.chromium.launch(executable_path=chromium, headless=True,
                                        args=["--no-sandbox"])
            for path in notebooks:
                nb = nbformat.read(path, as_version=4)
                line = [path.name + ":"]
                if equations:
                    shutil.copy(path, root / path.name)
                    context = browser.new_context(viewport={"width": width, "height": HEIGHT})
                    page = context.new_page()
                    page.goto(lab.url(path.name, f"eq-{path.stem}"), wait_until="load")
                    info = page.evaluate(MEASURE_EQUATIONS)
                    context.close()
                    lab.shutdown_kernels()
                    if "error" in info:
                        raise SystemExit(f"error: {path.name}: {info['error']}")
                    clipped = [e for e in info["equations"] if e["width"] > e["column"]]
                    columns = sorted({e["column"] for e in info["equations"]})
                    line.append(f"{len(info['equations'])} display equations, {len(clipped)} clipped "
                                f"(text column {'/'.join(map(str, columns)) or '?'} px, file browser "
                                f"{info['sidebar']} px, window {info['window']} px)")
                    for e in clipped:
                        texs = display_tex(nb.cells[e["cell"]].source)
                        tex = texs[e["index"]] if e["index"] < len(texs) else e["text"]
                        details.append(f"  {path.name} cell {e['cell'] + 1}, display {e['index'] + 1}: "
                                       f"{e['width']} px > {e['column']} px: {_snippet(tex)}")
                    failures += bool(clipped)
                dirty = 0
                for run in range(runs):
                    shutil.copy(path, root / path.name)    # a fresh copy: no output of a run before
                    context = browser.new_context(viewport={"width": width, "height": HEIGHT})
                    page = context.new_page()
                    page.goto(lab.url(path.name, f"run-{path.stem}-{run}"), wait_until="load")
                    info = page.evaluate(RUN_ALL)
                    if "error" in info:
                        raise SystemExit(f"error: {path.name}: {info['error']}")
                    outputs = page.evaluate(READ_OUTPUTS)
                    context.close()
                    lab.shutdown_kernels()
                    effective.add(str(info.get("comms")))
                    errors, warnings = classify(outputs)
                    if info["unrun"]:
                        errors.append({"cell": -1, "inWidget": False,
                                       "text": f"{info['unrun']} code cells did not run"})
                    errors += [{"cell": -1, "inWidget": False, "text": f"figure missing: {p}"}
                               for p in missing_figures(nb, outputs)]
                    dirty += bool(errors)
                    for out in errors:
                        where = ("" if out["cell"] < 0 else f"cell {out['cell'] + 1}"
                                 + (" (widget output)" if out["inWidget"] else ""))
                        details.append(f"  {path.name} run {run + 1} {where}: ERROR "
                                       + _snippet(out["text"].strip().splitlines()[-1] if out["text"].strip() else "", 200))
                    for out in warnings:
                        details.append(f"  {path.name} run {run + 1} cell {out['cell'] + 1}: warning "
                                       + _snippet(out["text"].strip(), 200))
                    details.append(f"  {path.name} run {run + 1}: {info['seconds']:.1f} s, "
                                   f"{len(errors)} errors, {len(warnings)} warnings")
                if runs:
                    line.append(f"Run All {runs - dirty}/{runs} without error")
                failures += bool(dirty)
                summary.append(" ".join(line[:1]) + " " + "; ".join(line[1:]))
                print(summary[-1], flush=True)
            browser.close()
    finally:
        lab.stop()
        if not keep:
            shutil.rmtree(home, ignore_errors=True)
    if details:
        print("\nDetails:")
        print("\n".join(details))
    if effective:
        print(f"\nJupyterLab's 'Kernel Comms over subshells' setting in these runs: "
              f"{', '.join(sorted(effective))}")
    return 1 if failures else 0


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="check_lab_browser.py", description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("notebooks", nargs="*", type=Path,
                        help="chapter notebooks (default: every notebooks/NN_*.ipynb)")
    parser.add_argument("--runs", type=int, default=5, help="Run Alls per chapter (default 5; 0: none)")
    parser.add_argument("--no-equations", action="store_true", help="skip the equation widths")
    parser.add_argument("--width", type=int, default=WIDTH, help="window width in px (default 1024)")
    parser.add_argument("--chromium", help="the Chromium executable (default: found on the PATH)")
    parser.add_argument("--keep", action="store_true", help="keep the temporary folder (logs)")
    parser.add_argument("--comms-over-subshells", choices=["disabled", "perComm", "perCommTarget"],
                        help="set JupyterLab's 'Kernel Comms over subshells' for the check "
                             "(default: as installed; the course sets 'disabled', JupyterLab's "
                             "own default is 'perCommTarget')")
    args = parser.parse_args(argv)
    notebooks = args.notebooks or sorted(NOTEBOOKS.glob("[0-9][0-9]_*.ipynb"))
    missing = [str(p) for p in notebooks if not p.is_file()]
    if missing:
        parser.error(f"no such notebook: {', '.join(missing)}")
    return check(notebooks, args.runs, not args.no_equations, find_chromium(args.chromium),
                 args.width, args.keep, args.comms_over_subshells)


if __name__ == "__main__":
    raise SystemExit(main())
