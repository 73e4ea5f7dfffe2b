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
import errno
import json
import os
import shutil
import socket
import stat
import sys
import tempfile
import threading
import time
from pathlib import Path

from radiosim.errors import RadiosimError, RadiosimIOError

__all__ = ["atomic_write", "atomic_path", "write_text", "OutputFolder", "MANIFEST",
           "native_output_silenced", "check_output_folder", "check_not_an_input", "safe_name",
           "is_staging", "RUN_MARKER", "check_name", "check_output_file", "BackgroundWrites",
           "why_not_a_file"]

def why_not_a_file(path) -> str | None:
    """Why ``path`` is no file to read, in words to follow its name (``"does not exist"``, ``"is
    a FIFO (named pipe), not a file"``, ``"is a symbolic link that loops"``, …), or ``None``
    for a regular file (or a link to one)."""
    try:
        mode = os.stat(path).st_mode
    except FileNotFoundError:
        return ("is a broken link (its target does not exist)" if os.path.islink(path)
                else "does not exist")
    except OSError as exc:
        if exc.errno == errno.ELOOP:
            return "is a symbolic link that loops back on itself"
        return f"cannot be read ({exc.strerror or exc})"
    if stat.S_ISREG(mode):
        return None
    if stat.S_ISDIR(mode):
        return "is a folder, not a file"
    if stat.S_ISFIFO(mode):
        return "is a FIFO (named pipe), not a file"
    if stat.S_ISCHR(mode) or stat.S_ISBLK(mode):
        return "is a device, not a file"
    if stat.S_ISSOCK(mode):
        return "is a socket, not a file"
    return "is not a regular file"


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


#: The temporary files of the atomic writes under way in this process (any thread): the
#: command removes them if its cleanup's time limit ends it before they unwind
#: (:func:`remove_open_temporaries`).
_OPEN_TEMPORARIES: set[Path] = set()
_OPEN_LOCK = threading.Lock()


@contextlib.contextmanager
def _registered(temporary: Path):
    with _OPEN_LOCK:
        _OPEN_TEMPORARIES.add(temporary)
    try:
        yield
    finally:
        with _OPEN_LOCK:
            _OPEN_TEMPORARIES.discard(temporary)


def remove_open_temporaries() -> None:
    """Remove the temporary files of the atomic writes still under way (best effort): for a
    process about to end without unwinding (when the cleanup's time limit runs out:
    ``radiosim.cli_signals._give_up``), so that a write is complete or absent even then."""
    with _OPEN_LOCK:
        open_now = list(_OPEN_TEMPORARIES)
    for temporary in open_now:
        with contextlib.suppress(OSError):
            temporary.unlink(missing_ok=True)


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
    _check_destination(path)
    try:
        handle, temporary = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".partial",
                                             dir=path.parent)
    except OSError as exc:
        raise RadiosimIOError(f"cannot write {path}: {exc.strerror or exc}") from None
    temporary = Path(temporary)
    with _registered(temporary):
        try:
            try:
                with os.fdopen(handle, mode, **kwargs) as stream:
                    yield stream
                    stream.flush()
                    os.fsync(stream.fileno())  # on the disk before the name points to it
                os.chmod(temporary, 0o666 & ~_umask())  # as open() would, not mkstemp's
                os.replace(temporary, path)
            except OSError as exc:  # a full disk, a quota: the earlier file stays as it was
                raise _io_error(path, exc) from None
            _sync_folder(path.parent)
        except BaseException:
            temporary.unlink(missing_ok=True)
            raise


def _check_destination(path: Path) -> None:
    """A file can be written at ``path``: its folder exists and it is not a folder."""
    if not path.parent.is_dir():
        for parent in [path.parent, *path.parent.parents]:  # a file where a folder should be
            if parent.exists() and not parent.is_dir():
                raise RadiosimError(f"cannot write {path}: {parent} is a file, not a folder")
        raise RadiosimError(f"cannot write {path}: folder {path.parent} does not exist")
    if path.is_dir():
        raise RadiosimError(f"cannot write {path}: it is a folder")


