"""`quadsim rig`: adopt a user's rigged quadruped as a character (see :mod:`quadsim.io.adopt`).

When the rig's structure cannot be found (three legs found, or feet on more
than two girdles: a second spine or skeleton), the command writes a draft of
the character file with the keys to set by hand -- each leg's ``chain``,
whose last joint names the foot -- and exits with status 2. Run again with
the same ``--out``, it reads the feet named there and adopts the rig with
them.
"""

from __future__ import annotations

import os
from pathlib import Path

from quadsim.errors import InputError
from quadsim.frames import LEGS

__all__ = ["adopt_command", "feet_by_hand", "register"]

_MODELS = (".gltf", ".glb", ".bvh")


def feet_by_hand(out: Path, model: Path) -> list[str] | None:
    """The four feet named in an existing character file (or draft) for ``model``: the last
    joint of each ``[legs.*] chain``; None when the file is absent, refers to another
    model or names no foot for some leg."""
    import tomllib

    from quadsim.io.adopt import rig_foot

    if not out.is_file():
        return None
    try:
        data = tomllib.loads(out.read_text(encoding="utf-8"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as e:
        raise InputError(f"{out}: not a readable character file ({e}); fix it or remove it "
                         "to adopt the rig afresh") from None
    ref = data.get("character", {}).get("model")
    if not isinstance(ref, str) or (out.parent / ref).resolve() != model.resolve():
        return None
    legs = data.get("legs", {})
    chains = [legs.get(leg, {}).get("chain") if isinstance(legs.get(leg), dict) else None
              for leg in LEGS]
    if not all(isinstance(c, list) and c and all(isinstance(n, str) for n in c)
               for c in chains):
        return None
    return [rig_foot(c) for c in chains]


def _draft(model: Path, ref: str, cid: str, err) -> str:
    """A character file draft for a rig that could not be mapped."""
    keys = ", ".join(err.keys)
    lines = [f"# `quadsim rig` could not map {model.name} by itself: {err.found}.",
             f"# Set by hand: {keys} -- each leg's joints from its top to its foot (the",
             "# foot, the last joint, is enough), then run again with the same --out:",
             f"#     quadsim rig {model} --out <this file>",
             "", "[character]", f'id = "{cid}"', f'name = "{model.stem}"',
             f"model = {_toml_string(ref)}", ""]
    for leg in LEGS:
        found = err.partial.get(leg, ())
        chain = ", ".join(f'"{n}"' for n in found)
        mark = "" if found else "  # SET BY HAND"
        lines += [f"[legs.{leg}]", f"chain = [{chain}]{mark}", ""]
    return "\n".join(lines)


def _toml_string(text: str) -> str:
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'


def adopt_command(args) -> int:
    """`quadsim rig MODEL [--out CHARACTER.toml] [--id ID]`: adopt, report, write."""
    from quadsim.io.adopt import adopt
    from quadsim.io.atomic import atomic_write, output_path
    from quadsim.io.rig_structure import RigMatchError

    model = Path(args.model)
    if model.suffix.lower() not in _MODELS:
        raise InputError(f"{model}: `quadsim rig` reads .gltf, .glb or .bvh rigs")
    out = Path(args.out) if args.out else Path(f"{model.stem}.toml")
    if out.suffix.lower() != ".toml":
        raise InputError(f"`--out` {str(out)!r}: a character file is written as .toml")
    output_path(out)
    ref = os.path.relpath(model.resolve(), out.resolve().parent) if model.exists() else ""
    cid = args.id or "".join(c if c.isalnum() else "_" for c in model.stem.lower())
    feet = feet_by_hand(out, model) if model.exists() else None
    try:
        adoption = adopt(model, feet=feet)
    except RigMatchError as e:
        if not e.keys:
            raise InputError(f"{model}: no quadruped found: {e}") from None
        out.parent.mkdir(parents=True, exist_ok=True)
        text = _draft(model, ref, cid, e)
        atomic_write(out, lambda f: f.write(text))
        raise InputError(f"{model}: no quadruped found: {e.found}; wrote the draft {out}: set "
                         f"{', '.join(e.keys)} there by hand (the foot joint is enough), then "
                         f"run `quadsim rig {model} --out {out}` again") from None
    out.parent.mkdir(parents=True, exist_ok=True)
    text = adoption.character_toml(cid, name=model.stem, model=ref)
    atomic_write(out, lambda f: f.write(text))
    print(adoption.report())
    if feet is not None:
        print(f"(the feet as named in {out}: {', '.join(feet)})")
    kind = "your model with the motion added" if model.suffix.lower() != ".bvh" \
        else "your own hierarchy"
    ext = ".bvh" if model.suffix.lower() == ".bvh" else ".glb"
    print(f"wrote {out}: character {cid!r}; run it with `quadsim run {out} --gait trot "
          f"--out {model.stem}_trot{ext}` (the {ext} is {kind})")
    return 0


def register(sub) -> None:
    """Add the ``rig`` sub-command to the ``quadsim`` parser's sub-parsers ``sub``."""
    rg = sub.add_parser("rig", help="adopt your own rigged quadruped (glTF, BVH) as a character",
                        description="Find a rig's legs, spine, neck, head and tail from its "
                        "shape, print what was matched and ignored, and write a character "
                        "file that refers to the model; `quadsim run` of that file writes "
                        ".glb files into your own model, .bvh in your own hierarchy.")
    rg.add_argument("model", metavar="MODEL.glb|.gltf|.bvh")
    rg.add_argument("--out", metavar="CHARACTER.toml",
                    help="character file to write (default <model name>.toml)")
    rg.add_argument("--id", help="character identifier (default from the model's name)")
    rg.set_defaults(func=adopt_command)
