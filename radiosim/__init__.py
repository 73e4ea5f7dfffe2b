"""
radiosim: a physically based radiometric simulator of infrared cameras.

Temperature frames → in-band Planck photon radiance → focal-plane array charge over the
integration time → noise, full well and ADC counts → the camera's calibration back to apparent
temperature. With :meth:`Camera.linear_ideal` it reproduces the box averages of Whitenton,
Heigel & Ivester, MSEC2009-84319, exactly.

The chain, one module per stage, imports flowing one way (:data:`CHAIN`):
:mod:`radiosim.scenes` → :mod:`radiosim.response` (:mod:`radiosim.radiometry`,
:mod:`radiosim.spectral`) → :mod:`radiosim.integrator` → :mod:`radiosim.optics` (its
point-spread functions in :mod:`radiosim.psf`; the image they form in :mod:`radiosim.imaging`) →
:mod:`radiosim.electronics` → :mod:`radiosim.calibration` → :mod:`radiosim.measurement`,
orchestrated by :class:`radiosim.camera.Camera`. Files in and out are in :mod:`radiosim.io`,
studies in :mod:`radiosim.study`, and everything specific to the paper in
:mod:`radiosim.paper`.
"""

import logging
import os

# The compiled kernels run one short parallel region per frame. OpenMP's default waiting spins
# idle threads for about 300 000 turns (milliseconds) between regions; on a 2-core machine they
# then compete with the thread that prepares the next frame, and a region can stall for
# milliseconds (measured: 8 ms per launch). Sleeping at once (OMP_WAIT_POLICY=PASSIVE) costs a
# wake-up per region instead (measured: 0.05 ms per launch, 10 % of a paper-sized frame). A
# short spin (GOMP_SPINCOUNT=3000, about 0.05 ms here) covers the gap between two frames'
# regions and then sleeps: 0.005 ms per launch. Set before numba loads its OpenMP layer (at the
# first parallel call); an explicit OMP_WAIT_POLICY or GOMP_SPINCOUNT in the environment wins.
if "OMP_WAIT_POLICY" not in os.environ:
    os.environ.setdefault("GOMP_SPINCOUNT", "3000")

from radiosim import errors, units  # noqa: F401  (reachable as attributes)
from radiosim.camera import Camera, FocalPlaneArray, Optics, available_presets
from radiosim.electronics import Electronics
from radiosim.errors import RadiosimError, RadiosimWarning
from radiosim.measurement import Measurement
from radiosim.scenes import FrameStack, MovingGaussianBand, UniformBlackbody
from radiosim import io, paper, scenes, study  # noqa: E402,F401  (public subpackages)

__version__ = "0.1.0"

#: The package's modules in the order of the chain: a module imports only modules before it
#: (tests/test_architecture.py checks this with ``ast``).
CHAIN = (
    "errors", "units", "checks", "config", "files", "spectral", "radiometry", "kernels", "scenes",
    "response", "fpa", "integrator", "psf", "optics", "imaging", "electronics", "calibration", "measurement", "presets",
    "camera", "characterization", "uncertainty", "io", "study", "plotting", "paper", "cli",
)

__all__ = [
    "Camera",
    "Optics",
    "FocalPlaneArray",
    "Electronics",
    "Measurement",
    "FrameStack",
    "UniformBlackbody",
    "MovingGaussianBand",
    "RadiosimError",
    "RadiosimWarning",
    "available_presets",
    "io",
    "scenes",
    "study",
    "paper",
    "CHAIN",
    "__version__",
]

logging.getLogger(__name__).addHandler(logging.NullHandler())
