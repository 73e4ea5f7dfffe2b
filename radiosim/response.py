"""
Response models: what one scene sample contributes to a pixel, per unit area, time and solid
angle.

-   :class:`LinearResponse`: the signal is the temperature itself [K]; with ideal electronics
    this is the paper's "linear camera response", and a pixel reads the mean of its tensor.
    Emissivity plays no part.
-   :class:`PlanckResponse`: the signal is the in-band photon radiance
    ε·L_q(T) [photons s⁻¹ m⁻² sr⁻¹] through the camera's spectral responsivity (filter ×
    optics × quantum efficiency), so the photo-electron rate of a pixel is signal × étendue.

Both expose ``signal(T, emissivity)`` per sample and ``conversion`` (electron rate per unit of
signal), so the camera's orchestrator can swap them.
"""

from __future__ import annotations

from colour import SpectralDistribution

import numpy as np

from radiosim.errors import RadiosimError
from radiosim.radiometry import QUANTITIES, BandRadianceTable

__all__ = ["LinearResponse", "PlanckResponse", "RESPONSES"]


class LinearResponse:
    """
    Signal = temperature [K]; electron rate = ``responsivity`` × T [e⁻/s].

    Parameters
    ----------
    responsivity
        Electron rate per kelvin [e⁻ s⁻¹ K⁻¹].
    """

    name = "linear"
    unit = "K"

    def __init__(self, responsivity: float = 1e6):
        if not responsivity > 0:
            raise RadiosimError(f"linear responsivity must be > 0 [e⁻ s⁻¹ K⁻¹], got {responsivity}")
        self.conversion = float(responsivity)  # [e⁻ s⁻¹ per K]

    def signal(self, temperature: np.ndarray, emissivity=None) -> np.ndarray:
        """The signal of each sample [K]: its temperature."""
        return temperature

    def signal_range(self, emissivity: float = 1.0) -> tuple[float, float]:
        """Signals [K] that have a temperature: any positive one."""
        return (np.nextafter(0.0, 1.0), np.inf)

    def temperature(self, signal: np.ndarray, emissivity: float = 1.0) -> np.ndarray:
        """Invert :meth:`signal` [K]; a signal ≤ 0 has no temperature (NaN)."""
        signal = np.asarray(signal, dtype=float)
        return np.where(signal > 0, signal, np.nan)


class PlanckResponse:
    """
    Signal = ε·L_q(T), in-band photon radiance [photons s⁻¹ m⁻² sr⁻¹].

    Parameters
    ----------
    band
        Integration limits (λ1, λ2) [m].
    responsivity
        Spectral curves that multiply (filter, optics transmission, quantum efficiency), as for
        :func:`~radiosim.radiometry.band_radiance`.
    etendue
        Étendue of the pixel [m² sr]: electron rate = signal × étendue.
    temperature_range
        Range of the radiance tables [K].
    """

    name = "planck"
    unit = QUANTITIES["photon"]

    def __init__(self, band, responsivity, etendue: float, temperature_range=(150.0, 3000.0)):
        self.band = tuple(band)
        self.responsivity = responsivity
        self.conversion = float(etendue)  # [e⁻ s⁻¹ per photons s⁻¹ m⁻² sr⁻¹] = [m² sr]
        self.temperature_range = tuple(temperature_range)
        self._tables: dict[int, tuple[SpectralDistribution | None, BandRadianceTable]] = {}

    def table(self, emissivity=1.0) -> BandRadianceTable:
        """
        The radiance table for a spectral emissivity curve, or the blackbody table for a grey
        (scalar or map) emissivity, which scales it.
        """
        curve = emissivity if isinstance(emissivity, SpectralDistribution) else None
        key = id(curve)
        if key not in self._tables:
            self._tables[key] = (curve, BandRadianceTable(
                self.band, "photon", self.responsivity, 1.0 if curve is None else curve,
                self.temperature_range,
            ))
        return self._tables[key][1]

    def signal(self, temperature: np.ndarray, emissivity=1.0) -> np.ndarray:
        """ε·L_q(T) of each sample [photons s⁻¹ m⁻² sr⁻¹]."""
        radiance = self.table(emissivity)(temperature)
        if isinstance(emissivity, SpectralDistribution) or (
            np.isscalar(emissivity) and emissivity == 1.0
        ):
            return radiance
        return radiance * emissivity

    def signal_range(self, emissivity: float = 1.0) -> tuple[float, float]:
        """Signals [photons s⁻¹ m⁻² sr⁻¹] of a grey emitter over the tabulated temperatures."""
        low, high = self.table().radiance_range
        return (low * emissivity, high * emissivity)

    def temperature(self, signal: np.ndarray, emissivity: float = 1.0) -> np.ndarray:
        """Temperature [K] of a grey emitter of ``emissivity`` with this signal (NaN outside)."""
        if not 0 < emissivity <= 1:
            raise RadiosimError(f"assumed emissivity must be in (0, 1], got {emissivity!r}")
        return self.table().temperature(np.asarray(signal, dtype=float) / emissivity)


#: Response models by name.
RESPONSES = {"linear": LinearResponse, "planck": PlanckResponse}
