"""Writing files so that a failure never leaves a half-written or lost file."""

from __future__ import annotations

import os
import secrets
from collections.abc import Callable
from pathlib import Path
from typing import IO

from quadsim.errors import InputError


def atomic_write(path: str | os.PathLike, write: Callable[[IO], None], *,
                 binary: bool = False) -> Path:
    """Write a file through a temporary file beside it, then move it into place.

    Parameters
    ----------
    path : str or path-like
        Destination. An existing file there is replaced only once the new one
        is complete; if anything fails, it is left as it was and the temporary
        file is removed.
    write : callable
        Called with the open temporary file (text, UTF-8 with ``\\n`` line
        ends, or binary).
    binary : bool

    Returns
    -------
    Path

    Raises
    ------
    InputError
        When the destination cannot be written (naming the path and the reason).
    """
    path = Path(path)
    tmp = path.parent / f".{path.name}.{os.getpid()}.{secrets.token_hex(4)}.tmp"
    try:
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
    except OSError as e:
        raise InputError(f"{path}: cannot write the file ({e.strerror})") from None
    try:
        mode = "wb" if binary else "w"
        kw = {} if binary else {"encoding": "utf-8", "newline": "\n"}
        with os.fdopen(fd, mode, **kw) as f:
            write(f)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException as e:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
        if isinstance(e, OSError):
            raise InputError(f"{path}: cannot write the file ({e.strerror or e})") from None
        raise
    return path


def atomic_write_bytes(path: str | os.PathLike, data: bytes) -> Path:
    """:func:`atomic_write` of a bytes object."""
    return atomic_write(path, lambda f: f.write(data), binary=True)
