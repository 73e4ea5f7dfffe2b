"""
radiosim: a physically based radiometric simulator of infrared cameras.

Temperature frames → in-band Planck photon radiance → focal-plane array charge over the
integration time → noise, full well and ADC counts → the camera's calibration back to apparent
temperature. With :meth:`Camera.linear_ideal` it reproduces the box averages of Whitenton,
Heigel & Ivester, MSEC2009-84319, exactly.

The chain, one module per stage: :mod:`radiosim.scenes` → :mod:`radiosim.response`
(:mod:`radiosim.radiometry`, :mod:`radiosim.spectral`) → :mod:`radiosim.integrator` →
:mod:`radiosim.electronics` → :mod:`radiosim.calibration` → :mod:`radiosim.measurement`,
orchestrated by :class:`radiosim.camera.Camera`.
"""

import logging

from radiosim.camera import Camera, FocalPlaneArray, Optics, available_presets
from radiosim.electronics import Electronics
from radiosim.errors import RadiosimError, RadiosimWarning
from radiosim.measurement import Measurement
from radiosim.scenes import FrameStack, MovingGaussianBand, UniformBlackbody

__version__ = "0.1.0"

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
    "__version__",
]

logging.getLogger(__name__).addHandler(logging.NullHandler())
