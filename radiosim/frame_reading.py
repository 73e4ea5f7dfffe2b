"""
Reading a scene's frames for the integrator and the image stage: ahead on a worker thread (in
batches when the frames are small, one hand-over between the threads per batch), and small
generated frames stacked into blocks of consecutive frames, one kernel call per block.
"""

from __future__ import annotations

import time
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from radiosim.kernels.merging import FRAME_BLOCK
from radiosim.scenes.base import Region, Scene

__all__ = ["prefetched", "frames_inline_or_prefetched", "stacked", "PREFETCH_SECONDS",
           "INLINE_BYTES", "STACK_BYTES"]


def prefetched(scene: Scene, indices, region: Region, checked: bool = True, batch: int = 1):
    """Scene frames of ``indices`` in order, read on a worker thread ``batch`` at a time, each
    batch while the previous one is being used (``checked=False``: as the scene holds them,
    for consumers that check every sample). Small frames come in batches: one hand-over
    between the threads per batch, not per frame. A frame that cannot be read raises its
    error after the frames before it, whatever the batch: the same error as read one by
    one."""
    read = scene.sample if checked else scene.sample_unchecked

    def read_batch(ks):
        frames = []
        try:
            for k in ks:
                frames.append(read(k, region))
        except Exception as error:  # noqa: BLE001 - raised after the frames read before it
            return frames, error
        return frames, None

    def delivered(future):
        frames, error = future.result()
        yield from frames
        if error is not None:
            raise error

    indices = list(indices)
    with ThreadPoolExecutor(max_workers=1) as pool:
        pending = None
        for lo in range(0, len(indices), batch):
            following = pool.submit(read_batch, indices[lo:lo + batch])
            if pending is not None:
                yield from delivered(pending)
            pending = following
        if pending is not None:
            yield from delivered(pending)


#: Time [s] of the frames a worker thread reads at once in
#: :func:`frames_inline_or_prefetched` (frames quick to make go in batches of several).
PREFETCH_SECONDS = 2e-3


def frames_inline_or_prefetched(scene, indices, region):
    """Scene frames of ``indices`` in order, unchecked (the kernels check every sample). Frames
    that come cheap (views of an array or a memory map: under 0.2 ms) are read on this thread;
    as soon as two are slow to produce, the rest are read ahead on a worker thread, so
    producing frames overlaps with integrating the previous ones: one at a time, or in batches
    of about :data:`PREFETCH_SECONDS` (at most :data:`STACK_BYTES`) when each takes less. Frames
    of at most :data:`INLINE_BYTES` stay on this thread however slow: the kernel's work per such
    frame is too small for reading ahead to pay, and a worker thread making them would mostly
    contend with this one for the interpreter."""
    indices = list(indices)
    slow = []  # the times of the slow frames read here: two, the first may pay for set-up
    for n, k in enumerate(indices):
        start = time.perf_counter()
        frame = scene.sample_unchecked(k, region)
        seconds = time.perf_counter() - start
        yield frame
        size = getattr(frame.temperature, "nbytes", STACK_BYTES)
        if seconds > 2e-4 and size > INLINE_BYTES:
            slow.append(seconds)
        if len(slow) == 2:
            batch = max(1, min(int(PREFETCH_SECONDS / min(slow)), STACK_BYTES // max(1, size)))
            yield from prefetched(scene, indices[n + 1:], region, checked=False, batch=batch)
            return


#: Most bytes of a frame :func:`frames_inline_or_prefetched` reads on the calling thread
#: however slow it is to make. Measured on 2 cores, read here against read ahead: the paper's
#: long integration (3625 chip crops of 9 × 9) 0.42–0.65 s against 0.79–1.06 s; chip crops of
#: 32 × 32 0.14–0.15 against 0.16–0.21 ms a frame, of 64 × 64 to 181 × 181 the same either
#: way; an FEA nodal scene of 120 × 240 (230 kB) 12 % slower read here (its interpolation
#: releases the interpreter), so it is read ahead.
INLINE_BYTES = 1 << 14


#: Most bytes of a block of small generated frames stacked into one kernel call
#: (:func:`stacked`); a frame of more than a sixteenth of it goes alone.
STACK_BYTES = 1 << 22


def stacked(samples):
    """Scene frames as (first frame, temperature, frames): small frames that differ in
    temperature only (same dtype and shape, the same emissivity, no region map, nothing
    reflected) stacked into 3-D blocks of consecutive frames, up to :data:`FRAME_BLOCK` frames
    or :data:`STACK_BYTES`, so that a scene that makes its frames one at a time (the chip) takes
    one kernel call per block, not per frame (the kernel merges a block's frames one after the
    other, exactly as frame by frame); any other frame alone, as it is (2-D)."""
    first, held = None, []
    for frame in samples:
        t = frame.temperature
        alone = not (isinstance(t, np.ndarray) and t.ndim == 2 and 16 * t.nbytes <= STACK_BYTES
                     and frame.regions is None and frame.region_emissivity is None
                     and frame.reflected_temperature is None)
        if held and (alone or frame.index != first.index + len(held)
                     or len(held) == FRAME_BLOCK or (len(held) + 1) * t.nbytes > STACK_BYTES
                     or t.dtype != held[0].dtype or t.shape != held[0].shape
                     or not _same_emissivity(first.emissivity, frame.emissivity)):
            yield first, np.stack(held) if len(held) > 1 else held[0], len(held)
            held = []
        if alone:
            yield frame, t, 1
            continue
        if not held:
            first = frame
        held.append(t)
    if held:
        yield first, np.stack(held) if len(held) > 1 else held[0], len(held)


def _same_emissivity(e, f) -> bool:
    """The same emissivity object, or views of the same memory (one signal table serves
    both)."""
    return e is f or (isinstance(e, np.ndarray) and isinstance(f, np.ndarray)
                      and e.shape == f.shape and e.strides == f.strides and e.dtype == f.dtype
                      and e.__array_interface__["data"][0] == f.__array_interface__["data"][0])
