"""
The engines: sets of operations that carry every hot pass of the chain.

An engine is an :class:`Engine`, a dataclass whose fields are its name and its operations. The
chain never asks which engine it has: the integrator, the image stage (sub-band signals and
blur) and the scenes with compiled terms call the chosen engine's operations, whatever it is.
:data:`ENGINES` holds them by name:

-   ``"compiled"`` (the default, unless numba's JIT is disabled, ``NUMBA_DISABLE_JIT=1``:
    then ``"numpy"``): the numba kernels on the CPU;
-   ``"numpy"``: their plain numpy references (:mod:`radiosim.kernels.reference`), always
    available, the tests' oracle.

The operations
--------------
-   ``pixel_mean(frame, rows, cols, *, frame_index=0, threads=None)``, ``accumulate(frame,
    rows, cols, time_weight, reference, dev, sq, tmax, signal_acc=None, response=None, *,
    frame_index=0, threads=None)`` and ``accumulate_merged(frame, rows, cols, reference,
    members, weight, signal_weight, response=None, *, moments=True, keep_moments=False,
    frame_index=0, threads=None)``: the integrator's footprint × window sums, with the
    arguments, checks, errors and return values of :mod:`radiosim.kernels.launch` (an engine
    may ignore ``threads``);
-   ``accumulate_bands(block, weights, tables, out, *, frame_index=0)``: the image stage's
    window sums of every sub-band's signal per sample (:mod:`radiosim.kernels.bands`);
-   ``fft``: the discrete Fourier transforms of the optics' blur, a namespace with the
    functions of :mod:`scipy.fft` (``rfft``, ``fft``, ``ifft``, ``irfft``; the transfer
    functions themselves, computed once per PSF and grid, are numpy's);
-   ``scene_terms``: the operations of scenes with terms of their own (the segmented chip's
    moving terms, ``"segmented_chip"``), registered by those scenes
    (:func:`register_scene_terms`) since they come later in the chain. A scene whose terms
    an engine lacks makes its frames with its numpy reference.

:func:`get_engine` picks one: an explicit name or :class:`Engine`, else the engine of the pass
under way (:func:`using_engine`: the integrator and the image stage read their frames inside
it, so a scene's own terms follow an ``engine=`` argument too), else the process setting
(:func:`set_engine`), else the environment variable ``RADIOSIM_ENGINE``, else ``"compiled"``.

What an engine receives is engine-neutral: frames as numpy arrays (float32 or float64,
possibly memory maps), footprints as :class:`~radiosim.kernels.layout.KernelAxis`, per-pixel
float64 arrays, and the response's signal as a :class:`~radiosim.kernels.table.SignalTable` or
``None`` (the signal is T). An engine may keep its own packed form of a table in
``table.engine_data[<engine name>]``.

Adding an engine (a GPU one, say)
---------------------------------
One new module beside this one implementing the operations, and one entry in :data:`ENGINES`::

    ENGINES["gpu"] = Engine("gpu", gpu.pixel_mean, gpu.accumulate, gpu.accumulate_merged,
                            gpu.accumulate_bands, cupyx.scipy.fft)

An engine made from another one (``dataclasses.replace(ENGINES["numpy"], name="x")``) shares
its operations and the scene terms registered so far; a scene registering later adds to the
engines it names only. Its tests compare it with the numpy engine, as
``tests/test_kernels.py`` does for the compiled one.
"""

from __future__ import annotations

import contextlib
import contextvars
import dataclasses
import os
from dataclasses import dataclass, field
from typing import Any, Callable

from scipy import fft as _scipy_fft

from radiosim.errors import RadiosimError
from radiosim.kernels import bands, launch, reference

__all__ = ["Engine", "ENGINES", "DEFAULT_ENGINE", "ENVIRONMENT_VARIABLE", "get_engine",
           "set_engine", "using_engine", "register_scene_terms"]

#: The engine taken when nothing else is chosen.
DEFAULT_ENGINE = "compiled"
#: The environment variable that chooses the engine of a process (below :func:`set_engine`).
ENVIRONMENT_VARIABLE = "RADIOSIM_ENGINE"


@dataclass(frozen=True)
class Engine:
    """An engine: its name and the operations the chain asks of it (module docstring)."""

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
    #: Window sums of every sub-band's signal per sample, as
    #: :func:`radiosim.kernels.bands.accumulate_bands`.
    accumulate_bands: Callable
    #: The Fourier transforms of the optics' blur (:mod:`scipy.fft`'s functions).
    fft: Any = _scipy_fft
    #: Operations registered by scenes with terms of their own, by the scene's name
    #: (:func:`register_scene_terms`).
    scene_terms: dict = field(default_factory=dict)


#: The engines by name.
ENGINES: dict[str, Engine] = {
    "compiled": Engine("compiled", launch.pixel_mean, launch.accumulate,
                       launch.accumulate_merged, bands.accumulate_bands),
    "numpy": Engine("numpy", reference.pixel_mean_reference, reference.accumulate_reference,
                    reference.accumulate_merged_reference, reference.accumulate_bands_reference),
}


def register_scene_terms(name: str, implementations: dict[str, Callable]) -> None:
    """Register a scene's operation ``name`` with the engines of ``implementations`` (engine
    name → function), e.g. the segmented chip's compiled and numpy moving terms: each named
    engine is replaced by one with the term added (engines made from it earlier keep theirs,
    and so make that scene's frames with its numpy reference)."""
    for engine, function in implementations.items():
        old = ENGINES[engine]
        ENGINES[engine] = dataclasses.replace(old, scene_terms={**old.scene_terms,
                                                                name: function})


_selected: str | None = None
_current: contextvars.ContextVar = contextvars.ContextVar("radiosim_engine", default=None)


@contextlib.contextmanager
def using_engine(engine):
    """Within the block, :func:`get_engine` with no name gives ``engine`` (a name or an
    :class:`Engine`): the integrator and the image stage read a scene's frames inside it, so
    that a scene's own terms follow their ``engine`` argument. Threads that read frames ahead
    run in a copy of the caller's context (:func:`radiosim.frame_reading.prefetched`)."""
    token = _current.set(get_engine(engine))
    try:
        yield
    finally:
        _current.reset(token)


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
    """The engine ``name``, or, for ``None``, the chosen one (the pass's, :func:`using_engine`;
    else :func:`set_engine`'s, else the environment variable ``RADIOSIM_ENGINE``'s, else
    ``"compiled"``)."""
    if isinstance(name, Engine):
        return name
    if name is not None:
        return ENGINES[_checked(name, "engine")]
    current = _current.get()
    if current is not None:
        return current
    if _selected is not None:
        return ENGINES[_selected]
    chosen = os.environ.get(ENVIRONMENT_VARIABLE)
    if chosen:
        return ENGINES[_checked(chosen, f"environment variable {ENVIRONMENT_VARIABLE}")]
    return ENGINES["numpy" if _jit_disabled() else DEFAULT_ENGINE]


def _jit_disabled() -> bool:
    """Whether numba runs its functions as plain Python (``NUMBA_DISABLE_JIT=1``): the compiled
    engine cannot run then (its LLVM intrinsics have no Python form), so the default is the
    numpy engine, which gives the same results to rounding."""
    import numba

    return bool(numba.config.DISABLE_JIT)
