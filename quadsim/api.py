"""The front door: from a config, a character or a command to a motion and a file.

Everything that turns a description into motion goes through here -- the
``quadsim`` command (``run``, ``diagram``, ``render``, ``preview``), the
notebooks and a library user's code::

    import quadsim

    motion = quadsim.run("configs/leopard.toml")            # a config file
    motion = quadsim.run("horse", mode="data", speed=4.0)   # a character and a command
    quadsim.save(motion, "out/horse.glb")                   # format from the extension

    leopard = quadsim.load_character("leopard")
    ctl = quadsim.make_controller(leopard)                  # step it yourself
    frame = ctl.step(quadsim.Command(speed=3.0), 1 / 60)

:func:`resolve` turns any of the accepted sources into a validated
:class:`~quadsim.config.RunConfig`; :func:`simulate` runs a character
through commands in either mode; :func:`run` is the two together.
"""

from __future__ import annotations

import os
import warnings
from pathlib import Path

from quadsim.commands import Command, Script
from quadsim.errors import InputError, QuadsimClampWarning

__all__ = ["DEFAULT_SECONDS", "FORMATS", "MODEL_SUFFIXES", "MODES", "adopted_character_file", "check_mode", "make_controller", "model_of",
           "resolve", "run", "save", "simulate"]

#: Length (s) of a run made from a character without a config.
DEFAULT_SECONDS = 10.0
#: Frame rate of a run made from a character without a config.
DEFAULT_FPS = 60.0
#: Output formats :func:`save` writes, by extension.
FORMATS = (".bvh", ".glb", ".npz", ".csv")
#: Controller modes.
MODES = ("procedural", "data")


#: The rig files ``quadsim run MODEL`` adopts on the fly (as ``quadsim rig`` does).
MODEL_SUFFIXES = (".gltf", ".glb", ".bvh")

_ADOPTED: dict[tuple[str, int], Path] = {}


def _is_model(source) -> bool:
    return isinstance(source, (str, os.PathLike)) and \
        Path(source).suffix.lower() in MODEL_SUFFIXES


def adopted_character_file(model) -> Path:
    """The character file of a user's rig ``model`` adopted on the fly.

    What ``quadsim rig MODEL`` would write, kept in a folder of this
    process's own (removed at exit) and referring to the model by its
    absolute path, so that a run, a render or a preview of the model itself
    animates it in its own file. Adopted once per model and modification time.

    Raises
    ------
    InputError
        For a missing file or one that holds no quadruped, naming ``quadsim
        rig`` to write a draft whose feet can be set by hand.
    """
    import atexit
    import shutil
    import tempfile

    from quadsim.io.adopt import adopt
    from quadsim.io.rig_structure import RigMatchError

    path = Path(model).resolve()
    try:
        key = (str(path), path.stat().st_mtime_ns)
    except OSError:
        raise InputError(f"{model}: no such model file") from None
    hit = _ADOPTED.get(key)
    if hit is not None and hit.is_file():
        return hit
    try:
        adoption = adopt(path)
    except RigMatchError as e:
        raise InputError(f"{model}: no quadruped found: {e}; run `quadsim rig {model} --out "
                         f"{path.stem}.toml` to write a draft naming the legs to set by hand, "
                         "then run that file") from None
    folder = Path(tempfile.mkdtemp(prefix="quadsim-rig-"))
    atexit.register(shutil.rmtree, folder, True)
    cid = "".join(c if c.isalnum() else "_" for c in path.stem.lower())
    out = folder / f"{cid}.toml"
    out.write_text(adoption.character_toml(cid, name=path.stem, model=str(path)),
                   encoding="utf-8")
    _ADOPTED[key] = out
    return out


def _character(ref):
    from quadsim.skeleton.character import Character, load_character

    if isinstance(ref, Character):
        return ref
    return load_character(adopted_character_file(ref) if _is_model(ref) else ref)


