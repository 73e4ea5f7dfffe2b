"""
The named, typed bundles the compiled kernel takes (numba passes a named tuple of arrays and
scalars by value, its fields read like attributes, at no cost inside the compiled code):

-   :class:`FrameBlock`: the frames of one launch (a flat view and its strides);
-   :class:`RowPieces`: the pieces of the row axis;
-   :class:`ColumnSlots`: the column axis as the sweeps take it (slots, duplicates, layout);
-   :class:`Accumulators`: the per-pixel accumulators of :func:`~radiosim.kernels.accumulate`;
-   :class:`Merging`: the jobs' moments of :func:`~radiosim.kernels.accumulate_merged`;
-   :class:`PackedTables`: the compiled CPU engine's radiance tables (its own format);
-   :class:`Emissivity`: the signal mode and the frame's grey and index maps;
-   :class:`ThreadBuffers`: each thread's scratch (one row per block of pixel rows).

Each field keeps the type it always has (the compiled kernel has one signature per index-map
dtype and read-only flags, never per value; float32 and float64 frames share it).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

__all__ = ["FrameBlock", "RowPieces", "ColumnSlots", "Accumulators", "Merging", "PackedTables",
           "Emissivity", "ThreadBuffers"]


class FrameBlock(NamedTuple):
    """The frames of one launch: frame f's sample (i, j) is
    ``base[f · frame_stride + i · row_length + j]`` (``base32`` for float32 frames). Both frame
    dtypes have the same numba type (one compiled kernel): the frames are in the array of their
    dtype, the other holds one element (:func:`~radiosim.kernels.layout.frame_bundle`)."""

    #: Flat read-only view of float64 frames [K] (never copied).
    base: np.ndarray
    #: Flat read-only view of float32 frames [K] (never copied).
    base32: np.ndarray
    #: The frames are float32 (in ``base32``).
    narrow: bool
    #: Elements between two rows.
    row_length: int
    #: Elements between two frames.
    frame_stride: int
    #: Frames in the block.
    n_frames: int


class RowPieces(NamedTuple):
    """The pieces of the row axis (:class:`~radiosim.kernels.layout.KernelAxis`)."""

    #: intp: the region row each piece reads.
    source: np.ndarray
    #: float64: each piece's weight (length / active width).
    weight: np.ndarray
    #: intp, pixel rows + 1: the pieces of pixel row i are ``bounds[i]:bounds[i + 1]``.
    bounds: np.ndarray


class ColumnSlots(NamedTuple):
    """The column axis as the sweeps take it (:attr:`KernelAxis.slots
    <radiosim.kernels.layout.KernelAxis.slots>`): slots 0 … n_samples − 1 are the region's
    samples, the slots after them the duplicate pieces (pixel edges inside a sample)."""

    #: Samples of the region a row sweep reads (the column extent).
    n_samples: int
    #: uintp (runs, 3): slots ``[start, stop)`` belong to pixel ``pixel``.
    runs: np.ndarray
    #: float64: each slot's weight (0: a sample no piece reads).
    weight: np.ndarray
    #: uintp: the slot of each piece.
    of_piece: np.ndarray
    #: uintp: the sample each duplicate slot reads.
    dup_source: np.ndarray
    #: uintp, pixels + 1: the pieces of pixel j are ``bounds[j]:bounds[j + 1]``.
    bounds: np.ndarray
    #: Layout code: bit 0, slot q is piece q; bit 1, each pixel's interior pieces lie on
    #: consecutive slots with one weight.
    layout: int


class Accumulators(NamedTuple):
    """The per-pixel accumulators of one frame (pixel rows, pixel columns), float64."""

    #: The frame's weight in the window.
    time_weight: float
    #: The per-pixel reference c [K] (written only when merging: the frame's mean).
    reference: np.ndarray
    #: Σ w_t Σ w (T − c) [K].
    dev: np.ndarray
    #: Σ w_t Σ w (T − c)² [K²].
    sq: np.ndarray
    #: max T [K].
    tmax: np.ndarray
    #: Σ w_t Σ w S [signal unit].
    signal: np.ndarray


class Merging(NamedTuple):
    """The moments of several jobs sharing the footprints (Chan et al.), with one row of
    weights per frame of the block; with ``merge`` off the kernel commits to
    :class:`Accumulators` instead."""

    #: Merge into the jobs (else add to the accumulators).
    merge: bool
    #: Merge the moments (else only the signals).
    moments: bool
    #: With ``moments`` and a signal: a pixel row whose only status is samples below the table
    #: still merges its moments (and moves its reference on), as a pass without the signal
    #: would; its signal is left to the caller (the row's status says so).
    keep_moments: bool
    #: (frames, jobs): each job's time weight of the frame (0: not in its window).
    weight: np.ndarray
    #: (frames, jobs): each job's total weight before the frame.
    count: np.ndarray
    #: (frames, jobs): each job's weight of the frame's signal.
    signal_weight: np.ndarray
    #: (jobs, rows, columns): merged mean [K], M2 [K²], maximum [K] and signal.
    mean: np.ndarray
    m2: np.ndarray
    max: np.ndarray
    signal: np.ndarray


class PackedTables(NamedTuple):
    """The radiance tables of a :class:`~radiosim.kernels.table.SignalTable` in the compiled CPU
    engine's format (:func:`radiosim.kernels.packing.pack`): the unique tables' cubic rows one
    after the other in one flat array, their grids' bit keys, and each entry's table and grey
    factor."""

    #: float64 (rows × 4): the cubics' coefficients, highest power of T − T_k first.
    coef: np.ndarray
    #: int64 per table: bit key of its first node (the grid of floats with their top mantissa
    #: bits set, :class:`~radiosim.radiometry.BandRadianceTable`).
    key0: np.ndarray
    #: uint64 per table: bits below the node keys.
    shift: np.ndarray
    #: intp per table: its last interval.
    last: np.ndarray
    #: uint64 per table: its first row in ``coef``.
    offset: np.ndarray
    #: float64 per table: the range it answers over [K].
    t_min: np.ndarray
    t_max: np.ndarray
    #: intp per entry: its table.
    entry_table: np.ndarray
    #: float64 per entry: its grey factor.
    entry_grey: np.ndarray


class Emissivity(NamedTuple):
    """How the kernel weights the radiance: the signal mode
    (:mod:`radiosim.kernels.codes` ``SIGNAL_*``) and the frame's maps."""

    #: SIGNAL_NONE, SIGNAL_SCALAR, SIGNAL_MAP or SIGNAL_INDEX.
    mode: int
    #: The grey factor the mode multiplies by (see ``launch._emissivity``).
    grey: float
    #: Flat read-only grey map (ones for a scalar grey), rows of ``map_length``.
    grey_map: np.ndarray
    #: Flat read-only index map (uint8 or intp), rows of ``map_length``.
    index_map: np.ndarray
    #: Elements between two rows of the maps.
    map_length: int
    #: Whether the grey map is read (else the scalar ``grey``).
    use_map: bool


class ThreadBuffers(NamedTuple):
    """Per-thread buffers, one row per block of pixel rows: the duplicate slots' gathered
    samples (frame rows, grey map row, index map row), each written through the first array
    and read through the second (a read-only view of the same memory, so that gathered frame
    rows have the type of float64 frame rows: one compilation serves the frame's rows and the
    gathered ones), and each slot's running maximum and minimum. The frame rows and extremes
    are float64 for either frame dtype (a float32 sample widens exactly), the index map row
    has the map's dtype."""

    rows_w: np.ndarray
    rows_r: np.ndarray
    grey_w: np.ndarray
    grey_r: np.ndarray
    index_w: np.ndarray
    index_r: np.ndarray
    am: np.ndarray
    an: np.ndarray
