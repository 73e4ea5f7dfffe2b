"""
Response models: what one scene sample contributes to a pixel, per unit area, time and solid
angle — the first stage after the scene.

Both models take a :class:`~radiosim.scenes.SceneFrame` (temperature and emissivity of every
sample) and return a signal per sample; the integrator averages it over footprint × window, the
optics turn the mean into an electron rate (:meth:`Response.rate_per_signal`), and the
calibration inverts a grey body's signal (:meth:`Response.grey_signal`,
:meth:`Response.temperature`).

-   :class:`LinearResponse`: the signal is the temperature itself [K]; with ideal electronics
    this is the paper's "linear camera response", and a pixel reads the mean of its tensor.
    Emissivity plays no part, and neither does the optics' étendue: the electron rate is the
    camera's linear responsivity × T.
-   :class:`PlanckResponse`: the signal is the in-band photon radiance
    ε·L_q(T) [photons s⁻¹ m⁻² sr⁻¹] through the camera's spectral responsivity (filter ×
    optics × quantum efficiency), so the photo-electron rate of a pixel is signal × étendue.
    Radiance comes from a table (:class:`~radiosim.radiometry.BandRadianceTable`) over the
    response's own temperature range, which is wider than any calibration's; samples colder
    than the table (a cryogenic background) get the exact quadrature, so they are measured and
    the calibration flags them, instead of raising.
"""

from __future__ import annotations

import math

from abc import ABC, abstractmethod
from typing import TYPE_CHECKING

import numpy as np

from radiosim.checks import check_positive
from radiosim.errors import RadiosimError
from radiosim.kernels import SignalTable
from radiosim.radiometry import QUANTITIES, BandRadianceTable, band_radiance
from radiosim.scenes.base import SceneFrame
from radiosim.spectral import is_spectrum

if TYPE_CHECKING:  # colour-science is imported when a curve is built
    from colour import SpectralDistribution

__all__ = ["Response", "LinearResponse", "PlanckResponse", "MakerCurveResponse", "RESPONSES",
           "PLANCK_TABLE_RANGE", "observed_signal", "object_signal", "reflectance"]

#: Temperatures the Planck response tabulates [K]: colder samples are integrated exactly,
#: hotter ones are refused. Its relative error against quadrature stays below 1e-7 over the
#: range (measured: 3e-10 for the nist-ir band; see BandRadianceTable).
PLANCK_TABLE_RANGE = (130.0, 4000.0)
#: Tables a response keeps per emissivity (Monte Carlo draws of a grey emissivity each pack
#: one): the oldest goes first.
_CACHED_TABLES = 64


def reflectance(emissivity):
    """
    The reflectance 1 − ε(λ) of an opaque surface of ``emissivity`` (a grey scalar, a grey map
    or a spectral curve), in the same form (Kirchhoff's law).
    """
    if is_spectrum(emissivity):
        out = emissivity.copy()
        out.values = 1.0 - np.asarray(emissivity.values, dtype=float)
        out.name = f"1 - {emissivity.name}"
        return out
    return 1.0 - emissivity


def observed_signal(emitted, reflected, path_transmission: float = 1.0, path_emitted=0.0):
    """
    The thermography equation, forward: the signal reaching the camera from an opaque surface,

        S = τ · (ε L(T) + (1 − ε) L(T_refl)) + (1 − τ) · L(T_path),

    from its ``emitted`` part ε L(T), its ``reflected`` part (1 − ε) L(T_refl), and a grey path
    of transmission τ that emits ``path_emitted`` = L(T_path) [all in the response's unit].

    Examples
    --------
    >>> observed_signal(3.0, 1.0, 0.5, 2.0)
    3.0
    """
    return path_transmission * (emitted + reflected) + (1.0 - path_transmission) * path_emitted


def object_signal(observed, reflected, path_transmission: float = 1.0, path_emitted=0.0):
    """
    The thermography equation, inverted: the emitted part ε L(T) of an ``observed`` signal,
    given the reflected part and the path (the inverse of :func:`observed_signal`).

    Examples
    --------
    >>> object_signal(observed_signal(3.0, 1.0, 0.5, 2.0), 1.0, 0.5, 2.0)
    3.0
    """
    return (observed - (1.0 - path_transmission) * path_emitted) / path_transmission - reflected


