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

Camera files (TOML) are read and written by :mod:`radiosim.presets`.
"""

from __future__ import annotations

import dataclasses
import warnings
import math
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path

import numpy as np


from radiosim.calibration import Calibration, NonUniformityCorrection, fit_calibration
from radiosim.checks import check_fraction, check_positive, check_rng, check_time
from radiosim.config import build_checked, build_from_toml, dumps_toml, edge_field
from radiosim.electronics import Electronics
from radiosim.errors import RadiosimError, RadiosimWarning
from radiosim.fpa import FocalPlaneArray
from radiosim.imaging import forms_image, image_signal
from radiosim.integrator import (FootprintIntegrator, Job, TensorStatistics, Window, integrate,
                                 integrate_many, integration_window, stack_rows)
from radiosim.measurement import Measurement
from radiosim.optics import Optics, collect
from radiosim.presets import PRESET_DIRECTORY, available_presets, camera_fields, camera_table
from radiosim.response import LinearResponse, PlanckResponse, Response
from radiosim.scenes.base import Scene

__all__ = ["Optics", "FocalPlaneArray", "Camera", "measure_many", "measure_many_statistics",
           "available_presets", "PRESET_DIRECTORY"]


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
        :meth:`fit_nuc`; not part of the camera file).

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
                               doc="'planck' or 'linear'")
    name: str = edge_field("custom", "name", kind="str", doc="camera name")
    frame_rate: float | None = edge_field(None, "frame_rate_hz", doc="frame rate [Hz]")
    assumed_emissivity: float = edge_field(1.0, "assumed_emissivity",
                                           doc="emissivity setting of the calibration")
    linear_responsivity: float = edge_field(1e6, "linear_responsivity_e_per_s_per_K",
                                            doc="electron rate per kelvin of the linear response")
    calibration_range: tuple[float, float] = edge_field(
        (150.0, 3000.0), "calibration_range_K", kind="numbers",
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

    def __post_init__(self):
        if self.response not in ("linear", "planck"):
            raise RadiosimError(f"response must be 'linear' or 'planck', got {self.response!r}")
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
        """The camera as a TOML preset (see :meth:`to_dict`)."""
        return dumps_toml(self.to_dict(), tables=("optics", "fpa", "electronics"))

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
        if self.response == "linear":
            return LinearResponse(self.linear_responsivity)
        return PlanckResponse(self.optics.band, self.responsivity)

    @property
    def rate_per_signal(self) -> float:
        """Electron rate per unit of response signal [e⁻ s⁻¹ per signal unit]."""
        return self.response_model.rate_per_signal(self.etendue)

    def instrument_signal(self, temperature: float | None = None) -> float:
        """The optics' own emission into a pixel [signal unit] at ``temperature`` [K] (default
        the optics' instrument temperature); 0 for the linear response."""
        if not self.response_model.radiometric:
            return 0.0
        return self.optics.emitted_radiance(self.fpa.quantum_efficiency, temperature)

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
                self.assumed_emissivity, self.calibration_range,
                self.assumed_reflected_temperature, self.assumed_path_transmission,
                self.assumed_path_temperature,
                self.instrument_signal(self.assumed_instrument_temperature),
                self.detection_sigma)
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
        """The integration window on ``scene`` [s]: from ``t_start``, else centred on the
        scene's event, else from t = 0; checked against the frame period."""
        check_scene(scene)
        t_int = check_time(integration_time, "integration_time")
        if t_start is not None:
            t_start = check_time(t_start, "t_start", positive=False)
        if self.frame_rate is not None:
            needed = self.fpa.frame_period(t_int, self.readout_shape)
            if needed > 1.0 / self.frame_rate * (1 + 1e-12):
                raise RadiosimError(
                    f"integration time {t_int:g} s" + (
                        f" with its readout ({needed:g} s)" if needed != t_int else "")
                    + f" exceeds the frame period {1 / self.frame_rate:g} s of {self.name} at "
                    f"{self.frame_rate:g} Hz")
        return integration_window(scene, t_int, t_start)

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
        window = self.window(scene, integration_time, t_start)  # [s]
        self.check_measurable(window.duration)
        if self.rolling:
            return self.read_out(self._rolling(scene, window), window, scene, rng)
        # Scene frames (T [K], ε) → response signal per sample → mean per pixel over
        # footprint × window [signal unit], with the tensor's T statistics [K].
        # (Reflections, where the scene has them, are the image stage's: below.)
        stats = integrate(scene, self.integrator(scene), window, self.response_model,
                          emission_only=True)
        if self.forms_image(scene):  # the statistics stay scene truth; the signal is imaged
            stats = dataclasses.replace(stats, signal_mean=self.image(scene, window))
        return self.read_out(stats, window, scene, rng)

    def check_measurable(self, integration_time: float):
        """Refuse (:class:`RadiosimError`, naming the camera, the integration time and the
        limits) an integration time at which no temperature of the calibration range gives
        a reading (:meth:`~radiosim.calibration.Calibration.check_measurable`)."""
        self.calibration(integration_time).check_measurable(self.name)

    @property
    def rolling(self) -> bool:
        """Whether the rows integrate over staggered windows (a rolling shutter)."""
        return self.fpa.shutter == "rolling" and self.fpa.row_time > 0

    def _rolling(self, scene: Scene, window: Window) -> TensorStatistics:
        """A rolling shutter's statistics: pixel row i integrates over the window delayed by
        i·row_time, all rows in one pass over the frames."""
        if self.forms_image(scene):
            raise RadiosimError(
                f"{self.name}: a rolling shutter with a PSF, reflections or a path would need "
                "one image per row; measure with shutter = 'snapshot' or without them")
        integrator = self.integrator(scene)
        delays = self.fpa.row_delays(integrator.shape[0])  # [s]
        last = window.start + window.duration + delays[-1]
        if scene.duration is not None and last > scene.duration * (1 + 1e-12):
            raise RadiosimError(
                f"the rolling shutter's last row integrates until {last:.6g} s, past the "
                f"scene's end at {scene.duration:.6g} s (row time {self.fpa.row_time:g} s × "
                f"{integrator.shape[0] - 1} rows)")
        jobs = [Job(integrator.pixel_rows(i, i + 1),
                    Window(window.start + delay, window.duration, window.alignment),
                    self.response_model) for i, delay in enumerate(delays)]
        return stack_rows(integrate_many(scene, jobs))

    def read_out(self, stats: TensorStatistics, window: Window, scene: Scene,
                 rng=None) -> Measurement:
        """
        The stages after the integrator: the optics, the electronics and the calibration turn
        a window's tensor statistics into a :class:`Measurement`.
        """
        calibration = self.calibration(window.duration)
        calibration.check_resolution(stacklevel=3)
        # Optics: mean signal and the optics' emission → mean photo-electrons [e⁻] through the
        # étendue.
        photoelectrons = collect(stats.signal_mean + self.instrument_signal(),
                                 self.rate_per_signal, window.duration)
        # Electronics: the fixed pattern, dark charge, shot noise, full well, non-linearity,
        # read noise, ADC → counts [DN].
        pattern = self.fpa.pattern(photoelectrons.shape)
        exposure = self.electronics.expose(photoelectrons, window.duration, rng, pattern)
        if self.nuc is not None:  # the NUC: counts [DN] → corrected counts [DN]; its bad
            # pixels take their neighbours' values, and their own flags no longer apply
            good = ~self.nuc.bad[:exposure.counts.shape[0], :exposure.counts.shape[1]]
            exposure = dataclasses.replace(
                exposure, counts=self.nuc.apply(exposure.counts),
                saturated=exposure.saturated & good, adc_floor=exposure.adc_floor & good)
        # Calibration: counts [DN] → apparent temperature [K] and flags.
        reading = calibration.read(exposure)
        if reading.saturated.any():
            warnings.warn(
                f"{self.name}: {int(reading.saturated.sum())} of {reading.saturated.size} pixels "
                f"saturated at {window.duration:g} s integration; their apparent temperature is "
                "NaN", RadiosimWarning, stacklevel=3)
        return Measurement(
            apparent_temperature=reading.apparent_temperature, counts=exposure.counts,
            electrons=exposure.electrons, saturated=reading.saturated,
            under_range=reading.under_range, over_range=reading.over_range,
            tensor_max=stats.max, tensor_mean=stats.mean,
            tensor_std=stats.std, signal_mean=stats.signal_mean,
            signal_unit=self.response_model.unit, camera=self,
            integration_time=window.duration, t_start=window.start, n_frames=stats.n_frames,
            scene=scene.describe(), alignment=window.alignment,
        )

    @property
    def readout_shape(self) -> tuple[int, int]:
        """The window the array reads, as its number of rows and columns: the array's shape, or
        one pixel if it has none."""
        return tuple(self.fpa.shape) if self.fpa.shape is not None else (1, 1)

    def frame_period(self, integration_time: float) -> float:
        """
        The camera's frame period [s] at ``integration_time`` [s]: the array's own (integration
        and readout, :meth:`~radiosim.fpa.FocalPlaneArray.frame_period`), or the frame rate's
        if that is slower. A camera with neither a frame rate nor a readout time has none.
        """
        own = self.fpa.frame_period(integration_time, self.readout_shape)
        if self.frame_rate is not None:
            return max(1.0 / self.frame_rate, own)
        if self.fpa.readout_time(self.readout_shape) == 0:
            raise RadiosimError(f"{self.name} has no frame rate nor readout time; set "
                                "frame_rate_hz or the [fpa] readout times")
        return own

    def record(self, scene: Scene, integration_time: float, n_frames: int,
               t_start: float | None = None, rng=None) -> list[Measurement]:
        """
        Record ``n_frames`` camera frames with the camera's real timing.

        Frame i integrates over [t_start + i·P, … + integration_time] with P the frame period
        (:meth:`frame_period`: the readout's, or the frame rate's if slower); ``t_start``
        defaults to the start that centres the first frame's window on the scene's event.
        One generator drives the noise of all frames.
        """
        if isinstance(n_frames, bool) or int(n_frames) != n_frames or n_frames < 1:
            raise RadiosimError(f"n_frames must be a whole number ≥ 1, got {n_frames!r}")
        period = self.frame_period(integration_time)
        rng = check_rng(rng)
        first = self.window(scene, integration_time, t_start)
        return [self.measure(scene, integration_time, first.start + i * period, rng)
                for i in range(int(n_frames))]

    def superframe(self, scene: Scene, integration_times, t_start: float | None = None,
                   rng=None) -> Measurement:
        """
        Superframing: integrate subframes of ``integration_times`` [s] in sequence with the
        camera's real timing (each starts one frame period after the previous one's start),
        calibrate each with its own calibration, and merge them per pixel: the longest
        subframe whose reading is valid (neither saturated, under nor over range); a pixel with
        no valid subframe keeps the flags of its shortest subframe if any is saturated, else of
        its longest. The scene moves between subframes, and the merged frame shows it.

        Parameters
        ----------
        scene
            The scene.
        integration_times
            The subframes' integration times [s], in the order the camera cycles them.
        t_start
            Start of the first subframe [s]; ``None``: as :meth:`window` chooses.
        rng
            Seed or generator; the subframes draw their noise from it in turn.

        Returns
        -------
        Measurement
            Per-pixel fields from each pixel's subframe; ``subframe`` says which;
            ``integration_time`` is the longest subframe's, ``t_start`` the first's.
        """
        times = [check_positive(t, "integration time", "s") for t in integration_times]
        if not times:
            raise RadiosimError("a superframe needs at least one integration time")
        rng = check_rng(rng)
        start = self.window(scene, times[0], t_start).start
        subframes = []
        for t_int in times:
            subframes.append(self.measure(scene, t_int, start, rng))
            start += self.frame_period(t_int) if (self.frame_rate is not None or
                                                  self.fpa.readout_time(self.readout_shape) > 0
                                                  ) else t_int
        order = np.argsort(times, kind="stable")  # shortest first
        shape = subframes[0].shape
        chosen = np.full(shape, -1)
        for j in order:  # longer valid subframes overwrite shorter ones
            chosen = np.where(subframes[j].valid, j, chosen)
        none = chosen < 0
        any_saturated = np.any([m.saturated for m in subframes], axis=0)
        chosen = np.where(none & any_saturated, order[0], np.where(none, order[-1], chosen))

        def pick(name):
            stack = np.stack([getattr(m, name) for m in subframes])
            return np.take_along_axis(stack, chosen[None], 0)[0]

        first = subframes[0]
        return Measurement(
            **{name: pick(name) for name in (
                "apparent_temperature", "counts", "electrons", "saturated", "under_range",
                "over_range", "tensor_max", "tensor_mean", "tensor_std", "signal_mean")},
            signal_unit=first.signal_unit, camera=self, integration_time=max(times),
            t_start=first.t_start, n_frames=sum(m.n_frames for m in subframes),
            scene=first.scene, alignment=first.alignment, subframe=chosen,
            subframe_times=tuple(times), subframe_starts=tuple(m.t_start for m in subframes))

    # -- the array's fixed pattern and its correction ------------------------------------------

    def flat_fields(self, temperature: float | None, integration_time: float,
                    frames: int = 16, rng=None):
        """
        ``frames`` read-outs [DN] (frames, rows, columns) of a uniform blackbody filling the
        array at ``temperature`` [K] — or of darkness (no photo-charge) for ``None`` — and the
        pixels saturated in any of them.

        The blackbody is imaged once; each frame is a new read-out of the electronics (shot
        and read noise, with the array's fixed pattern), without the NUC.
        """
        from radiosim.scenes.analytic import UniformBlackbody

        if self.fpa.shape is None:
            raise RadiosimError(f"{self.name} has no array shape: a flat field needs one")
        if isinstance(frames, bool) or int(frames) != frames or frames < 1:
            raise RadiosimError(f"frames must be a whole number ≥ 1, got {frames!r}")
        rng = check_rng(rng)
        t_int = check_positive(integration_time, "integration_time", "s")
        if temperature is None:
            photo = np.zeros(self.fpa.shape)
        else:
            scene = UniformBlackbody(check_positive(temperature, "temperature", "K"),
                                     shape=self.fpa.shape, dx=self.fpa.pixel_pitch, dt=t_int)
            at_corner = self.replace(fpa=dataclasses.replace(self.fpa, origin=(0.0, 0.0)))
            window = at_corner.window(scene, t_int, 0.0)
            stats = integrate(scene, at_corner.integrator(scene), window, self.response_model)
            photo = collect(stats.signal_mean + self.instrument_signal(), self.rate_per_signal,
                            t_int)  # [e⁻]
        pattern = self.fpa.pattern(photo.shape)
        counts = np.empty((int(frames), *photo.shape))
        saturated = np.zeros(photo.shape, dtype=bool)
        for k in range(int(frames)):
            exposure = self.electronics.expose(photo, t_int, rng, pattern)
            counts[k] = exposure.counts
            saturated |= exposure.saturated
        return counts, saturated

    def flat_field(self, temperature: float | None, integration_time: float, frames: int = 16,
                   rng=None):
        """The mean of :meth:`flat_fields` [DN] and the pixels saturated in any frame."""
        counts, saturated = self.flat_fields(temperature, integration_time, frames, rng)
        return counts.mean(axis=0), saturated

    def fit_nuc(self, temperatures, integration_time: float, frames: int = 16,
                rng=None) -> Camera:
        """
        The camera with a non-uniformity correction computed as cameras do: flat fields of
        uniform blackbodies at ``temperatures`` [K] (two: a two-point NUC; more: multi-point),
        ``frames`` read-outs each, at ``integration_time`` [s]
        (:class:`~radiosim.calibration.NonUniformityCorrection`).
        """
        rng = check_rng(rng)
        temperatures = [float(t) for t in temperatures]
        flats, saturated = zip(*(self.flat_field(t, integration_time, frames, rng)
                                 for t in temperatures))
        nuc = NonUniformityCorrection.from_flat_fields(
            np.array(flats), temperatures, integration_time, np.any(saturated, axis=0))
        return self.replace(nuc=nuc)

    # -- calibrating from measured points ---------------------------------------------------------

    def fit_calibration(self, temperatures, counts, integration_time: float, frames: int = 1,
                        emissivity: float = 1.0, instrument_temperatures=None,
                        exclude_unusable: bool = False, fit_full_well: bool = False):
        """
        Fit the camera's system gain K [DN/e⁻] and offset [DN] (and, with several
        ``instrument_temperatures`` [K], the optics' emissivity) to a measured calibration
        table: blackbody ``temperatures`` [K] against mean ``counts`` [DN] at
        ``integration_time`` [s], each the mean of ``frames`` read-outs; points beyond the full
        well or the converter's range are refused, excluded (``exclude_unusable``) or widen the
        well (``fit_full_well``). See :func:`radiosim.calibration.fit_calibration`.

        Returns
        -------
        camera : Camera
            This camera with the fitted gain and offset (and optics emissivity).
        residuals : numpy.ndarray
            Measured minus fitted counts [DN] (NaN at excluded points).
        """
        return fit_calibration(self, temperatures, counts, integration_time, frames,
                               emissivity, instrument_temperatures, exclude_unusable,
                               fit_full_well)

    # -- performance ----------------------------------------------------------------------------

    def netd(self, temperature, integration_time: float) -> np.ndarray:
        """
        Noise-equivalent temperature difference [K] of a grey body (the camera's assumed
        emissivity and settings) at ``temperature`` [K]: the temporal noise [e⁻ rms] over the
        slope of the mean charge, d e⁻/dT (shot noise of signal, background and dark charge;
        read and quantisation noise). The fixed pattern is not temporal noise and is not
        included.
        """
        return self.calibration(integration_time).netd(temperature)

    def measurable_range(self, integration_time: float) -> tuple[float, float]:
        """
        (lowest measurable temperature, saturation temperature) [K] of a grey body at
        ``integration_time`` [s]: the temperature whose mean counts reach the detection limit
        (blank + k σ, k = :attr:`detection_sigma`), and the one that fills the well or the
        converter (NaN or ∞ where the calibration range does not hold them).
        """
        calibration = self.calibration(integration_time)
        return calibration.lowest_measurable_temperature(), calibration.saturation_temperature


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


