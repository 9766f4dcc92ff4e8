"""Re-execute notebooks top to bottom in one fresh kernel and save them with outputs.

Usage (from the repository root, in the course environment)::

    python tools/run_notebooks.py                      # every notebook
    python tools/run_notebooks.py notebooks/01_*.ipynb # some of them

Run it after every edit to a notebook or to the ``bayesfilt`` code it uses,
then commit the saved notebooks: ``pytest`` re-executes them under strict
nbval and fails if a stored output differs from what the code produces now.
Per-cell run times are printed so that a slow cell shows up (aim: < 5 s).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import nbformat
from nbclient import NotebookClient

ROOT = Path(__file__).resolve().parents[1]
MAX_BYTES = 1_000_000


def run(path: Path, timeout: int = 600) -> None:
    nb = nbformat.read(path, as_version=4)
    nb.metadata["kernelspec"] = {"name": "python3", "display_name": "Python 3 (ipykernel)",
                                 "language": "python"}
    client = NotebookClient(nb, timeout=timeout, kernel_name="python3",
                            resources={"metadata": {"path": str(path.parent)}},
                            record_timing=True)
    start = time.perf_counter()
    client.execute()
    total = time.perf_counter() - start
    slow = []
    for cell in nb.cells:
        if cell.cell_type != "code":
            continue
        timing = cell.metadata.get("execution", {})
        t0, t1 = timing.get("iopub.execute_input"), timing.get("shell.execute_reply")
        if t0 and t1:
            from datetime import datetime
            dt = (datetime.fromisoformat(t1.rstrip("Z")) - datetime.fromisoformat(t0.rstrip("Z"))).total_seconds()
            if dt > 5:
                slow.append((cell.execution_count, dt))
        # Timestamps would make every re-run a diff; keep outputs only.
        cell.metadata.pop("execution", None)
    nb.metadata.pop("widgets", None) if not _has_widgets(nb) else None
    nbformat.write(nb, path)
    size = path.stat().st_size
    print(f"{path.relative_to(ROOT)}: {total:.1f} s, {size / 1e3:.0f} kB"
          + "".join(f"\n  cell [{n}] took {dt:.1f} s (> 5 s)" for n, dt in slow))
    if size > MAX_BYTES:
        print(f"  WARNING: {size} bytes is over the 1 MB limit", file=sys.stderr)


def _has_widgets(nb) -> bool:
    return any("application/vnd.jupyter.widget-view+json" in out.get("data", {})
               for cell in nb.cells if cell.cell_type == "code" for out in cell.get("outputs", []))


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
