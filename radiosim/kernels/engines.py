"""
The integration engines, chosen in one place.

An engine is an :class:`Engine`: a name and the operations the chain asks of it
(:meth:`~Engine.pixel_mean`, :meth:`~Engine.accumulate`, :meth:`~Engine.accumulate_merged`,
with the arguments and results of :mod:`radiosim.kernels.launch`). :data:`ENGINES` holds them
by name:

-   ``"compiled"`` (the default): the numba kernels on the CPU;
-   ``"numpy"``: their plain numpy references (:mod:`radiosim.kernels.reference`), always
    available, the tests' oracle. The integrator then keeps its own reference arithmetic (each
    job on its own, :attr:`Engine.reference` is true).

:func:`get_engine` picks one: an explicit name (an argument of the integrator or the image
stage), else the process setting (:func:`set_engine`), else the environment variable
``RADIOSIM_ENGINE``, else ``"compiled"``. :func:`compiled_selected` answers the scenes'
question, whether their own compiled terms should run.

Adding an engine (a GPU one, say)
---------------------------------
It is one new module beside this one, ``radiosim/kernels/<engine>.py``, and one entry in
:data:`ENGINES` here; nothing else in the chain changes (the integrator, the image stage and
the chip scene reach engines only through :func:`get_engine` and :func:`compiled_selected`).
The module implements the three operations with the arguments, checks, errors and return
values of :mod:`radiosim.kernels.launch`:

-   ``pixel_mean(frame, rows, cols, *, frame_index=0, threads=None)``;
-   ``accumulate(frame, rows, cols, time_weight, reference, dev, sq, tmax, signal_acc=None,
    response=None, *, frame_index=0, threads=None)``;
-   ``accumulate_merged(frame, rows, cols, reference, members, weight, signal_weight,
    response=None, *, moments=True, frame_index=0, threads=None)``.

What it receives is engine-neutral: frames as numpy arrays (float32 or float64, possibly memory
maps), footprints as :class:`~radiosim.kernels.layout.KernelAxis` (from
:func:`~radiosim.kernels.layout.kernel_axis`), per-pixel float64 arrays, and the response's
signal as a :class:`~radiosim.kernels.table.SignalTable` (the radiance tables' temperature
grids [K] and cubic coefficients, the exact radiance below them, grey factors, grey and index
maps) or ``None`` (the signal is T). It packs the table into its own format (as
:func:`radiosim.kernels.packing.pack` does for the CPU kernels) and may keep that, e.g. on the
device, in ``table.engine_data[<engine>]``, which the table's per-frame copies share. The
argument checks are shared (:func:`~radiosim.kernels.layout.merged_arguments`,
:func:`~radiosim.kernels.reference.checked_arguments`), and so is the treatment of a flagged
frame (:mod:`radiosim.kernels.messages`: the errors; samples below the table redone by
:func:`~radiosim.kernels.reference.accumulate_numpy`). Its tests compare it with the numpy
engine (:mod:`radiosim.kernels.reference`, the oracle), as ``tests/test_kernels.py`` does for
the compiled one.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import Callable

from radiosim.errors import RadiosimError
from radiosim.kernels import launch, reference

__all__ = ["Engine", "ENGINES", "DEFAULT_ENGINE", "ENVIRONMENT_VARIABLE", "get_engine",
           "set_engine", "compiled_selected"]

#: The engine taken when nothing else is chosen.
DEFAULT_ENGINE = "compiled"
#: The environment variable that chooses the engine of a process (below :func:`set_engine`).
ENVIRONMENT_VARIABLE = "RADIOSIM_ENGINE"


@dataclass(frozen=True)
class Engine:
    """An integration engine: the operations the integrator and the image stage ask of it."""

    #: Its name in :data:`ENGINES`.
    name: str
    #: Per-pixel area mean of a frame region (the reference c), as
    #: :func:`radiosim.kernels.launch.pixel_mean`.
    pixel_mean: Callable
    #: One frame into the per-pixel accumulators, as :func:`radiosim.kernels.launch.accumulate`.
    accumulate: Callable
    #: Frames merged into several jobs' moments, as
    #: :func:`radiosim.kernels.launch.accumulate_merged`.
    accumulate_merged: Callable
    #: Whether it is the numpy reference (the integrator then integrates each job on its own
    #: with its reference arithmetic).
    reference: bool = False


#: The engines by name.
ENGINES: dict[str, Engine] = {
    "compiled": Engine("compiled", launch.pixel_mean, launch.accumulate,
                       launch.accumulate_merged),
    "numpy": Engine("numpy", reference.pixel_mean_reference, reference.accumulate_reference,
                    reference.accumulate_merged_reference, reference=True),
}

_selected: str | None = None


def _checked(name, source: str) -> str:
    if name not in ENGINES:
        raise RadiosimError(f"{source}: engine must be one of {', '.join(ENGINES)}, got "
                            f"{name!r}")
    return name


def set_engine(name: str | None) -> None:
    """Choose the engine of this process (``None``: back to ``RADIOSIM_ENGINE`` or the
    default)."""
    global _selected
    _selected = None if name is None else _checked(name, "set_engine")


def get_engine(name: str | Engine | None = None) -> Engine:
    """The engine ``name``, or, for ``None``, the chosen one (:func:`set_engine`, else the
    environment variable ``RADIOSIM_ENGINE``, else ``"compiled"``)."""
    if isinstance(name, Engine):
        return name
    if name is not None:
        return ENGINES[_checked(name, "engine")]
    if _selected is not None:
        return ENGINES[_selected]
    chosen = os.environ.get(ENVIRONMENT_VARIABLE)
    if chosen:
        return ENGINES[_checked(chosen, f"environment variable {ENVIRONMENT_VARIABLE}")]
    return ENGINES[DEFAULT_ENGINE]


def compiled_selected(name: str | Engine | None = None) -> bool:
    """Whether the chosen engine runs compiled code (the scenes' own compiled terms then run
    too; with the numpy engine they take their numpy references)."""
    return not get_engine(name).reference