def check_mode(character, mode: str, label: str = "`mode`") -> None:
    """Raise unless ``character`` can run in ``mode``.

    Raises
    ------
    InputError
        For an unknown mode, or ``"data"`` with a character that has no clip
        database; ``label`` names the field or flag in the message.
    """
    if mode not in MODES:
        raise InputError(f"{label} = {mode!r} is not a known mode; allowed: "
                         f"{', '.join(map(repr, MODES))}")
    if mode == "data":
        from quadsim.io.clips import clip_folder

        if clip_folder(character) is None:
            raise InputError(f"{label} = 'data' needs a character with a clip database; "
                             f"{character.id!r} has none; drop `--mode data` (or set mode = "
                             "'procedural') to run it with the procedural controller, pick "
                             "a character with clips (`quadsim preview horse --mode data`), or "
                             "cut a database from your takes (`quadsim clips-from TAKE.bvh "
                             "--character CHARACTER.toml --out DIR`) and name it in the "
                             "character file's [character] table (`clips = \"DIR\"`)")


def make_controller(character, mode: str = "procedural", *, dt: float = 1.0 / 60.0,
                    seed: int = 0, gait: str | None = None, database=None):
    """A controller for ``character`` in ``mode``, to step yourself.

    Parameters
    ----------
    character : Character or str
        A character, its identifier (``"leopard"``) or a character file.
    mode : {"procedural", "data"}
        ``"data"`` plays the character's clip database (the horse's shipped
        one, or the one its file names: ``[character] clips``).
    dt : float
        Default step (s).
    seed : int
        Procedural mode: the seed of the oscillators' start.
    gait : str, optional
        Procedural mode: the starting gait.
    database : ClipDatabase, optional
        Data mode: the clips (default: the character's shipped ones).

    Returns
    -------
    Controller
        ``step(command, dt) -> Frame`` (see :mod:`quadsim.controller`).
    """
    character = _character(character)
    check_mode(character, mode)
    if mode == "data":
        from quadsim.horse.controller import HorseDataController
        from quadsim.io.clips import load_default_database

        return HorseDataController(character, database or load_default_database(character),
                                   dt=dt)
    from quadsim.locomotion.controller import ProceduralController

    return ProceduralController(character, dt=dt, seed=seed, gait=gait)


def simulate(character, commands: Script | Command, *, seconds: float,
             fps: float = DEFAULT_FPS, mode: str = "procedural", seed: int = 0):
    """Run ``character`` through ``commands`` and return the motion.

    Parameters
    ----------
    character : Character or str
    commands : Script or Command
        What to do over time (a single command is held throughout).
    seconds : float
        Length of the run (s); the motion has ``round(seconds * fps)`` frames.
    fps : float
        Frames per second; the controller steps once a frame.
    mode : {"procedural", "data"}
    seed : int
        Procedural mode's seed.

    Returns
    -------
    Motion
        With planned contacts, gait labels and per-frame extras (the data
        mode's ``extras["ground"]`` is the ground under each foot joint and
        ``extras["toe_ground"]`` under each toe tip).

    Raises
    ------
    InputError
        For a run shorter than one frame, a bad mode or character.
    """
    character = _character(character)
    check_mode(character, mode)
    if isinstance(commands, Command):
        commands = Script.constant(commands)
    if not (seconds > 0 and fps > 0) or round(seconds * fps) < 1:
        raise InputError(f"a run of {seconds!r} s at {fps!r} fps has no frame; give at least "
                         "one frame (seconds * fps >= 1)")
    if mode == "data":
        from quadsim.horse.controller import simulate as simulate_data
        from quadsim.io.clips import load_default_database

        return simulate_data(character, commands, seconds, fps,
                             database=load_default_database(character))
    from quadsim.locomotion.offline import simulate as simulate_procedural

    return simulate_procedural(character, commands, seconds, fps, seed=seed)


def _animation_name(motion) -> str:
    gaits = [] if motion.gaits is None else list(dict.fromkeys(
        str(g) for g in motion.gaits if "->" not in str(g)))
    return "+".join(gaits) or "quadsim"


