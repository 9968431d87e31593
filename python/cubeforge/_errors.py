"""cubeforge's exceptions: every one is a ``cubeforge.Error``; a bad argument is also a
``ValueError``, a file that cannot be read, written or decoded also an ``OSError``."""


class Error(Exception):
    """Anything cubeforge refuses or fails at, with the command line's one-line message."""


class ArgumentError(Error, ValueError):
    """A bad argument, options that do not fit together, or a limit exceeded."""


class FileError(Error, OSError):
    """A file that could not be read, written or decoded (its name starts the message)."""
