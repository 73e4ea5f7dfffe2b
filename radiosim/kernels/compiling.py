"""
Compiling the kernels ahead of time.

numba compiles an entry point at its first call with new argument types and keeps the machine
code in its on-disk cache (:func:`cache_location`); a later process loads it from there. Here:

-   :func:`compile_pending` tells, from the cache's index files, whether a launch would compile
    (the command uses it to say, once, that a first run compiles);
-   :func:`warmup` compiles (or loads) every variant a measurement can launch, on tiny frames,
    in this process: for every frame dtype, or those asked for; ``radiosim warmup`` calls it.
"""

from __future__ import annotations

import os

import numpy as np

from radiosim.kernels.intrinsics import FRAME_DTYPES
from radiosim.kernels.launch import accumulate, accumulate_merged, pixel_mean
from radiosim.kernels.layout import KernelAxis
from radiosim.kernels.reference import Members
from radiosim.kernels.rows import ACCUMULATE_KERNELS, accumulate_kernel
from radiosim.kernels.table import SignalTable

__all__ = ["compile_pending", "cache_location", "warmup", "warmup_bands"]


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


def warmup_bands(table=None) -> None:
    """
    Compile (or load) the image stage's sub-band kernel, :func:`warmup`'s ``bands`` alone:
    its one variant, on tiny frames (``table``: a radiance table to launch it with, default
    :func:`_tiny_table`'s).
    """
    from radiosim.kernels.bands import accumulate_bands

    table = SignalTable(table if table is not None else _tiny_table(), grey=0.9)
    frames = np.full((2, 3, 5), 300.0) + np.arange(5) * 0.5
    accumulate_bands(frames, np.full(2, 0.5), [table] * 2, np.zeros((2, 3, 5)))


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