def _shipped_ids() -> set[str]:
    from quadsim.skeleton.character import list_characters

    return set(list_characters())


def _is_config(source) -> bool:
    """A TOML file holding a run configuration (a ``[[command]]`` script)."""
    p = Path(source)
    if p.suffix.lower() != ".toml" or not p.is_file():
        return False
    import tomllib

    try:
        data = tomllib.loads(p.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError):
        return True  # let load_config say what is wrong with it
    return "command" in data or "duration" in data


def resolve(source, *, mode: str | None = None, seconds: float | None = None,
            fps: float | None = None, units: str | None = None, speed: float | None = None,
            gait: str | None = None, turn_rate_deg_s: float | None = None):
    """A validated :class:`~quadsim.config.RunConfig` for any accepted source.

    Parameters
    ----------
    source : str, os.PathLike, RunConfig or Character
        A config file, a character identifier (``"leopard"``), a character
        file, a user's rigged model (``.gltf``, ``.glb`` or ``.bvh``, adopted
        on the fly: :func:`adopted_character_file`), or a config or character
        already loaded.
    mode : {"procedural", "data"}, optional
        Replaces a config's mode; for a character the default is procedural.
    seconds, fps, units, speed, gait, turn_rate_deg_s : optional
        As the ``quadsim run`` flags: the first three replace the config's;
        any of the last three replace its commands with one constant command
        (``gait`` alone at its preferred speed). A character without any of
        them walks at its slowest gait's preferred speed for
        :data:`DEFAULT_SECONDS`.

    Raises
    ------
    InputError
        Naming the file, key or flag and what is allowed.
    """
    from dataclasses import replace

    from quadsim.config import RunConfig, constant_command, load_config, with_overrides
    from quadsim.skeleton.character import Character

    if isinstance(source, RunConfig):
        config = source
    elif not isinstance(source, Character) and _is_config(source):
        config = load_config(source)
    else:
        if _is_model(source):
            source = adopted_character_file(source)
        character = _character(source)
        if isinstance(source, (str, os.PathLike)) and str(source).endswith(".toml"):
            ref = str(Path(source).resolve())
        elif getattr(character, "path", None) is not None and \
                character.id not in _shipped_ids():
            ref = str(character.path)
        else:
            ref = character.id
        run_mode = mode or "procedural"
        check_mode(character, run_mode, "`--mode`")
        config = RunConfig(character=ref, duration=DEFAULT_SECONDS, fps=DEFAULT_FPS, seed=0,
                           mode=run_mode, units="m",
                           commands=Script.constant(constant_command(character)))
    if mode is not None and mode != config.mode:
        character = config.load_character()
        check_mode(character, mode, "`--mode`")
        if speed is None and gait is None and turn_rate_deg_s is None:
            _check_script_for(config, character, mode)
        config = replace(config, mode=mode)
    return with_overrides(config, duration=seconds, fps=fps, units=units, speed=speed,
                          gait=gait, turn_rate_deg_s=turn_rate_deg_s)


def _check_script_for(config, character, mode: str) -> None:
    """A config's commands must suit the mode ``--mode`` switches it to."""
    where = str(config.source) if config.source is not None else "the config"
    if mode == "data":
        from quadsim.io.clips import playable_gaits

        clips = playable_gaits(character)
        for k, c in enumerate(config.commands.commands):
            if c.gait is not None and (c.gait if c.gait != "transverse_gallop"
                                       else "gallop") not in clips:
                raise InputError(f"`--mode data`: {where}: `command[{k}].gait` = {c.gait!r} "
                                 f"has no clips in {character.id}'s database; allowed: "
                                 f"{', '.join(clips)}")
    else:
        for k, c in enumerate(config.commands.commands):
            if c.slope:
                raise InputError(f"`--mode {mode}`: {where}: `command[{k}].slope_deg` needs "
                                 "the data mode (the procedural mode walks on flat ground)")


