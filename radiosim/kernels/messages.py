"""
The errors of a flagged frame, found again in numpy from the samples the pieces read: a bad
sample (in the format of :func:`radiosim.checks.check_frame`), an index that is no table entry,
a sample above its table; and the reference path's checks (:func:`check_samples`).
"""

from __future__ import annotations

import numpy as np

from radiosim.checks import bad_sample_message
from radiosim.errors import RadiosimError
from radiosim.kernels.layout import KernelAxis
from radiosim.kernels.table import SignalTable

__all__ = ["raise_bad_sample", "raise_bad_index", "raise_above_table", "check_samples"]


def _touched(frame2d: np.ndarray, rows: KernelAxis, cols: KernelAxis):
    """The samples the pieces read (unique rows × unique columns), as float64, with their
    region-relative row and column indices."""
    r = np.unique(rows.source)
    c = np.unique(cols.source)
    return np.asarray(frame2d[np.ix_(r, c)], dtype=np.float64), r, c


def raise_bad_sample(frame2d, rows: KernelAxis, cols: KernelAxis, k: int):
    """The error of the first non-finite or ≤ 0 K sample the pieces read, in the format of
    :func:`radiosim.checks.check_frame` (row and column in full-scene coordinates)."""
    values, r, c = _touched(frame2d, rows, cols)
    bad = ~((values > 0) & (values < np.inf))
    if not bad.any():  # the samples are fine: the NaN came from the reference c
        raise RadiosimError(f"frame {k}: the per-pixel reference (pixel_mean of the first "
                            "frame) must be finite")
    i, j = (int(v) for v in np.argwhere(bad)[0])
    raise RadiosimError(bad_sample_message(float(values[i, j]), k, int(r[i]) + rows.offset,
                                           int(c[j]) + cols.offset, int(bad.sum())))


def _entries(response: SignalTable, r, c):
    if response.index is None:
        return np.zeros((r.size, c.size), dtype=np.intp)
    return np.asarray(response.index[np.ix_(r, c)], dtype=np.intp)


def raise_bad_index(frame2d, rows: KernelAxis, cols: KernelAxis, k: int, response):
    r, c = np.unique(rows.source), np.unique(cols.source)
    entries = _entries(response, r, c)
    bad = (entries < 0) | (entries >= response.n_entries)
    i, j = (int(v) for v in np.argwhere(bad)[0])
    raise RadiosimError(
        f"frame {k}: table index {entries[i, j]} at row {r[i] + rows.offset}, column "
        f"{c[j] + cols.offset} is not an entry of the radiance table (0–"
        f"{response.n_entries - 1}; {int(bad.sum())} such sample(s) in this frame)"
    )


def raise_above_table(frame2d, rows: KernelAxis, cols: KernelAxis, k: int, response):
    values, r, c = _touched(frame2d, rows, cols)
    table_of = response.entry_table[_entries(response, r, c)]
    above = values > response.t_max[table_of]
    i, j = (int(v) for v in np.argwhere(above)[0])
    lo, hi = response.t_min[table_of[i, j]], response.t_max[table_of[i, j]]
    raise RadiosimError(
        f"frame {k}: temperature {values[i, j]:g} K at row {r[i] + rows.offset}, column "
        f"{c[j] + cols.offset} is outside the radiance table's range {lo:g}–{hi:g} K (above "
        f"it; {int(above.sum())} such sample(s) in this frame)"
    )


def check_samples(frame2d, rows: KernelAxis, cols: KernelAxis, k: int, response) -> bool:
    """Raise for bad samples, indices or samples above the table (the reference path's
    checks); True if some samples are below their table."""
    values, r, c = _touched(frame2d, rows, cols)
    if not np.all((values > 0) & (values < np.inf)):
        raise_bad_sample(frame2d, rows, cols, k)
    if response is None:
        return False
    entries = _entries(response, r, c)
    if np.any((entries < 0) | (entries >= response.n_entries)):
        raise_bad_index(frame2d, rows, cols, k, response)
    table_of = response.entry_table[entries]
    if np.any(values > response.t_max[table_of]):
        raise_above_table(frame2d, rows, cols, k, response)
    return bool(np.any(values < response.t_min[table_of]))
