"""
radiosim: a physically based radiometric simulator of infrared cameras.

Temperature frames → in-band Planck photon radiance → focal-plane array charge over the
integration time → noise, full well and ADC counts → the camera's calibration back to apparent
temperature. With :meth:`Camera.linear_ideal` it reproduces the box averages of Whitenton,
Heigel & Ivester, MSEC2009-84319, exactly.

The chain, one module per stage, imports flowing one way (:data:`CHAIN`):
:mod:`radiosim.scenes` → :mod:`radiosim.response` (:mod:`radiosim.radiometry`,
:mod:`radiosim.spectral`) → :mod:`radiosim.integrator` (the frames read for it by
:mod:`radiosim.frame_reading`; every hot pass through an engine of :mod:`radiosim.kernels`) →
:mod:`radiosim.optics` (its
point-spread functions in :mod:`radiosim.psf`; the image they form in :mod:`radiosim.imaging`) →
:mod:`radiosim.electronics` → :mod:`radiosim.calibration` (a camera maker's own curve in
:mod:`radiosim.flir`) → :mod:`radiosim.measurement`
(several spectral channels and their ratio temperature in :mod:`radiosim.ratio`),
orchestrated by :class:`radiosim.camera.Camera` (its acquisition modes in
:mod:`radiosim.acquisition`, its laboratory procedures in :mod:`radiosim.characterization` and
:mod:`radiosim.calibration_table`). Files in and out are in :mod:`radiosim.io` (a camera's
recordings in :mod:`radiosim.io.recordings`, put beside a simulation by
:mod:`radiosim.comparison`),
studies in :mod:`radiosim.study`, everything specific to the paper in :mod:`radiosim.paper`,
and the ``radiosim`` command in :mod:`radiosim.cli` (its signal handling in
:mod:`radiosim.cli_signals`; the interrupt the library's loops poll in
:mod:`radiosim.interrupts`).
"""

import importlib
import logging

from radiosim._version import __version__

# Nothing heavy is imported here: the names below load their module on first use (PEP 562), so
# `import radiosim` (and the command's --help) costs little and changes nothing in the process:
# numpy's print options and os.environ are left as they were.
_LAZY = {
    "Camera": "radiosim.camera",
    "FocalPlaneArray": "radiosim.camera",
    "Optics": "radiosim.camera",
    "available_presets": "radiosim.camera",
    "Electronics": "radiosim.electronics",
    "RadiosimError": "radiosim.errors",
    "RadiosimWarning": "radiosim.errors",
    "Measurement": "radiosim.measurement",
    "Channel": "radiosim.ratio",
    "FrameStack": "radiosim.scenes",
    "MovingGaussianBand": "radiosim.scenes",
    "UniformBlackbody": "radiosim.scenes",
    "compare": "radiosim.comparison",
    "read_recording": "radiosim.io.recordings",
}
_SUBMODULES = frozenset({"errors", "units", "io", "paper", "scenes", "study", "acquisition",
                         "characterization", "calibration_table", "ratio"})


def __getattr__(name):
    if name in _LAZY:
        value = getattr(importlib.import_module(_LAZY[name]), name)
    elif name in _SUBMODULES:
        value = importlib.import_module(f"radiosim.{name}")
    else:
        raise AttributeError(f"module 'radiosim' has no attribute {name!r}")
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(_LAZY) | _SUBMODULES)

#: The package's modules in the order of the chain: a module imports only modules before it
#: (tests/test_architecture.py checks this with ``ast``).
CHAIN = (
    "_version", "errors", "interrupts", "units", "checks", "config", "files", "scheduling", "spectral", "radiometry",
    "kernels", "scenes", "response", "fpa", "frame_reading", "integrator",
    "psf", "optics",
    "imaging", "electronics", "calibration", "flir", "measurement", "ratio", "presets", "acquisition",
    "camera", "characterization", "defects", "psf_measurement", "correction", "calibration_table", "moments", "budget_reuse",
    "uncertainty", "io", "study_spec", "study", "plotting", "comparison", "reporting",
    "paper",
    "example_data", "console", "warmup", "cli_checks", "cli_signals", "cli_recording",
    "cli",
)

__all__ = [
    "Camera",
    "Optics",
    "FocalPlaneArray",
    "Electronics",
    "Measurement",
    "Channel",
    "FrameStack",
    "UniformBlackbody",
    "MovingGaussianBand",
    "RadiosimError",
    "RadiosimWarning",
    "available_presets",
    "compare",
    "read_recording",
    "io",
    "scenes",
    "study",
    "paper",
    "CHAIN",
    "__version__",
]

logging.getLogger(__name__).addHandler(logging.NullHandler())
