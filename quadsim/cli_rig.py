"""`quadsim rig`: adopt a user's rigged quadruped as a character (see :mod:`quadsim.io.adopt`)."""

from __future__ import annotations

from pathlib import Path

from quadsim.errors import InputError

__all__ = ["adopt_command"]


def adopt_command(args) -> int:
    """`quadsim rig MODEL [--out CHARACTER.toml] [--id ID]`: adopt, report, write."""
    import os

    from quadsim.io.adopt import adopt
    from quadsim.io.atomic import atomic_write, output_path

    model = Path(args.model)
    if model.suffix.lower() not in (".gltf", ".glb"):
        raise InputError(f"{model}: `quadsim rig` reads .gltf or .glb models")
    try:
        adoption = adopt(model)
    except ValueError as e:
        if isinstance(e, InputError):
            raise
        raise InputError(f"{model}: no quadruped found: {e}; the character file's [chains] "
                         "and [legs.*] tables name the joints by hand") from None
    out = Path(args.out) if args.out else Path(f"{model.stem}.toml")
    if out.suffix.lower() != ".toml":
        raise InputError(f"`--out` {str(out)!r}: a character file is written as .toml")
    output_path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    ref = os.path.relpath(model.resolve(), out.resolve().parent)
    cid = args.id or "".join(c if c.isalnum() else "_" for c in model.stem.lower())
    text = adoption.character_toml(cid, name=model.stem, model=ref)
    atomic_write(out, lambda f: f.write(text))
    print(adoption.report())
    print(f"wrote {out}: character {cid!r}; run it with `quadsim run {out} --gait trot "
          f"--out {model.stem}_trot.glb` (the .glb is your model with the motion added)")
    return 0
