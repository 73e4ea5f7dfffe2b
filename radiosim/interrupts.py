"""
The command's interrupt, as the library's loops see it: the ``radiosim`` command records here
that it was interrupted (:mod:`radiosim.cli_signals`), and the work's loops (frame by frame,
measurement by measurement) call :func:`raise_if_interrupted` between their steps, so that an
interrupt a library swallowed where it arrived still ends the work. Outside the command's work
nothing here does anything.
"""

from radiosim.errors import Interrupted

__all__ = ["command_state", "raise_if_interrupted", "GRACE"]

#: Seconds the command's cleanup may take after an interrupt before it ends at once.
GRACE = 15.0


class command_state:  # noqa: N801 - a namespace, not a class of objects
    """State of the running command process (not of an in-process ``main(argv)`` call)."""

    active = False  # main() runs as the radiosim command
    interrupted = False
    signal_name = ""  # the interrupting signal: "Ctrl-C" or "SIGTERM"
    signum = 0  # its number


def raise_if_interrupted() -> None:
    """
    Raise again the interrupt the command has received (:func:`radiosim.cli_signals.on_interrupt`), if any: the
    exception the signal raised may have been swallowed where it arrived (by a library that
    catches every exception there), and the work would then go on until the cleanup's time
    limit (:data:`GRACE`) ends the process, in the middle of a write. The work's loops (frame
    by frame, measurement by measurement) call this between their steps; it does nothing
    outside the ``radiosim`` command's work or before a signal.
    """
    if command_state.active and command_state.interrupted:
        if command_state.signal_name == "Ctrl-C":
            raise KeyboardInterrupt
        raise Interrupted(command_state.signal_name)
