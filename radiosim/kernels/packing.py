"""
The compiled CPU engine's own format of a response's signal: :func:`pack` turns an
engine-neutral :class:`~radiosim.kernels.table.SignalTable` into
:class:`~radiosim.kernels.bundles.PackedTables` (the distinct tables' cubic rows one after the
other in one flat array, their grids as bit keys: what the radiance pass reads), kept in the
table's :attr:`~radiosim.kernels.table.SignalTable.engine_data` so that the copies of a table
with other maps (one per frame) pack once; :func:`emissivity` gives the kernel's signal mode
and map arguments (:class:`~radiosim.kernels.bundles.Emissivity`) for a frame region.
"""

from __future__ import annotations

import numpy as np

from radiosim.errors import RadiosimError
from radiosim.kernels.bundles import Emissivity, PackedTables
from radiosim.kernels.codes import SIGNAL_MAP, SIGNAL_NONE, SIGNAL_SCALAR
from radiosim.kernels.layout import read_only, rows_of
from radiosim.kernels.table import SignalTable

__all__ = ["pack", "emissivity", "NO_TABLES", "NO_EMISSIVITY"]

#: The key of the compiled engine's packed form in ``SignalTable.engine_data``.
ENGINE_KEY = "compiled"

#: The tables argument of a launch without a response (never read).
NO_TABLES = PackedTables(np.zeros(4), np.zeros(1, dtype=np.int64), np.zeros(1, dtype=np.uint64),
                         np.zeros(1, dtype=np.intp), np.zeros(1, dtype=np.uint64), np.zeros(1),
                         np.full(1, np.inf), np.zeros(1, dtype=np.intp), np.ones(1))
#: The emissivity argument of a launch without a response (SIGNAL_NONE: no signal).
NO_EMISSIVITY = Emissivity(SIGNAL_NONE, 1.0, read_only(np.zeros(1)),
                           read_only(np.zeros(1, dtype=np.uint8)), 0, False)


def pack(table: SignalTable) -> PackedTables:
    """
    ``table``'s radiance tables in the compiled kernels' format (packed once per table and the
    copies :meth:`~radiosim.kernels.table.SignalTable.with_maps` makes of it).

    Per distinct table j (``table.unique_tables``): its cubic rows from row ``offset[j]`` of
    the flat ``coef`` (four coefficients a row, highest power of T − T_k first), the bit key
    ``key0[j]`` of its first node and the ``shift`` below the node keys (the interval of T is
    (bits(T) >> shift) − key0, clamped to ``last[j]``), and its range [``t_min[j]``,
    ``t_max[j]``] [K]; per entry its table and grey factor.
    """
    if not isinstance(table, SignalTable):
        raise RadiosimError(f"response must be a SignalTable or None, got "
                            f"{type(table).__name__}")
    packed = table.engine_data.get(ENGINE_KEY)
    if packed is None:
        unique = table.unique_tables
        packed = PackedTables(
            coef=np.concatenate([t.coefficients for t in unique]).reshape(-1),
            key0=np.array([t.key0 for t in unique], dtype=np.int64),
            shift=np.array([t.shift for t in unique], dtype=np.uint64),
            last=np.array([t.intervals - 1 for t in unique], dtype=np.intp),
            offset=np.cumsum([0] + [t.intervals for t in unique[:-1]]).astype(np.uint64),
            t_min=table.t_min, t_max=table.t_max,
            entry_table=table.entry_table, entry_grey=table.entry_grey)
        table.engine_data[ENGINE_KEY] = packed
    return packed


_ONES: dict[int, np.ndarray] = {}


def _ones(n: int) -> np.ndarray:
    """A read-only row of n ones (the grey map row of a scalar grey factor)."""
    ones = _ONES.get(n)
    if ones is None:
        _ONES.clear()
        ones = _ONES[n] = read_only(np.ones(n))
    return ones


def _uint8_index(index: np.ndarray, n_entries: int) -> np.ndarray:
    """An index map as uint8 when the table has at most 255 entries (one compiled variant
    serves every map): values outside 0 … 255 become 255, which is no entry either, so the
    kernel flags them as before (the error message reads the original map). A table of more
    entries keeps its intp map (a variant compiled on first use)."""
    if index.dtype == np.uint8 or n_entries > 255:
        return index
    return np.where((index >= 0) & (index <= 255), index, 255).astype(np.uint8)


def emissivity(table: SignalTable | None, frame_shape) -> Emissivity:
    """The kernel's signal mode, grey factor and maps for ``table`` on a frame region of
    ``frame_shape`` (:data:`NO_EMISSIVITY` without a table). The kernel's grey factor: S = L ·
    grey (SIGNAL_SCALAR), L · (grey · map) (SIGNAL_MAP), L · grey_e · grey or L · grey_e · map
    (SIGNAL_INDEX), as :meth:`SignalTable.signal <radiosim.kernels.table.SignalTable.signal>`."""
    if table is None:
        return NO_EMISSIVITY
    table.check_maps(frame_shape)
    mode = table.mode
    use_map = table.grey_scalar is None
    if mode == SIGNAL_SCALAR:
        grey = table.entry_grey[0] * table.grey_scalar
    elif mode == SIGNAL_MAP:
        grey = table.entry_grey[0]
    else:
        grey = 1.0 if use_map else table.grey_scalar
    grey_map, map_length = rows_of(table.grey) if use_map else (_ones(frame_shape[1]), 0)
    if table.index is not None:
        index_map, map_length = rows_of(_uint8_index(table.index, table.n_entries))
    else:
        index_map = NO_EMISSIVITY.index_map
    return Emissivity(mode, float(grey), grey_map, index_map, map_length, use_map)