def measure_many(scene: Scene, cases, rng=None, progress=None) -> list[Measurement]:
    """
    Several measurements of one scene in one pass over its frames.

    Each frame any window touches is read (or generated) once and feeds every measurement
    (:func:`~radiosim.integrator.integrate_many`); the read-outs then follow in the order of
    ``cases``, drawing their noise from one generator, so the result equals calling
    :meth:`Camera.measure` on each case in turn with that generator, bit for bit.

    Parameters
    ----------
    scene
        The scene.
    cases
        ``(camera, integration_time [s], t_start [s] or None)`` triples.
    rng
        Seed or :class:`numpy.random.Generator`.
    progress
        Called as ``progress(done, total)`` after each frame.
    """
    rng = check_rng(rng)
    cases = list(cases)
    return [camera.read_out(stats, window, scene, rng)
            for (camera, _, _), (window, stats) in zip(
                cases, measure_many_statistics(scene, cases, progress))]


def measure_many_statistics(scene: Scene, cases, progress=None) -> list:
    """
    The noise-free part of :func:`measure_many`: each case's window and tensor statistics
    (mean signal, with the optics' image where the camera forms one), from one pass over the
    scene's frames. A read-out (:meth:`Camera.read_out`) with any generator turns each into a
    measurement, so callers can give each case its own seed.

    Returns
    -------
    list of (Window, TensorStatistics)
        In the order of ``cases``.
    """
    cases = list(cases)
    windows = [camera.window(scene, t_int, t_start) for camera, t_int, t_start in cases]
    for (camera, _, _), window in zip(cases, windows):
        camera.check_measurable(window.duration)
    integrators = {}
    jobs = []
    snapshot = [i for i, (camera, _, _) in enumerate(cases) if not camera.rolling]
    for (camera, _, _), window in ((cases[i], windows[i]) for i in snapshot):
        fpa = camera.fpa
        key = (fpa.pixel_pitch, fpa.fill_factor, fpa.shape, fpa.origin)
        if key not in integrators:  # cameras with the same footprints share them
            integrators[key] = camera.integrator(scene)
        jobs.append(Job(integrators[key], window, camera.response_model))
    snapshot_statistics = dict(zip(snapshot, integrate_many(scene, jobs, progress,
                                                            emission_only=True)))
    statistics = [snapshot_statistics[i] if i in snapshot_statistics
                  else camera._rolling(scene, window)  # its own pass, one job per row
                  for i, ((camera, _, _), window) in enumerate(zip(cases, windows))]
    statistics = [dataclasses.replace(stats, signal_mean=camera.image(scene, window))
                  if not camera.rolling and camera.forms_image(scene) else stats
                  for (camera, _, _), window, stats in zip(cases, windows, statistics)]
    return list(zip(windows, statistics))
