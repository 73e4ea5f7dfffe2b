"""Errors and warnings raised by radiosim.

The library never prints: it raises :class:`RadiosimError` (a :class:`ValueError`) for bad input,
naming the offending value and what was expected, and warns with :class:`RadiosimWarning`.
"""

__all__ = ["RadiosimError", "RadiosimIOError", "RadiosimWarning", "Interrupted"]


class RadiosimError(ValueError):
    """Invalid input or configuration: the message names the value and what was expected."""


class RadiosimIOError(RadiosimError):
    """The system refused a read or write (a full disk, a read-only folder): not the user's
    input, so the command exits with 1, not 2. The message names the file."""


class RadiosimWarning(UserWarning):
    """A result is valid but may not be what the user expects (e.g. a saturated pixel)."""


class Interrupted(BaseException):
    """Ctrl-C or SIGTERM: unwinds like KeyboardInterrupt, so every ``finally`` runs."""
