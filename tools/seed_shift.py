"""Re-execute chapters with every literal seed shifted, to show that no assert leans on one seed.

Usage (from the repository root)::

    python tools/seed_shift.py 101 202 303                          # every chapter
    python tools/seed_shift.py 101 --notebooks notebooks/03_*.ipynb

Every ``default_rng(<integer>)`` in a copy of the notebook becomes
``default_rng(<integer> + shift)``; the copy is executed top to bottom in a
temporary folder and nothing is saved. An assert that fails on a shifted
run fails here, with its cell. Exercise checks compare with references
computed on the statement's seeds, so they may say "Not yet" on a shifted
run; they never raise, so that is not a failure.
"""

from __future__ import annotations

import argparse
import re
import sys
import tempfile
import time
from pathlib import Path

import nbformat
from nbclient import NotebookClient
from nbclient.exceptions import CellExecutionError

from run_notebooks import wake_up_in_slices  # a missed wake-up costs 0.5 s, not the timeout

ROOT = Path(__file__).resolve().parents[1]
SEED = re.compile(r"default_rng\(\s*(\d+)\s*\)")


def shifted(source: str, shift: int) -> str:
    """``source`` with every ``default_rng(n)`` replaced by ``default_rng(n + shift)``."""
    return SEED.sub(lambda m: f"default_rng({int(m.group(1)) + shift})", source)


def run_shifted(path: Path, shift: int, timeout: int = 120) -> str | None:
    """Execute a seed-shifted copy of ``path``; return None, or the error text."""
    nb = nbformat.read(path, as_version=4)
    for cell in nb.cells:
        if cell.cell_type == "code":
            cell.source = shifted(cell.source, shift)
    wake_up_in_slices()
    with tempfile.TemporaryDirectory() as tmp:
        client = NotebookClient(nb, timeout=timeout, kernel_name="python3",
                                resources={"metadata": {"path": tmp}})
        try:
            client.execute()
        except CellExecutionError as err:
            return str(err)[-3000:]
    return None


def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("shifts", nargs="+", type=int, help="seed shifts, e.g. 101 202 303")
    parser.add_argument("--notebooks", nargs="*", type=Path,
                        default=sorted((ROOT / "notebooks").glob("0*.ipynb")))
    args = parser.parse_args(argv)
    failures = 0
    for path in args.notebooks:
        for shift in args.shifts:
            start = time.perf_counter()
            error = run_shifted(path, shift)
            status = "ok" if error is None else "FAILED"
            print(f"{path.name} seeds +{shift}: {status} ({time.perf_counter() - start:.1f} s)", flush=True)
            if error is not None:
                failures += 1
                print(error, flush=True)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
