"""
Footprint layouts as the kernels take them (:class:`KernelAxis`: the pieces of one axis,
region-relative, with the column slot layout of the sweeps), prepared once per
:class:`~radiosim.integrator.AxisFootprints`; frames and frame blocks as flat read-only views
with their strides (never copied when their rows are contiguous); argument checks.
"""

from __future__ import annotations

import weakref
from dataclasses import dataclass

import numpy as np

from radiosim.errors import RadiosimError
from radiosim.kernels.bundles import ColumnSlots, FrameBlock

__all__ = ["KernelAxis", "kernel_axis", "rows_of", "frames_of", "frame_bundle", "frame_region",
           "frame_block", "per_pixel", "per_frame", "merged_arguments", "read_only"]


@dataclass(frozen=True)
class KernelAxis:
    """The pieces of one axis as the kernels take them (region-relative sample indices)."""

    source: np.ndarray  # intp, sample index of each piece minus ``offset``
    weight: np.ndarray  # float64, piece length / active width
    bounds: np.ndarray  # intp, n_pixels + 1: pieces of pixel j are bounds[j]:bounds[j + 1]
    pixel: np.ndarray  # intp, the pixel of each piece
    offset: int  # scene sample index of the region's first sample (span.start)
    identity: bool  # the pieces are the region's samples, in order, each once

    @property
    def slots(self) -> ColumnSlots:
        """The kernels' column layout (:class:`~radiosim.kernels.bundles.ColumnSlots`; see the
        comment on the compiled kernels): the region's samples (the extent), the runs of
        slots of one pixel (start, stop, pixel; slots are the samples 0 … extent − 1, then the
        duplicate pieces), the weight of each slot (0 for a sample no piece reads), the slot of
        each piece, the sample of each duplicate slot, the piece bounds of the pixels (the
        index arrays as uintp), and the layout code the reduction to pixels takes (bit 0: the
        pieces are the samples; bit 1: each pixel's interior pieces lie on consecutive slots
        with one weight)."""
        cached = self.__dict__.get("_slots")
        if cached is None:
            n = self.extent
            first = np.ones(self.source.size, dtype=bool)  # first piece reading its sample
            first[1:] = self.source[1:] != self.source[:-1]
            duplicate = np.flatnonzero(~first)
            slot_of_piece = np.where(first, self.source,
                                     n + np.cumsum(~first) - 1).astype(np.uintp)
            slot_pixel = np.zeros(n + duplicate.size, dtype=np.uintp)
            slot_weight = np.zeros(n + duplicate.size)
            slot_pixel[self.source[first]] = self.pixel[first]
            slot_weight[self.source[first]] = self.weight[first]
            slot_pixel[n:] = self.pixel[duplicate]
            slot_weight[n:] = self.weight[duplicate]
            change = np.flatnonzero(np.diff(slot_pixel) != 0) + 1
            starts, stops = np.append(0, change), np.append(change, slot_pixel.size)
            slot_runs = np.ascontiguousarray(
                np.stack([starts, stops, slot_pixel[starts]], axis=1).astype(np.uintp))
            # Regular: every pixel's interior pieces (not its first or last) lie on
            # consecutive slots and weigh the same (whole samples), as axis_footprints makes.
            position = np.arange(self.source.size) - self.bounds[self.pixel]
            count = np.diff(self.bounds)[self.pixel]
            interior = (position > 0) & (position < count - 1)
            pairs = interior[:-1] & interior[1:]
            regular = bool(np.all(np.diff(slot_of_piece.astype(np.int64))[pairs] == 1)
                           and np.all(self.weight[:-1][pairs] == self.weight[1:][pairs]))
            layout = int(self.identity) | (2 if regular else 0)
            cached = ColumnSlots(n, slot_runs, slot_weight, slot_of_piece,
                                 self.source[duplicate].astype(np.uintp),
                                 self.bounds.astype(np.uintp), layout)
            object.__setattr__(self, "_slots", cached)
        return cached

    @property
    def n_pixels(self) -> int:
        return self.bounds.size - 1

    @property
    def starts(self) -> np.ndarray:
        return self.bounds[:-1]

    @property
    def extent(self) -> int:
        """Samples of the region the pieces need (the last piece's sample + 1)."""
        return int(self.source[-1]) + 1

    def pixels(self, start: int, stop: int) -> "KernelAxis":
        """The pieces of pixels ``start`` to ``stop - 1`` only (same region)."""
        a, b = int(self.bounds[start]), int(self.bounds[stop])
        return KernelAxis(self.source[a:b], self.weight[a:b], self.bounds[start:stop + 1] - a,
                     self.pixel[a:b] - start, self.offset, False)

    @classmethod
    def of(cls, axis, name: str) -> "KernelAxis":
        source = np.asarray(axis.source, dtype=np.intp)
        weight = np.array(axis.weight, dtype=np.float64)  # a writeable copy: one compilation
        starts = np.asarray(axis.starts, dtype=np.intp)
        if source.ndim != 1 or source.size == 0 or weight.shape != source.shape:
            raise RadiosimError(f"{name} footprints must have one weight per piece and at least "
                                f"one piece, got {source.size} pieces and {weight.size} weights")
        if not np.all((weight > 0) & np.isfinite(weight)):
            bad = weight[~((weight > 0) & np.isfinite(weight))][0]
            raise RadiosimError(f"{name} footprints: every piece's weight must be a finite "
                                f"number > 0 (a piece reads its sample), got {bad!r}")
        if starts.ndim != 1 or starts.size == 0 or starts[0] != 0 or np.any(
                np.diff(starts) <= 0) or starts[-1] >= source.size:
            raise RadiosimError(f"{name} footprints: starts must begin at 0 and increase "
                                f"strictly inside the {source.size} pieces")
        offset = int(source[0])
        relative = np.ascontiguousarray(source - offset)
        if np.any(relative < 0):
            raise RadiosimError(f"{name} footprints: the first piece must lie on the region's "
                                "first sample (span.start)")
        bounds = np.append(starts, source.size).astype(np.intp)
        pixel = np.repeat(np.arange(starts.size, dtype=np.intp), np.diff(bounds))
        if np.any(np.diff(relative) < 0):
            raise RadiosimError(f"{name} footprints: pieces must read non-decreasing samples")
        identity = bool(np.array_equal(relative, np.arange(relative.size)))
        return cls(relative, weight, bounds, pixel, offset, identity)


