"""quadsim: kinematic, real-time quadruped locomotion.

What a library user needs is here, without deep imports::

    import quadsim

    motion = quadsim.run("leopard", gait="trot", seconds=5)
    quadsim.save(motion, "out/leopard.glb")

- characters: :func:`load_character`, :func:`list_characters`, :class:`Character`;
- commands: :class:`Command`, :class:`Script`;
- controllers: :func:`make_controller` gives a :class:`Controller` whose
  ``step(command, dt)`` returns a :class:`Frame`;
- offline: :func:`run` (a config, or a character and a command) and
  :func:`simulate` give a :class:`Motion`; :func:`save` writes it by extension.

Conventions (see ``quadsim.frames``): SI units, right-handed world frame with
+Y up, characters face +Z with their left on +X, legs ordered LF, RF, LH, RH,
quaternions stored as (w, x, y, z).
"""

from quadsim import _kernel_cache

_kernel_cache.install()  # before any kernel is defined: cached kernels keyed by all kernel sources

from quadsim.api import make_controller, resolve, run, save, simulate  # noqa: E402
from quadsim.commands import Command, Script  # noqa: E402
from quadsim.controller import Controller, Frame  # noqa: E402
from quadsim.errors import InputError, QuadsimClampWarning  # noqa: E402
from quadsim.skeleton import (  # noqa: E402
    Character,
    Motion,
    Skeleton,
    list_characters,
    load_character,
)

__all__ = ["Character", "Command", "Controller", "Frame", "InputError", "Motion",
           "QuadsimClampWarning", "Script", "Skeleton", "list_characters", "load_character",
           "make_controller", "resolve", "run", "save", "simulate"]
from quadsim._version import __version__  # noqa: E402
