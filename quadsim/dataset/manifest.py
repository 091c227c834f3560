"""A sweep's folder: its manifest of finished clips, its lock, its leftovers.

``DIR/manifest.jsonl`` holds one JSON object a line, one line per finished
clip, appended as clips finish. A clip counts as finished when its line is
there and its file exists with the size the line records. The file is
written (atomically) and then its line (:func:`publish`), with SIGTERM and
SIGINT held back meanwhile, so a stopped job leaves both or neither; after
a harder stop (SIGKILL, a crash of the machine) a clip whose line or file is
missing is made again on the next run, the same bytes. A line cut short is
ignored when read and removed before the next append.

When a run ends, :func:`compact` rewrites the manifest in the grid's order,
each clip once, so the manifest too is the same whatever the workers were.
While a run is going, :class:`Manifest` holds an exclusive lock on the file,
so two sweeps never write the same folder at once.
"""

from __future__ import annotations

import json
import os
import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from quadsim.errors import InputError

__all__ = ["MANIFEST", "Manifest", "compact", "deferred_signals", "publish", "read_manifest",
           "remove_leftovers"]

#: The manifest's name inside a sweep's folder.
MANIFEST = "manifest.jsonl"


def read_manifest(path) -> dict[str, dict]:
    """The entries of a manifest by clip id, in the order of their first lines (the last
    line of an id counts; lines that are not a JSON object with an ``id``, such as one
    cut short, are skipped)."""
    out: dict[str, dict] = {}
    try:
        text = Path(path).read_text(encoding="utf-8", errors="replace")
    except FileNotFoundError:
        return out
    for line in text.splitlines():
        try:
            entry = json.loads(line)
        except ValueError:
            continue
        if isinstance(entry, dict) and isinstance(entry.get("id"), str):
            out[entry["id"]] = entry
    return out


def _line(entry: dict) -> str:
    return json.dumps(entry, separators=(", ", ": "), allow_nan=False) + "\n"


@contextmanager
def deferred_signals(signals=(signal.SIGTERM, signal.SIGINT)) -> Iterator[None]:
    """Hold SIGTERM and SIGINT back while the block runs, then deliver them.

    A signal received meanwhile is raised again, to the handlers of before,
    when the block ends: a clip's file and its manifest line are written both
    or neither. Outside the main thread it does nothing.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    got: list[int] = []
    old = {s: signal.signal(s, lambda signum, frame: got.append(signum)) for s in signals}
    try:
        yield
    finally:
        for s, h in old.items():
            signal.signal(s, h)
        if got:
            signal.raise_signal(got[0])


def publish(folder, entry: dict, data: bytes) -> None:
    """Write a finished clip's file (atomically) and then its manifest line, both or
    neither: a stop meanwhile waits for the two (:func:`deferred_signals`).

    Parameters
    ----------
    folder : path-like
        The sweep's folder.
    entry : dict
        The clip's manifest entry; ``entry["path"]`` is its file, relative to
        ``folder``.
    data : bytes
        The file's bytes.
    """
    from quadsim.io.atomic import atomic_output

    folder = Path(folder)
    line = _line(entry).encode("utf-8")
    with deferred_signals():
        # not flushed to the disk clip by clip (it would cost more than making the
        # clip): after a crash of the machine, a clip whose size is not the one
        # its line records is made again (sweep.pending)
        with atomic_output(folder / entry["path"], sync=False) as tmp:
            fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
            with os.fdopen(fd, "wb") as f:
                f.write(data)
        # one write of the whole line at the end of the file: the lines of
        # workers appending at the same time never mix
        fd = os.open(folder / MANIFEST, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o666)
        try:
            view = memoryview(line)
            while view:
                view = view[os.write(fd, view):]
        finally:
            os.close(fd)


def remove_leftovers(folder) -> int:
    """Delete the temporary files a stopped run left in ``folder`` and ``folder/clips``
    (``.NAME.*.tmp`` of :mod:`quadsim.io.atomic`); returns how many. Call it only
    while holding the folder's :class:`Manifest` lock."""
    n = 0
    for d in (Path(folder), Path(folder) / "clips"):
        if not d.is_dir():
            continue
        for p in d.iterdir():
            if p.name.startswith(".") and ".tmp" in p.name and p.is_file():
                try:
                    p.unlink()
                    n += 1
                except OSError:
                    pass
    return n


class Manifest:
    """The manifest of a sweep's folder, opened for appending under a lock.

    Parameters
    ----------
    folder : path-like
        The sweep's folder (created if missing).

    Raises
    ------
    InputError
        When the folder cannot be created, or another sweep is writing it.
    """

    def __init__(self, folder):
        self.folder = Path(folder)
        self.path = self.folder / MANIFEST
        try:
            (self.folder / "clips").mkdir(parents=True, exist_ok=True)
            self._f = open(self.path, "a+b")
        except OSError as e:
            raise InputError(f"`--out` {str(self.folder)!r}: cannot write there "
                             f"({e.strerror or e})") from None
        try:
            import fcntl

            fcntl.flock(self._f.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except ImportError:  # no fcntl (Windows): no lock
            pass
        except OSError:
            self._f.close()
            raise InputError(f"`--out` {str(self.folder)!r}: another sweep is writing this "
                             "folder; wait for it to finish or give another --out") from None
        self._repair()

    def _repair(self) -> None:
        """Cut a last line left without its line end (a stopped run)."""
        f = self._f
        f.seek(0, os.SEEK_END)
        size = f.tell()
        if size == 0:
            return
        f.seek(size - 1)
        if f.read(1) == b"\n":
            return
        f.seek(0)
        data = f.read()
        f.truncate(data.rfind(b"\n") + 1)
        f.flush()

    def entries(self) -> dict[str, dict]:
        """The finished entries by id (see :func:`read_manifest`)."""
        return read_manifest(self.path)

    def close(self) -> None:
        """Flush to the disk and release the lock."""
        if self._f.closed:
            return
        try:
            os.fsync(self._f.fileno())
        except OSError:
            pass
        self._f.close()

    def __enter__(self) -> Manifest:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def compact(manifest: Manifest, order: list[str]) -> int:
    """Rewrite the manifest atomically: the grid's clips first in ``order`` (ids), then
    any others in their order, each once, only those whose file exists. Returns the
    number of lines. Call it with the manifest open (its lock held)."""
    from quadsim.io.atomic import atomic_write

    entries = manifest.entries()
    folder = manifest.folder
    wanted = set(order)
    ids = [i for i in order if i in entries] + [i for i in entries if i not in wanted]
    keep = [entries[i] for i in ids if (folder / str(entries[i].get("path", ""))).is_file()]
    text = "".join(_line(e) for e in keep)
    atomic_write(manifest.path, lambda f: f.write(text))
    return len(keep)
