"""Re-execute notebooks top to bottom in one fresh kernel and save them with outputs.

Usage (from the repository root, in the course environment)::

    python tools/run_notebooks.py                      # every notebook
    python tools/run_notebooks.py notebooks/01_*.ipynb # some of them

Run it after every edit to a notebook or to the ``bayesfilt`` code it uses,
then commit the saved notebooks: ``pytest`` re-executes them under strict
nbval and fails if a stored output differs from what the code produces now.
Per-cell run times are printed so that a slow cell shows up (aim: < 5 s).

A re-run on unchanged code writes a byte-identical file, so that a diff
shows only real changes. What changes from run to run is not saved: the
per-cell timestamps, and the state of live widgets (``metadata.widgets``,
with fresh random model ids each run, and the ``widget-view`` pointers into
it). A widget's output keeps its ``text/plain`` fallback, which is what a
saved notebook can show without a kernel anyway; nbval does not compare
widget views (their ids are random).
"""

from __future__ import annotations

import argparse
import sys
import time
from datetime import datetime
from pathlib import Path
from queue import Empty

import nbformat
from jupyter_client.channels import AsyncZMQSocketChannel
from nbclient import NotebookClient

ROOT = Path(__file__).resolve().parents[1]
MAX_BYTES = 1_000_000
SLOW_SECONDS = 5.0
WIDGET_VIEW = "application/vnd.jupyter.widget-view+json"
KERNELSPEC = {"name": "python3", "display_name": "Python 3 (ipykernel)", "language": "python"}


POLL_SLICE = 0.5   # seconds: the longest a missed wake-up can delay a message


def sliced(get_msg, slice_seconds: float = POLL_SLICE):
    """``get_msg(timeout)`` of a kernel channel, waiting in slices of ``slice_seconds``.

    Why: jupyter_client's asynchronous channel waits for a message with pyzmq's
    asyncio poll, which wakes on the socket's edge-triggered file descriptor. If
    that edge is consumed elsewhere (a send on the same socket), the poll sleeps
    until its timeout, and only its final zero-timeout check finds the message
    (pyzmq ``zmq/_future.py``, ``_AsyncPoller.poll``). A Run All then waits the
    whole cell timeout between two cells and goes on without an error (nbclient
    0.11, jupyter_client 8, pyzmq 27): 3 of 114 Run Alls of chapter 02 under load,
    none of 147 with the slices. The kernel's twin of this fault is fixed in
    ipykernel 7.4 (ipython/ipykernel#1529). Ending every slice with that
    zero-timeout check bounds the delay.
    """
    async def get_msg_in_slices(self, timeout=None):
        deadline = None if timeout is None else time.monotonic() + timeout
        while True:
            left = slice_seconds if deadline is None else deadline - time.monotonic()
            try:
                return await get_msg(self, timeout=max(0.0, min(slice_seconds, left)))
            except Empty:
                if deadline is not None and time.monotonic() >= deadline:
                    raise
    get_msg_in_slices.sliced, get_msg_in_slices.wrapped = True, get_msg
    return get_msg_in_slices


def wake_up_in_slices() -> None:
    """Make every asynchronous kernel channel of this process wait in slices (idempotent)."""
    if not getattr(AsyncZMQSocketChannel.get_msg, "sliced", False):
        AsyncZMQSocketChannel.get_msg = sliced(AsyncZMQSocketChannel.get_msg)


def strip_volatile(nb) -> list[tuple[int, float]]:
    """Remove what differs between two runs of unchanged code, in place.

    Drops each code cell's ``metadata.execution`` timestamps, the notebook's
    widget state ``metadata.widgets`` and every ``widget-view`` entry of the
    outputs (an output left with no data at all is dropped).

    Parameters
    ----------
    nb : nbformat.NotebookNode
        An executed notebook (nbformat 4).

    Returns
    -------
    list of (int, float)
        ``(execution_count, seconds)`` of the cells slower than 5 s, read
        from the timestamps before they are removed.
    """
    if not isinstance(nb, nbformat.NotebookNode) or "cells" not in nb:
        raise TypeError(f"nb must be an nbformat NotebookNode with cells, got {type(nb).__name__}")
    slow = []
    for cell in nb.cells:
        if cell.cell_type != "code":
            continue
        timing = cell.metadata.pop("execution", {})
        t0, t1 = timing.get("iopub.execute_input"), timing.get("shell.execute_reply")
        if t0 and t1:
            dt = (datetime.fromisoformat(t1.rstrip("Z"))
                  - datetime.fromisoformat(t0.rstrip("Z"))).total_seconds()
            if dt > SLOW_SECONDS:
                slow.append((cell.execution_count, dt))
        outputs = []
        for out in cell.get("outputs", []):
            data = out.get("data")
            if data is not None and WIDGET_VIEW in data:
                del data[WIDGET_VIEW]
                if not data:
                    continue  # nothing but a pointer to the dropped widget state
            outputs.append(out)
        if "outputs" in cell:
            cell.outputs = outputs
    nb.metadata.pop("widgets", None)
    return slow


def run(path: Path, timeout: int = 120) -> None:
    """Execute the notebook at ``path`` in a fresh ``python3`` kernel and save it in place.

    ``timeout`` (seconds) bounds each cell, as ``--nbval-cell-timeout=120`` does in
    pytest. The kernel's messages are read in slices (:func:`wake_up_in_slices`).
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"path must be an existing notebook file, got {str(path)!r}")
    nb = nbformat.read(path, as_version=4)
    nb.metadata["kernelspec"] = dict(KERNELSPEC)
    wake_up_in_slices()
    client = NotebookClient(nb, timeout=timeout, kernel_name="python3",
                            resources={"metadata": {"path": str(path.parent)}},
                            record_timing=True,
                            coalesce_streams=True)  # one stdout block a cell, as nbval compares
    start = time.perf_counter()
    client.execute()
    total = time.perf_counter() - start
    slow = strip_volatile(nb)
    nbformat.write(nb, path)
    size = path.stat().st_size
    try:
        shown = path.resolve().relative_to(ROOT)
    except ValueError:  # a notebook outside the repository, e.g. a scratch copy
        shown = path
    print(f"{shown}: {total:.1f} s, {size / 1e3:.0f} kB"
          + "".join(f"\n  cell [{n}] took {dt:.1f} s (> {SLOW_SECONDS:g} s)" for n, dt in slow))
    if size > MAX_BYTES:
        print(f"  WARNING: {size} bytes is over the 1 MB limit", file=sys.stderr)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("notebooks", nargs="*", type=Path)
    args = parser.parse_args(argv)
    paths = args.notebooks or sorted((ROOT / "notebooks").glob("[0-9][0-9]_*.ipynb"))
    for path in paths:
        run(path.resolve())
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
