"""
The command's console: progress on stderr and warnings as one line.

The library never prints (it logs and warns); the ``radiosim`` command (:mod:`radiosim.cli`)
owns the console, through these helpers. Nothing heavy is imported here: tqdm loads only
when a bar is drawn on a terminal.

A reader that leaves (``radiosim run | head -1``: a closed pipe) does not end the work: the
command's output goes to the null device from then on (:func:`outlive_the_reader`), and the
run completes, its files written and its exit status its own.
"""

from __future__ import annotations

import os
import sys

from radiosim.errors import RadiosimWarning

__all__ = ["Progress", "show_warning", "shell_expanded", "outlive_the_reader"]


class Progress:
    """Progress on stderr, created before the work it measures: a tqdm bar on a terminal, one
    plain line per step otherwise (no carriage returns: logs stay readable) unless
    ``terminal_only``, nothing when ``quiet``; nothing for the first ``delay`` [s]. Called as
    ``progress(done, total, label)`` (``total`` may be ``None``: unknown)."""

    def __init__(self, unit="measurement", quiet=False, delay=0.0, stream=None,
                 terminal_only=False):
        import time

        self.stream = stream or sys.stderr  # looked up now, not at import: redirections hold
        self.quiet, self.bar, self.clock = quiet, None, time.monotonic
        self.quiet = quiet or (terminal_only and not self.stream.isatty())
        self.shown_after = self.clock() + delay
        if not self.quiet and self.stream.isatty():
            from tqdm import tqdm

            self.bar = tqdm(file=self.stream, unit=unit, dynamic_ncols=True, delay=delay)

    def __call__(self, done, total=None, label=""):
        if self.bar is not None:
            self.bar.total = total
            self.bar.set_postfix_str(str(label)[:50], refresh=False)
            self.bar.update(done - self.bar.n)
            if total and done >= total:
                self.bar.close()
        elif not self.quiet and self.clock() >= self.shown_after:
            print(f"[{done}/{total or '?'}] {label}".rstrip(), file=self.stream, flush=True)

    def close(self):
        if self.bar is not None:
            self.bar.close()


def show_warning(message, category, filename, lineno, file=None, line=None):
    """Warnings as one line on stderr, without the source line."""
    name = "warning" if issubclass(category, RadiosimWarning) else category.__name__
    print(f"radiosim: {name}: {message}", file=sys.stderr)


def shell_expanded(message: str) -> str:
    """argparse's ``message``, or, where its unrecognised arguments are all existing files
    (``radiosim measure run/frame_*.exr`` unquoted: the shell expanded the pattern), one
    short line saying so instead of listing them."""
    if not message.startswith("unrecognized arguments: "):
        return message
    extra = message.split(": ", 1)[1].split()
    if len(extra) < 2 or not all(os.path.isfile(word) for word in extra):
        return message
    return (f"unrecognized arguments: {len(extra)} more files ({extra[0]} …): a pattern the "
            "shell expanded? quote it (radiosim measure 'run/frame_*.exr' reads a pattern)")


class _ReaderMayLeave:
    """``stream`` (a text stream on a file descriptor) whose writes, once its reader has gone
    (``BrokenPipeError``), go to the null device: the descriptor itself is pointed there, so
    the buffered rest, the interpreter's last flush and child processes sharing it write
    nowhere instead of failing."""

    def __init__(self, stream):
        self._stream = stream

    def write(self, text):
        try:
            return self._stream.write(text)
        except BrokenPipeError:
            self._to_null()
            return len(text)

    def flush(self):
        try:
            self._stream.flush()
        except BrokenPipeError:
            self._to_null()

    def _to_null(self):
        null = os.open(os.devnull, os.O_WRONLY)
        try:
            os.dup2(null, self._stream.fileno())
        finally:
            os.close(null)
        try:
            self._stream.flush()  # what the buffer still holds, to the null device
        except (OSError, ValueError):
            pass

    def __getattr__(self, name):
        return getattr(self._stream, name)


def outlive_the_reader() -> None:
    """Let the command's stdout and stderr outlive their reader (see the module docstring):
    called by the ``radiosim`` command itself, once, before its work."""
    for name in ("stdout", "stderr"):
        stream = getattr(sys, name)
        if isinstance(stream, _ReaderMayLeave):
            continue
        try:
            stream.fileno()
        except (AttributeError, OSError, ValueError):  # not on a descriptor: left as it is
            continue
        setattr(sys, name, _ReaderMayLeave(stream))