def check_output_file(path, option: str = "--out") -> Path:
    """
    The destination of a command's one output file, checked before any work: its folder
    exists (and is a folder), the path is not a folder, and its name is not longer than the
    file system allows.
    """
    path = Path(path)
    try:
        longest = os.pathconf(path.parent if path.parent.is_dir() else ".", "PC_NAME_MAX")
    except (OSError, ValueError, AttributeError):
        longest = 255
    if len(os.fsencode(path.name)) > longest:
        raise RadiosimError(f"{option} {path.name[:40]}…: the file name is "
                            f"{len(os.fsencode(path.name))} bytes long; expected at most "
                            f"{longest} bytes on this file system")
    try:
        _check_destination(path)
    except RadiosimError as exc:
        raise RadiosimError(f"{option} {path}: {str(exc).split(': ', 1)[1]}") from None
    return path


def _io_error(path: Path, exc: BaseException) -> RadiosimIOError:
    """A system's refusal to write ``path`` as one line naming the file."""
    if isinstance(exc, OSError) and exc.errno == errno.ENOSPC:
        return RadiosimIOError(f"cannot write {path}: the disk is full (no space left on "
                               "device); nothing was written and any earlier file is unchanged")
    reason = exc.strerror if isinstance(exc, OSError) and exc.strerror else exc
    return RadiosimIOError(f"cannot write {path}: {reason}; nothing was written and any earlier "
                           "file is unchanged")


