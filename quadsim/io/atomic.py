"""Writing files whole or not at all.

Every file quadsim writes -- motions, videos, GIFs, diagrams, benchmark
results -- goes through :func:`atomic_output`: the data is written to a
temporary file beside the destination (``.NAME.PID.RANDOM.tmp``), flushed to
the disk, and only then moved over the destination with :func:`os.replace`.
A failure at any point (a full disk, a codec error, an exception) removes the
temporary file and leaves an existing file as it was.

Two rules about the destination (:func:`output_path`):

- a **symbolic link** is written through: the file it points to is replaced
  (atomically, in the target's folder), and the link stays a link;
- a **read-only** file is refused with an :class:`~quadsim.errors.InputError`
  naming it, instead of being silently replaced.

Temporary files in flight are registered here, so that a program stopped by
SIGTERM or SIGINT can remove them: :func:`cleanup_on_signals` installs the
handlers (the ``quadsim`` command does, for the whole command), and
:func:`remove_temporaries` is what they call.
"""

from __future__ import annotations

import os
import secrets
import signal
import stat
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import IO

from quadsim.errors import InputError

__all__ = ["SignalExit", "atomic_output", "atomic_write", "atomic_write_bytes",
           "check_signals", "cleanup_on_signals", "output_path", "pending_temporaries",
           "remove_temporaries"]

_PENDING: set[str] = set()
_LOCK = threading.Lock()
#: The signal received under :func:`cleanup_on_signals`, until the block ends.
_RECEIVED: list[int] = []


class SignalExit(SystemExit):
    """Raised by the handler :func:`cleanup_on_signals` installs: exit with ``128 + signum``.

    Attributes
    ----------
    signum : int
        The signal received.
    """

    def __init__(self, signum: int):
        super().__init__(128 + int(signum))
        self.signum = int(signum)


def output_path(path: str | os.PathLike) -> Path:
    """The file that writing to ``path`` replaces, checked.

    Parameters
    ----------
    path : str or path-like

    Returns
    -------
    Path
        ``path`` itself, or the file a symbolic link at ``path`` points to
        (followed to the end of a chain; it need not exist yet).

    Raises
    ------
    InputError
        When ``path`` (or the link's target) is a folder, or an existing file
        without write permission.
    """
    given = Path(path)
    target = Path(os.path.realpath(given)) if given.is_symlink() else given
    shown = str(given) if target == given else f"{given} (a link to {target})"
    if target.is_dir():
        raise InputError(f"{shown}: cannot write the file: it is a folder; give a file name")
    try:
        st = target.stat()
    except FileNotFoundError:
        return target
    except OSError as e:
        raise InputError(f"{shown}: cannot write the file ({e.strerror or e})") from None
    if not st.st_mode & (stat.S_IWUSR | stat.S_IWGRP | stat.S_IWOTH) \
            or not os.access(target, os.W_OK):
        raise InputError(f"{shown}: the file is read-only; quadsim does not replace it. "
                         f"Make it writable (chmod u+w {target}) or write to another file")
    return target


def pending_temporaries() -> list[str]:
    """The temporary files being written now (paths), oldest first not guaranteed."""
    with _LOCK:
        return sorted(_PENDING)


def remove_temporaries() -> int:
    """Delete every temporary file being written now; returns how many existed.

    Safe to call from a signal handler: it only unlinks registered paths.
    """
    with _LOCK:
        paths = list(_PENDING)
    n = 0
    for p in paths:
        try:
            os.unlink(p)
            n += 1
        except OSError:
            pass
    return n


def _default_mode() -> int:
    umask = os.umask(0)
    os.umask(umask)
    return 0o666 & ~umask


