"""Datasets at scale: sweeps of clips over characters, gaits, speeds, turn rates and seeds.

A grid file (:mod:`quadsim.dataset.grid`) names lists of parameters; the
sweep is their product, one clip each, written to ``DIR/clips/`` with one
line per finished clip in ``DIR/manifest.jsonl`` holding its parameters and
its measured figures (:mod:`quadsim.dataset.manifest`). The clips are made
in batches (:mod:`quadsim.dataset.clips`) on local processes or a Dask
cluster (:mod:`quadsim.dataset.sweep`), resumably, and a clip's bytes depend
only on its parameters::

    from quadsim.dataset import load_grid, run_sweep

    summary = run_sweep(load_grid("grid.toml"), "out/dataset", workers=2)

The ``quadsim sweep`` command (:mod:`quadsim.cli_sweep`) is the same from a shell.
"""

from quadsim.dataset.clips import clip_bytes, generate, make_clips, measure, npz_bytes
from quadsim.dataset.grid import ClipSpec, Grid, load_grid, parse_grid
from quadsim.dataset.manifest import MANIFEST, read_manifest
from quadsim.dataset.sweep import Progress, SweepSummary, run_sweep

__all__ = ["MANIFEST", "ClipSpec", "Grid", "Progress", "SweepSummary", "clip_bytes",
           "generate", "load_grid", "make_clips", "measure", "npz_bytes", "parse_grid",
           "read_manifest", "run_sweep"]
