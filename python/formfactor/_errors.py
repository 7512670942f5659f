"""The exceptions of formfactor. Every error the library reports on purpose is a
:class:`formfactor.Error`; bad input and bad arguments are also :class:`ValueError`."""

__all__ = ["Error", "InputError", "OptionError", "GeometryError", "ResourceError", "Cancelled"]


class Error(Exception):
    """Base of every error formfactor reports on purpose."""


class InputError(Error, ValueError):
    """Bad input in a file. ``file`` names it, ``line`` is the line (1-based) or None."""

    def __init__(self, message, file=None, line=None):
        super().__init__(message)
        self.file = file
        self.line = line


class OptionError(Error, ValueError):
    """A bad keyword argument (or combination). ``option`` is the keyword's name."""

    def __init__(self, message, option=None):
        super().__init__(message)
        self.option = option


class GeometryError(Error, ValueError):
    """Geometry formfactor cannot handle (degenerate, non-planar, ...), outside a file."""


class ResourceError(Error, MemoryError):
    """A run that needs more memory than the machine has, refused before it starts; the
    message says what it needs and what to do instead."""


class Cancelled(Error):
    """A computation stopped because it was asked to (Ctrl-C raises KeyboardInterrupt)."""
