"""
Which implementation evaluates the segmented chip's moving terms: the compiled kernel
(:mod:`.compiled`, the default) or the numpy reference (:mod:`.reference`, the tests' oracle).

:func:`use_compiled` is the one place the choice is read. A call's ``compiled`` argument
(``SegmentedChip._evaluate(..., compiled=...)``) wins; without one, radiosim's engine setting
decides (:func:`radiosim.kernels.engines.compiled_selected`: ``set_engine("numpy")`` or
``RADIOSIM_ENGINE=numpy`` select the numpy references of the integrator and of the chip alike).
"""

from __future__ import annotations

from radiosim.kernels.engines import compiled_selected

__all__ = ["use_compiled"]


def use_compiled(compiled: bool | None = None) -> bool:
    """``compiled`` if given, else whether the selected engine runs compiled code (True: the
    compiled kernel, False: the numpy reference)."""
    if compiled is None:
        return compiled_selected()
    return compiled
