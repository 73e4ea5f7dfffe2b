"""
The optics: lens, filter and cold stop between the scene and the focal plane.

This stage turns the mean in-band radiance a pixel sees into the rate at which it collects
photo-electrons, through the étendue of its active area. The optics' point-spread function
(:mod:`radiosim.psf`, ``Optics.psf``) acts on image-plane radiance before the pixel footprint
(:mod:`radiosim.imaging`). Optics at an instrument temperature T_i with transmission τ(λ) emit
(1 − τ(λ))·L(λ, T_i) into every pixel (Kirchhoff's law for a non-scattering lens), seen through
the filter and the detector's quantum efficiency: a background charge with its shot noise.

The light cone reaching a pixel is limited by the narrower of two apertures: the camera's cold
stop, of image-space f-number N (sin θ' = 1 / √(4N² + 1)), and, behind a microscope objective
of object-side numerical aperture NA at magnification m, the objective's image-side cone
sin θ' = NA / m (Abbe's sine condition).

References
----------
-   Born, M. & Wolf, E. (1999). Principles of Optics, 7th ed., §4.5 (the sine condition) and
    §4.8 (étendue; radiance through a lossless system).
-   EMVA Standard 1288, Release 4.0 Linear (2021), §2.1 (photons on a pixel).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

from radiosim.checks import check_positive
from radiosim.config import edge_field
from radiosim.errors import RadiosimError
from radiosim.fpa import FocalPlaneArray
from radiosim.psf import PSF, as_psf
from radiosim.radiometry import DEFAULT_BAND, band_radiance
from radiosim.response import reflectance
from radiosim.spectral import as_spectrum
from radiosim.units import MICRO

if TYPE_CHECKING:  # colour-science is imported when a curve is built
    from colour import SpectralDistribution

__all__ = ["Optics", "etendue", "f_number_of", "collect"]


def etendue(active_area: float, f_number: float) -> float:
    """
    Étendue of a detector pixel behind a lens of image-space f-number N.

    G = A · π sin²θ' = A · π / (4 N² + 1): the projected solid angle of the exit-pupil cone of
    half-angle θ' with sin θ' = 1 / √(4N² + 1), times the area.

    Parameters
    ----------
    active_area
        Active (photosensitive) area of the pixel in the image plane [m²].
    f_number
        Image-space f-number N (dimensionless).

    Returns
    -------
    float
        Étendue [m² sr].

    Examples
    --------
    >>> round(etendue(1.0, 0.5), 6)  # N = 0.5: sin θ' = 1/√2, a 45° cone: π/2 sr
    1.570796
    >>> round(etendue(1.0, 1e-9), 6)  # N → 0: the full hemisphere, π sr
    3.141593
    """
    if not (active_area > 0 and f_number > 0):
        raise RadiosimError(f"need area > 0 [m²] and f-number > 0, got {active_area}, {f_number}")
    return active_area * math.pi / (4.0 * f_number**2 + 1.0)


def f_number_of(sine: float) -> float:
    """
    The image-space f-number N of a cone of half-angle θ' with sin θ' = ``sine``
    (N = √(1/sin²θ' − 1) / 2, the inverse of :func:`etendue`'s relation).

    Examples
    --------
    >>> round(f_number_of(1 / math.sqrt(26)), 12)
    2.5
    """
    if not 0 < sine <= 1:
        raise RadiosimError(f"sin θ' must be in (0, 1], got {sine!r}")
    return math.sqrt(1.0 / sine**2 - 1.0) / 2.0


@dataclass(frozen=True, eq=False)
class Optics:
    """
    Lens, filter, cold stop and spectral band.

    Attributes
    ----------
    band : tuple of float
        Spectral integration limits (λ1, λ2) [m].
    f_number : float
        Image-space f-number N of the cold stop (dimensionless).
    transmission : float or SpectralDistribution
        Optics transmission (dimensionless); curves have a domain in metres.
    spectral_filter : float or SpectralDistribution
        Band-pass filter transmission (dimensionless).
    objective_na : float or None
        Object-side numerical aperture of a microscope objective (dimensionless); ``None``:
        the cold stop alone limits the cone.
    psf : tuple of PSF or None
        Point-spread functions (their convolution; :mod:`radiosim.psf`); ``None``: a perfect
        lens. A single PSF or TOML tables (``[[optics.psf]]`` with a ``type``) are accepted.
    instrument_temperature : float or None
        Temperature of the lens and windows [K], which emit (1 − transmission); ``None``: cold
        optics, no emission.
    emissivity : float or None
        The optics' grey emissivity as seen by the pixel [1], where it is known; ``None``:
        1 − transmission (Kirchhoff's law for a non-scattering lens).
    instrument_factor : float or None
        The factor [1], ≥ 0, by which radiation at the instrument temperature reaches the
        detector, relative to a blackbody filling the cold stop's cone, as a calibration at
        several instrument temperatures measures it
        (:func:`radiosim.calibration.fit_calibration`): the lens's own emission and whatever
        warm parts (housing, barrel, window mounts) the detector sees inside and beyond that
        cone. It may exceed 1 (a detector that sees warm parts over more than the cone).
        When given it replaces the lens's emission (``emissivity``); ``None``: the lens's
        emission alone.

    Examples
    --------
    >>> from radiosim.fpa import FocalPlaneArray
    >>> fpa = FocalPlaneArray(6e-6, detector_pitch=30e-6)
    >>> round(Optics(f_number=2.5, objective_na=0.2).image_f_number(fpa), 4)  # NA/m = 0.04
    12.49
    """

    band: tuple[float, float] = edge_field(DEFAULT_BAND, "band_um", MICRO, kind="numbers",
                                           doc="integration limits in µm")
    f_number: float = edge_field(2.5, "f_number", doc="image-space f-number of the cold stop")
    transmission: float | SpectralDistribution = edge_field(
        1.0, "transmission", kind="curve", doc="optics transmission curve or number")
    spectral_filter: float | SpectralDistribution = edge_field(
        1.0, "spectral_filter", kind="curve", doc="filter transmission curve or number")
    objective_na: float | None = edge_field(
        None, "objective_na", doc="object-side numerical aperture of the objective")
    psf: tuple[PSF, ...] | None = edge_field(None, "psf", kind="psf",
                                             doc="point-spread functions (tables with a type)")
    instrument_temperature: float | None = edge_field(
        None, "instrument_temperature_K", doc="temperature of the emitting lens and windows [K]")
    emissivity: float | None = edge_field(None, "emissivity",
                                          doc="the optics' grey emissivity (default 1 − τ)")
    instrument_factor: float | None = edge_field(
        None, "instrument_factor",
        doc="share of a black cone's radiance at the instrument temperature the detector sees")

    def __post_init__(self):
        try:
            lo, hi = (float(b) for b in self.band)
        except (TypeError, ValueError):
            raise RadiosimError(f"band must be (λ1, λ2) in metres, got {self.band!r}") from None
        if not 0 < lo < hi <= 1e-3:
            raise RadiosimError(f"band must be (λ1, λ2) in metres with 0 < λ1 < λ2 ≤ 1 mm, got "
                                f"{self.band}")
        object.__setattr__(self, "band", (lo, hi))
        object.__setattr__(self, "f_number", check_positive(self.f_number, "f_number", "1"))
        object.__setattr__(self, "transmission", as_spectrum(self.transmission,
                                                             "optics transmission"))
        object.__setattr__(self, "spectral_filter", as_spectrum(self.spectral_filter,
                                                                "spectral filter"))
        if self.objective_na is not None:
            na = check_positive(self.objective_na, "objective_na", "1")
            if na >= 1:
                raise RadiosimError(f"objective_na must be < 1 (a dry objective), got {na!r}")
            object.__setattr__(self, "objective_na", na)
        object.__setattr__(self, "psf", as_psf(self.psf))
        if self.instrument_temperature is not None:
            object.__setattr__(self, "instrument_temperature", check_positive(
                self.instrument_temperature, "instrument_temperature", "K"))
        if self.emissivity is not None and not 0 <= self.emissivity <= 1:
            raise RadiosimError(f"optics emissivity must be in [0, 1], got {self.emissivity!r}")
        if self.instrument_factor is not None:
            factor = float(self.instrument_factor)
            if not (math.isfinite(factor) and factor >= 0):
                raise RadiosimError(f"instrument_factor must be finite and ≥ 0, got "
                                    f"{self.instrument_factor!r}")
            object.__setattr__(self, "instrument_factor", factor)

    def __repr__(self) -> str:
        """One line: f-number, band, objective, PSFs (the curves by name, not their values)."""
        def curve(value):
            return getattr(value, "name", None) or f"{value:g}"

        psf = ", ".join(type(p).__name__ for p in self.psf) if self.psf else "perfect lens"
        na = "" if self.objective_na is None else f", objective NA {self.objective_na:g}"
        return (f"Optics(f/{self.f_number:g}, {self.band[0] * 1e6:g}–{self.band[1] * 1e6:g} µm"
                f"{na}, transmission {curve(self.transmission)}, filter "
                f"{curve(self.spectral_filter)}, {psf})")

    def image_f_number(self, fpa: FocalPlaneArray) -> float:
        """
        The working image-space f-number [1]: the cold stop's, or the objective's image-side
        cone (sin θ' = NA / m) where that is narrower.
        """
        if self.objective_na is None:
            return self.f_number
        return max(self.f_number, f_number_of(self.objective_na / fpa.magnification))

    def object_na(self, fpa: FocalPlaneArray) -> float:
        """The object-side numerical aperture the working cone implies [1]: m · sin θ'."""
        return fpa.magnification / math.sqrt(4 * self.image_f_number(fpa) ** 2 + 1)

    def etendue(self, fpa: FocalPlaneArray) -> float:
        """Étendue of one pixel's active area [m² sr]."""
        return etendue(fpa.active_area, self.image_f_number(fpa))

    @property
    def responsivity(self) -> list:
        """The optics' spectral factors of the Planck response: filter and transmission."""
        return [self.spectral_filter, self.transmission]

    def emitted_radiance(self, quantum_efficiency, temperature: float | None = None) -> float:
        """
        In-band photon radiance the optics emit into a pixel [photons s⁻¹ m⁻² sr⁻¹]:
        ∫ ε_o(λ) · filter(λ) · QE(λ) · L_q(λ, T_i) dλ with ε_o = 1 − τ(λ) (or the grey
        :attr:`emissivity`, or the measured :attr:`instrument_factor`, which may exceed 1), at
        ``temperature`` [K] (default the instrument temperature; 0 for cold optics).

        Examples
        --------
        >>> Optics(transmission=1.0, instrument_temperature=300.0).emitted_radiance(1.0)
        0.0
        """
        t = self.instrument_temperature if temperature is None else temperature
        if t is None:
            return 0.0
        t = check_positive(t, "instrument temperature", "K")
        curves = [self.spectral_filter, quantum_efficiency]
        if self.instrument_factor is not None:  # measured: may exceed a black lens's 1
            return self.instrument_factor * float(band_radiance(t, self.band, "photon",
                                                                curves, 1.0))
        emissivity = reflectance(self.transmission) if self.emissivity is None else \
            self.emissivity
        return float(band_radiance(t, self.band, "photon", curves, emissivity))


def collect(signal_mean, rate_per_signal: float, integration_time: float):
    """
    Mean photo-electrons per pixel [e⁻]: mean signal [signal unit] × electron rate per unit of
    signal [e⁻ s⁻¹ per unit] (the étendue for radiance) × integration time [s].
    """
    return signal_mean * rate_per_signal * integration_time
