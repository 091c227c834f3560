"""`quadsim sweep`: make a dataset of clips from a grid file (see :mod:`quadsim.dataset`).

::

    quadsim sweep GRID.toml [--out DIR] [--workers N] [--scheduler tcp://HOST:PORT]
                            [--limit K]

On a terminal a progress bar on stderr shows the clips done, clips per
second and the time left; a summary line on stdout ends the run. Run again
with the same ``--out``, it makes only the clips not yet finished.
"""

from __future__ import annotations

import sys
from pathlib import Path

from quadsim.errors import InputError

__all__ = ["ProgressBar", "register", "sweep_command"]


def _duration(seconds: float | None) -> str:
    if seconds is None:
        return "--:--"
    s = round(seconds)
    h, m = divmod(s, 3600)
    m, s = divmod(m, 60)
    return f"{h}:{m:02d}:{s:02d}" if h else f"{m:02d}:{s:02d}"


class ProgressBar:
    """A one-line progress bar redrawn in place on a terminal stream.

    Parameters
    ----------
    stream : text stream
        Drawn only if it is a terminal (``isatty``).
    width : int
        Characters of the bar itself.
    """

    def __init__(self, stream=None, width: int = 28):
        self.stream = sys.stderr if stream is None else stream
        self.width = width
        self.live = bool(getattr(self.stream, "isatty", lambda: False)())
        self._shown = 0  # the length of the line drawn

    @staticmethod
    def line(p, width: int = 28) -> str:
        """The bar's text for a :class:`~quadsim.dataset.sweep.Progress`."""
        frac = p.done / p.total if p.total else 1.0
        full = int(frac * width)
        bar = "#" * full + "-" * (width - full)
        return (f"[{bar}] {p.done}/{p.total} clips  {p.rate:.1f} clips/s  "
                f"ETA {_duration(p.eta)}")

    def __call__(self, p) -> None:
        if not self.live:
            return
        text = self.line(p, self.width)
        self.stream.write("\r" + text.ljust(self._shown))  # a shorter line covers the last
        self.stream.flush()
        self._shown = len(text)

    def close(self) -> None:
        """End the bar's line (if one was drawn)."""
        if self._shown:
            self.stream.write("\n")
            self.stream.flush()
            self._shown = 0


def sweep_command(args) -> int:
    """`quadsim sweep GRID.toml ...`: run the sweep, print its summary."""
    from quadsim.dataset import MANIFEST, load_grid, run_sweep
    from quadsim.dataset.grid import clamps

    grid_path = Path(args.grid)
    if grid_path.suffix.lower() != ".toml":
        raise InputError(f"{grid_path}: a grid file is a .toml file")
    if args.scheduler is not None and args.workers is not None:
        raise InputError("`--workers` and `--scheduler` are both given: --workers sets local "
                         "processes, --scheduler sends the clips to a Dask cluster; give one")
    if args.workers is not None and args.workers < 1:
        raise InputError(f"`--workers` {args.workers}: give a number of processes >= 1")
    if args.limit is not None and args.limit < 1:
        raise InputError(f"`--limit` {args.limit}: give a number of clips >= 1")
    if args.scheduler is not None and "://" not in args.scheduler:
        raise InputError(f"`--scheduler` {args.scheduler!r}: give the scheduler's address "
                         "with its protocol, e.g. tcp://HOST:8786")
    grid = load_grid(grid_path)
    out = Path(args.out) if args.out else Path("out") / grid_path.stem
    for message in clamps(grid.clips()):
        print(f"quadsim: warning: {grid_path}: {message}", file=sys.stderr)
    bar = ProgressBar()
    try:
        s = run_sweep(grid, out, workers=args.workers, scheduler=args.scheduler,
                      limit=args.limit, progress=bar)
    finally:
        bar.close()
    rest = f", {s.remaining} still to make (run again)" if s.remaining else ""
    if not s.made:
        print(f"{s.folder}: nothing to make: the {s.clips} clips of the grid are there"
              f"{rest}; manifest {Path(s.folder) / MANIFEST}")
        return 0
    print(f"{s.folder}: {s.made} clip{'' if s.made == 1 else 's'} made, {s.skipped} already "
          f"there, {s.clips} in the grid{rest}; {s.seconds:.1f} s on {s.workers}: "
          f"{s.clips_per_second:.1f} clips/s, {s.frames_per_second:,.0f} character-frames/s, "
          f"{s.bytes / 1e6:.1f} MB; manifest {Path(s.folder) / MANIFEST}")
    return 0


def register(sub) -> None:
    """Add the ``sweep`` sub-command to the ``quadsim`` parser's sub-parsers ``sub``."""
    sw = sub.add_parser("sweep", help="make a dataset of clips from a grid of characters, "
                        "gaits, speeds, turn rates and seeds",
                        description="Make every clip of a grid file's product of "
                        "characters, gaits, speeds, turn rates, seeds, lengths and frame "
                        "rates, each written atomically to DIR/clips/ with one line of "
                        "parameters and measured figures in DIR/manifest.jsonl. Run again, "
                        "it makes only the clips not yet finished; a clip's bytes depend "
                        "only on its parameters.")
    sw.add_argument("grid", metavar="GRID.toml")
    sw.add_argument("--out", metavar="DIR", help="the dataset's folder (default "
                    "out/<grid name>)")
    sw.add_argument("--workers", type=int, metavar="N",
                    help="local worker processes (default: the CPU count)")
    sw.add_argument("--scheduler", metavar="ADDRESS",
                    help="a running Dask distributed scheduler, e.g. tcp://HOST:8786 "
                    "(needs quadsim[dask])")
    sw.add_argument("--limit", type=int, metavar="K",
                    help="make at most K clips in this run")
    sw.set_defaults(func=sweep_command)
