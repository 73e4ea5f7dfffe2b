"""
One freshness stamp for every compiled kernel of radiosim.

numba's on-disk cache (``cache=True``) keys a compiled function on its own file's modification
time and size. A kernel in :mod:`~radiosim.kernels.rows` inlines functions of
:mod:`~radiosim.kernels.intrinsics`, :mod:`~radiosim.kernels.sweeps` and
:mod:`~radiosim.kernels.radiance` (and the segmented chip's kernels use
:data:`~radiosim.kernels.fast_exp`): after a change to one of those files alone, numba would load
the stale machine code of the kernel that inlined it. Here every compiled function of the
kernel package and of the chip's package is stamped with the modification times and sizes of
*all* their source files, so a change to any of them recompiles every kernel that could have
inlined it, once.

The locator wraps numba's own choice (``NUMBA_CACHE_DIR``, the package's ``__pycache__`` or
the user-wide cache): where the cache lives does not change. The stamp is also part of the
cache files' names (``rows.accumulate_kernel-226-<stamp>.py311.nbi``), so that an index can
only name a data file written for the same sources (numba writes the index first). It is
registered when :mod:`radiosim.kernels` is imported, before any kernel is decorated.

Files stamped for other sources (an earlier radiosim, or the same one installed again: an
install gives the files new modification times) are never read again: the first time this
process writes into a cache folder (it has compiled, so its sources are new to that folder),
:func:`prune_stale` removes those older than its sources there, radiosim's kernel files only,
so that the folder holds one version's files instead of a few MB more after every update.

References
----------
-   numba documentation, "Cache invalidation" (notes on caching): "changes in the functions
    called by a cached function are not detected".
"""

from __future__ import annotations

import functools
import hashlib
import logging
import re
import threading
from pathlib import Path

from numba.core import caching

__all__ = ["KERNEL_SOURCES", "source_stamp", "register", "prune_stale"]

_PACKAGE = Path(__file__).resolve().parent.parent  # radiosim/

#: The folders whose Python files hold compiled kernels (and what they inline).
KERNEL_SOURCES = (_PACKAGE / "kernels", _PACKAGE / "scenes" / "segmented_chip")


@functools.cache
def source_stamp() -> str:
    """A digest of the path, modification time [ns] and size [bytes] of every kernel source
    file (computed once per process)."""
    digest = hashlib.sha1()
    for folder in KERNEL_SOURCES:
        for path in sorted(folder.glob("*.py")):
            status = path.stat()
            digest.update(f"{path.name}:{status.st_mtime_ns}:{status.st_size};".encode())
    return digest.hexdigest()


#: A numba cache file of a cached function (index .nbi, data .nbc): module, qualified name,
#: line, this locator's stamp (absent from files of radiosim before the stamp was in the names),
#: Python version and ABI flags.
_CACHE_FILE = re.compile(r"(?P<module>\w+)\.[\w.]+-\d+(-(?P<stamp>[0-9a-f]{10}))?"
                         r"\.py\d+\w*(\.\d+)?\.nb[ci]")

_PRUNED: set[str] = set()  # the cache folders pruned by this process
_PRUNING = threading.Lock()


def prune_stale(folder) -> list[Path]:
    """
    Remove from ``folder`` the numba cache files of radiosim's kernel modules (those of
    :data:`KERNEL_SOURCES`) stamped for sources other than these, or not stamped, and older than
    the newest of these sources: files no radiosim of these sources reads. A newer one was
    written by a process of other sources since these were installed (a run of the previous
    version still going): it stays, as do other files and any that cannot be removed. Returns
    the paths removed.
    """
    current = source_stamp()[:10]
    sources = [path for kernels in KERNEL_SOURCES for path in kernels.glob("*.py")]
    modules = {path.stem for path in sources}
    removed = []
    try:
        installed = max(path.stat().st_mtime for path in sources)
        names = sorted(entry.name for entry in Path(folder).iterdir())
    except (OSError, ValueError):
        return removed
    for name in names:
        match = _CACHE_FILE.fullmatch(name)
        if not (match and match["module"] in modules and match["stamp"] != current):
            continue
        path = Path(folder) / name
        try:
            if path.stat().st_mtime < installed:
                path.unlink()
                removed.append(path)
        except OSError:
            continue
    return removed


def _is_kernel_source(py_file) -> bool:
    try:
        folder = Path(py_file).resolve().parent
    except (OSError, TypeError, ValueError):
        return False
    return folder in KERNEL_SOURCES


class _PackageStampLocator(caching._CacheLocator):
    """numba's own locator for the function, with the package-wide stamp added."""

    def __init__(self, inner):
        self._inner = inner

    def ensure_cache_path(self):
        # numba calls it before it writes a function's files: this process compiled, so the
        # folder may hold an earlier version's files; they go, once per folder and process.
        self._inner.ensure_cache_path()
        folder = str(self.get_cache_path())
        with _PRUNING:
            if folder in _PRUNED:
                return
            _PRUNED.add(folder)
        try:
            prune_stale(folder)
        except Exception as exc:  # noqa: BLE001  (a clean-up: never in the way of the compile)
            logging.getLogger(__name__).info("could not prune %s: %s", folder, exc)

    def get_cache_path(self):
        return self._inner.get_cache_path()

    def get_source_stamp(self):
        return (self._inner.get_source_stamp(), source_stamp())

    def get_disambiguator(self):
        # The stamp in the file names too: numba writes a function's index before its data
        # file, and a reader checks only the index's stamp. With one name for every source
        # version, a process reading between the two writes (or after a writer was stopped
        # between them) would load the data file an older version left under that name; with
        # the stamp in the name, it finds no file, and compiles.
        return f"{self._inner.get_disambiguator()}-{source_stamp()[:10]}"

    @property
    def _py_file(self):
        # numba's warning that a result cannot be cached names the source file through it
        # (e.g. under NUMBA_OPT=0, where a kernel keeps dynamic globals).
        return self._inner._py_file

    @classmethod
    def from_function(cls, py_func, py_file):
        if not _is_kernel_source(py_file):
            return None
        for other in caching.CacheImpl._locator_classes:
            if other is cls:
                continue
            inner = other.from_function(py_func, py_file)
            if inner is not None:
                return cls(inner)
        return None


def register() -> None:
    """Put the package-stamp locator first in numba's list (once)."""
    classes = caching.CacheImpl._locator_classes
    if _PackageStampLocator not in classes:
        classes.insert(0, _PackageStampLocator)
