"""
The command's console: progress on stderr and warnings as one line.

The library never prints (it logs and warns); the ``radiosim`` command (:mod:`radiosim.cli`)
owns the console, through these two helpers. Nothing heavy is imported here: tqdm loads only
when a bar is drawn on a terminal.
"""

from __future__ import annotations

import sys

from radiosim.errors import RadiosimWarning

__all__ = ["Progress", "show_warning"]


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
