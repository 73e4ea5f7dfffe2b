"""
Files radiosim writes: atomically, into folders it owns, never over a user's file.

-   :func:`atomic_write`: a file is written under a hidden temporary name beside its destination
    and renamed into place only when complete; on any exit before that — an error, Ctrl-C,
    SIGTERM — the temporary file is removed. A reader never sees half a file, and an existing
    file is never destroyed by a failed write.
-   :class:`OutputFolder`: a run's results go to a new or empty folder, or, with
    ``overwrite=True``, to a folder radiosim wrote before: then only the files named in the
    manifest it left there (:data:`MANIFEST`) are replaced. Files are staged in a clearly named
    sibling folder (``NAME.partial``) and moved in when the run completes; a run that fails or is
    interrupted leaves that partial folder only if it holds a completed result, never an empty
    skeleton.
"""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import sys
import tempfile
import threading
from pathlib import Path

from radiosim.errors import RadiosimError, RadiosimIOError

__all__ = ["atomic_write", "atomic_path", "write_text", "OutputFolder", "MANIFEST",
           "native_output_silenced"]

_NATIVE = threading.Lock()


@contextlib.contextmanager
def native_output_silenced():
    """
    Keep what a native library prints (OpenEXR's own messages on a damaged file) off the
    terminal: file descriptors 1 and 2 point to the null device for the duration. Python's
    own error for the same problem still reaches the caller, who reports it in one line.
    """
    with _NATIVE:
        for stream in (sys.stdout, sys.stderr):
            with contextlib.suppress(Exception):
                stream.flush()
        try:
            saved = [os.dup(1), os.dup(2)]
        except OSError:  # no descriptors to redirect (an embedded interpreter)
            yield
            return
        null = os.open(os.devnull, os.O_WRONLY)
        try:
            os.dup2(null, 1)
            os.dup2(null, 2)
            with open(os.devnull, "w") as sink, contextlib.redirect_stdout(sink), \
                    contextlib.redirect_stderr(sink):
                yield
        finally:
            os.dup2(saved[0], 1)
            os.dup2(saved[1], 2)
            for fd in (*saved, null):
                os.close(fd)

#: The file in which a run lists what it wrote (so that ``--overwrite`` replaces only those).
MANIFEST = "radiosim-manifest.json"


@contextlib.contextmanager
def atomic_write(path, mode: str = "w", **kwargs):
    """
    Open a temporary file beside ``path`` for writing; rename it to ``path`` when the block
    completes, remove it on any exit before (exceptions and interrupts included).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> with atomic_write(folder / "a.txt") as handle:
    ...     _ = handle.write("done")
    >>> sorted(p.name for p in folder.iterdir())
    ['a.txt']
    """
    path = Path(path)
    if not path.parent.is_dir():
        raise RadiosimError(f"cannot write {path}: folder {path.parent} does not exist")
    if path.is_dir():
        raise RadiosimError(f"cannot write {path}: it is a folder")
    try:
        handle, temporary = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".partial",
                                             dir=path.parent)
    except OSError as exc:
        raise RadiosimIOError(f"cannot write {path}: {exc.strerror or exc}") from None
    temporary = Path(temporary)
    try:
        with os.fdopen(handle, mode, **kwargs) as stream:
            yield stream
        os.chmod(temporary, 0o666 & ~_umask())  # as open() would create it, not mkstemp's 0600
        os.replace(temporary, path)
    except BaseException:
        temporary.unlink(missing_ok=True)
        raise


@contextlib.contextmanager
def atomic_path(path):
    """
    A temporary path beside ``path`` for a library that writes by file name (OpenEXR,
    xarray); renamed to ``path`` when the block completes, removed on any exit before. A
    library's own error becomes a :class:`~radiosim.errors.RadiosimIOError` naming ``path``.
    """
    path = Path(path)
    if not path.parent.is_dir():
        raise RadiosimError(f"cannot write {path}: folder {path.parent} does not exist")
    temporary = path.with_name(f".{path.name}.{os.getpid()}.partial")
    try:
        yield temporary
        os.replace(temporary, path)
    except BaseException as exc:  # interrupts too: no temporary file is left behind
        temporary.unlink(missing_ok=True)
        if not isinstance(exc, Exception) or isinstance(exc, RadiosimError):
            raise
        raise RadiosimIOError(f"cannot write {path}: {exc}") from exc


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def write_text(path, text: str) -> Path:
    """Write ``text`` to ``path`` atomically (UTF-8)."""
    with atomic_write(path, "w", encoding="utf-8", newline="") as stream:
        stream.write(text)
    return Path(path)


