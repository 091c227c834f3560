"""The one exception type for bad user input.

Anything a user can get wrong -- a config value, a file, a command -- raises
:class:`InputError` with a message that names the source (file and key) and
says what is allowed. The CLI prints it and exits with status 2.
:func:`read_toml` reads a TOML file with such messages.
"""

from pathlib import Path


class InputError(ValueError):
    """Bad user input; the message names the file or field and the fix."""


class QuadsimClampWarning(UserWarning):
    """A command was beyond what the character can do and was clamped.

    The message names the value, the limit and what was used instead. Both
    controllers raise it once per distinct clamp.
    """


def read_toml(path, kind: str) -> dict:
    """The parsed TOML file at ``path``, a ``kind`` (``"config"``, ``"character"``) file.

    Raises
    ------
    InputError
        When the file is missing, a folder, not UTF-8 text or not valid TOML
        (tomllib's message gives the line and column); the message names the file.
    """
    import tomllib

    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise InputError(f"{path}: no such {kind} file") from None
    except IsADirectoryError:
        raise InputError(f"{path}: is a folder, not a {kind} file") from None
    except UnicodeDecodeError:
        raise InputError(f"{path}: not a text file (expected UTF-8 TOML)") from None
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise InputError(f"{path}: not valid TOML: {e}") from None


def read_text_lines(path, kind: str = "") -> list[str]:
    """The lines of the text file at ``path`` (UTF-8, with or without a byte
    order mark, else Latin-1; any line ending), a ``kind`` file ("BVH", say).

    Raises
    ------
    InputError
        When the file is missing or cannot be read; the message names the file.
    """
    import re

    path = Path(path)
    what = f"{kind} file" if kind else "file"
    try:
        raw = path.read_bytes()
    except FileNotFoundError:
        raise InputError(f"{path}: no such {what}") from None
    except OSError as e:
        raise InputError(f"{path}: cannot read the file ({e.strerror or e})") from None
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError:
        text = raw.decode("latin-1")
    return re.split(r"\r\n|\r|\n", text)