class Response(ABC):
    """The interface of a response model (see the module docstring)."""

    #: Name (its key in :data:`RESPONSES`) and unit of the signal.
    name: str
    unit: str
    #: Whether :meth:`signal_table` describes the signal to the engines (the linear
    #: response's is ``None``: the signal is T); responses that do not are integrated job by
    #: job in numpy (:func:`radiosim.integrator.integrate_many`).
    has_table: bool = False
    #: Whether the signal is a radiance, so that reflections, paths and the optics' emission add
    #: to it (the linear response's signal is the temperature itself: the paper's ideal).
    radiometric: bool = False

    @classmethod
    @abstractmethod
    def for_camera(cls, camera) -> Response:
        """This response of ``camera`` (a :class:`~radiosim.camera.Camera`: its optics, focal
        plane array and settings), as the camera's ``response`` name picks it."""

    @abstractmethod
    def signal(self, frame: SceneFrame) -> np.ndarray:
        """The signal of each sample of ``frame`` [:attr:`unit`]."""

    @abstractmethod
    def grey_signal(self, temperature, emissivity: float = 1.0) -> np.ndarray:
        """The signal of a grey body of ``emissivity`` at ``temperature`` [K]."""

    @abstractmethod
    def temperature(self, signal, emissivity: float = 1.0) -> np.ndarray:
        """The temperature [K] of a grey body with this signal (NaN where there is none)."""

    def signal_table(self, frame: SceneFrame):
        """
        This response's signal on ``frame`` as tables, engine-neutral
        (:class:`~radiosim.kernels.SignalTable`: each entry's radiance table, its temperature
        grid [K] and cubic coefficients [signal unit K⁻ᵏ], the exact radiance below it, the
        entries' grey factors and the frame's emissivity maps; each engine packs it into its
        own format), or ``None`` when the signal is the temperature itself (see
        :attr:`has_table`).
        """
        return None

    @abstractmethod
    def rate_per_signal(self, etendue: float) -> float:
        """Electron rate per unit of signal [e⁻ s⁻¹ per :attr:`unit`] for a pixel of
        ``etendue`` [m² sr]."""

    def sub_bands(self, n: int) -> list:
        """
        The response split into ``n`` spectral sub-bands of equal width, whose signals add up
        to this one's, each with its centre wavelength [m]: ``[(response, wavelength), …]``
        (sub-bands where the responsivity is zero are left out).
        A response without a spectrum (the linear one) is one band at the centre of
        ``band``.
        """
        return [(self, float("nan"))]


    def slope(self, temperature, emissivity: float = 1.0) -> np.ndarray:
        """d(signal)/dT of a grey body [:attr:`unit` K⁻¹] (central difference of 1 mK)."""
        t = np.asarray(temperature, dtype=float)
        h = 1e-3
        return (self.grey_signal(t + h, emissivity) - self.grey_signal(t - h, emissivity)) / (
            2 * h)


class LinearResponse(Response):
    """
    Signal = temperature [K]; electron rate = ``responsivity`` × T [e⁻/s].

    Parameters
    ----------
    responsivity
        Electron rate per kelvin [e⁻ s⁻¹ K⁻¹].

    Examples
    --------
    >>> r = LinearResponse(1e6)
    >>> r.signal(SceneFrame(np.array([[300.0, 900.0]]))).tolist(), r.rate_per_signal(1e-12)
    ([[300.0, 900.0]], 1000000.0)
    """

    name = "linear"
    unit = "K"
    has_table = True

    def __init__(self, responsivity: float = 1e6):
        self.responsivity = check_positive(responsivity, "linear responsivity", "e⁻ s⁻¹ K⁻¹")

    @classmethod
    def for_camera(cls, camera) -> LinearResponse:
        """The camera's linear response: its ``linear_responsivity`` [e⁻ s⁻¹ K⁻¹]."""
        return cls(camera.linear_responsivity)

    def signal(self, frame: SceneFrame) -> np.ndarray:
        """The signal of each sample [K]: its temperature."""
        return frame.temperature

    def grey_signal(self, temperature, emissivity: float = 1.0) -> np.ndarray:
        return np.asarray(temperature, dtype=float)

    def temperature(self, signal, emissivity: float = 1.0) -> np.ndarray:
        """Invert :meth:`grey_signal` [K]; a signal ≤ 0 has no temperature (NaN)."""
        signal = np.asarray(signal, dtype=float)
        return np.where(signal > 0, signal, np.nan)

    def rate_per_signal(self, etendue: float) -> float:
        """The responsivity [e⁻ s⁻¹ K⁻¹]: the paper's ideal camera has no geometry."""
        return self.responsivity