_LAYOUTS: dict[int, tuple[weakref.ref, KernelAxis]] = {}


def kernel_axis(axis, name: str) -> KernelAxis:
    """The kernel layout of an AxisFootprints, prepared once per object."""
    if isinstance(axis, KernelAxis):
        return axis
    key = id(axis)
    cached = _LAYOUTS.get(key)
    if cached is not None and cached[0]() is axis:
        return cached[1]
    layout = KernelAxis.of(axis, name)
    try:
        ref = weakref.ref(axis, lambda _, key=key: _LAYOUTS.pop(key, None))
    except TypeError:  # not weak-referenceable: prepare it every call
        return layout
    _LAYOUTS[key] = (ref, layout)
    return layout


def rows_of(array: np.ndarray) -> tuple[np.ndarray, int]:
    """A 2-D array whose rows are contiguous, as a read-only 1-D view and its row stride
    [elements], without copying (a region of a larger C-contiguous frame or memmap included)."""
    flat, row_length, _ = frames_of(np.asarray(array)[None])
    return flat, row_length


def frames_of(a: np.ndarray) -> tuple[np.ndarray, int, int]:
    """A 3-D array (frames, rows, columns) whose rows are contiguous, as a read-only 1-D view,
    its row stride and its frame stride [elements], without copying (a region of a stack of
    frames or of a memmap included); otherwise one copy, same dtype."""
    item = a.itemsize
    n_frames, n_rows, n_cols = a.shape
    if a.flags.c_contiguous:
        flat, row_length, frame_stride = a.reshape(-1), n_cols, n_rows * n_cols
    elif (n_rows > 0 and n_cols > 0 and a.strides[2] == item
          and a.strides[1] >= n_cols * item and a.strides[1] % item == 0
          and (n_frames == 1 or (a.strides[0] >= n_rows * a.strides[1]
                                 and a.strides[0] % item == 0))):
        row_length = a.strides[1] // item
        frame_stride = a.strides[0] // item if n_frames > 1 else n_rows * row_length
        size = (n_frames - 1) * frame_stride + (n_rows - 1) * row_length + n_cols
        flat = np.lib.stride_tricks.as_strided(a, shape=(size,), strides=(item,),
                                               writeable=False)
    else:  # rows not contiguous (a transposed view, a column step): one copy, same dtype
        a = np.ascontiguousarray(a)
        flat, row_length, frame_stride = a.reshape(-1), n_cols, n_rows * n_cols
    flat = flat.view()
    flat.flags.writeable = False
    return flat, int(row_length), int(frame_stride)


#: The frame arrays a :class:`~radiosim.kernels.bundles.FrameBlock` holds for the dtype its
#: frames are not (one element, read-only: the type of a frame block's flat view).
_NO_FLOAT64, _NO_FLOAT32 = np.zeros(1), np.zeros(1, np.float32)
_NO_FLOAT64.flags.writeable = _NO_FLOAT32.flags.writeable = False


