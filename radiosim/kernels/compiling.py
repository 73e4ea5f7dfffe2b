"""
Compiling the kernels ahead of time, and in other processes.

numba compiles an entry point at its first call with new argument types and keeps the machine
code in its on-disk cache (:func:`cache_location`); a later process loads it in well under a
second. Here:

-   :func:`compile_pending` tells, from the cache's index files, whether a launch would compile;
-   :func:`warmup` compiles (or loads) every variant a measurement can launch, on tiny frames,
    in this process: for every frame dtype, or those asked for;
-   :func:`compile_in_background` has another Python process compile the integrator's kernel
    (one entry point for both frame dtypes) while this one goes on (``radiosim warmup``
    meanwhile compiles that kernel's last helpers ahead of it, :func:`compile_helpers_ahead`,
    then the chip's and the sub-band kernels: the two cores compile at once; ``radiosim run``
    does the reverse, :func:`radiosim.warmup.compile_for_run`). The first
    launch of the integrator here waits for that process
    (:func:`~radiosim.kernels.background.wait_for_background`), then loads what it cached.
    Within one command, at most one process compiles the integrator's kernel, at most one the
    sub-band kernel (one variant) and at most one the chip's kernels (``radiosim run``: the
    chip's frames and the loading thread leave them to it), and the helpers have no cache files
    (``INNER``), so no two of its processes write one function's cache index (numba writes it
    without a lock; two commands compiling at once from an empty cache still could), except
    the integrator's last helpers (``AHEAD``, one signature each): one process compiles them
    ahead (:func:`compile_helpers_ahead`) while the other compiles the entry point, which
    loads them from the cache; where the two meet, both may compile one and write its index
    (the same entry, for the same code; the cache files' names carry the sources' stamp, so an
    index never names a data file of other sources, :mod:`~radiosim.kernels.cache`).
    If such a process cannot start, fails or is stopped, this one compiles what it needs
    itself, as it would without it: the results do not depend on which process compiled.
"""

from __future__ import annotations

import os
import threading

import numpy as np

from radiosim.compiling_process import CHILD, start, watch_parent
from radiosim.kernels import background
from radiosim.kernels.bands import band_kernel
from radiosim.kernels.intrinsics import FRAME_DTYPES
from radiosim.kernels.launch import accumulate, accumulate_merged, pixel_mean
from radiosim.kernels.layout import KernelAxis
from radiosim.kernels.reference import Members
from radiosim.kernels.rows import ACCUMULATE_KERNELS, accumulate_kernel
from radiosim.kernels.table import SignalTable

__all__ = ["compile_pending", "cache_location", "warmup", "warmup_bands",
           "compile_in_background", "load_in_background", "compile_helpers_ahead"]


def _fresh_signatures(dispatcher) -> list:
    """The signatures of ``dispatcher`` compiled in this process or held, fresh (stamped with
    the current sources) and loadable here (compiled for this machine's CPU, from this
    bytecode: the whole index key), in numba's on-disk cache, read from its small index file."""
    try:
        cache = dispatcher._cache
        overloads = cache._cache_file._load_index()  # {} when missing or stale
        codegen = dispatcher.targetctx.codegen()
        keys = [key for key in overloads if key == cache._index_key(key[0], codegen)]
    except Exception:  # numba's private API moved, or an unreadable index: assume nothing
        keys = []
    return [key[0] for key in keys] + list(dispatcher.signatures)


def _cached_variants(dispatcher) -> set:
    """The index map dtypes of the fresh signatures of the integrator's entry point (each
    serves float32 and float64 frames)."""
    names = dispatcher.py_func.__code__.co_varnames
    signs = names.index("emissivity")
    cached = set()
    for signature in _fresh_signatures(dispatcher):
        try:  # the bundles' numba types: named tuples with their fields' types
            index = signature[signs].types[signature[signs].fields.index("index_map")]
            cached.add(str(index.dtype))
        except (AttributeError, IndexError, TypeError, ValueError):
            continue
    return cached


def compile_pending(frame_dtypes=("float64",), index_dtypes=("uint8",), also=()) -> bool:
    """
    Whether launching the kernel on frames of ``frame_dtypes`` with index maps of
    ``index_dtypes`` (uint8 also serves the linear response and grey maps), or any of the
    numba dispatchers ``also`` (e.g. a scene's kernels), would compile: no fresh variant in
    numba's on-disk cache and none compiled in this process. Cheap (reads the cache's index
    files, compiles nothing): the command uses it to say, once, that a first run compiles.
    """
    # An index map of any integer type is launched as uint8 where its table has at most 255
    # entries (every scene's region map): its variant is uint8's, for either frame dtype.
    if any(np.dtype(name).name not in ACCUMULATE_KERNELS for name in frame_dtypes):
        return True
    if frame_dtypes and "uint8" not in _cached_variants(accumulate_kernel):
        return True
    return not all(_fresh_signatures(d) for d in also)