class PlanckResponse(Response):
    """
    Signal = ε·L_q(T), in-band photon radiance [photons s⁻¹ m⁻² sr⁻¹].

    Parameters
    ----------
    band
        Integration limits (λ1, λ2) [m].
    responsivity
        Spectral curves that multiply (filter, optics transmission, quantum efficiency), as for
        :func:`~radiosim.radiometry.band_radiance`.
    temperature_range
        Range of the radiance tables [K] (default :data:`PLANCK_TABLE_RANGE`).
    """

    name = "planck"
    unit = QUANTITIES["photon"]
    has_table = True

    radiometric = True

    def __init__(self, band, responsivity, temperature_range=PLANCK_TABLE_RANGE):
        self.band = tuple(band)
        self.responsivity = responsivity
        self.temperature_range = tuple(float(t) for t in temperature_range)
        self._tables: dict[int, tuple[SpectralDistribution | None, BandRadianceTable]] = {}
        self._signal_tables: dict[tuple, SignalTable] = {}
        self._split: dict[int, list] = {}

    @classmethod
    def for_camera(cls, camera) -> PlanckResponse:
        """The camera's Planck response: its optics' band [m] and spectral responsivity
        (filter, optics, quantum efficiency)."""
        return cls(camera.optics.band, camera.responsivity)

    def sub_bands(self, n: int) -> list:
        if n not in self._split:
            edges = np.linspace(self.band[0], self.band[1], int(n) + 1)
            # Sub-bands where the responsivity is zero (a band wider than its filter) carry no
            # light: they are left out.
            hot = self.temperature_range[1]
            self._split[n] = [
                (self if n == 1 else PlanckResponse((lo, hi), self.responsivity,
                                                    self.temperature_range), 0.5 * (lo + hi))
                for lo, hi in zip(edges[:-1], edges[1:])
                if n == 1 or band_radiance(hot, (lo, hi), "photon", self.responsivity) > 0]
        return self._split[n]

    def table(self, emissivity=1.0) -> BandRadianceTable:
        """
        The radiance table for a spectral emissivity curve, or the blackbody table for a grey
        (scalar or map) emissivity, which scales it.
        """
        curve = emissivity if is_spectrum(emissivity) else None
        key = id(curve)
        if key not in self._tables and len(self._tables) >= _CACHED_TABLES:
            self._tables.pop(next(k for k in self._tables if k != id(None)))  # bounded
        if key not in self._tables:
            # L, cubic in T (BandRadianceTable); its grid runs a few intervals past
            # the range, clear of the spline's end effects, and it answers (and the kernels
            # read it) over the range only.
            table = BandRadianceTable(self.band, "photon", self.responsivity,
                                      1.0 if curve is None else curve, self.temperature_range)
            low, high = self.temperature_range
            table.radiance_range = (float(table(low)), float(table(high)))
            self._tables[key] = (curve, table)
        return self._tables[key][1]

    def _radiance(self, temperature: np.ndarray, curve) -> np.ndarray:
        """L_q(T) [photons s⁻¹ m⁻² sr⁻¹] through the table, or by quadrature below it."""
        table = self.table(curve if curve is not None else 1.0)
        t = np.asarray(temperature, dtype=float)
        low, high = self.temperature_range
        if t.size == 0 or t.min() >= low:
            return table(t)
        cold = t < low
        out = np.empty(t.shape)
        out[~cold] = table(t[~cold])
        out[cold] = band_radiance(t[cold], self.band, "photon", self.responsivity,
                                  1.0 if curve is None else curve)
        return out

    def _grey_or_curve(self, temperature, emissivity):
        if is_spectrum(emissivity):
            return self._radiance(temperature, emissivity)
        radiance = self._radiance(temperature, None)
        if np.isscalar(emissivity) and emissivity == 1.0:
            return radiance
        return radiance * emissivity

    def _surface(self, temperature, frame: SceneFrame, optical) -> np.ndarray:
        """optical(ε)·L_q(T) per sample, with the frame's emissivity (grey, curve, map or per
        region) passed through ``optical`` (the identity, or :func:`reflectance`)."""
        if frame.regions is None:
            return self._grey_or_curve(temperature, optical(frame.emissivity))
        out = np.zeros(temperature.shape)
        for code, value in frame.region_emissivity.items():
            here = frame.regions == code
            if here.any():
                out[here] = self._grey_or_curve(temperature[here], optical(value))
        return out

    def signal(self, frame: SceneFrame) -> np.ndarray:
        """ε·L_q(T) + (1 − ε)·L_q(T_refl) of each sample [photons s⁻¹ m⁻² sr⁻¹] (the second
        term where the frame reflects a temperature)."""
        out = self._surface(frame.temperature, frame, lambda e: e)
        if frame.reflected_temperature is not None:
            reflected = np.broadcast_to(np.asarray(frame.reflected_temperature, dtype=float),
                                        np.shape(frame.temperature))
            out = out + self._surface(reflected, frame, reflectance)
        return out

    def grey_signal(self, temperature, emissivity: float = 1.0) -> np.ndarray:
        return self._grey_or_curve(np.asarray(temperature, dtype=float), emissivity)

    def _entries_table(self, entries: tuple) -> SignalTable:
        """The signal table of ``entries`` (grey scalars or curves), cached (its copies with
        each frame's maps share the engines' packed forms)."""
        key = tuple(id(e) if is_spectrum(e) else float(e) for e in entries)
        table = self._signal_tables.get(key)
        if table is None and len(self._signal_tables) >= _CACHED_TABLES:
            self._signal_tables.pop(next(iter(self._signal_tables)))  # the oldest: bounded
        if table is None:
            tables, exact, grey = [], [], []
            for value in entries:
                curve = value if is_spectrum(value) else None
                tables.append(self.table(curve if curve is not None else 1.0))
                exact.append(dict(band=self.band, quantity="photon",
                                  responsivity=self.responsivity,
                                  emissivity=1.0 if curve is None else curve))
                grey.append(1.0 if curve is not None else float(value))
            table = self._signal_tables[key] = SignalTable(tables, exact, entry_grey=grey)
        return table

    def signal_table(self, frame: SceneFrame) -> SignalTable:
        if frame.regions is not None:
            codes = sorted(frame.region_emissivity)
            if codes != list(range(len(codes))) or len(codes) > 255:
                raise RadiosimError(f"region codes must be 0, 1, … (fewer than 256), got {codes}")
            table = self._entries_table(tuple(frame.region_emissivity[c] for c in codes))
            return table.with_maps(grey=1.0, index=frame.regions.astype(np.uint8, copy=False))
        emissivity = frame.emissivity
        if isinstance(emissivity, np.ndarray):
            return self._entries_table((1.0,)).with_maps(grey=emissivity, index=None)
        return self._entries_table((emissivity,)).with_maps(grey=1.0, index=None)

    def temperature(self, signal, emissivity: float = 1.0) -> np.ndarray:
        """Temperature [K] of a grey emitter of ``emissivity`` with this signal (NaN outside
        the table)."""
        if not 0 < emissivity <= 1:
            raise RadiosimError(f"assumed emissivity must be in (0, 1], got {emissivity!r}")
        return self.table().temperature(np.asarray(signal, dtype=float) / emissivity)

    def rate_per_signal(self, etendue: float) -> float:
        """The étendue [m² sr]: radiance × étendue is the photon rate, and the quantum
        efficiency is part of the spectral responsivity."""
        return float(etendue)


