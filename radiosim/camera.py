"""
The camera, and the measurement chain that runs a scene through it.

:meth:`Camera.measure` is a short list of stage calls in physical order, one module per stage:

1. scene (:mod:`radiosim.scenes`): temperature and emissivity of every sample, frame by frame;
2. response (:mod:`radiosim.response`): the signal of every sample;
3. integrator (:mod:`radiosim.integrator`): its mean over each pixel's footprint × window, with
   the scene-truth statistics of the same tensor;
   — or, with a point-spread function, reflections or a path, the image the optics form
   (:mod:`radiosim.imaging`: per-sample radiance per sub-band, the thermography equation's
   terms, the PSF, then the footprint mean), the statistics staying scene truth;
4. optics (:mod:`radiosim.optics`): mean signal, plus the optics' own emission → photo-electrons
   through the étendue;
5. electronics (:mod:`radiosim.electronics`): dark charge, shot and read noise, full well, ADC;
6. calibration (:mod:`radiosim.calibration`): DN → apparent temperature and flags;
7. :class:`~radiosim.measurement.Measurement`.

Stages 2–3 and 4–7 are :func:`radiosim.acquisition.tensor_statistics` and
:func:`radiosim.acquisition.read_out`, shared with :func:`~radiosim.acquisition.measure_many`
(several measurements of one scene in one pass). The camera stays thin: how it takes frames in
time (recording, superframing, its frame period) is in :mod:`radiosim.acquisition`, the
laboratory procedures (flat fields, NUC and calibration fits, NETD, measurable range) in
:mod:`radiosim.characterization`, all functions taking the camera first. Camera files (TOML) are
read and written by :mod:`radiosim.presets`.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path

import numpy as np

from radiosim.acquisition import (ChannelStatistics, Exposure, ReadOut, check_frame_period,
                                  check_readout_fits, instrument_signal, is_rolling,
                                  measure_many, measure_many_statistics, read_out,
                                  split_statistics)
from radiosim.calibration import Calibration, NonUniformityCorrection
from radiosim.checks import check_fraction, check_positive, check_rng, check_time
from radiosim.config import build_checked, build_from_toml, dumps_toml, edge_field
from radiosim.electronics import Electronics
from radiosim.errors import RadiosimError
from radiosim.fpa import FocalPlaneArray
from radiosim.imaging import forms_image, image_signal
from radiosim.integrator import FootprintIntegrator, Window, integration_window
from radiosim.measurement import Measurement
from radiosim.optics import Optics
from radiosim.presets import PRESET_DIRECTORY, available_presets, camera_fields, camera_table
from radiosim.radiometry import CALIBRATION_RANGE
from radiosim.ratio import Channel, channel_cameras, combine
from radiosim.response import RESPONSES, Response
from radiosim.scenes.base import Scene

__all__ = ["Optics", "FocalPlaneArray", "Camera", "Channel", "measure_many",
           "measure_many_statistics", "available_presets", "PRESET_DIRECTORY"]


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
        The response model's name in :data:`radiosim.response.RESPONSES`: ``"planck"``
        (in-band photon radiance) or ``"linear"`` (signal = T, the paper's ideal camera).
    name : str
        Preset or user name.
    frame_rate : float or None
        Frame rate [Hz]; the integration time may not exceed the frame period.
    assumed_emissivity : float
        The camera's emissivity setting, used by its calibration (dimensionless).
    linear_responsivity : float
        Electron rate per kelvin of the linear response [e⁻ s⁻¹ K⁻¹].
    calibration_range : tuple of float
        Temperatures the calibration covers [K].
    assumed_reflected_temperature : float or None
        The camera's reflected-temperature setting [K]; ``None``: nothing reflected.
    assumed_path_transmission, assumed_path_temperature : float, float or None
        The camera's setting for the path between scene and camera: transmission [1] and
        temperature [K].
    assumed_instrument_temperature : float or None
        The instrument temperature [K] the calibration was made at (the optics' emission it
        subtracts); ``None``: the optics' current ``instrument_temperature``.
    calibration_scale : float
        The calibration's error of radiometric scale: it believes each unit of signal gives
        ``calibration_scale`` times the electrons it truly does (1: exact; an uncertainty input).
    detection_sigma : float
        k of the detection limit [1]: a pixel is reported only where its counts exceed the
        blank reading (dark and assumed background) by k times that reading's temporal noise;
        others are flagged under range (3: IUPAC's convention; see
        :mod:`radiosim.calibration`).
    nuc : NonUniformityCorrection or None
        The non-uniformity correction applied to counts before the calibration (measured:
        :func:`radiosim.characterization.fit_nuc`; not part of the camera file).
    assumed_emissivity_ratio : float
        The camera's setting of ε₁/ε₂, the emissivity ratio of its first two channels that
        the ratio temperature assumes (1: a grey body; :mod:`radiosim.ratio`).
    ratio_noise_limit : float or None
        The largest noise (NETD of the ratio at the measured signals) [K] of a reported ratio
        temperature: weaker pixels are flagged under range, as ratio pyrometers report only
        above a minimum signal; ``None``: every pixel both channels read.
    channels : tuple of Channel or None
        Spectral channels (:meth:`with_channels`; ``[[channels]]`` tables in a camera
        file): measuring measures each with its own band and reports the ratio temperature
        of the first two; ``None``: a single-channel camera.

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
    response: str = edge_field("planck", "response", kind="str",
                               doc="'planck', 'linear' or 'maker-curve'")
    name: str = edge_field("custom", "name", kind="str", doc="camera name")
    frame_rate: float | None = edge_field(None, "frame_rate_hz", doc="frame rate [Hz]")
    assumed_emissivity: float = edge_field(1.0, "assumed_emissivity",
                                           doc="emissivity setting of the calibration")
    linear_responsivity: float = edge_field(1e6, "linear_responsivity_e_per_s_per_K",
                                            doc="electron rate per kelvin of the linear response")
    calibration_range: tuple[float, float] = edge_field(
        CALIBRATION_RANGE, "calibration_range_K", kind="numbers",
        doc="temperatures the calibration covers [K]")
    assumed_reflected_temperature: float | None = edge_field(
        None, "assumed_reflected_temperature_K", doc="reflected-temperature setting [K]")
    assumed_path_transmission: float = edge_field(1.0, "assumed_path_transmission",
                                                  doc="path transmission setting")
    assumed_path_temperature: float | None = edge_field(
        None, "assumed_path_temperature_K", doc="path temperature setting [K]")
    assumed_instrument_temperature: float | None = edge_field(
        None, "assumed_instrument_temperature_K",
        doc="instrument temperature of the calibration [K]")
    calibration_scale: float = edge_field(1.0, "calibration_scale",
                                          doc="the calibration's error of radiometric scale")
    detection_sigma: float = edge_field(3.0, "detection_sigma",
                                        doc="k of the detection limit, blank + k σ [1]")
    nuc: NonUniformityCorrection | None = None
    assumed_emissivity_ratio: float = edge_field(
        1.0, "assumed_emissivity_ratio", doc="ε₁/ε₂ of the channels the ratio assumes")
    ratio_noise_limit: float | None = edge_field(
        None, "ratio_noise_limit_K", doc="largest noise of a reported ratio temperature [K]")
    channels: tuple[Channel, ...] | None = None
    maker_curve: tuple[float, ...] | None = edge_field(
        None, "maker_curve_R1_R2_B_F_O", kind="numbers",
        doc="the maker's calibration curve (R1, R2, B [K], F, O [DN]) of response 'maker-curve'")
    maker_curve_time: float | None = edge_field(
        None, "maker_curve_time_us", 1e-6, doc="the integration time the maker curve holds at")

    def __post_init__(self):
        if self.response not in RESPONSES:
            raise RadiosimError(f"response must be one of {', '.join(map(repr, RESPONSES))}, "
                                f"got {self.response!r}")
        if self.frame_rate is not None:
            object.__setattr__(self, "frame_rate",
                               check_positive(self.frame_rate, "frame_rate", "Hz"))
        object.__setattr__(self, "assumed_emissivity",
                           check_fraction(self.assumed_emissivity, "assumed_emissivity"))
        span = tuple(self.calibration_range) if isinstance(self.calibration_range,
                                                           (tuple, list)) else ()
        if len(span) != 2 or not all(isinstance(t, (int, float, np.integer, np.floating))
                                     and not isinstance(t, bool) for t in span) or not (
                0 < span[0] < span[1] < math.inf):
            raise RadiosimError(f"calibration_range must be (T_min, T_max) with 0 < T_min < "
                                f"T_max [K], got {self.calibration_range!r}")
        object.__setattr__(self, "calibration_range", tuple(float(t) for t in span))
        for name in ("assumed_reflected_temperature", "assumed_path_temperature",
                     "assumed_instrument_temperature"):
            if getattr(self, name) is not None:
                object.__setattr__(self, name, check_positive(getattr(self, name), name, "K"))
        tau = check_fraction(self.assumed_path_transmission, "assumed_path_transmission")
        if tau == 0 or (tau < 1 and self.assumed_path_temperature is None):
            raise RadiosimError(f"assumed_path_transmission must be in (0, 1], and below 1 needs "
                                f"assumed_path_temperature [K]; got {tau!r}")
        object.__setattr__(self, "assumed_path_transmission", tau)
        object.__setattr__(self, "calibration_scale",
                           check_positive(self.calibration_scale, "calibration_scale", "1"))
        if isinstance(self.detection_sigma, bool):
            raise RadiosimError(f"detection_sigma must be a number > 0 [1], got "
                                f"{self.detection_sigma!r}")
        object.__setattr__(self, "detection_sigma",
                           check_positive(self.detection_sigma, "detection_sigma", "1"))
        if isinstance(self.assumed_emissivity_ratio, bool):
            raise RadiosimError(f"assumed_emissivity_ratio must be a number > 0 [1], got "
                                f"{self.assumed_emissivity_ratio!r}")
        object.__setattr__(self, "assumed_emissivity_ratio", check_positive(
            self.assumed_emissivity_ratio, "assumed_emissivity_ratio", "1"))
        if self.ratio_noise_limit is not None:
            object.__setattr__(self, "ratio_noise_limit", check_positive(
                self.ratio_noise_limit, "ratio_noise_limit", "K"))
        if self.channels is not None:
            object.__setattr__(self, "channels", check_channels(self.channels, self.response))
        if self.maker_curve is not None:
            curve = tuple(float(v) for v in self.maker_curve)
            if len(curve) != 5 or not all(math.isfinite(v) for v in curve):
                raise RadiosimError(f"maker_curve must be (R1, R2, B, F, O), five finite "
                                    f"numbers, got {self.maker_curve!r}")
            object.__setattr__(self, "maker_curve", curve)
        if self.maker_curve_time is not None:
            object.__setattr__(self, "maker_curve_time", check_positive(
                self.maker_curve_time, "maker_curve_time", "s"))
        check_readout_fits(self)

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
    def from_recording(cls, recording, distance: float | None = None) -> Camera:
        """
        The camera that made ``recording`` (a :class:`~radiosim.io.recordings.Recording` with
        its maker's calibration curve, a FLIR file): response ``"maker-curve"`` with the file's
        Planck R1, R2, B, F and O (the offset, at a gain of 1 DN per unit), noise-free
        16-bit electronics, the file's frame rate, and its pixel in object space from the
        horizontal field of view over the object ``distance`` [m] (default the file's):
        2 d tan(FOV/2) / columns. The curve holds at the file's integration time (or, not
        stated, one frame period).
        """
        curve = getattr(recording, "curve", None)
        if curve is None:
            raise RadiosimError(f"{recording.path}: the file holds no maker's calibration "
                                "curve (a FLIR file does); a PTW recording needs a camera of "
                                "its own, fitted to the camera's tables")
        meta = recording.metadata
        fov = float(meta.get("FieldOfView", 0.0))
        d = float(meta.get("object_parameters", {}).get("distance", 0.0)
                  if distance is None else distance)
        if not (0 < fov < 180 and d > 0):
            raise RadiosimError(f"{recording.path}: the pixel in object space needs a field "
                                f"of view in (0, 180)° and an object distance > 0 m; the file "
                                f"gives {fov:g}° and {d:g} m (pass distance=)")
        _, rows, cols = recording.shape
        pitch = 2 * d * math.tan(math.radians(fov) / 2) / cols
        rate = float(meta.get("FrameRate") or 0) or None
        t_curve = recording.integration_time or (1 / rate if rate else None)
        if t_curve is None:
            raise RadiosimError(f"{recording.path}: states neither an integration time nor a "
                                "frame rate; the maker curve's time is unknown")
        electronics = Electronics(full_well=None, dark_current=0.0, read_noise=0.0,
                                  shot_noise=False, gain=1.0, offset=-curve.O, adc_bits=16)
        return cls(fpa=FocalPlaneArray(pixel_pitch=pitch, shape=(rows, cols)),
                   electronics=electronics, response="maker-curve",
                   name=f"{recording.camera_name or 'camera'} ({recording.path.name})",
                   frame_rate=rate, maker_curve=(curve.R1, curve.R2, curve.B, curve.F, curve.O),
                   maker_curve_time=t_curve, calibration_range=(150.0, 2500.0),
                   assumed_reflected_temperature=None)

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
        A camera from a TOML file (the preset format of :mod:`radiosim.presets`: units in the
        keys, µm for lengths). Spectral curves are shipped names, CSV paths (relative to the
        file) or numbers.
        """
        return build_from_toml(path, "camera file", lambda data, base: cls.from_dict(data, base))

    @classmethod
    def from_dict(cls, data: dict, base: Path | None = None) -> Camera:
        """A camera from the preset structure (a dict as parsed from TOML)."""
        return build_checked(cls, camera_fields(cls, data, base), data, "")

    def to_dict(self) -> dict:
        """
        The camera in the preset structure (edge units in the keys), so that
        :meth:`from_dict` rebuilds it exactly. Shipped curves are named; others are inlined.
        """
        return camera_table(self)

    def to_toml(self) -> str:
        """The camera as a TOML preset (see :meth:`to_dict`). Written once per camera (it is
        frozen) and kept: every EXR file and dataset of its measurements carries it."""
        text = self.__dict__.get("_toml")
        if text is None:
            data = self.to_dict()
            channels = data.pop("channels", None)
            text = dumps_toml(data, tables=("optics", "fpa", "electronics"))
            if channels is not None:
                text += "\n" + dumps_toml({"channels": channels})
            self.__dict__["_toml"] = text
        return text

    def __repr__(self) -> str:
        """One line: the name, response, array, band(s), f-number and converter (the whole
        configuration is :meth:`to_toml`)."""
        fpa, optics = self.fpa, self.optics
        array = (f"{fpa.shape[1]} × {fpa.shape[0]} px" if fpa.shape else "any array")
        bands = [c.band for c in self.channels] if self.channels else [optics.band]
        band = " + ".join(f"{lo * 1e6:g}–{hi * 1e6:g} µm" for lo, hi in bands)
        adc = self.electronics.adc_bits
        return (f"Camera({self.name!r}: {self.response}, {array} of {fpa.pixel_pitch * 1e6:g} µm "
                f"in object space, {band}, f/{optics.f_number:g}, "
                f"{'no converter' if adc is None else f'{adc}-bit'})")

    def replace(self, **changes) -> Camera:
        """A copy with some fields changed (``dataclasses.replace``); it keeps this camera's
        response model (and its radiance tables) when the response, band and spectral curves
        are the same. An unknown field is refused, naming the likely one."""
        fields = [f.name for f in dataclasses.fields(self) if f.init]
        unknown = [k for k in changes if k not in fields]
        if unknown:
            from radiosim.config import reject_unknown

            reject_unknown(unknown, fields, "Camera.replace")
        out = dataclasses.replace(self, **changes)
        built = self.__dict__.get("response_model")
        if built is not None and out._response_key() == self._response_key():
            out.__dict__["response_model"] = built
        return out

    def _response_key(self) -> tuple:
        """What the response model depends on (curves by identity: a replaced camera shares
        its components' curve objects)."""
        return (self.response, self.linear_responsivity, self.optics.band,
                *(id(c) if not isinstance(c, float) else c for c in self.responsivity))

    def with_channels(self, bands, slot_time: float = 0.0) -> Camera:
        """
        The same camera with one spectral channel per ``(λ_low, λ_high)`` band [m] of
        ``bands`` (in order), each with this camera's optics, FPA and electronics and its own
        band (:class:`~radiosim.ratio.Channel`). Measuring it measures every channel and reads
        the ratio temperature of the first two (:mod:`radiosim.ratio`).

        ``slot_time`` [s]: 0 (default) for the simultaneous layout (a beam splitter or a
        two-colour detector: every channel over the same window); > 0 for a filter wheel,
        channel k's window starting k·``slot_time`` after the first's.

        Examples
        --------
        >>> cam = Camera.preset("nist-ir").with_channels([(3.8e-6, 4.2e-6), (4.6e-6, 5.1e-6)])
        >>> [tuple(round(b * 1e6, 3) for b in c.band) for c in cam.channels]
        [(3.8, 4.2), (4.6, 5.1)]
        """
        if isinstance(bands, (str, bytes)) or not hasattr(bands, "__len__") or not len(bands):
            raise RadiosimError(f"with_channels needs at least one (λ_low, λ_high) band [m], "
                                f"got {bands!r}")
        slot = check_time(slot_time, "slot_time", positive=False)
        return self.replace(channels=tuple(
            _channel(k, lambda k=k, band=band: Channel(band=band, time_offset=k * slot))
            for k, band in enumerate(bands)))

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

    # -- the stages ---------------------------------------------------------------------------

    @property
    def responsivity(self) -> list:
        """The spectral factors of the Planck response: filter, optics, quantum efficiency."""
        return [*self.optics.responsivity, self.fpa.quantum_efficiency]

    @property
    def etendue(self) -> float:
        """Étendue of one pixel's active area [m² sr]."""
        return self.optics.etendue(self.fpa)

    @cached_property
    def response_model(self) -> Response:
        """The response model (built once per camera; the Planck one tabulates radiance)."""
        return RESPONSES[self.response].for_camera(self)

    @property
    def rate_per_signal(self) -> float:
        """Electron rate per unit of response signal [e⁻ s⁻¹ per signal unit]."""
        return self.response_model.rate_per_signal(self.etendue)

    def calibration(self, integration_time: float) -> Calibration:
        """The camera's DN → temperature calibration for ``integration_time`` [s], under its
        settings (emissivity, reflected temperature, path, instrument temperature). A camera
        is immutable: its last few calibrations are kept, with what they computed once (the
        noise floor), for the next measurements of the same integration time."""
        kept = self.__dict__.setdefault("_calibrations", {})
        key = float(integration_time)
        calibration = kept.get(key)
        if calibration is None:
            calibration = Calibration(
                self.response_model, self.electronics,
                self.rate_per_signal * self.calibration_scale, integration_time,
                assumed_emissivity=self.assumed_emissivity,
                temperature_range=self.calibration_range,
                reflected_temperature=self.assumed_reflected_temperature,
                path_transmission=self.assumed_path_transmission,
                path_temperature=self.assumed_path_temperature,
                background_signal=instrument_signal(self, self.assumed_instrument_temperature),
                detection_sigma=self.detection_sigma)
            if len(kept) >= 16:
                kept.pop(next(iter(kept)))
            kept[key] = calibration
        return calibration

    def forms_image(self, scene: Scene) -> bool:
        """Whether measuring ``scene`` takes the image stage (:mod:`radiosim.imaging`): a
        PSF, or reflections or a path a radiometric response sees."""
        return forms_image(scene, self.response_model, self.optics.psf)

    def image(self, scene: Scene, window: Window, progress=None):
        """Mean signal per pixel of the image the optics form of ``scene`` over ``window``
        [signal unit] (:func:`radiosim.imaging.image_signal`)."""
        return image_signal(scene, self.integrator(scene), window, self.response_model,
                            self.optics.psf, self.optics.band, self.optics.object_na(self.fpa),
                            progress)

    def integrator(self, scene: Scene) -> FootprintIntegrator:
        """The footprints of this camera's pixels on ``scene``."""
        return FootprintIntegrator.for_scene(scene, self.fpa.pixel_pitch, self.fpa.fill_factor,
                                             self.fpa.shape, self.fpa.origin)

    def window(self, scene: Scene, integration_time: float,
               t_start: float | None = None) -> Window:
        """The integration window on ``scene`` [s], made and checked here: from ``t_start``,
        else centred on the scene's event, else from the scene's first frame
        (:func:`~radiosim.integrator.integration_window`: a time, inside the scene's frames),
        and within this camera's frame period."""
        window = integration_window(check_scene(scene), integration_time, t_start)
        check_frame_period(self, window.duration)
        return window

    @property
    def channel_cameras(self) -> tuple[Camera, ...]:
        """The single-channel cameras of this camera's channels, in order, held by the camera
        (:func:`radiosim.ratio.channel_cameras`); a camera without channels is its own."""
        return channel_cameras(self)

    def exposure(self, scene: Scene, window: Window) -> Exposure:
        """What the noise-free stage needs of this (single-channel) camera's ``window`` on
        ``scene`` (:class:`~radiosim.acquisition.Exposure`): footprints, window, response, the
        image the optics form (if they form one) and a rolling shutter's row time."""
        fpa, optics = self.fpa, self.optics
        image = ((optics.psf, optics.band, optics.object_na(fpa))
                 if self.forms_image(scene) else None)
        return Exposure(self.name, (fpa.pixel_pitch, fpa.fill_factor, fpa.shape, fpa.origin),
                        window, self.response_model, image,
                        fpa.row_time if is_rolling(self) else None)

    def readout(self, integration_time: float) -> ReadOut:
        """What the stages after the integrator need of this (single-channel) camera at
        ``integration_time`` [s] (:class:`~radiosim.acquisition.ReadOut`)."""
        return ReadOut(self, self.calibration(integration_time), self.fpa, self.electronics,
                       self.nuc, self.rate_per_signal, instrument_signal(self),
                       self.response_model.unit)

    def read_out(self, stats, window: Window, scene: Scene, rng=None) -> Measurement:
        """The measurement of ``scene`` from a window's noise-free statistics: each channel
        read out in turn (:func:`radiosim.acquisition.read_out`, its noise drawn from the
        same generator, in the channels' order) and, for a multi-channel camera
        (``stats`` its :class:`~radiosim.acquisition.ChannelStatistics`), the readings
        combined (:func:`radiosim.ratio.combine`)."""
        if isinstance(stats, ChannelStatistics):
            rng = check_rng(rng)
            return combine(self, [own.read_out(own_stats, own_window, scene, rng)
                                  for own, (own_window, own_stats) in zip(
                                      self.channel_cameras, stats.channels)])
        return read_out(self.readout(window.duration), stats, window, scene, rng)

    def measure(self, scene: Scene, integration_time: float, t_start: float | None = None,
                rng=None, scheduler=None, progress=None) -> Measurement:
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
        scheduler
            Where the window's frames are integrated: ``None``, in this process; a
            ``distributed.Client`` or a scheduler's address (``"tcp://HOST:PORT"``), one task
            per part of the window's frames (:func:`~radiosim.acquisition.part_frames`) on its
            workers.
            Either way the window is integrated in those parts, merged in order: the same
            bits in this process and on any number of workers
            (:func:`~radiosim.acquisition.split_statistics`). The noise is drawn here.
        progress
            Called as ``progress(done, total)`` after each frame of the window (with an image
            stage, after each frame of both passes, counted together; on a cluster once, at
            the end); ``None``: silent.

        Returns
        -------
        Measurement
        """
        if self.channels is not None:  # each channel through the stages below, one pass
            if scheduler is not None:
                raise RadiosimError(f"{self.name} has {len(self.channels)} channels: they are "
                                    "measured in one pass in this process, not on a Dask "
                                    "scheduler (give none)")
            return measure_many(scene, [(self, integration_time, t_start)], rng, progress)[0]
        window = self.window(scene, integration_time, t_start)  # [s], made and checked
        readout = self.readout(window.duration)  # calibration, electronics, étendue
        readout.calibration.check_measurable(self.name)
        # Scene → response → integrator (→ the optics' image): the tensor statistics, in
        # parts of the window's frames merged in order, here or on a cluster's workers.
        stats = split_statistics(scene, self.exposure(scene, window), progress, scheduler)
        # Optics → electronics → calibration: the measurement.
        return read_out(readout, stats, window, scene, rng)


def _channel(k: int, build) -> Channel:
    """``build()`` (a :class:`Channel`), its errors naming channel ``k`` (from 0) as 1, 2, …"""
    try:
        return build()
    except RadiosimError as exc:
        raise RadiosimError(f"channel {k + 1}: {exc}") from None


def check_channels(channels, response: str) -> tuple[Channel, ...]:
    """``channels`` as a tuple of :class:`Channel` (bands [m] accepted), at least one; two or
    more need the radiometric response (their ratio)."""
    if isinstance(channels, (str, bytes, Channel)) or not hasattr(channels, "__len__"):
        raise RadiosimError(f"channels must be a sequence of Channel, got {channels!r:.80}")
    if len(channels) < 1:
        raise RadiosimError(f"a camera with channels needs at least one channel, got "
                            f"{channels!r}")
    out = tuple(c if isinstance(c, Channel) else _channel(k, lambda c=c: Channel(band=c))
                for k, c in enumerate(channels))
    if len(out) >= 2 and not (response in RESPONSES and RESPONSES[response].radiometric):
        raise RadiosimError(f"a camera with {len(out)} channels reads their ratio, which needs "
                            f"a radiometric response (response = 'planck'), got {response!r}")
    return out


def check_scene(scene) -> Scene:
    """
    ``scene`` if it is a :class:`~radiosim.scenes.Scene`; otherwise a :class:`RadiosimError`
    saying how to make one (a bare array of temperatures: wrap it in a FrameStack).
    """
    if isinstance(scene, Scene):
        return scene
    if isinstance(scene, (np.ndarray, list, tuple)):
        what = (f"a numpy array of shape {scene.shape}" if isinstance(scene, np.ndarray)
                else f"a {type(scene).__name__} of {len(scene)} item(s)")
        raise RadiosimError(
            f"measure needs a Scene, got {what}: wrap temperature frames [K] in "
            "FrameStack(frames, dt=…, dx=…) (frame interval [s], sample pitch [m])")
    raise RadiosimError(f"measure needs a Scene (e.g. FrameStack(frames, dt=…, dx=…) or "
                        f"UniformBlackbody), got {type(scene).__name__} {scene!r:.60}")