def run(source, **overrides):
    """The motion of a config, or of a character under a constant command.

    ``run(source, **overrides)`` is ``simulate`` of ``resolve(source,
    **overrides)``; see :func:`resolve` for the sources and overrides.

    Returns
    -------
    Motion
    """
    from quadsim.skeleton.character import Character

    config = resolve(source, **overrides)
    character = source if isinstance(source, Character) else config.load_character()
    return simulate(character, config.commands, seconds=config.duration,
                    fps=config.fps, mode=config.mode, seed=config.seed)


def run_reporting(config, report=None):
    """:func:`simulate` a resolved config, each distinct clamp warning passed to
    ``report(message)`` once (default: re-issued as warnings)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        motion = simulate(config.load_character(), config.commands, seconds=config.duration,
                          fps=config.fps, mode=config.mode, seed=config.seed)
    seen: set[str] = set()
    for w in caught:
        msg = str(w.message)
        if msg in seen:
            continue
        seen.add(msg)
        if report is None:
            warnings.warn(msg, w.category if issubclass(w.category, Warning)
                          else QuadsimClampWarning, stacklevel=2)
        else:
            report(msg)
    return motion


def model_of(character):
    """The user's own model (a ``.gltf``/``.glb``/``.bvh`` path) a character was adopted
    from, or None."""
    f = getattr(character, "file", None)
    return None if f is None else f.character.model


def save(motion, path, *, units: str = "m", character=None) -> Path:
    """Write ``motion`` to ``path``, the format chosen by the extension.

    Parameters
    ----------
    motion : Motion
    path : str or os.PathLike
        ``.bvh`` (Biovision hierarchy), ``.glb`` (binary glTF with a skinned
        body), ``.npz`` or ``.csv`` (joint world positions and contacts).
        Missing folders are created; the file is written whole or not at all.
    units : {"m", "cm"}
        Length unit of a BVH file; the other formats are always in metres.
    character : Character, optional
        The character the motion is of. When it was adopted from the user's own
        model (its file's ``character.model``), a ``.glb`` is that glTF model
        with the motion added as an animation (:mod:`quadsim.io.rig_export`)
        and a ``.bvh`` the user's own hierarchy, joint names, offsets, axes and
        unit (:mod:`quadsim.io.bvh_rig`; ``units`` does not apply).

    Returns
    -------
    Path
        The file written.

    Raises
    ------
    InputError
        For an extension quadsim does not write, a folder as ``path``, or a
        unit other than m/cm.
    """
    path = Path(path)
    if path.is_dir():
        raise InputError(f"{str(path)!r} is a folder; give a file name")
    ext = path.suffix.lower()
    if ext not in FORMATS:
        kind = f"{ext} files" if ext else "files without an extension"
        raise InputError(f"{str(path)!r}: cannot write {kind}; supported: "
                         f"{', '.join(FORMATS)}")
    if units not in ("m", "cm"):
        raise InputError(f"`units` = {units!r}; allowed: 'm', 'cm'")
    if units != "m" and ext != ".bvh":
        warnings.warn(f"{ext} files are always in metres; units {units!r} apply to .bvh "
                      "files only", UserWarning, stacklevel=2)
    model = model_of(character)
    if units != "m" and ext == ".bvh" and model is not None:
        warnings.warn(f"units {units!r} do not apply: the .bvh is written in the unit of "
                      f"{character.id}'s own model ({model.name})", UserWarning, stacklevel=2)
    path.parent.mkdir(parents=True, exist_ok=True)
    if model is not None and (ext == ".bvh" or (ext == ".glb"
                                                and model.suffix.lower() != ".bvh")):
        from quadsim.io.adopt import write_for_character

        write_for_character(character, motion, path, names=[_animation_name(motion)])
    elif ext == ".bvh":
        from quadsim.io.bvh import write_bvh

        write_bvh(motion, path, units=units)
    elif ext == ".glb":
        from quadsim.io.gltf import write_glb

        write_glb(motion, path)
    elif ext == ".npz":
        from quadsim.io.npz import write_npz

        write_npz(motion, path)
    else:
        from quadsim.io.npz import write_csv

        write_csv(motion, path)
    return path