class MakerCurveResponse(Response):
    """
    A camera maker's calibration curve (FLIR's; the Sakuma–Hattori form): a blackbody at T
    gives R1 / (R2 (exp(B/T) − F)) counts above the offset −O in the curve's integration time
    t_c [s], linear in radiance, so a pixel that sees several temperatures averages their
    curve values (not their temperatures). The signal is that rate, ε · R1 / (R2 (exp(B/T) −
    F)) / t_c [DN s⁻¹] (reflections add (1 − ε) times the reflected temperature's), and
    1/gain electrons are one DN: the camera's counts are the curve's at t_c, and scale with
    the integration time.

    Parameters
    ----------
    curve
        (R1, R2, B, F) as the camera's files state them (B [K]).
    curve_time
        t_c, the integration time the curve holds at [s].
    gain
        The camera's system gain [DN/e⁻].

    Examples
    --------
    >>> r = MakerCurveResponse((21106.77, 0.012545, 1501.0, 1.0), 1e-3, 1.0)
    >>> round(float(r.temperature(r.grey_signal(310.0))), 9)
    310.0
    """

    name = "maker-curve"
    unit = "DN s⁻¹"
    radiometric = True

    def __init__(self, curve, curve_time: float, gain: float):
        values = tuple(float(v) for v in curve)
        if len(values) != 4 or not all(math.isfinite(v) for v in values) or min(
                values[0], values[1], values[2]) <= 0:
            raise RadiosimError(f"a maker curve is (R1, R2, B, F) with R1, R2, B > 0, got "
                                f"{curve!r}")
        self.r1, self.r2, self.b, self.f = values
        self.curve_time = check_positive(curve_time, "maker_curve_time", "s")
        self.gain = check_positive(gain, "gain", "DN/e⁻")

    @classmethod
    def for_camera(cls, camera) -> MakerCurveResponse:
        """The camera's ``maker_curve`` (R1, R2, B, F, O: O is the electronics' offset),
        ``maker_curve_time`` and gain."""
        if camera.maker_curve is None or camera.maker_curve_time is None:
            raise RadiosimError(f"{camera.name}: response 'maker-curve' needs maker_curve "
                                "(R1, R2, B, F, O) and maker_curve_time [s] (Camera."
                                "from_recording sets them from a FLIR file)")
        return cls(camera.maker_curve[:4], camera.maker_curve_time, camera.electronics.gain)

    def _curve(self, temperature) -> np.ndarray:
        t = np.asarray(temperature, dtype=float)
        return self.r1 / (self.r2 * (np.exp(self.b / t) - self.f)) / self.curve_time

    def _emissivity(self, frame: SceneFrame):
        emissivity = frame.emissivity
        if is_spectrum(emissivity) or (frame.regions is not None and any(
                is_spectrum(v) for v in frame.region_emissivity.values())):
            raise RadiosimError("a maker's calibration curve has no spectrum: a spectral "
                                "emissivity needs response 'planck'")
        if frame.regions is None:
            return emissivity
        out = np.zeros(frame.regions.shape)
        for code, value in frame.region_emissivity.items():
            out[frame.regions == code] = value
        return out

    def signal(self, frame: SceneFrame) -> np.ndarray:
        """ε·C(T) + (1 − ε)·C(T_refl) of each sample [DN s⁻¹], C the curve over t_c."""
        e = self._emissivity(frame)
        out = e * self._curve(frame.temperature)
        if frame.reflected_temperature is not None:
            out = out + (1 - e) * self._curve(frame.reflected_temperature)
        return np.broadcast_to(out, np.shape(frame.temperature)).astype(float)

    def grey_signal(self, temperature, emissivity: float = 1.0) -> np.ndarray:
        return emissivity * self._curve(temperature)

    def temperature(self, signal, emissivity: float = 1.0) -> np.ndarray:
        """B / ln(R1 / (R2 S t_c / ε) + F) [K]; NaN where the signal has none."""
        if not 0 < emissivity <= 1:
            raise RadiosimError(f"assumed emissivity must be in (0, 1], got {emissivity!r}")
        s = np.asarray(signal, dtype=float) * self.curve_time / emissivity
        with np.errstate(divide="ignore", invalid="ignore"):
            t = self.b / np.log(self.r1 / (self.r2 * s) + self.f)
        return np.where(np.isfinite(t) & (t > 0), t, np.nan)

    def rate_per_signal(self, etendue: float) -> float:
        """1/gain [e⁻ per DN]: the curve already holds the camera's optics and detector."""
        return 1.0 / self.gain


#: Response models by name: a camera's ``response`` picks one, which builds itself for the
#: camera (:meth:`Response.for_camera`). A new response is one class registered here.
RESPONSES: dict[str, type[Response]] = {"linear": LinearResponse, "planck": PlanckResponse,
                                        "maker-curve": MakerCurveResponse}
