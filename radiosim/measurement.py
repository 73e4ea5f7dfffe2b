"""
The result of one camera measurement, with the units of every field.

Two differences from the truth carry different names and signs:

-   :attr:`Measurement.peak_error` = tensor maximum − apparent temperature [K], per pixel: the
    paper's "measurement error", *positive* when the camera reads low;
-   a *bias* (the study tables' ``peak_bias_K``, ``column_I_bias_K``) = reading − scene truth
    [K]: *negative* when the camera reads low.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from datetime import datetime, timezone
from typing import ClassVar, NamedTuple

import numpy as np

from radiosim._version import __version__
from radiosim.errors import RadiosimError
from radiosim.units import readable_time

__all__ = ["Measurement", "Field", "FIELDS", "FLAGS", "SIGNAL_UNITS", "CONVENTIONS",
           "field_attributes", "global_attributes"]

#: The metadata conventions of radiosim's NetCDF files and xarray datasets.
CONVENTIONS = "CF-1.8"


class Field(NamedTuple):
    """
    One field of a :class:`Measurement`: the single table of names and units that the
    measurement, the EXR writer (:mod:`radiosim.io.exr`) and the NetCDF writer
    (:mod:`radiosim.io.netcdf`) read.

    Attributes
    ----------
    name : str
        The measurement's attribute (a dataclass field, a property or a scalar).
    unit : str or None
        Unit as radiosim writes it (:attr:`Measurement.UNITS`, the EXR header's
        ``radiosim:unit:<channel>``); ``None``: the measurement's ``signal_unit``.
    udunits : str or None
        The same unit as a UDUNITS-2 string (the CF conventions' ``units``): counts of
        digital numbers and of electrons are numbers, ``"1"``, their ``long_name`` says what
        they count; ``None``: from :data:`SIGNAL_UNITS`.
    long_name : str
        What the field holds (the CF ``long_name``).
    standard_name : str or None
        Its name in the CF standard name table, where one exists (only the flags,
        ``status_flag``: no entry of the table describes a camera's reading or the scene's
        statistics over a pixel's footprint).
    kind : str
        ``"array"`` (a per-pixel array stored by the measurement), ``"derived"`` (a per-pixel
        property computed from them) or ``"scalar"``.
    channel : str or None
        The EXR channel that holds it (``None``: not written to EXR).
    """

    name: str
    unit: str | None
    udunits: str | None
    long_name: str
    standard_name: str | None
    kind: str
    channel: str | None


_WINDOW = "the pixel's footprint and integration window"

#: Every field of a measurement, in the order of the EXR channels and of the NetCDF variables.
FIELDS: tuple[Field, ...] = (
    Field("apparent_temperature", "K", "K",
          "apparent temperature: the camera's reading through its calibration (NaN where "
          "flagged)", None, "array", "apparent_temperature"),
    Field("counts", "DN", "1", "digital number (analogue-to-digital converter counts, DN)",
          None, "array", "counts"),
    Field("electrons", "e-", "1", "charge in the well at the end of integration (electrons)",
          None, "array", "electrons"),
    Field("saturated", "1", None,
          "saturated: full well or converter top code, or above the calibration's range",
          "status_flag", "array", "saturated"),
    Field("under_range", "1", None,
          "under range: converter code 0 or below the calibration's range", "status_flag",
          "array", "under_range"),
    Field("over_range", "1", None,
          "over range: above the calibration's range with neither well nor converter full",
          "status_flag", "array", "over_range"),
    Field("peak_error", "K", "K",
          "peak error: tensor maximum minus apparent temperature (positive when the camera "
          "reads low)", None, "derived", "peak_error"),
    Field("uncertainty", "K", "K",
          "uncertainty: standard deviation of scene temperature over " + _WINDOW, None,
          "derived", "uncertainty"),
    Field("tensor_max", "K", "K", "maximum scene temperature over " + _WINDOW, None,
          "array", "tensor_max"),
    Field("tensor_mean", "K", "K",
          "area- and time-weighted mean scene temperature over " + _WINDOW, None, "array",
          "tensor_mean"),
    Field("tensor_std", "K", "K",
          "weighted population standard deviation of scene temperature over " + _WINDOW,
          None, "array", None),
    Field("signal_mean", None, None, "weighted mean response signal over " + _WINDOW, None,
          "array", "signal_mean"),
    Field("integration_time", "s", "s", "integration time", None, "scalar", None),
    Field("t_start", "s", "s", "start of the integration window (scene time)", None,
          "scalar", None),
)

#: The flag fields (booleans; NetCDF ``status_flag`` variables with ``flag_values`` 0 and 1).
FLAGS: tuple[str, ...] = tuple(f.name for f in FIELDS if f.standard_name == "status_flag")

#: A response's signal unit → (its UDUNITS-2 form, what the signal is). UDUNITS has no photon:
#: a photon radiance is a number of photons per second, square metre and steradian.
SIGNAL_UNITS: dict[str, tuple[str, str]] = {
    "K": ("K", "temperature (linear response)"),
    "photons s-1 m-2 sr-1": ("s-1 m-2 sr-1", "in-band photon radiance"),
    "W m-2 sr-1": ("W m-2 sr-1", "in-band radiance"),
}


def field_attributes(name: str, signal_unit: str = "K") -> dict:
    """
    The CF attributes (``units``, ``long_name``, ``standard_name`` where one exists; flags
    with ``flag_values`` and ``flag_meanings``) of the field ``name`` of :data:`FIELDS`.

    Examples
    --------
    >>> field_attributes("counts")["units"], field_attributes("tensor_max")["units"]
    ('1', 'K')
    >>> field_attributes("signal_mean", "photons s-1 m-2 sr-1")["units"]
    's-1 m-2 sr-1'
    """
    entry = next((f for f in FIELDS if f.name == name), None)
    if entry is None:
        raise RadiosimError(f"{name!r} is not a field of a measurement; fields: "
                       f"{', '.join(f.name for f in FIELDS)}")
    if entry.standard_name == "status_flag":
        return {"long_name": entry.long_name, "standard_name": entry.standard_name,
                "flag_values": np.array([0, 1], dtype=np.int8),
                "flag_meanings": f"not_{name} {name}"}
    if entry.unit is None:
        udunits, what = SIGNAL_UNITS.get(signal_unit, (signal_unit, "signal"))
        return {"units": udunits, "long_name": f"{entry.long_name}: {what}"}
    attrs = {"units": entry.udunits, "long_name": entry.long_name}
    if entry.standard_name:
        attrs["standard_name"] = entry.standard_name
    return attrs


def global_attributes(title: str, history: str) -> dict:
    """
    The CF global attributes radiosim's datasets start with: ``Conventions``
    (:data:`CONVENTIONS`), ``title``, ``history`` (one line: the UTC time, radiosim's version
    and ``history``), ``source`` and ``radiosim_version``.

    Examples
    --------
    >>> attrs = global_attributes("a title", "radiosim run msec2009")
    >>> attrs["Conventions"], attrs["history"].endswith("radiosim run msec2009")
    ('CF-1.8', True)
    """
    now = datetime.now(timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")
    return {"Conventions": CONVENTIONS, "title": title,
            "history": f"{now} radiosim {__version__}: {history}",
            "source": f"radiosim {__version__}, a physically based radiometric simulator of "
                      "infrared cameras", "radiosim_version": __version__}


@dataclass(frozen=True, eq=False)
class Measurement:
    """
    What one integration of the camera produced, pixel by pixel, with the scene truth beside it.

    Arrays are shaped like the pixel array that the scene covers (rows, columns), row 0 at the
    top. Pixels that are ``saturated``, ``under_range`` or ``over_range`` have no apparent
    temperature (NaN):
    they are never reported as plausible numbers.

    Attributes
    ----------
    apparent_temperature : numpy.ndarray
        Temperature the camera reports [K] (NaN where flagged).
    counts : numpy.ndarray
        Digital numbers [DN].
    electrons : numpy.ndarray
        Charge in the well at the end of integration [e⁻].
    saturated : numpy.ndarray of bool
        Full well or converter top code, or (with a full well's worth of signal) above the
        calibration's range.
    under_range : numpy.ndarray of bool
        Converter code 0 or below the calibration's range.
    tensor_max : numpy.ndarray
        Maximum scene temperature over the pixel's footprint × window [K].
    tensor_mean : numpy.ndarray
        Area- and time-weighted mean scene temperature over the same tensor [K].
    tensor_std : numpy.ndarray
        Weighted population standard deviation (ddof = 0) of the same [K].
    signal_mean : numpy.ndarray
        Weighted mean response signal [``signal_unit``].
    signal_unit : str
        Unit of ``signal_mean`` (``"K"`` or ``"photons s-1 m-2 sr-1"``).
    camera : Camera
        The camera that measured.
    integration_time : float
        Integration time [s].
    t_start : float
        Start of the integration window [s].
    n_frames : int
        Scene frames the window touched.
    scene : dict
        Description of the scene (units in the keys).
    alignment : str
        How the window start was chosen: ``"given"``, ``"centred"`` on the scene's event, or
        ``"scene start"``.
    over_range : numpy.ndarray of bool
        Readings above the calibration range although neither the well nor the converter is
        full (with a very short integration, noise can carry a reading there).
    subframe : numpy.ndarray of int or None
        For a superframe (:func:`~radiosim.acquisition.superframe`): the subframe each pixel
        was taken from (an index into ``subframe_times``).
    subframe_times : tuple of float
        A superframe's integration times [s], in the order they were taken.
    subframe_starts : tuple of float
        The start of each subframe's window [s].
    channels : tuple of Measurement
        A multi-channel camera's (:mod:`radiosim.ratio`): each channel's single-channel
        measurement, in the camera's order; empty for a single-channel camera. With channels,
        the scene-truth statistics, counts, electrons, signal and window are the first
        channel's.
    ratio_temperature : numpy.ndarray or None
        With two or more channels: the temperature [K] whose band-signal ratio equals the
        first two channels' measured ratio (over the camera's ``assumed_emissivity_ratio``);
        NaN where a channel is flagged or the ratio lies outside the calibration. It is then
        also the ``apparent_temperature`` (and the flags combine the channels').
    ratio_netd : numpy.ndarray or None
        The ratio temperature's noise [K]: √((σ₁/S₁)² + (σ₂/S₂)²) / abs(d ln r/dT),
        from both channels' temporal noise at their measured charge.
    """

    #: Units of the array fields and derived properties, as radiosim writes them (the EXR
    #: header's ``radiosim:unit:<channel>``); :data:`FIELDS` holds them with their UDUNITS form.
    UNITS: ClassVar[dict[str, str]] = {f.name: f.unit for f in FIELDS if f.unit is not None}

    #: The per-pixel arrays and their units (``signal_mean``'s is :attr:`signal_unit`).
    ARRAYS: ClassVar[dict[str, str | None]] = {f.name: f.unit for f in FIELDS
                                               if f.kind == "array"}

    apparent_temperature: np.ndarray
    counts: np.ndarray
    electrons: np.ndarray
    saturated: np.ndarray
    under_range: np.ndarray
    tensor_max: np.ndarray
    tensor_mean: np.ndarray
    tensor_std: np.ndarray
    signal_mean: np.ndarray
    signal_unit: str
    camera: object
    integration_time: float
    t_start: float
    n_frames: int
    scene: dict = field(default_factory=dict)
    alignment: str = "given"
    over_range: np.ndarray | None = None
    subframe: np.ndarray | None = None
    subframe_times: tuple = ()
    subframe_starts: tuple = ()
    channels: tuple = ()
    ratio_temperature: np.ndarray | None = None
    ratio_netd: np.ndarray | None = None

    def __post_init__(self):
        if self.over_range is None:
            object.__setattr__(self, "over_range", np.zeros(np.shape(self.saturated), bool))

    def __repr__(self) -> str:
        name = getattr(self.camera, "name", type(self.camera).__name__)
        valid = self.apparent_temperature[self.valid]
        reading = (f"{valid.min():.1f}–{valid.max():.1f} K" if valid.size else "no valid pixel")
        return (f"<Measurement {self.shape[0]} × {self.shape[1]} px by {name}: "
                f"{readable_time(self.integration_time)} from {readable_time(self.t_start)} "
                f"({self.n_frames} frames, "
                f"{self.alignment}); reads {reading}; {int(self.saturated.sum())} saturated, "
                f"{int(self.under_range.sum())} under range, "
                f"{int(self.over_range.sum())} over range>")

    def to_xarray(self, history: str | None = None):
        """
        The measurement as a CF-1.8 :class:`xarray.Dataset`.

        Dimensions ``y``, ``x`` with the pixel centres' coordinates [m] (object space, from
        the array's origin); every array of :data:`ARRAYS` a variable with the CF attributes
        of :data:`FIELDS` (UDUNITS ``units``, ``long_name``; the flags as booleans with
        ``standard_name = "status_flag"``, ``flag_values`` and ``flag_meanings``, named by
        ``apparent_temperature``'s ``ancillary_variables``); as attributes ``Conventions``,
        ``title``, ``history``, ``source``, the camera (TOML, which rebuilds it exactly), the
        window and the scene (``scene_<key>``). :func:`radiosim.io.from_xarray` turns it
        back, and :func:`radiosim.io.write_netcdf` writes it.

        Parameters
        ----------
        history
            What made the measurement (for instance the command line), the end of the
            ``history`` attribute's line; ``None``: the camera and the window.

        Examples
        --------
        >>> from radiosim import Camera, UniformBlackbody
        >>> scene = UniformBlackbody(500.0, (6, 8), 1e-6, 1e-6)
        >>> ds = Camera.linear_ideal(2e-6).measure(scene, 1e-6).to_xarray()
        >>> ds.apparent_temperature.dims, ds.apparent_temperature.units, ds.x.units
        (('y', 'x'), 'K', 'm')
        >>> (ds.x.values * 1e6).round(9).tolist()  # pixel centres [µm]
        [1.0, 3.0, 5.0, 7.0]
        >>> ds.counts.units, ds.Conventions
        ('1', 'CF-1.8')
        """
        import xarray as xr

        fpa = self.camera.fpa
        rows, cols = self.shape
        y = fpa.origin[0] + (np.arange(rows) + 0.5) * fpa.pixel_pitch
        x = fpa.origin[1] + (np.arange(cols) + 0.5) * fpa.pixel_pitch
        data = {}
        for name in self.ARRAYS:
            values = np.asarray(getattr(self, name))
            values = values.astype(bool) if name in FLAGS else values.astype(np.float64)
            data[name] = (("y", "x"), values, field_attributes(name, self.signal_unit))
        data["apparent_temperature"][2]["ancillary_variables"] = " ".join(FLAGS)
        what = (f"camera {self.camera.name}, {self.integration_time:.10g} s from "
                f"{self.t_start:.10g} s")
        attrs = global_attributes(f"radiosim measurement: {what}", history or what)
        attrs.update({"camera": self.camera.to_toml(), "camera_name": self.camera.name,
                      "signal_unit": self.signal_unit, "alignment": self.alignment,
                      "integration_time_s": self.integration_time, "t_start_s": self.t_start,
                      "n_frames": self.n_frames})
        for key, value in self.scene.items():
            attrs[f"scene_{key}"] = value
        where = "centre of the pixel in object space, from the array's origin"
        coords = {"y": ("y", y, {"units": "m", "long_name": f"row position: {where}"}),
                  "x": ("x", x, {"units": "m", "long_name": f"column position: {where}"})}
        if self.channels:
            self._channel_variables(data, coords)
        return xr.Dataset(data, coords=coords, attrs=attrs)

    def _channel_variables(self, data: dict, coords: dict):
        """A multi-channel measurement's variables: each channel's arrays along a
        ``channel`` dimension (``channel_<field>``), its window, and the ratio temperature
        and its noise."""
        channels = self.channels
        coords["channel"] = ("channel", np.arange(1, len(channels) + 1, dtype=np.int32),
                             {"long_name": "spectral channel (1: the ratio's numerator)"})
        bands = np.array([m.camera.optics.band for m in channels], dtype=np.float64)
        for i, end in enumerate(("low", "high")):
            coords[f"band_{end}"] = ("channel", bands[:, i], {
                "units": "m", "long_name": f"{end} wavelength limit of the channel's band"})
        for name in self.ARRAYS:
            stack = np.stack([np.asarray(getattr(m, name)) for m in channels])
            stack = stack.astype(bool) if name in FLAGS else stack.astype(np.float64)
            attrs = dict(field_attributes(name, self.signal_unit))
            attrs["long_name"] = f"each channel's {attrs['long_name']}"
            data[f"channel_{name}"] = (("channel", "y", "x"), stack, attrs)
        for name in ("integration_time", "t_start"):
            attrs = dict(field_attributes(name))
            attrs["long_name"] = f"each channel's {attrs['long_name']}"
            data[f"channel_{name}"] = ("channel", np.array(
                [getattr(m, name) for m in channels], dtype=np.float64), attrs)
        data["channel_n_frames"] = ("channel", np.array([m.n_frames for m in channels],
                                                        dtype=np.int64),
                                    {"units": "1", "long_name": "scene frames each channel's "
                                                                "window touched"})
        if self.ratio_temperature is not None:
            data["ratio_temperature"] = (("y", "x"), np.asarray(
                self.ratio_temperature, dtype=np.float64), {
                "units": "K", "long_name": "ratio temperature: the temperature whose band-"
                "signal ratio equals the first two channels' measured ratio (NaN where "
                "flagged)"})
            data["ratio_netd"] = (("y", "x"), np.asarray(self.ratio_netd, dtype=np.float64), {
                "units": "K", "long_name": "noise-equivalent temperature difference of the "
                "ratio temperature, from both channels' temporal noise"})

    @property
    def peak_error(self) -> np.ndarray:
        """Tensor maximum minus apparent temperature [K] (the paper's local peak error):
        positive when the camera reads low."""
        return self.tensor_max - self.apparent_temperature

    @property
    def uncertainty(self) -> np.ndarray:
        """Tensor standard deviation [K] (the paper's measurement uncertainty)."""
        return self.tensor_std

    @property
    def shape(self) -> tuple[int, int]:
        return self.apparent_temperature.shape

    @property
    def valid(self) -> np.ndarray:
        """Pixels with an apparent temperature (neither saturated nor under range)."""
        return ~(self.saturated | self.under_range | self.over_range)

    @property
    def saturated_fraction(self) -> float:
        """Fraction of pixels flagged saturated."""
        return float(np.mean(self.saturated))

    @property
    def t_stop(self) -> float:
        """End of the integration window [s]."""
        return self.t_start + self.integration_time
