"""Side-by-side speed of this tree against another revision, interleaved.

::

    python -m benchmarks.compare REV [--rounds 5] [--characters leopard,horse]

checks ``REV`` (any git revision) out into a temporary worktree, warms both
trees' numba caches (each its own cache folder), then runs the same short
probes in fresh processes, alternating between the two trees round after
round (the order flips every round), so that a machine whose speed wanders
-- shared cores, turbo, other jobs -- slows both alike. Each probe calls the
tree's *own* ``benchmarks.suite`` functions (``bench_step``,
``bench_horse_data``, ``bench_many``, ``bench_simulate``), which both engines
have, so each side is measured the way its own benchmark measures it.

Prints, per figure, the median over rounds of each side and the ratio
(this tree / REV; above 1 is faster for rates, below 1 faster for seconds),
with the spread of the per-round ratios. ``--json FILE`` keeps the rounds.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]

#: What a probe measures, run by ``python -c`` inside one tree. It prints one
#: JSON object of figures: ``name -> (value, "rate" | "seconds")``.
_PROBE = r"""
import json, sys, warnings
warnings.simplefilter("ignore")
from benchmarks import suite
chars = {characters!r}
out = {{}}
for c in chars:
    r = suite.bench_step(c, {frames}, 3)
    out[c + " step posed (frames/s)"] = (r["pose"]["steps_per_s"], "rate")
    out[c + " step plan only (frames/s)"] = (r["plan_only"]["steps_per_s"], "rate")
    s, _ = suite.bench_simulate(c, 3)
    out[c + " simulate 60 s (s)"] = (s["seconds"], "seconds")
h = suite.bench_horse_data({frames}, 3)
if h is not None:
    out["data horse step (frames/s)"] = (h["steps_per_s"], "rate")
m = suite.bench_many(chars[0], {ns!r}, lambda n: max(5, 3000 // n), lambda n: 3, loop_up_to=0)
for n, r in m["by_n"].items():
    out["batch N=%s (character-frames/s)" % n] = (r["character_frames_per_s"], "rate")
print("PROBE" + json.dumps(out))
"""


def _probe(tree: Path, cache: Path, characters, frames: int, ns) -> dict:
    env = dict(os.environ, PYTHONPATH=str(tree), NUMBA_CACHE_DIR=str(cache),
               OMP_WAIT_POLICY=os.environ.get("OMP_WAIT_POLICY", "PASSIVE"))
    code = _PROBE.format(characters=tuple(characters), frames=frames, ns=tuple(ns))
    done = subprocess.run([sys.executable, "-c", code], cwd=tree, env=env,
                          capture_output=True, text=True, check=False)
    for line in done.stdout.splitlines():
        if line.startswith("PROBE"):
            return json.loads(line[5:])
    raise RuntimeError(f"probe in {tree} failed:\n{done.stderr[-2000:]}")


def compare(rev: str, rounds: int = 5, characters=("leopard", "horse"), frames: int = 3000,
            ns=(1, 100, 1000), log=print) -> dict:
    """Run the interleaved comparison; returns ``{figure: {...}}`` (see module doc).

    Raises
    ------
    ValueError
        When ``rev`` names no commit of this repository.
    """
    known = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--verify", "--quiet",
                            f"{rev}^{{commit}}"], capture_output=True, text=True, check=False)
    if known.returncode != 0:
        raise ValueError(f"{rev!r} is not a commit of {ROOT}: give a commit, tag or branch "
                         "(e.g. `git log --oneline` lists them)")
    work = Path(tempfile.mkdtemp(prefix="quadsim-compare-"))
    other = work / "tree"
    try:  # (the worktree inside: an interrupt while git checks it out removes it too)
        subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "--detach", "-q", str(other),
                        rev], check=True)
        sides = {"this": (ROOT, work / "cache-this"), rev: (other, work / "cache-other")}
        for name, (tree, cache) in sides.items():
            log(f"warming {name} (compiling into {cache}) ...")
            _probe(tree, cache, characters[:1], 50, (1,))
        runs = {name: [] for name in sides}
        for k in range(rounds):
            order = list(sides) if k % 2 == 0 else list(sides)[::-1]
            for name in order:
                runs[name].append(_probe(*sides[name], characters, frames, ns))
            log(f"round {k + 1}/{rounds} done")
    finally:
        subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force", str(other)],
                       check=False, capture_output=True)
        shutil.rmtree(work, ignore_errors=True)
        subprocess.run(["git", "-C", str(ROOT), "worktree", "prune"], check=False)
    table = {}
    for fig, (_, kind) in runs["this"][0].items():
        if fig not in runs[rev][0]:
            continue
        a = np.array([r[fig][0] for r in runs["this"]])
        b = np.array([r[fig][0] for r in runs[rev]])
        ratios = a / b if kind == "rate" else b / a  # > 1: this tree is faster
        table[fig] = {"kind": kind, "this": float(np.median(a)), rev: float(np.median(b)),
                      "speed_ratio": float(np.median(ratios)),
                      "ratio_range": [float(ratios.min()), float(ratios.max())],
                      "rounds_this": a.tolist(), "rounds_other": b.tolist()}
    return table


def _stop(signum, frame):
    """SIGTERM as an interrupt: the temporary worktree and caches are removed on the way out."""
    raise KeyboardInterrupt


def main(argv=None) -> int:
    signal.signal(signal.SIGTERM, _stop)
    ap = argparse.ArgumentParser(prog="python -m benchmarks.compare", description=__doc__.split(
        "\n\n")[0])
    ap.add_argument("rev", help="the git revision to compare against (e.g. a commit or tag)")
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--characters", default="leopard,horse", metavar="A,B")
    ap.add_argument("--frames", type=int, default=3000, help="steps per step probe")
    ap.add_argument("--json", metavar="FILE", help="also write the figures and rounds here")
    args = ap.parse_args(argv)
    if args.rounds < 1:
        ap.error("--rounds must be at least 1")
    try:
        table = compare(args.rev, args.rounds, tuple(args.characters.split(",")), args.frames,
                        log=lambda m: print(m, file=sys.stderr))
    except (ValueError, RuntimeError) as e:
        print(f"benchmarks.compare: error: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("benchmarks.compare: stopped; the temporary worktree was removed", file=sys.stderr)
        return 130
    w = max(len(f) for f in table)
    print(f"{'figure':<{w}}  {'this tree':>12}  {args.rev[:12]:>12}  speed ratio (range)")
    for fig, r in table.items():
        print(f"{fig:<{w}}  {r['this']:>12,.2f}  {r[args.rev]:>12,.2f}  "
              f"{r['speed_ratio']:.3f} ({r['ratio_range'][0]:.3f}-{r['ratio_range'][1]:.3f})")
    print(f"medians over {args.rounds} interleaved rounds; speed ratio > 1: this tree is "
          "faster (rates this/other, seconds other/this)")
    if args.json:
        Path(args.json).write_text(json.dumps(table, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
