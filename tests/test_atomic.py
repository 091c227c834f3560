"""Files are written whole or not at all (quadsim.io.atomic)."""

import os
import signal

import pytest

from quadsim.errors import InputError
from quadsim.io.atomic import (
    SignalExit,
    atomic_output,
    atomic_write,
    cleanup_on_signals,
    pending_temporaries,
    remove_temporaries,
)


def names(folder):
    return sorted(p.name for p in folder.iterdir())


def test_a_written_file_replaces_the_old_one_and_keeps_its_permissions(tmp_path):
    path = tmp_path / "a.txt"
    path.write_text("old")
    path.chmod(0o600)
    assert atomic_write(path, lambda f: f.write("new")) == path
    assert path.read_text() == "new"
    assert path.stat().st_mode & 0o777 == 0o600
    assert names(tmp_path) == ["a.txt"] and pending_temporaries() == []


def test_a_failed_write_leaves_the_old_file_and_no_temporary(tmp_path):
    path = tmp_path / "a.txt"
    path.write_text("old")

    def disk_full(f):
        f.write("half")
        raise OSError(28, "No space left on device")

    with pytest.raises(InputError, match=r"a\.txt: cannot write the file \(No space left"):
        atomic_write(path, disk_full)

    def bug(f):
        raise RuntimeError("a bug")

    with pytest.raises(RuntimeError, match="a bug"):
        atomic_write(path, bug)
    assert path.read_text() == "old"
    assert names(tmp_path) == ["a.txt"] and pending_temporaries() == []


def test_the_temporary_file_is_registered_while_it_is_written(tmp_path):
    seen = []
    with atomic_output(tmp_path / "v.mp4", suffix=".mp4") as tmp:
        tmp.write_bytes(b"frames")
        seen = pending_temporaries()
        assert tmp.name.startswith(".v.mp4.") and tmp.name.endswith(".tmp.mp4")
    assert seen == [str(tmp)]
    assert pending_temporaries() == [] and (tmp_path / "v.mp4").read_bytes() == b"frames"


def test_remove_temporaries_deletes_the_files_in_flight(tmp_path):
    # the file is gone when it would be moved into place
    with pytest.raises(InputError), atomic_output(tmp_path / "x.bin") as tmp:
        tmp.write_bytes(b"x")
        assert remove_temporaries() == 1
        assert not tmp.exists()
    assert names(tmp_path) == []


def test_sigterm_while_writing_removes_the_file_and_exits_143(tmp_path):
    path = tmp_path / "keep.txt"
    path.write_text("old")

    def write(f):
        f.write("part")
        f.flush()
        os.kill(os.getpid(), signal.SIGTERM)   # handled at the next bytecode
        f.write("never")

    before = signal.getsignal(signal.SIGTERM)
    with pytest.raises(SignalExit) as e, cleanup_on_signals():
        atomic_write(path, write)
    assert e.value.code == 143 and e.value.signum == signal.SIGTERM
    assert signal.getsignal(signal.SIGTERM) == before
    assert path.read_text() == "old" and names(tmp_path) == ["keep.txt"]


def test_links_are_written_through_and_read_only_files_refused(tmp_path):
    target = tmp_path / "real.txt"
    target.write_text("old")
    link = tmp_path / "link.txt"
    link.symlink_to(target)
    atomic_write(link, lambda f: f.write("new"))
    assert link.is_symlink() and target.read_text() == "new"
    target.chmod(0o444)
    with pytest.raises(InputError, match=r"link\.txt \(a link to .*real\.txt\): the file is "
                                         r"read-only"):
        atomic_write(link, lambda f: f.write("newer"))
    assert target.read_text() == "new"
    (tmp_path / "dir.txt").mkdir()
    with pytest.raises(InputError, match=r"dir\.txt: cannot write the file: it is a folder"):
        atomic_write(tmp_path / "dir.txt", lambda f: f.write("x"))


def test_a_signal_swallowed_by_a_callback_still_stops_the_write(tmp_path):
    """C code calling back into Python (VTK) may swallow the exception and carry on."""
    path = tmp_path / "keep.txt"
    path.write_text("old")

    def write(f):
        try:
            os.kill(os.getpid(), signal.SIGINT)
            f.write("part")                      # the handler raises here...
        except KeyboardInterrupt:
            pass                                 # ...and a careless callback swallows it
        f.write("rest")

    with pytest.raises(KeyboardInterrupt), cleanup_on_signals():
        atomic_write(path, write)
    assert path.read_text() == "old" and names(tmp_path) == ["keep.txt"]