class OutputFolder:
    """
    The folder a run writes into (see the module docstring).

    Parameters
    ----------
    path
        The destination folder.
    overwrite
        Allow a folder that holds radiosim's own files from an earlier run (listed in its
        manifest); other files are never touched, and a run that would write over one refuses.

    Use :attr:`staging` as the run's folder, :meth:`commit` when it completed, and
    :meth:`abandon` when it failed.
    """

    def __init__(self, path, overwrite: bool = False):
        self.path = Path(path)
        self.overwrite = overwrite
        self.previous: list[str] = []
        if self.path.exists() and not self.path.is_dir():
            raise RadiosimError(f"--out {self.path} is an existing file, not a folder; choose a "
                                "new folder")
        if self.path.is_dir() and any(self.path.iterdir()):
            manifest = self.path / MANIFEST
            if not overwrite:
                raise RadiosimError(
                    f"--out {self.path} is not empty; choose a new or empty folder, or pass "
                    "--overwrite to replace the files of radiosim's previous run there "
                    f"(those listed in {MANIFEST})")
            if not manifest.is_file():
                raise RadiosimError(
                    f"--out {self.path} is not empty and radiosim did not write it (it holds no "
                    f"{MANIFEST}); --overwrite replaces only radiosim's own files: choose a new "
                    "or empty folder")
            if manifest.is_file():
                try:
                    self.previous = [str(f) for f in json.loads(manifest.read_text())["files"]]
                except (OSError, ValueError, KeyError, TypeError):
                    raise RadiosimError(f"{manifest} is not a radiosim manifest; --overwrite "
                                        "will not touch that folder") from None
                root = self.path.resolve()
                for name in self.previous:  # only files inside the folder, never beyond it
                    target = (self.path / name).resolve()
                    if Path(name).is_absolute() or root not in target.parents:
                        raise RadiosimError(f"{manifest} lists {name!r}, outside {self.path}; "
                                            "--overwrite will not touch that folder")
                    if target.exists() and not target.is_file():
                        raise RadiosimError(f"{manifest} lists {name!r}, which is a folder, "
                                            "not a file radiosim wrote; --overwrite will not "
                                            "touch that folder")
        parent = self.path.parent
        self.created: list[Path] = []  # parent folders made for this run, removed if it fails
        try:
            for folder in [*reversed(parent.parents), parent]:
                if not folder.exists():
                    folder.mkdir()
                    self.created.append(folder)
        except OSError as exc:
            raise RadiosimIOError(f"cannot create {exc.filename or parent}: "
                                  f"{exc.strerror or exc}") from None
        self.staging = parent / f"{self.path.name}.partial"
        if self.staging.exists():
            raise RadiosimError(f"{self.staging} exists (an earlier run's partial result); move "
                                "or delete it first")
        try:
            self.staging.mkdir()
        except OSError as exc:
            self._remove_created()
            raise RadiosimIOError(f"cannot write in {parent}: {exc.strerror or exc}") from None

    def _remove_created(self):
        for folder in reversed(self.created):
            with contextlib.suppress(OSError):
                folder.rmdir()

    def files(self) -> list[str]:
        """The files written in the staging folder, relative to it."""
        return sorted(str(p.relative_to(self.staging)) for p in self.staging.rglob("*")
                      if p.is_file() and not p.name.endswith(".partial"))

    def commit(self) -> list[Path]:
        """Move the staged files into the destination and write the manifest; returns the
        destination paths."""
        from radiosim import __version__

        written = self.files()
        clash = [f for f in written if (self.path / f).exists() and f not in self.previous]
        if clash:
            raise RadiosimError(f"{self.path / clash[0]} exists and is not radiosim's (not in "
                                f"{MANIFEST}); nothing was replaced. Partial results are in "
                                f"{self.staging}")
        write_text(self.staging / MANIFEST, json.dumps(
            {"radiosim": __version__, "files": written}, indent=1) + "\n")
        if not self.path.exists():
            self.staging.rename(self.path)
        else:
            for name in self.previous:  # the previous run's files go, the user's stay
                if name not in written:
                    (self.path / name).unlink(missing_ok=True)
            for name in written + [MANIFEST]:
                target = self.path / name
                target.parent.mkdir(parents=True, exist_ok=True)
                os.replace(self.staging / name, target)
            shutil.rmtree(self.staging, ignore_errors=True)
        return [self.path / f for f in written]

    def abandon(self, keep: bool) -> Path | None:
        """
        After a failure: keep the staging folder as a clearly named partial result if ``keep``
        and it holds files, else remove it. Returns the partial folder kept, if any.
        """
        if keep and self.files():
            return self.staging
        shutil.rmtree(self.staging, ignore_errors=True)
        self._remove_created()
        return None