@contextmanager
def atomic_output(path: str | os.PathLike, *, suffix: str = "",
                  make_folder: bool = False, sync: bool = True) -> Iterator[Path]:
    """A temporary file to write ``path`` through; moved into place on success.

    Use it for writers that want a file name (a video encoder, a plotting
    library)::

        with atomic_output("out/clip.mp4", suffix=".mp4") as tmp:
            encode(frames, tmp)

    Parameters
    ----------
    path : str or path-like
        Destination (see :func:`output_path` for links and read-only files).
    suffix : str
        Appended to the temporary name, for writers that pick the format by
        extension (``".mp4"``).
    make_folder : bool
        Create the destination's folder if it is missing (else a missing
        folder is an error).
    sync : bool
        Flush the finished file to the disk before moving it (False when the
        writer has done so itself), so that a late "disk full" still fails
        here and not after the old file is gone.

    Yields
    ------
    Path
        The temporary file's path (not yet created). When the block ends
        normally, the file must exist; it is flushed to the disk, given the
        replaced file's permissions (else the usual ones for a new file) and
        moved over the destination.

    Raises
    ------
    InputError
        When the destination is refused, or the file cannot be written
        (naming the path and the reason, e.g. "No space left on device").
        Any other exception from the block passes through; in every case the
        temporary file is removed and the destination left as it was.
    """
    target = output_path(path)
    shown = str(path)
    if make_folder:
        try:
            target.parent.mkdir(parents=True, exist_ok=True)
        except OSError as e:
            raise InputError(f"{shown}: cannot create its folder ({e.strerror or e})") from None
    tmp = target.parent / f".{target.name}.{os.getpid()}.{secrets.token_hex(4)}.tmp{suffix}"
    key = os.fspath(tmp)
    with _LOCK:
        _PENDING.add(key)       # before the file exists: a signal can always find it
    try:
        yield tmp
        check_signals()
        try:
            mode = stat.S_IMODE(target.stat().st_mode)
        except OSError:
            mode = _default_mode()
        if sync:
            fd = os.open(tmp, os.O_RDWR)
            try:
                os.fsync(fd)
            finally:
                os.close(fd)
        os.chmod(tmp, mode)
        os.replace(tmp, target)
    except BaseException as e:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        if isinstance(e, OSError):
            raise InputError(f"{shown}: cannot write the file "
                             f"({e.strerror or e}); the old file, if any, is unchanged") from None
        raise
    finally:
        with _LOCK:
            _PENDING.discard(key)


def atomic_write(path: str | os.PathLike, write: Callable[[IO], None], *,
                 binary: bool = False) -> Path:
    """Write a file whole or not at all (see :func:`atomic_output`).

    Parameters
    ----------
    path : str or path-like
        Destination. An existing file there is replaced only once the new one
        is complete; if anything fails, it is left as it was and the temporary
        file is removed. A symbolic link is written through; a read-only file
        is refused.
    write : callable
        Called with the open temporary file (text, UTF-8 with ``\\n`` line
        ends, or binary).
    binary : bool

    Returns
    -------
    Path
        ``path`` as given.

    Raises
    ------
    InputError
        When the destination cannot be written (naming the path and the reason).
    """
    with atomic_output(path, sync=False) as tmp:
        try:
            fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
        except FileNotFoundError:
            raise InputError(f"{path}: cannot write the file (its folder "
                             f"{Path(tmp).parent} does not exist)") from None
        mode = "wb" if binary else "w"
        kw = {} if binary else {"encoding": "utf-8", "newline": "\n"}
        with os.fdopen(fd, mode, **kw) as f:
            write(f)
            f.flush()
            os.fsync(f.fileno())
    return Path(path)


def atomic_write_bytes(path: str | os.PathLike, data: bytes) -> Path:
    """:func:`atomic_write` of a bytes object."""
    return atomic_write(path, lambda f: f.write(data), binary=True)


@contextmanager
def cleanup_on_signals(signals=(signal.SIGTERM, signal.SIGINT)) -> Iterator[None]:
    """While the block runs, SIGTERM and SIGINT remove unfinished output files.

    The handler deletes every registered temporary file at once, then raises
    :class:`KeyboardInterrupt` (SIGINT) or :class:`SignalExit` (other
    signals, exit status ``128 + signum``) so the program unwinds as usual.
    The previous handlers come back when the block ends. Outside the main
    thread (where Python cannot install handlers) it does nothing.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def handler(signum, frame):
        _RECEIVED.append(int(signum))
        remove_temporaries()
        _raise_for(int(signum))

    old = {}
    _RECEIVED.clear()
    try:
        for s in signals:
            old[s] = signal.signal(s, handler)
        yield
    finally:
        for s, h in old.items():
            signal.signal(s, h)
        _RECEIVED.clear()


def _raise_for(signum: int):
    if signum == signal.SIGINT:
        raise KeyboardInterrupt
    raise SignalExit(signum)


def check_signals() -> None:
    """Raise again for a signal already received under :func:`cleanup_on_signals`.

    The handler raises where the program is, and code that calls back into
    Python from C (a VTK pipeline) may swallow the exception and carry on;
    long loops and :func:`atomic_output` call this so that the program still
    stops, and never publishes a file after the signal.
    """
    if _RECEIVED:
        _raise_for(_RECEIVED[0])