def cache_location() -> str:
    """Where numba keeps radiosim's compiled kernels (``NUMBA_CACHE_DIR``, else the package's
    ``__pycache__`` folders, else numba's user-wide cache)."""
    try:
        return str(accumulate_kernel._cache.cache_path)
    except AttributeError:
        return os.environ.get("NUMBA_CACHE_DIR", "numba's cache")


def _tiny_axis(n_pixels: int) -> KernelAxis:
    """Pieces of a small axis: each pixel 2.5 samples wide, so pixel edges fall inside samples
    (duplicate slots) as on a real camera."""
    edges = np.arange(n_pixels + 1) * 2.5
    source, weight, starts = [], [], []
    for j in range(n_pixels):
        starts.append(len(source))
        a, b = edges[j], edges[j + 1]
        for s in range(int(np.floor(a)), int(np.ceil(b))):
            source.append(s)
            weight.append((min(b, s + 1) - max(a, s)) / 2.5)
    axis = type("Axis", (), {})()
    axis.source, axis.weight, axis.starts = np.array(source), np.array(weight), np.array(starts)
    return KernelAxis.of(axis, "warmup")


def warmup(progress=None, memmap_dir=None, frame_dtypes=FRAME_DTYPES, bands=True) -> dict:
    """
    Compile (or load from numba's on-disk cache) every variant of the streaming kernel a
    measurement can launch, on tiny frames: frames of ``frame_dtypes`` (float32 and float64),
    in memory and as read-only numpy memory maps; no response (linear), and the radiance table
    (Planck) with a grey scalar, a grey map, and emissivity index maps of uint8 and intp
    (converted to uint8: one variant); through :func:`pixel_mean`, :func:`accumulate` and
    :func:`accumulate_merged`; and with ``bands`` the image stage's sub-band kernel
    (:func:`radiosim.kernels.bands.accumulate_bands`). Later processes load the compiled code
    from the cache (:func:`cache_location`) in well under a second.

    Parameters
    ----------
    progress
        Called as ``progress(done, total, label)`` after each variant.
    memmap_dir
        Folder for the small temporary memory-mapped file (default: the system's temporary
        folder); it is removed after.
    frame_dtypes
        The frame dtypes to compile for (names or dtypes of :data:`FRAME_DTYPES`).
    bands
        Also the sub-band kernel (one variant: float32 frames are widened for it).

    Returns
    -------
    dict
        ``seconds`` (wall time [s]), ``compiled`` (signatures compiled or loaded in this call),
        ``variants`` (variants launched), ``cache`` (:func:`cache_location`).
    """
    import tempfile
    import time

    from radiosim.kernels import dispatchers

    began = time.perf_counter()
    before = sum(len(d.signatures) for d in dispatchers())
    rows, cols = _tiny_axis(3), _tiny_axis(5)
    shape = (rows.extent, cols.extent)
    table = _tiny_table()
    grey_map = np.full(shape, 0.9)
    responses = [("linear", None),
                 ("Planck, grey", SignalTable(table, grey=0.9)),
                 ("Planck, grey map", SignalTable(table, grey=grey_map))]
    for name, dtype in (("uint8", np.uint8), ("intp", np.intp)):
        index = (np.arange(shape[0] * shape[1]) % 2).astype(dtype).reshape(shape)
        responses.append((f"Planck, {name} index map",
                          SignalTable([table, table], grey=1.0, index=index,
                                      entry_grey=[1.0, 0.8])))
    frames = np.full((2, *shape), 300.0) + np.arange(shape[1]) * 0.5
    dtypes = [np.dtype(d) for d in frame_dtypes]
    total = len(dtypes) * 2 * len(responses)
    done = 0
    with tempfile.TemporaryDirectory(dir=memmap_dir) as folder:
        for dtype in dtypes:
            path = os.path.join(folder, f"frames-{dtype.name}.npy")
            np.save(path, frames.astype(dtype))
            for storage, block in (("in memory", frames.astype(dtype)),
                                   ("memory map", np.load(path, mmap_mode="r"))):
                for name, response in responses:
                    _launch_tiny(block, rows, cols, response)
                    done += 1
                    if progress is not None:
                        progress(done, total, f"{dtype.name} frames {storage}, {name}")
                del block  # the memory map's file is closed before its folder goes
    if bands:  # the image stage's sub-bands from one lookup (one variant: float32 widened)
        warmup_bands(table=table)
    after = sum(len(d.signatures) for d in dispatchers())
    return {"seconds": time.perf_counter() - began, "compiled": after - before,
            "variants": total, "cache": cache_location()}


