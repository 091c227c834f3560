"""Optional dependencies: import them, or say which extra to install.

The core of quadsim needs only numpy and numba. Drawing and video (``quadsim
preview``, ``render``, ``diagram`` and :mod:`quadsim.viz`) need the ``viz``
extra (pyvista, matplotlib, imageio, imageio-ffmpeg). :func:`require` imports
such a module or raises :class:`~quadsim.errors.InputError` with the command
to install it, so a user without the extra gets one clear line instead of a
traceback. This module sits at the bottom of the package: it imports nothing
of quadsim but the error type.

Example::

    from quadsim._optional import require, require_for

    plt_figure = require("matplotlib.figure", "`quadsim diagram`")
    require_for("render")          # pyvista and imageio
    require("imageio_ffmpeg", "`quadsim render` to .mp4")
"""

from __future__ import annotations

import importlib
from types import ModuleType

from quadsim.errors import InputError

__all__ = ["NEEDS", "PIP_NAMES", "require", "require_for"]

#: What each command that draws needs, in import names (an .mp4 from
#: ``render`` needs ``imageio_ffmpeg`` as well; a GIF does not).
NEEDS: dict[str, tuple[str, ...]] = {
    "diagram": ("matplotlib",),
    "preview": ("pyvista",),
    "render": ("pyvista", "imageio"),
}

#: Import name -> the name pip knows it by, where they differ.
PIP_NAMES: dict[str, str] = {"imageio_ffmpeg": "imageio-ffmpeg"}


def require(module: str, feature: str, extra: str = "viz") -> ModuleType:
    """Import ``module``, or raise an :class:`InputError` saying how to get it.

    Parameters
    ----------
    module : str
        Import name, possibly dotted (``"matplotlib.figure"``).
    feature : str
        What needs it, as the user knows it (``"`quadsim diagram`"``).
    extra : str
        The quadsim extra that installs it.

    Returns
    -------
    ModuleType
        The imported module.

    Raises
    ------
    InputError
        When ``module`` (or the package it belongs to) is not installed:
        ``"`quadsim diagram` needs matplotlib: pip install 'quadsim[viz]'"``.
        An installed module that fails to import for another reason (one of
        its own dependencies missing, a broken build) raises its own error
        unchanged, since reinstalling quadsim's extra would not fix it.
    """
    try:
        return importlib.import_module(module)
    except ModuleNotFoundError as e:
        parts = module.split(".")
        ours = {".".join(parts[:k]) for k in range(1, len(parts) + 1)}
        if e.name not in ours:
            raise
        top = parts[0]
        raise InputError(f"{feature} needs {PIP_NAMES.get(top, top)}: "
                         f"pip install 'quadsim[{extra}]'") from None


def require_for(command: str) -> tuple[ModuleType, ...]:
    """Import everything the CLI command ``command`` draws with (:data:`NEEDS`).

    Parameters
    ----------
    command : str
        ``"diagram"``, ``"preview"`` or ``"render"``.

    Returns
    -------
    tuple of ModuleType
        The modules, in :data:`NEEDS` order.

    Raises
    ------
    InputError
        Naming the command and the first missing package (see :func:`require`).
    KeyError
        When ``command`` draws nothing (a programming error, not user input).
    """
    return tuple(require(m, f"`quadsim {command}`") for m in NEEDS[command])
