"""The benchmark suite's command line (``python -m benchmarks``, ``quadsim bench``).

A full run writes ``benchmarks/results/<machine>.json`` (``<machine>`` names
the CPU model and its number of cores), the figures committed with the
source. A ``--quick`` run is a rough smoke test and never replaces them: it
writes ``out/bench-quick.json`` (in the current folder) unless ``--out``
names a file, the committed one included.
"""

from __future__ import annotations

import argparse
import json
import os
from pathlib import Path

from benchmarks.suite import CHARACTERS, RESULTS, machine_slug, run

__all__ = ["QUICK_RESULT", "add_arguments", "main", "result_path", "run_from_args"]

#: Where a ``--quick`` run writes without ``--out`` (relative to the current folder).
QUICK_RESULT = Path("out") / "bench-quick.json"


def add_arguments(ap: argparse.ArgumentParser) -> None:
    ap.add_argument("--quick", action="store_true",
                    help="a short smoke run (seconds, not minutes); figures are rough, "
                    f"written to {QUICK_RESULT} unless --out says otherwise")
    ap.add_argument("--max-n", type=int, default=1000, metavar="N",
                    help="largest number of characters stepped together (1000; 10000 adds "
                    "the largest herd)")
    ap.add_argument("--characters", metavar="A,B",
                    help="characters to measure, comma-separated (default: all four; the "
                    "first is used for the many-characters and export figures)")
    ap.add_argument("--out", metavar="FILE.json",
                    help="result file (default benchmarks/results/<machine>.json; "
                    f"{QUICK_RESULT} with --quick)")


def result_path(out: str | None, quick: bool, machine: dict) -> Path:
    """The result file: ``out`` if given, else the quick file or the committed one."""
    if out:
        return Path(out)
    return QUICK_RESULT if quick else RESULTS / f"{machine_slug(machine)}.json"


def main(argv: list[str] | None = None) -> int:
    os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")   # as the quadsim command does
    ap = argparse.ArgumentParser(prog="python -m benchmarks",
                                 description="Benchmark quadsim: step, simulate, many "
                                 "characters, export.")
    add_arguments(ap)
    return run_from_args(ap.parse_args(argv))


def run_from_args(args) -> int:
    """Run the suite as the parsed arguments say and write the result (atomically)."""
    from quadsim.io.atomic import atomic_write

    chars = tuple(args.characters.split(",")) if getattr(args, "characters", None) else CHARACTERS
    result = run(quick=args.quick, max_n=args.max_n, characters=chars)
    out = result_path(args.out, args.quick, result["machine"])
    out.parent.mkdir(parents=True, exist_ok=True)
    atomic_write(out, lambda f: f.write(json.dumps(result, indent=2) + "\n"))
    print(f"wrote {out}")
    return 0
