"""
Reading a scene's frames for the integrator and the image stage, one scheme for both
(:func:`frame_blocks`): a scene that holds its frames as one array gives blocks of consecutive
frames as views; other scenes' frames are read ahead on a worker thread (:func:`read_ahead`),
so that making a frame overlaps with integrating the previous ones, and consecutive frames are
stacked into blocks (:func:`stacked`), one engine call per block. Every choice is made from
the frames' sizes, never from timings.
"""

from __future__ import annotations

import contextvars
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from radiosim.kernels.merging import FRAME_BLOCK, frame_runs
from radiosim.scenes.base import Region, Scene

__all__ = ["frame_blocks", "prefetched", "read_ahead", "stacked", "INLINE_BYTES",
           "STACK_BYTES", "IMAGE_BLOCK"]

#: Most bytes of a frame :func:`read_ahead` makes on the calling thread: the work per such
#: frame is too small for a hand-over between threads to pay.
INLINE_BYTES = 1 << 14

#: Most bytes of a block of small frames stacked into one engine call (:func:`stacked`), and
#: of a batch of frames read ahead at once (:func:`read_ahead`); a frame of more than a
#: sixteenth of it is large.
STACK_BYTES = 1 << 22

#: Large frames stacked into one block where the image stage sums sub-bands from them (its
#: per-sample sums are then read and written once per block, not once per frame).
IMAGE_BLOCK = 4


def frame_blocks(scene: Scene, indices, region: Region, large: int = 1,
                 reflections: bool = False):
    """
    The frames of ``indices`` (sorted) over ``region``, unchecked (the engines check every
    sample), as ``(first scene frame, temperature, n)``: ``temperature`` one 2-D frame
    (``n`` = 1) or a 3-D block of ``n`` consecutive frames that share their maps. A scene that
    holds its frames as one array (:meth:`~radiosim.scenes.base.Scene.block_unchecked`) gives
    views of up to :data:`FRAME_BLOCK` frames, unless ``reflections`` are wanted (the image
    stage) and its reflected temperature changes from frame to frame (a block shares its first
    frame's); other scenes' frames are read ahead (:func:`read_ahead`) and stacked
    (:func:`stacked`, up to ``large`` large frames a block).
    """
    indices = list(indices)
    if not indices:
        return
    reflected = scene.reflected_temperature
    per_frame = reflections and isinstance(reflected, np.ndarray) and reflected.ndim == 1
    if not per_frame and scene.block_unchecked(indices[0], indices[0] + 1, region) is not None:
        for start, stop in frame_runs(indices, FRAME_BLOCK):
            yield (scene.sample_unchecked(start, region),
                   scene.block_unchecked(start, stop, region), stop - start)
        return
    yield from stacked(read_ahead(scene, indices, region), large)


def prefetched(scene: Scene, indices, region: Region, checked: bool = True, batch: int = 1):
    """Scene frames of ``indices`` in order, read on a worker thread ``batch`` at a time, each
    batch while the previous one is being used (``checked=False``: as the scene holds them,
    for consumers that check every sample). A frame that cannot be read raises its error
    after the frames before it, whatever the batch: the same error as read one by one. The
    worker reads in a copy of the caller's context (the engine of the pass under way,
    :func:`radiosim.kernels.engines.using_engine`)."""
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
            following = pool.submit(contextvars.copy_context().run, read_batch,
                                    indices[lo:lo + batch])
            if pending is not None:
                yield from delivered(pending)
            pending = following
        if pending is not None:
            yield from delivered(pending)


def read_ahead(scene: Scene, indices, region: Region):
    """Scene frames of ``indices`` in order, unchecked. The first is made on this thread; frames
    of at most :data:`INLINE_BYTES` stay on it, larger ones are read ahead on a worker thread
    in batches of at most :data:`STACK_BYTES` (one hand-over between the threads per batch) —
    unless the kernels have one thread (a single-thread Dask worker's ``NUMBA_NUM_THREADS=1``):
    a process given one core reads on its one thread too."""
    from radiosim.kernels.launch import thread_count

    indices = list(indices)
    if not indices:
        return
    first = scene.sample_unchecked(indices[0], region)
    yield first
    size = getattr(first.temperature, "nbytes", STACK_BYTES)
    if size <= INLINE_BYTES or thread_count() == 1:
        for k in indices[1:]:
            yield scene.sample_unchecked(k, region)
        return
    yield from prefetched(scene, indices[1:], region, checked=False,
                          batch=max(1, STACK_BYTES // size))


def _scalar(value) -> bool:
    return not isinstance(value, np.ndarray)


def stacked(samples, large: int = 1):
    """
    Scene frames as (first frame, temperature, frames): consecutive frames that differ in
    temperature only stacked into 3-D blocks (the engines merge a block's frames into the
    integrator's moments one after the other, exactly as frame by frame; the image stage's
    sub-band sums add a block's sum):

    -   small frames (at most a sixteenth of :data:`STACK_BYTES`) with the same emissivity, no
        region map and nothing reflected, up to :data:`FRAME_BLOCK` frames or
        :data:`STACK_BYTES`;
    -   other frames with one scalar emissivity, no region map and at most one reflected
        temperature, the same for all, up to ``large`` frames;

    any other frame alone, as it is (2-D).
    """
    first, held, limit = None, [], 0
    for frame in samples:
        t = frame.temperature
        plain = (isinstance(t, np.ndarray) and t.ndim == 2 and frame.regions is None
                 and frame.region_emissivity is None)
        if plain and 16 * t.nbytes <= STACK_BYTES and frame.reflected_temperature is None:
            most = min(FRAME_BLOCK, STACK_BYTES // max(1, t.nbytes))
        elif plain and large > 1 and _scalar(frame.emissivity) \
                and _scalar(frame.reflected_temperature):
            most = large
        else:
            most = 1
        if held and (most != limit or frame.index != first.index + len(held)
                     or len(held) == limit or t.dtype != held[0].dtype
                     or t.shape != held[0].shape
                     or not _same_emissivity(first.emissivity, frame.emissivity)
                     or frame.reflected_temperature != first.reflected_temperature):
            yield first, np.stack(held) if len(held) > 1 else held[0], len(held)
            held = []
        if most == 1:
            yield frame, t, 1
            continue
        if not held:
            first, limit = frame, most
        held.append(t)
    if held:
        yield first, np.stack(held) if len(held) > 1 else held[0], len(held)


def _same_emissivity(e, f) -> bool:
    """The same emissivity object, equal scalars, or views of the same memory (one signal
    table serves both)."""
    if e is f:
        return True
    if _scalar(e) and _scalar(f) and isinstance(e, (int, float)) and isinstance(f, (int, float)):
        return e == f
    return (isinstance(e, np.ndarray) and isinstance(f, np.ndarray)
            and e.shape == f.shape and e.strides == f.strides and e.dtype == f.dtype
            and e.__array_interface__["data"][0] == f.__array_interface__["data"][0])
