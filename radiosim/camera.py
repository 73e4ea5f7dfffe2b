"""
The camera: optics, focal-plane array, electronics and response, and the measurement chain
that runs a scene through them.

``Camera.measure`` is a thin orchestrator over one module per stage, in physical order:

1. integrator (:mod:`radiosim.integrator`): tensor statistics and mean response signal per
   pixel over its active footprint × integration window;
2. response (:mod:`radiosim.response`): signal per sample, and its conversion to an electron
   rate (étendue for the Planck response);
3. electronics (:mod:`radiosim.electronics`): dark charge, shot and read noise, full well, ADC;
4. calibration (:mod:`radiosim.calibration`): DN → apparent temperature, flags.

Presets are TOML files in ``radiosim/presets``; lengths there are in µm and every key carries
its unit (``pixel_pitch_um``), converted once to SI on loading.
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path

import numpy as np
from colour import SpectralDistribution

from radiosim.calibration import Calibration
from radiosim.electronics import Electronics, etendue
from radiosim.errors import RadiosimError, RadiosimWarning
from radiosim.integrator import FootprintIntegrator, integrate
from radiosim.measurement import Measurement
from radiosim.response import LinearResponse, PlanckResponse
from radiosim.scenes.base import Scene, check_positive
from radiosim.spectral import as_spectrum, available_spectra, read_spectrum, spectral_distribution
from radiosim.tomlio import build_from_toml, dumps_toml
from radiosim.units import shift

__all__ = ["Optics", "FocalPlaneArray", "Camera", "available_presets", "PRESET_DIRECTORY"]

#: Folder of the shipped camera presets.
PRESET_DIRECTORY = Path(__file__).resolve().parent / "presets"

_UNBOUNDED = 2**31 - 1


def _curve(value, what):
    return as_spectrum(value, what)


@dataclass(frozen=True, eq=False)
class Optics:
    """
    Lens, filter and spectral band.

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
    """

    band: tuple[float, float] = (3.8e-6, 5.1e-6)
    f_number: float = 2.5
    transmission: float | SpectralDistribution = 1.0
    spectral_filter: float | SpectralDistribution = 1.0

    def __post_init__(self):
        lo, hi = (float(b) for b in self.band)
        if not 0 < lo < hi <= 1e-3:
            raise RadiosimError(f"band must be (λ1, λ2) in metres with 0 < λ1 < λ2, got {self.band}")
        object.__setattr__(self, "band", (lo, hi))
        object.__setattr__(self, "f_number", check_positive(self.f_number, "f_number", "1"))
        object.__setattr__(self, "transmission", _curve(self.transmission, "optics transmission"))
        object.__setattr__(self, "spectral_filter", _curve(self.spectral_filter, "spectral filter"))


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
    """

    pixel_pitch: float
    shape: tuple[int, int] | None = None
    fill_factor: float = 1.0
    detector_pitch: float | None = None
    quantum_efficiency: float | SpectralDistribution = 1.0
    origin: tuple[float, float] = (0.0, 0.0)

    def __post_init__(self):
        object.__setattr__(self, "pixel_pitch", check_positive(self.pixel_pitch, "pixel_pitch", "m"))
        if self.shape is not None:
            rows, cols = (int(v) for v in self.shape)
            if rows < 1 or cols < 1:
                raise RadiosimError(f"array shape must be (rows ≥ 1, columns ≥ 1), got {self.shape}")
            object.__setattr__(self, "shape", (rows, cols))
        if not 0 < self.fill_factor <= 1:
            raise RadiosimError(f"fill_factor must be in (0, 1], got {self.fill_factor!r}")
        if self.detector_pitch is not None:
            object.__setattr__(self, "detector_pitch",
                               check_positive(self.detector_pitch, "detector_pitch", "m"))
        object.__setattr__(self, "quantum_efficiency",
                           _curve(self.quantum_efficiency, "quantum efficiency"))
        y, x = (float(v) for v in self.origin)
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


