"""
The codes the compiled kernels and their Python side share: the status bits a launch returns
and the signal modes of a :class:`~radiosim.kernels.table.SignalTable`. Inside the
compiled functions they are compile-time constants (numba freezes module globals).
"""

__all__ = ["STATUS_OK", "STATUS_BAD_SAMPLE", "STATUS_BELOW_TABLE", "STATUS_ABOVE_TABLE",
           "STATUS_BAD_INDEX", "SIGNAL_NONE", "SIGNAL_SCALAR", "SIGNAL_MAP", "SIGNAL_INDEX"]

#: Status bits the compiled kernels return (OR-ed over pixel rows).
STATUS_OK = 0
#: A sample is NaN, ±inf or ≤ 0 K: :func:`accumulate` raises (the message of ``check_frame``).
STATUS_BAD_SAMPLE = 1
#: A sample is below its radiance table: :func:`accumulate` redoes those pixel rows with the
#: numpy reference, which integrates them exactly (the frame is still accumulated).
STATUS_BELOW_TABLE = 2
#: A sample is above its radiance table: :func:`accumulate` raises, naming value and range.
STATUS_ABOVE_TABLE = 4
#: A table-index map value is not an entry of the :class:`~radiosim.kernels.table.SignalTable`: raises.
STATUS_BAD_INDEX = 8

#: Signal modes of the kernel: no signal (the linear response: the signal is T), one grey
#: factor, a grey map, or an index map of table entries (each with its grey factor).
SIGNAL_NONE = 0
SIGNAL_SCALAR = 1
SIGNAL_MAP = 2
SIGNAL_INDEX = 3