def frame_bundle(block: np.ndarray) -> FrameBlock:
    """The :class:`~radiosim.kernels.bundles.FrameBlock` of a 3-D float32 or float64 block
    (frames, rows, columns), read in place (:func:`frames_of`)."""
    base, row_length, frame_stride = frames_of(block)
    narrow = base.dtype == np.float32
    return FrameBlock(_NO_FLOAT64 if narrow else base, base if narrow else _NO_FLOAT32,
                      bool(narrow),
                      row_length, frame_stride, block.shape[0])


def frame_region(frame, rows: KernelAxis, cols: KernelAxis) -> np.ndarray:
    """The frame region as a 2-D float32 or float64 array covering the pieces (not copied)."""
    a = np.asarray(frame)
    if a.ndim != 2:
        raise RadiosimError(f"a frame region must be 2-D, got shape {a.shape}")
    if a.dtype not in (np.float32, np.float64):
        a = a.astype(np.float64)
    if a.shape[0] < rows.extent or a.shape[1] < cols.extent:
        raise RadiosimError(
            f"frame region has shape {a.shape}, but the footprints need at least "
            f"({rows.extent}, {cols.extent}) samples from sample ({rows.offset}, {cols.offset})"
        )
    return a


def frame_block(frames, rows: KernelAxis, cols: KernelAxis) -> np.ndarray:
    """One frame region (2-D) or several (3-D: frames, rows, columns), as a 3-D float32 or
    float64 array covering the pieces (not copied)."""
    a = np.asarray(frames)
    if a.ndim == 2:
        return frame_region(a, rows, cols)[None]
    if a.ndim != 3 or a.shape[0] == 0:
        raise RadiosimError(f"frames must be one 2-D frame region or a non-empty 3-D stack "
                            f"(frames, rows, columns), got shape {a.shape}")
    if a.dtype not in (np.float32, np.float64):
        a = a.astype(np.float64)
    frame_region(a[0], rows, cols)  # the shape check
    return a


def per_pixel(array, shape, name: str):
    """Check a per-pixel array: float64, C-contiguous, ``shape``, writeable unless it is the
    reference."""
    writeable = name != "reference"
    if (not isinstance(array, np.ndarray) or array.dtype != np.float64
            or array.shape != shape or not array.flags.c_contiguous
            or (writeable and not array.flags.writeable)):
        raise RadiosimError(f"{name} must be a {'writeable ' if writeable else ''}C-contiguous "
                            f"float64 array of shape {shape} (one value per pixel)")
    return array


def per_frame(values, n_frames: int, n_jobs: int, name: str) -> np.ndarray:
    """Per-frame, per-job weights as a C-contiguous (frames, jobs) float64 array."""
    try:
        a = np.asarray(values, dtype=np.float64)
        got = f"shape {a.shape}"
    except (TypeError, ValueError):
        a, got = np.zeros(0), "ragged or non-numeric values"
    if a.ndim == 1:
        a = a[None]
    if a.shape != (n_frames, n_jobs):
        raise RadiosimError(f"{name} must have shape ({n_jobs},) for one frame or "
                            f"({n_frames}, {n_jobs}) for {n_frames} frames (one weight per "
                            f"frame and job), got {got}")
    return np.ascontiguousarray(a)


def merged_arguments(frame, rows, cols, members, weight, signal_weight, moments: bool) -> tuple:
    """The checked arguments of a merging accumulation (every engine's
    ``accumulate_merged``): the axes' :class:`KernelAxis`, the 3-D frame block, the
    (frames, jobs) ``weight`` (zeros without ``moments``) and ``signal_weight``, and the jobs'
    total weights n_b before each frame and after the last, (frames + 1, jobs)."""
    rows, cols = kernel_axis(rows, "row"), kernel_axis(cols, "column")
    block = frame_block(frame, rows, cols)
    n_frames, n_jobs = block.shape[0], members.count.size
    weight = per_frame(weight, n_frames, n_jobs, "weight")
    signal_weight = per_frame(signal_weight, n_frames, n_jobs, "signal_weight")
    if not moments:
        weight = np.zeros_like(weight)
    # n_b before each frame, and after the last, added up frame by frame.
    counts = np.cumsum(np.vstack([members.count[None], weight]), axis=0)
    return rows, cols, block, weight, signal_weight, counts


def read_only(array: np.ndarray) -> np.ndarray:
    view = array.view()
    view.flags.writeable = False
    return view