@dataclass(frozen=True, eq=False)
class Camera:
    """
    An infrared camera: optics, focal-plane array, electronics and response model.

    Attributes
    ----------
    fpa : FocalPlaneArray
        Detector geometry and quantum efficiency.
    optics : Optics
        Band, f-number, optics and filter transmission.
    electronics : Electronics
        Dark current, noise, full well, gain, offset, ADC.
    response : str
        ``"planck"`` (in-band photon radiance) or ``"linear"`` (signal = T, the paper's ideal
        camera).
    name : str
        Preset or user name.
    frame_rate : float or None
        Frame rate [Hz]; the integration time may not exceed the frame period.
    assumed_emissivity : float
        The camera's emissivity setting, used by its calibration (dimensionless).
    linear_responsivity : float
        Electron rate per kelvin of the linear response [e⁻ s⁻¹ K⁻¹].
    calibration_range : tuple of float
        Temperatures the Planck calibration covers [K].

    Examples
    --------
    >>> from radiosim.scenes import UniformBlackbody
    >>> camera = Camera.linear_ideal(pixel_pitch=3e-6)
    >>> m = camera.measure(UniformBlackbody(900.0, shape=(9, 12), dx=1e-6, dt=1e-6), 5e-6)
    >>> m.shape, float(m.apparent_temperature.mean()), float(m.peak_error.max())
    ((3, 4), 900.0, 0.0)
    """

    fpa: FocalPlaneArray
    optics: Optics = field(default_factory=Optics)
    electronics: Electronics = field(default_factory=Electronics.ideal)
    response: str = "planck"
    name: str = "custom"
    frame_rate: float | None = None
    assumed_emissivity: float = 1.0
    linear_responsivity: float = 1e6
    calibration_range: tuple[float, float] = (150.0, 3000.0)

    def __post_init__(self):
        if self.response not in ("linear", "planck"):
            raise RadiosimError(f"response must be 'linear' or 'planck', got {self.response!r}")
        if self.frame_rate is not None:
            object.__setattr__(self, "frame_rate",
                               check_positive(self.frame_rate, "frame_rate", "Hz"))
        if not 0 < self.assumed_emissivity <= 1:
            raise RadiosimError(
                f"assumed_emissivity must be in (0, 1], got {self.assumed_emissivity!r}"
            )

    # -- construction -------------------------------------------------------------------------

    @classmethod
    def linear_ideal(cls, pixel_pitch: float, shape=None, fill_factor: float = 1.0) -> Camera:
        """
        The paper's ideal camera: linear response, no noise, no saturation, no quantisation.

        Each pixel reads the mean temperature of its footprint × window exactly.

        Parameters
        ----------
        pixel_pitch
            Pixel pitch in object space [m].
        shape
            Array (rows, columns); ``None``: as many pixels as the scene holds.
        fill_factor
            Active area fraction (1 in the paper).
        """
        return cls(
            fpa=FocalPlaneArray(pixel_pitch=pixel_pitch, shape=shape, fill_factor=fill_factor),
            electronics=Electronics.ideal(),
            response="linear",
            name="linear-ideal",
        )

    @classmethod
    def preset(cls, name: str) -> Camera:
        """
        A camera from a shipped TOML preset (see :func:`available_presets`).

        Examples
        --------
        >>> cam = Camera.preset("nist-ir")
        >>> cam.fpa.shape, round(cam.fpa.pixel_pitch * 1e6, 3), cam.electronics.adc_bits
        ((120, 160), 6.0, 14)
        """
        path = PRESET_DIRECTORY / f"{name}.toml"
        if not path.is_file():
            raise RadiosimError(
                f"unknown camera preset {name!r}; available: {', '.join(available_presets())}"
            )
        return cls.from_toml(path)

    @classmethod
    def from_toml(cls, path) -> Camera:
        """
        A camera from a TOML file (the preset format: units in the keys, µm for lengths).

        Spectral curves are given as shipped names, CSV paths (relative to the file) or numbers.
        """
        return build_from_toml(path, "camera file", lambda data, base: cls.from_dict(data, base=base))

    @classmethod
    def from_dict(cls, data: dict, base: Path | None = None) -> Camera:
        """A camera from the preset structure (a dict as parsed from TOML)."""
        data = dict(data)
        sections = {key: dict(data.pop(key, {})) for key in ("optics", "fpa", "electronics")}

        def take(section: dict, key: str, default=None, exponent=None):
            """A value converted to SI by the power of ten ``exponent`` (−6 for µm)."""
            value = section.pop(key, default)
            if value is None or exponent is None:
                return value
            try:
                if isinstance(value, list):
                    return tuple(shift(v, exponent) for v in value)
                return shift(value, exponent)
            except (TypeError, ValueError):
                raise RadiosimError(f"{key} must be a number or a list of numbers, got "
                                    f"{value!r}") from None

        def curve(section: dict, key: str):
            value = section.pop(key, 1.0)
            if isinstance(value, str) and base is not None and (base / value).is_file():
                return base / value
            if isinstance(value, dict):  # inline: {name, wavelength_um = [...], value = [...]}
                try:
                    return spectral_distribution(np.asarray(value["wavelength_um"]) * 1e-6,
                                                 value["value"], value.get("name", key))
                except KeyError as exc:
                    raise RadiosimError(f"inline curve {key} needs wavelength_um and value "
                                        f"lists, missing {exc}") from None
            return value

        um = -6
        optics = Optics(
            band=take(sections["optics"], "band_um", [3.8, 5.1], um),
            f_number=take(sections["optics"], "f_number", 2.5),
            transmission=curve(sections["optics"], "transmission"),
            spectral_filter=curve(sections["optics"], "spectral_filter"),
        )
        fpa_data = sections["fpa"]
        if "pixel_pitch_um" not in fpa_data:
            raise RadiosimError("[fpa] needs pixel_pitch_um (object-space pixel pitch in µm)")
        shape = fpa_data.pop("shape", None)
        fpa = FocalPlaneArray(
            pixel_pitch=take(fpa_data, "pixel_pitch_um", exponent=um),
            shape=None if shape is None else tuple(shape),
            fill_factor=take(fpa_data, "fill_factor", 1.0),
            detector_pitch=take(fpa_data, "detector_pitch_um", exponent=um),
            quantum_efficiency=curve(fpa_data, "quantum_efficiency"),
            origin=take(fpa_data, "origin_um", [0.0, 0.0], um),
        )
        el = sections["electronics"]
        bits = el.pop("adc_bits", None)
        electronics = Electronics(
            full_well=take(el, "full_well_e"),
            dark_current=take(el, "dark_current_e_per_s", 0.0),
            read_noise=take(el, "read_noise_e", 0.0),
            shot_noise=bool(el.pop("shot_noise", True)),
            gain=take(el, "gain_dn_per_e", 1.0),
            offset=take(el, "offset_dn", 0.0),
            adc_bits=None if bits is None else int(bits),
        )
        camera = cls(
            fpa=fpa,
            optics=optics,
            electronics=electronics,
            response=data.pop("response", "planck"),
            name=data.pop("name", "custom"),
            frame_rate=take(data, "frame_rate_hz"),
            assumed_emissivity=take(data, "assumed_emissivity", 1.0),
            linear_responsivity=take(data, "linear_responsivity_e_per_s_per_K", 1e6),
            calibration_range=take(data, "calibration_range_K", [150.0, 3000.0], 0),
        )
        data.pop("description", None)
        leftovers = [k for k in data] + [
            f"[{name}] {k}" for name, section in sections.items() for k in section
        ]
        if leftovers:
            raise RadiosimError(f"unknown camera key(s): {', '.join(leftovers)}")
        return camera

    def to_dict(self) -> dict:
        """
        The camera in the preset structure (edge units in the keys), so that
        :meth:`from_dict` rebuilds it exactly. Shipped curves are named; others are inlined.
        """
        el, fpa, optics = self.electronics, self.fpa, self.optics

        def um(value):  # [m] → [µm], exact on the decimal representation
            return shift(value, 6)

        fpa_out = {"pixel_pitch_um": um(fpa.pixel_pitch), "fill_factor": fpa.fill_factor,
                   "quantum_efficiency": _curve_entry(fpa.quantum_efficiency),
                   "origin_um": [um(fpa.origin[0]), um(fpa.origin[1])]}
        if fpa.shape is not None:
            fpa_out["shape"] = list(fpa.shape)
        if fpa.detector_pitch is not None:
            fpa_out["detector_pitch_um"] = um(fpa.detector_pitch)
        electronics = {"dark_current_e_per_s": el.dark_current, "read_noise_e": el.read_noise,
                       "shot_noise": el.shot_noise, "gain_dn_per_e": el.gain,
                       "offset_dn": el.offset}
        if el.full_well is not None:
            electronics["full_well_e"] = el.full_well
        if el.adc_bits is not None:
            electronics["adc_bits"] = el.adc_bits
        out = {"name": self.name, "response": self.response,
               "assumed_emissivity": self.assumed_emissivity,
               "linear_responsivity_e_per_s_per_K": self.linear_responsivity,
               "calibration_range_K": list(self.calibration_range)}
        if self.frame_rate is not None:
            out["frame_rate_hz"] = self.frame_rate
        out["optics"] = {"band_um": [um(b) for b in optics.band], "f_number": optics.f_number,
                         "transmission": _curve_entry(optics.transmission),
                         "spectral_filter": _curve_entry(optics.spectral_filter)}
        out["fpa"] = fpa_out
        out["electronics"] = electronics
        return out

    def to_toml(self) -> str:
        """The camera as a TOML preset (see :meth:`to_dict`)."""
        return dumps_toml(self.to_dict(), tables=("optics", "fpa", "electronics"))

    def replace(self, **changes) -> Camera:
        """A copy with some fields changed (``dataclasses.replace``)."""
        return dataclasses.replace(self, **changes)

    def with_pixel_pitch(self, pixel_pitch: float) -> Camera:
        """
        The same camera with object-space pixels of ``pixel_pitch`` [m] and the same
        magnification: its detector pixels scale with them, as in the paper's sensor-area sweep.
        """
        fpa = self.fpa
        detector = None if fpa.detector_pitch is None else (
            fpa.detector_pitch * pixel_pitch / fpa.pixel_pitch)
        return self.replace(fpa=dataclasses.replace(fpa, pixel_pitch=pixel_pitch,
                                                    detector_pitch=detector))

    # -- the chain ----------------------------------------------------------------------------

    @property
    def responsivity(self) -> list:
        """The spectral factors of the Planck response: filter, optics, quantum efficiency."""
        return [self.optics.spectral_filter, self.optics.transmission,
                self.fpa.quantum_efficiency]

    @property
    def etendue(self) -> float:
        """Étendue of one pixel's active area [m² sr]."""
        return etendue(self.fpa.active_area, self.optics.f_number)

    @cached_property
    def response_model(self) -> LinearResponse | PlanckResponse:
        """The response model (built once per camera; the Planck one tabulates radiance)."""
        if self.response == "linear":
            return LinearResponse(self.linear_responsivity)
        return PlanckResponse(self.optics.band, self.responsivity, self.etendue,
                              self.calibration_range)

    def calibration(self, integration_time: float) -> Calibration:
        """The camera's DN → temperature calibration for ``integration_time`` [s]."""
        return Calibration(self, integration_time)

    def integrator(self, scene: Scene) -> FootprintIntegrator:
        """The footprints of this camera's pixels on ``scene``."""
        shape = self.fpa.shape or (_UNBOUNDED, _UNBOUNDED)
        return FootprintIntegrator.for_scene(scene, self.fpa.pixel_pitch, self.fpa.fill_factor,
                                             shape, self.fpa.origin)

    def measure(self, scene: Scene, integration_time: float, t_start: float | None = None,
                rng=None) -> Measurement:
        """
        Measure ``scene`` over one integration.

        Parameters
        ----------
        scene
            The scene (:class:`~radiosim.scenes.Scene`).
        integration_time
            Integration time [s].
        t_start
            Start of the window [s]; ``None``: centred on ``scene.event_time`` if the scene
            has one, else starting at t = 0.
        rng
            Seed or :class:`numpy.random.Generator` for shot and read noise.

        Returns
        -------
        Measurement
        """
        t_int = check_positive(integration_time, "integration_time", "s")
        if self.frame_rate is not None and t_int > 1.0 / self.frame_rate * (1 + 1e-12):
            raise RadiosimError(
                f"integration time {t_int:g} s exceeds the frame period {1 / self.frame_rate:g} s "
                f"of {self.name} at {self.frame_rate:g} Hz"
            )
        if t_start is None:
            t_start = 0.0 if scene.event_time is None else scene.event_time - 0.5 * t_int
            if t_start < 0:
                raise RadiosimError(
                    f"a {t_int:g} s window centred on the scene's event at {scene.event_time:g} s "
                    "would start before the first frame; give t_start"
                )
        integrator = self.integrator(scene)
        response = self.response_model
        signal = None
        if isinstance(response, PlanckResponse):
            signal = self._signal_function(scene, integrator, response)

        # Tensor statistics [K] and mean signal [response unit] over footprint × window.
        stats = integrate(scene, integrator, float(t_start), t_int, signal)
        # Mean photo-electrons [e⁻] = signal × conversion [e⁻ s⁻¹ per unit] × time [s].
        photoelectrons = stats.signal_mean * response.conversion * t_int
        # Dark charge, noise, full well, ADC → electrons [e⁻] and counts [DN].
        exposure = self.electronics.expose(photoelectrons, t_int, rng)
        # Calibration: counts [DN] → apparent temperature [K].
        apparent, below, above = self.calibration(t_int).invert(exposure.counts)
        high = exposure.saturated | above
        low = ~high & (exposure.adc_floor | below)
        apparent = np.where(high | low, np.nan, apparent)
        if high.any():
            warnings.warn(
                f"{self.name}: {int(high.sum())} of {high.size} pixels saturated at "
                f"{t_int:g} s integration; their apparent temperature is NaN",
                RadiosimWarning, stacklevel=2,
            )
        return Measurement(
            apparent_temperature=apparent,
            counts=exposure.counts,
            electrons=exposure.electrons,
            saturated=high,
            under_range=low,
            tensor_max=stats.max,
            tensor_mean=stats.mean,
            tensor_std=stats.std,
            signal_mean=stats.signal_mean,
            signal_unit=response.unit,
            camera=self,
            integration_time=t_int,
            t_start=float(t_start),
            n_frames=stats.n_frames,
            scene=scene.describe(),
        )

    @staticmethod
    def _signal_function(scene, integrator, response):
        """The per-piece signal of frame k: T [K] → ε·L_q(T) [photons s⁻¹ m⁻² sr⁻¹], with the
        scene's emissivity (uniform, a grey map, or per region and frame)."""
        emissivity = scene.emissivity
        if isinstance(emissivity, np.ndarray):
            emissivity = integrator.expand(emissivity[integrator.region])

        def signal(t_pieces, k):
            by_region = scene.emissivity_map(k, integrator.region)
            if by_region is None:
                return response.signal(t_pieces, emissivity)
            codes, values = by_region
            codes = integrator.expand(codes)
            out = np.empty_like(t_pieces)
            for code, value in values.items():
                here = codes == code
                if here.any():
                    out[here] = response.signal(t_pieces[here], value)
            return out

        return signal

    def record(self, scene: Scene, integration_time: float, n_frames: int,
               t_start: float | None = None, rng=None) -> list[Measurement]:
        """
        Record ``n_frames`` camera frames at the camera's frame rate.

        Frame i integrates over [t_start + i/frame_rate, … + integration_time]; ``t_start``
        defaults to the start that centres the first frame's window on the scene's event.
        One generator drives the noise of all frames.
        """
        if self.frame_rate is None:
            raise RadiosimError(f"{self.name} has no frame rate; set frame_rate to record")
        if int(n_frames) != n_frames or n_frames < 1:
            raise RadiosimError(f"n_frames must be a whole number ≥ 1, got {n_frames!r}")
        rng = np.random.default_rng(rng)
        if t_start is None:
            t_start = 0.0 if scene.event_time is None else scene.event_time - 0.5 * float(
                integration_time)
        period = 1.0 / self.frame_rate
        return [self.measure(scene, integration_time, t_start + i * period, rng)
                for i in range(int(n_frames))]


def _curve_entry(value):
    """A curve as a shipped name (if it is one, unchanged) or an inline table."""
    if not isinstance(value, SpectralDistribution):
        return float(value)
    name = value.name
    if name in available_spectra():
        shipped = read_spectrum(name)
        if np.array_equal(shipped.domain, value.domain) and np.array_equal(shipped.values,
                                                                           value.values):
            return name
    return {"name": name, "wavelength_um": (np.asarray(value.domain) * 1e6).tolist(),
            "value": np.asarray(value.values).tolist()}


def available_presets() -> tuple[str, ...]:
    """
    Names of the shipped camera presets.

    Examples
    --------
    >>> "nist-ir" in available_presets()
    True
    """
    return tuple(sorted(p.stem for p in PRESET_DIRECTORY.glob("*.toml")))