def _tiny_table():
    """A small radiance table (a coarse grid over 200–800 K) for the tiny launches."""
    from radiosim.radiometry import BandRadianceTable

    return BandRadianceTable(temperature_range=(200.0, 800.0), per_octave=16)


def warmup_bands(wait_for_processes: bool = True, table=None) -> None:
    """
    Compile (or load) the image stage's sub-band kernel, :func:`warmup`'s ``bands`` alone:
    its one variant, on tiny frames (``table``: a radiance table to launch it with, default
    :func:`_tiny_table`'s). ``wait_for_processes=False``: without waiting for the processes
    compiling the integrator's kernels (``radiosim warmup`` compiles this one here meanwhile;
    they share no cache file).
    """
    from radiosim.kernels.bands import accumulate_bands

    table = SignalTable(table if table is not None else _tiny_table(), grey=0.9)
    frames = np.full((2, 3, 5), 300.0) + np.arange(5) * 0.5
    accumulate_bands(frames, np.full(2, 0.5), [table] * 2, np.zeros((2, 3, 5)),
                     _wait_for_processes=wait_for_processes)


def _launch_tiny(block, rows: KernelAxis, cols: KernelAxis, response) -> None:
    """One frame through :func:`pixel_mean` and :func:`accumulate`, two through
    :func:`accumulate_merged`: every entry point of the kernel, for this block's type."""
    shape = (rows.n_pixels, cols.n_pixels)
    reference = pixel_mean(block[0], rows, cols)
    dev, sq, signal = np.zeros(shape), np.zeros(shape), np.zeros(shape)
    tmax = np.full(shape, -np.inf)
    accumulate(block[0], rows, cols, 0.5, reference, dev, sq, tmax,
               signal if response is not None else None, response)
    n_jobs = 2
    members = Members(n_jobs, shape)
    accumulate_merged(block, rows, cols, reference.copy(), members, np.full((2, n_jobs), 0.5),
                      np.full((2, n_jobs), 0.5), response)


# -- other processes ----------------------------------------------------------------------------


def _helpers_ahead() -> list:
    """The integrator entry point's helpers that its compile reaches last (``AHEAD``: cached
    on their own), each with the types of the entry point's call, in the reverse of the order
    the entry point's compile reaches them: the pixels' commit, the reductions to pixels (the
    pixel's end with them), the radiance pass's row (its one-sample loop and the cubics with
    it). The types are those of the entry point's one signature: its bundles' types from the
    bundles a launch passes, the rest plain arrays (contiguous; read-only where the entry
    point reads through read-only views) and scalars. A test compiles them, then the entry
    point, and checks that it compiled none of them again."""
    import numba
    from numba.core import types

    from radiosim.kernels import radiance, rows
    from radiosim.kernels.bundles import Accumulators
    from radiosim.kernels.launch import _NO_MEMBERS
    from radiosim.kernels.packing import NO_TABLES

    f64, u64 = types.float64[::1], types.uint64[::1]
    i64, flag, real = types.int64, types.boolean, types.float64
    accumulators = numba.typeof(Accumulators(0.5, *(np.zeros((1, 1)),) * 5))
    sums = (f64,) * 6 + (u64, u64, flag, flag, real, real) + (f64,) * 4
    return [
        (rows._commit_row, (i64, i64, accumulators, numba.typeof(_NO_MEMBERS), i64, flag)
         + (f64,) * 4 + (i64,)),
        (rows._pixel_sums, sums),
        (rows._pixel_sums_regular, sums),
        (radiance._signal_row, (types.float32[::1].copy(readonly=True),
                                f64.copy(readonly=True), flag, f64.copy(readonly=True),
                                types.uint8[::1].copy(readonly=True), f64, real, i64, real, flag,
                                numba.typeof(NO_TABLES), u64) + (f64,) * 4),
    ]


def compile_helpers_ahead(count: int | None = None) -> None:
    """
    Compile (or load) the integrator entry point's last helpers (:func:`_helpers_ahead`) into
    numba's cache, in the reverse of the order the entry point's compile reaches them: run by
    one process while another compiles the entry point (``radiosim warmup``,
    :func:`radiosim.warmup.compile_for_run`, :func:`radiosim.warmup.compile_helpers_aside`),
    the two meet in the middle, and that one loads these from the cache instead of compiling
    them (4–6 s of its compile). ``count``: the first ``count`` of them only (default all),
    those the other process's compile reaches last. The results are the same either way (a
    cached helper keeps its code for linking; no fast-math). Only a speed-up: a helper that
    fails to compile here is left to the entry point's compile, which then reports what goes
    wrong.
    """
    for dispatcher, signature in _helpers_ahead()[:count]:
        try:
            dispatcher.compile(signature)
        except Exception:  # noqa: BLE001 - compiled (and reported) by the entry point's compile
            return


