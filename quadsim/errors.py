"""The one exception type for bad user input.

Anything a user can get wrong -- a config value, a file, a command -- raises
:class:`InputError` with a message that names the source (file and key) and
says what is allowed. The CLI prints it and exits with status 2.
"""


class InputError(ValueError):
    """Bad user input; the message names the file or field and the fix."""


class QuadsimClampWarning(UserWarning):
    """A command was beyond what the character can do and was clamped.

    The message names the value, the limit and what was used instead. Both
    controllers raise it once per distinct clamp.
    """
