"""
The focal-plane array's geometry and quantum efficiency.

The integrator lays the array's pixel cells on the scene (:attr:`FocalPlaneArray.pixel_pitch`,
:attr:`~FocalPlaneArray.fill_factor`, :attr:`~FocalPlaneArray.origin`,
:attr:`~FocalPlaneArray.shape`); the optics use the active area on the focal plane for the
étendue; the quantum efficiency is one of the spectral factors of the Planck response.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from colour import SpectralDistribution

from radiosim.checks import check_fraction, check_positive
from radiosim.config import edge_field
from radiosim.errors import RadiosimError
from radiosim.spectral import as_spectrum

__all__ = ["FocalPlaneArray"]

_UM = 1e-6


@dataclass(frozen=True, eq=False)
class FocalPlaneArray:
    """
    Geometry and quantum efficiency of the detector array.

    Attributes
    ----------
    pixel_pitch : float
        Pixel pitch projected into object space [m].
    shape : tuple of int or None
        Array size (rows, columns); ``None``: as many pixels as the scene holds.
    fill_factor : float
        Active over total pixel area, in (0, 1]; the active square is pitch × √fill factor.
    detector_pitch : float or None
        Pixel pitch on the focal plane [m]; ``None``: equal to ``pixel_pitch`` (unit
        magnification). The magnification is detector_pitch / pixel_pitch.
    quantum_efficiency : float or SpectralDistribution
        Electrons per absorbed photon (dimensionless).
    origin : tuple of float
        Offset (y, x) [m] of the first pixel cell from the scene's top-left corner, ≥ 0.

    Examples
    --------
    >>> fpa = FocalPlaneArray(6e-6, detector_pitch=30e-6, fill_factor=0.85)
    >>> fpa.magnification, round(fpa.active_area * 1e12, 6)
    (5.0, 765.0)
    """

    pixel_pitch: float = edge_field(None, "pixel_pitch_um", _UM,
                                    doc="object-space pixel pitch in µm")
    shape: tuple[int, int] | None = edge_field(None, "shape", kind="ints",
                                               doc="rows, columns")
    fill_factor: float = edge_field(1.0, "fill_factor", doc="active area fraction")
    detector_pitch: float | None = edge_field(None, "detector_pitch_um", _UM,
                                              doc="focal-plane pixel pitch in µm")
    quantum_efficiency: float | SpectralDistribution = edge_field(
        1.0, "quantum_efficiency", kind="curve", doc="quantum efficiency curve or number")
    origin: tuple[float, float] = edge_field((0.0, 0.0), "origin_um", _UM, kind="numbers",
                                             doc="offset (y, x) of the first pixel cell in µm")

    def __post_init__(self):
        object.__setattr__(self, "pixel_pitch", check_positive(self.pixel_pitch, "pixel_pitch",
                                                               "m"))
        if self.shape is not None:
            try:
                rows, cols = (int(v) for v in self.shape)
            except (TypeError, ValueError):
                raise RadiosimError(f"array shape must be (rows, columns), got "
                                    f"{self.shape!r}") from None
            if rows < 1 or cols < 1:
                raise RadiosimError(f"array shape must be (rows ≥ 1, columns ≥ 1), got {self.shape}")
            object.__setattr__(self, "shape", (rows, cols))
        object.__setattr__(self, "fill_factor", check_fraction(self.fill_factor, "fill_factor"))
        if self.detector_pitch is not None:
            object.__setattr__(self, "detector_pitch",
                               check_positive(self.detector_pitch, "detector_pitch", "m"))
        object.__setattr__(self, "quantum_efficiency",
                           as_spectrum(self.quantum_efficiency, "quantum efficiency"))
        try:
            y, x = (float(v) for v in self.origin)
        except (TypeError, ValueError):
            raise RadiosimError(f"origin must be (y, x) [m], got {self.origin!r}") from None
        if not (y >= 0 and x >= 0 and math.isfinite(y + x)):
            raise RadiosimError(f"origin must be (y ≥ 0, x ≥ 0) [m], got {self.origin}")
        object.__setattr__(self, "origin", (y, x))

    @property
    def magnification(self) -> float:
        """Image size over object size (dimensionless)."""
        return 1.0 if self.detector_pitch is None else self.detector_pitch / self.pixel_pitch

    @property
    def active_area(self) -> float:
        """Photosensitive area of one pixel on the focal plane [m²]."""
        return self.fill_factor * (self.pixel_pitch * self.magnification) ** 2
