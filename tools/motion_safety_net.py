"""Record the motion of every shipped config, or compare against a recording.

The safety net of a refactor: record before changing the engine, compare after
every step. A recording is one ``.npz`` per case holding the root positions,
the joint world positions, the local quaternions, the contacts and the gait
labels. Cases: every config in ``configs/``, and a constant command per
character and gait (plus the data-driven horse at four speeds).

::

    python tools/motion_safety_net.py record DIR
    python tools/motion_safety_net.py compare DIR [--tol 1e-9]

``compare`` prints the largest difference of each case (m for positions) and
exits 1 if any case differs by more than ``--tol`` or its labels differ.
"""

from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]

#: (case name, character, gait or None, speed or None, seconds, mode)
CONSTANT_CASES = [
    *[(f"{c}-{g}", c, g, None, 6.0, "procedural")
      for c in ("leopard", "leopard_cub", "dog_cub", "horse")
      for g in ("walk", "trot", "pace", "canter", "transverse_gallop", "rotary_gallop")],
    *[(f"horse_data-{v:g}", "horse", None, v, 6.0, "data") for v in (1.5, 4.0, 6.5, 12.0)],
    ("leopard-turn", "leopard", "trot", None, 6.0, "procedural"),
]


def _cases():
    """Yield ``(name, motion)`` for every case, using the public front door."""
    import quadsim

    for path in sorted((ROOT / "configs").glob("*.toml")):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            yield f"config-{path.stem}", _run_config(quadsim, path)
    for name, cid, gait, speed, seconds, mode in CONSTANT_CASES:
        turn = 25.0 if name.endswith("-turn") else None
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            yield name, _run_constant(quadsim, cid, gait, speed, seconds, mode, turn)


def _run_config(quadsim, path):
    if hasattr(quadsim, "run"):
        return quadsim.run(path)
    from quadsim.config import load_config
    from quadsim.horse.controller import simulate as simulate_data
    from quadsim.locomotion import simulate

    cfg = load_config(path)
    if cfg.mode == "data":
        from quadsim.io.clips import load_default_database

        ch = cfg.load_character()
        return simulate_data(ch, cfg.commands, cfg.duration, cfg.fps,
                             database=load_default_database(ch))
    return simulate(cfg.load_character(), cfg.commands, cfg.duration, cfg.fps, seed=cfg.seed)


def _run_constant(quadsim, cid, gait, speed, seconds, mode, turn):
    if hasattr(quadsim, "run"):
        return quadsim.run(cid, mode=mode, gait=gait, speed=speed, turn_rate_deg_s=turn,
                           seconds=seconds, fps=60.0)
    from quadsim.config import constant_command
    from quadsim.horse.controller import simulate as simulate_data
    from quadsim.locomotion import Script, simulate
    from quadsim.skeleton import load_character

    ch = load_character(cid)
    script = Script.constant(constant_command(ch, speed=speed, gait=gait,
                                              turn_rate_deg_s=turn))
    if mode == "data":
        from quadsim.io.clips import load_default_database

        return simulate_data(ch, script, seconds, 60.0, database=load_default_database(ch))
    return simulate(ch, script, seconds, 60.0, seed=0)


def _arrays(motion) -> dict[str, np.ndarray]:
    gaits = motion.gaits if motion.gaits is not None else np.array([], dtype=object)
    return {
        "root": np.asarray(motion.root_positions, float),
        "world": np.asarray(motion.world_positions(), float),
        "quat": np.asarray(motion.rotations, float),
        "contacts": np.asarray(motion.contacts if motion.contacts is not None else [], bool),
        "gaits": np.array([str(g) for g in gaits], dtype="U40"),
    }


def record(folder: Path) -> int:
    folder.mkdir(parents=True, exist_ok=True)
    for name, motion in _cases():
        np.savez_compressed(folder / f"{name}.npz", **_arrays(motion))
        print(f"recorded {name}: {motion.n_frames} frames")
    return 0


def compare(folder: Path, tol: float) -> int:
    bad = 0
    for name, motion in _cases():
        ref_path = folder / f"{name}.npz"
        if not ref_path.is_file():
            print(f"{name}: no recording")
            bad += 1
            continue
        ref = np.load(ref_path)
        new = _arrays(motion)
        worst, notes = 0.0, []
        for key in ("root", "world", "quat"):
            if ref[key].shape != new[key].shape:
                notes.append(f"{key} shape {ref[key].shape} -> {new[key].shape}")
                worst = np.inf
                continue
            d = float(np.max(np.abs(ref[key] - new[key]))) if ref[key].size else 0.0
            worst = max(worst, d)
        same_labels = (ref["contacts"].shape == new["contacts"].shape
                       and np.array_equal(ref["contacts"], new["contacts"])
                       and np.array_equal(ref["gaits"], new["gaits"]))
        if not same_labels:
            notes.append("contacts or gait labels differ")
        ok = worst <= tol and same_labels
        bad += not ok
        print(f"{'ok  ' if ok else 'DIFF'} {name}: max |d| {worst:.3g} {'; '.join(notes)}")
    print(f"{bad} case(s) differ" if bad else "all cases match")
    return 1 if bad else 0


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("action", choices=("record", "compare"))
    p.add_argument("folder", type=Path)
    p.add_argument("--tol", type=float, default=1e-9)
    a = p.parse_args(argv)
    return record(a.folder) if a.action == "record" else compare(a.folder, a.tol)


if __name__ == "__main__":
    sys.exit(main())