def _sync_folder(folder: Path) -> None:
    """fsync a folder, so that a rename in it survives a crash (where the system allows)."""
    try:
        fd = os.open(folder, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:  # some file systems cannot sync a folder: the rename itself stands
        pass
    finally:
        os.close(fd)


def _sync_file(path: Path) -> None:
    """fsync a file written by name (by a library), before it is renamed into place."""
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


@contextlib.contextmanager
def atomic_path(path):
    """
    A temporary path beside ``path`` for a library that writes by file name (OpenEXR,
    xarray); renamed to ``path`` when the block completes, removed on any exit before. A
    library's own error becomes a :class:`~radiosim.errors.RadiosimIOError` naming ``path``.
    """
    path = Path(path)
    _check_destination(path)
    temporary = path.with_name(f".{path.name}.{os.getpid()}.partial")
    with _registered(temporary):
        try:
            yield temporary
            _sync_file(temporary)
            os.replace(temporary, path)
            _sync_folder(path.parent)
        except BaseException as exc:  # interrupts too: no temporary file is left behind
            temporary.unlink(missing_ok=True)
            if not isinstance(exc, Exception) or isinstance(exc, RadiosimError):
                raise
            raise _io_error(path, exc) from exc


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def write_text(path, text: str) -> Path:
    """Write ``text`` to ``path`` atomically (UTF-8)."""
    with atomic_write(path, "w", encoding="utf-8", newline="") as stream:
        stream.write(text)
    return Path(path)


#: The marker a running run leaves in its staging folder: its process id and host.
RUN_MARKER = ".radiosim-run"

#: Seconds a run waits for the marker of an empty staging folder another run has just made.
MARKER_WAIT = 2.0

_STAGING: set[Path] = set()  # staging folders of the OutputFolders open in this process


def is_staging(path) -> bool:
    """Whether ``path`` is the staging folder of an :class:`OutputFolder` open in this process
    (a run writes straight into it; the folder's owner commits it)."""
    try:
        return Path(path).resolve() in _STAGING
    except OSError:
        return False


def _process_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # alive, another user's
        return True
    except (OSError, OverflowError, ValueError):
        return False
    return True


def _just_made(staging: Path) -> bool:
    """Whether ``staging`` is a folder holding nothing but, perhaps, its marker being written
    (a run's staging folder between its creation and its marker)."""
    try:
        return staging.is_dir() and all(p.name.startswith((RUN_MARKER, "." + RUN_MARKER))
                                        for p in staging.iterdir())
    except OSError:
        return False


def _read_marker(staging: Path) -> tuple[int | None, str]:
    try:
        pid, _, host = (staging / RUN_MARKER).read_text(encoding="utf-8").strip().partition(" ")
        return int(pid), host
    except (OSError, ValueError):
        return None, ""


def _overwrite_word(option: str) -> str:
    """How the caller who named the folder ``option`` asks to overwrite: the command's
    ``--overwrite``, or Python's ``overwrite=True``."""
    return "--overwrite" if option.startswith("--") else "overwrite=True"


def check_output_folder(path, overwrite: bool = False, option: str = "--out") -> list[str]:
    """
    The policy for a run's output folder, shared by the commands and :meth:`Study.run
    <radiosim.study.Study.run>`: ``path`` must be new, an empty folder, or — with
    ``overwrite`` — a folder radiosim wrote (its manifest lists its files, all inside it).
    A dangling symbolic link, a file or any other non-folder is refused. Returns the files the
    previous run's manifest lists (to be replaced), checked before any work.
    """
    path = Path(path)
    if path.is_symlink() and not path.exists():
        raise RadiosimError(f"{option} {path} is a symbolic link to {os.readlink(path)}, which "
                            "does not exist; give a folder (new or empty)")
    if path.exists() and not path.is_dir():
        raise RadiosimError(f"{option} {path} is an existing file, not a folder; choose a "
                            "new folder")
    for parent in path.parents:  # a file where a parent folder should be
        if parent.exists() or parent.is_symlink():
            if not parent.is_dir():
                raise RadiosimError(f"{option} {path}: {parent} is not a folder")
            break
    if not (path.is_dir() and any(path.iterdir())):
        return []
    manifest = path / MANIFEST
    flag = _overwrite_word(option)
    if not overwrite:
        raise RadiosimError(
            f"{option} {path} is not empty; choose a new or empty folder, or pass {flag} to "
            f"replace the files of radiosim's previous run there (those listed in {MANIFEST})")
    if not manifest.is_file():
        raise RadiosimError(
            f"{option} {path} is not empty and radiosim did not write it (it holds no "
            f"{MANIFEST}); {flag} replaces only radiosim's own files: choose a new "
            "or empty folder")
    try:
        previous = [str(f) for f in json.loads(manifest.read_text())["files"]]
    except (OSError, ValueError, KeyError, TypeError):
        raise RadiosimError(f"{manifest} is not a radiosim manifest; {flag} "
                            "will not touch that folder") from None
    root = path.resolve()
    for name in previous:  # only files inside the folder, never beyond it
        target = (path / name).resolve()
        if Path(name).is_absolute() or root not in target.parents:
            raise RadiosimError(f"{manifest} lists {name!r}, outside {path}; "
                                f"{flag} will not touch that folder")
        if target.exists() and not target.is_file():
            raise RadiosimError(f"{manifest} lists {name!r}, which is a folder, "
                                f"not a file radiosim wrote; {flag} will not "
                                "touch that folder")
    return previous


def check_not_an_input(path, inputs, option: str = "--out") -> None:
    """Refuse to write ``path`` if it is one of ``inputs`` (the files a command reads)."""
    target = Path(path).resolve()
    for item in inputs:
        if Path(item).resolve() == target:
            raise RadiosimError(f"{option} {path} is one of this command's inputs ({item}); "
                                "writing it would destroy what is being read: choose another "
                                "name")


def safe_name(name, what: str) -> str:
    """
    A name from a study file made safe as one file-name component: path separators, ``..``,
    leading dots and characters other than letters, digits, ``-``, ``_``, ``.``, ``+`` become
    ``_``; an empty name (or one that would still leave the folder) is refused.

    Examples
    --------
    >>> safe_name("../../x", "sweep name")
    '_.__._x'
    >>> safe_name("long integration", "sweep name")
    'long_integration'
    """
    import re

    text = str(name).strip()
    cleaned = re.sub(r"[^\w.+-]", "_", text)
    cleaned = cleaned.replace("..", "_.")
    cleaned = cleaned.lstrip(".")
    if not text or not cleaned or set(cleaned) <= {"_", "."}:
        raise RadiosimError(f"{what} {name!r} cannot name a file: give letters or digits "
                            "(e.g. name = \"sweep-1\")")
    return cleaned


def check_name(name, what: str) -> str:
    """
    A name from a study file that radiosim uses in file names (a study's, a sweep's, a
    camera's): refused if empty, ``.`` or ``..``, or if it holds a path separator or a control
    character, so that nothing it names can land outside the output folder.
    """
    text = name if isinstance(name, str) else str(name)
    if (not text.strip() or text.strip(".") == "" or any(c in text for c in "/\\")
            or any(ord(c) < 32 for c in text)):
        raise RadiosimError(f"{what} {name!r} cannot name files: give a name without path "
                            "separators (/ or \\), control characters, or only dots")
    return text


class BackgroundWrites:
    """
    File writes done on one background thread while the caller goes on, in the order they
    were asked for: ``writes(path, *args)`` calls ``write(path, *args)`` there.

    A write that has failed is raised by the next one asked for (the caller stops there, as
    it would have with the write in its own hands). Used as a context manager: on leaving it,
    every write asked for has finished (complete or absent: the writer is an atomic one), also
    through the body's exception or an interrupt (raised after; on an interrupt the writes
    not yet started are not done). The first failure is raised, and :attr:`failed` holds the
    paths of the writes that failed or were not done.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> with BackgroundWrites(write_text) as writes:
    ...     writes(folder / "a.txt", "one")
    >>> (folder / "a.txt").read_text()
    'one'
    """

    def __init__(self, write):
        self._write = write
        self._pool = None
        self._pending: list = []
        self.failed: list[Path] = []

    def __call__(self, path, *args) -> None:
        for _, future in self._pending:
            if future.done() and future.exception() is not None:
                raise future.exception()
        if self._pool is None:
            from concurrent.futures import ThreadPoolExecutor

            self._pool = ThreadPoolExecutor(max_workers=1, thread_name_prefix="radiosim-write")
        self._pending.append((path, self._pool.submit(self._write, path, *args)))

    def __enter__(self) -> BackgroundWrites:
        return self

    def __exit__(self, kind, value, traceback) -> None:
        from concurrent.futures import wait

        if kind is not None and not issubclass(kind, Exception):  # interrupted: no new write
            for _, future in self._pending:  # starts (those asked for after a failure are
                future.cancel()  # of completed work: they are done)
        interrupted = None
        while self._pending:
            try:
                wait([future for _, future in self._pending])
                break
            except BaseException as exc:  # noqa: BLE001 (raised once the writes are done)
                interrupted = exc
                for _, future in self._pending:
                    future.cancel()
        first = None
        for path, future in self._pending:
            if future.cancelled() or future.exception() is not None:
                self.failed.append(Path(path))
                if not future.cancelled():
                    first = first or future.exception()
        self._pending = []
        if self._pool is not None:
            self._pool.shutdown(wait=True)
            self._pool = None
        if interrupted is not None:
            raise interrupted
        if first is not None and kind is None:
            raise first


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
    inputs
        Files the run reads: refused if the run would replace or delete one of them.
    option
        How errors name the folder: a command's option (``--out``, then ``--overwrite`` is
        suggested), or words for a Python caller (then ``overwrite=True``).

    Use :attr:`staging` as the run's folder, :meth:`commit` when it completed, and
    :meth:`abandon` when it failed. While the run lasts, the staging folder holds
    :data:`RUN_MARKER` (the process id), so that a second run on the same folder is told that
    another run is writing it; a marker whose process is gone is recognised as stale.
    """

    def __init__(self, path, overwrite: bool = False, inputs=(), option: str = "--out"):
        self.path, self.option = Path(path), option
        self.overwrite = overwrite
        self.previous: list[str] = check_output_folder(self.path, overwrite, option)
        self.check_inputs(inputs)
        parent = self.path.parent
        self.staging = parent / f"{self.path.name}.partial"
        self._refuse_existing_staging()
        self.created: list[Path] = []  # parent folders made for this run, removed if it fails
        try:
            for folder in [*reversed(parent.parents), parent]:
                if not folder.exists():
                    folder.mkdir()
                    self.created.append(folder)
        except OSError as exc:
            raise RadiosimIOError(f"cannot create {exc.filename or parent}: "
                                  f"{exc.strerror or exc}") from None
        try:
            self.staging.mkdir()
        except FileExistsError:  # another run took it in the meantime
            self._remove_created()
            self._refuse_existing_staging()
            raise
        except OSError as exc:
            self._remove_created()
            raise RadiosimIOError(f"cannot write in {parent}: {exc.strerror or exc}") from None
        try:
            write_text(self.staging / RUN_MARKER, f"{os.getpid()} {socket.gethostname()}\n")
        except BaseException:
            shutil.rmtree(self.staging, ignore_errors=True)
            self._remove_created()
            raise
        _STAGING.add(self.staging.resolve())

    def check_inputs(self, inputs) -> None:
        """Refuse if committing would replace or delete one of ``inputs``."""
        at_risk = {(self.path / name).resolve() for name in self.previous}
        for item in inputs:
            if Path(item).resolve() in at_risk:
                raise RadiosimError(f"{self.option} {self.path}: the run reads {item}, a file "
                                    f"of radiosim's previous run there that "
                                    f"{_overwrite_word(self.option)} would replace; copy it "
                                    f"elsewhere or choose another {self._another()}")

    def _another(self) -> str:
        """What to choose instead, in the caller's words: ``--out`` or a folder."""
        return self.option if self.option.startswith("--") else "folder"

    def _refuse_existing_staging(self):
        if not (self.staging.exists() or self.staging.is_symlink()):
            return
        pid, host = _read_marker(self.staging)
        waited = 0.0
        while pid is None and waited < MARKER_WAIT and _just_made(self.staging):
            # An empty staging folder without its marker: another run may have just made it
            # (between its mkdir and its marker's write); give its marker a moment.
            time.sleep(0.05)
            waited += 0.05
            pid, host = _read_marker(self.staging)
        if pid is not None and host in ("", socket.gethostname()) and _process_alive(pid):
            raise RadiosimError(f"another run (pid {pid}) is writing {self.path} (its partial "
                                f"results are in {self.staging}); wait for it to finish or "
                                f"choose another {self._another()}")
        if pid is not None and host not in ("", socket.gethostname()):
            raise RadiosimError(f"another run (pid {pid} on {host}) is writing {self.path} "
                                f"or was interrupted ({self.staging}); if it is not running, "
                                f"move or delete {self.staging}")
        stale = (f" (left by run pid {pid}, which is no longer running)" if pid is not None
                 else " (an earlier run's partial result)")
        raise RadiosimError(f"{self.staging} exists{stale}; move or delete it first")

    def _remove_created(self):
        for folder in reversed(self.created):
            with contextlib.suppress(OSError):
                folder.rmdir()

    def _release(self):
        (self.staging / RUN_MARKER).unlink(missing_ok=True)
        _STAGING.discard(self.staging.resolve())

    def files(self) -> list[str]:
        """The files written in the staging folder, relative to it."""
        return sorted(str(p.relative_to(self.staging)) for p in self.staging.rglob("*")
                      if p.is_file() and not p.name.endswith(".partial")
                      and p.name != RUN_MARKER)

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
        self._release()
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
        _sync_folder(self.path)
        return [self.path / f for f in written]

    def abandon(self, keep: bool) -> Path | None:
        """
        After a failure: keep the staging folder as a clearly named partial result if ``keep``
        and it holds files, else remove it. Returns the partial folder kept, if any.
        """
        self._release()
        if keep and self.files():
            return self.staging
        shutil.rmtree(self.staging, ignore_errors=True)
        self._remove_created()
        return None