def _pending_work(frame_dtypes, bands: bool) -> tuple[tuple[str, ...], bool] | None:
    """The one process to start, as (the frame dtypes it launches, whether it compiles the
    sub-band kernel), or ``None``: one when the cache lacks the integrator's kernel (one entry
    point for every frame dtype of ``frame_dtypes``) or, with ``bands``, the sub-band kernel
    (one variant)."""
    names = tuple(dict.fromkeys(np.dtype(d).name for d in frame_dtypes))
    if not names:
        return None
    with_bands = bool(bands) and not _fresh_signatures(band_kernel)
    if not (compile_pending(names) or with_bands):
        return None
    return names, with_bands


def compile_in_background(frame_dtypes=("float64",), bands: bool = False) -> list:
    """
    Start compiling, in another Python process, the integrator's kernel variants
    (:func:`warmup`, launched on frames of ``frame_dtypes``) if numba's cache does not hold
    them (with ``bands``, the sub-band kernel too, if it lacks that), and return the list of
    processes started: empty when all are cached, else the one (its ``frame_dtypes`` and
    ``with_bands`` say what it launches). This process goes on; its first kernel launch waits
    for it (:func:`~radiosim.kernels.background.wait_for_background`). It writes nothing but
    numba's cache and its own temporary folder (made by
    :func:`radiosim.compiling_process.start`, its working folder, removed once it has ended);
    it imports this process's radiosim; its output is discarded; it stops when this process
    exits or is interrupted, and ends by itself if this one is killed.
    """
    started = []
    work = _pending_work(frame_dtypes, bands)
    if work is not None:
        child = start(*work, child=_CHILD)
        if child is not None:  # else this process compiles itself
            background.register(*child)
            started.append(child[0])
    return started


_CHILD = CHILD


def _main(argv) -> int:
    """The other process: ``python -c _CHILD [DTYPE ...] [--bands] [--memmap-dir DIR]
    [--parent PID]`` (the process that started it: it ends when that one has, even before
    this one got here); no DTYPE: every frame dtype."""
    argv = list(argv)
    watch_parent(argv)
    memmap_dir = None
    if "--memmap-dir" in argv:
        at = argv.index("--memmap-dir")
        memmap_dir = argv[at + 1]
        del argv[at:at + 2]
    bands = "--bands" in argv
    dtypes = [a for a in argv if a != "--bands"] or list(FRAME_DTYPES)
    try:
        warmup(memmap_dir=memmap_dir, frame_dtypes=dtypes, bands=bands)
    except KeyboardInterrupt:  # the terminal's interrupt reaches this process too
        return 130
    return 0


# -- loading ahead of time ----------------------------------------------------------------------


def load_in_background(dispatchers) -> threading.Thread | None:
    """
    Load into this process, on a background thread, the variants of ``dispatchers`` that
    numba's cache holds fresh and this process has not loaded yet (numba's registries with
    the first: about 0.6 s for the chip's and the integrator's kernels), while this thread
    goes on (a study checks its plan and builds its scene's static fields meanwhile). Nothing
    is compiled: a variant the cache lacks is not among them, and compiles at its first call.
    A launch (or a chip frame) meanwhile waits for the thread to end
    (:func:`~radiosim.kernels.background.wait_for_background`), then finds the variants
    loaded. Returns the thread, or ``None`` when there is nothing to load.
    """
    wanted = [(d, signature) for d in dispatchers if d is not None
              for signature in _fresh_signatures(d) if signature not in d.signatures]
    if not wanted:
        return None
    thread = threading.Thread(target=_load, args=(wanted,), daemon=True,
                              name="radiosim-kernel-loader")
    background.register_loader(thread)  # launches wait for it (numba's typing is not
    thread.start()  # thread-safe while a load fills its tables)
    return thread


def _load(wanted) -> None:
    """:func:`load_in_background`'s thread: each (dispatcher, signature) from the cache."""
    for dispatcher, signature in wanted:
        try:
            dispatcher.compile(signature)
        except Exception:  # noqa: BLE001 - a variant that does not load is loaded (or
            # compiled) by its first call, which reports what goes wrong there
            return
