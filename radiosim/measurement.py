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
from typing import ClassVar

import numpy as np

__all__ = ["Measurement"]


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
        For a superframe (:meth:`~radiosim.camera.Camera.superframe`): the subframe each pixel
        was taken from (an index into ``subframe_times``).
    subframe_times : tuple of float
        A superframe's integration times [s], in the order they were taken.
    subframe_starts : tuple of float
        The start of each subframe's window [s].
    """

    #: Units of the array fields and derived properties.
    UNITS: ClassVar[dict[str, str]] = {
        "apparent_temperature": "K",
        "counts": "DN",
        "electrons": "e-",
        "saturated": "1",
        "under_range": "1",
        "over_range": "1",
        "tensor_max": "K",
        "tensor_mean": "K",
        "tensor_std": "K",
        "peak_error": "K",
        "uncertainty": "K",
        "integration_time": "s",
        "t_start": "s",
    }

    #: The per-pixel arrays and their units (``signal_mean``'s is :attr:`signal_unit`).
    ARRAYS: ClassVar[dict[str, str | None]] = {
        "apparent_temperature": "K", "counts": "DN", "electrons": "e-", "saturated": "1",
        "under_range": "1", "over_range": "1", "tensor_max": "K", "tensor_mean": "K",
        "tensor_std": "K", "signal_mean": None}

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

    def __post_init__(self):
        if self.over_range is None:
            object.__setattr__(self, "over_range", np.zeros(np.shape(self.saturated), bool))

    def __repr__(self) -> str:
        name = getattr(self.camera, "name", type(self.camera).__name__)
        valid = self.apparent_temperature[self.valid]
        reading = (f"{valid.min():.1f}–{valid.max():.1f} K" if valid.size else "no valid pixel")
        return (f"<Measurement {self.shape[0]} × {self.shape[1]} px by {name}: "
                f"{self.integration_time:g} s from {self.t_start:g} s ({self.n_frames} frames, "
                f"{self.alignment}); reads {reading}; {int(self.saturated.sum())} saturated, "
                f"{int(self.under_range.sum())} under range, "
                f"{int(self.over_range.sum())} over range>")

    def to_xarray(self):
        """
        The measurement as an :class:`xarray.Dataset`: dimensions ``y``, ``x`` with the pixel
        centres' coordinates [m] (object space, from the array's origin), every array a
        variable with its unit (``attrs["units"]``), flags as booleans, and as attributes the
        camera (TOML), the window and the scene (``scene:<key>``).
        :func:`radiosim.io.from_xarray` turns it back, and
        :func:`radiosim.io.write_netcdf` writes it.

        Examples
        --------
        >>> from radiosim import Camera, UniformBlackbody
        >>> scene = UniformBlackbody(500.0, (6, 8), 1e-6, 1e-6)
        >>> ds = Camera.linear_ideal(2e-6).measure(scene, 1e-6).to_xarray()
        >>> ds.apparent_temperature.dims, ds.apparent_temperature.units, ds.x.units
        (('y', 'x'), 'K', 'm')
        >>> (ds.x.values * 1e6).round(9).tolist()  # pixel centres [µm]
        [1.0, 3.0, 5.0, 7.0]
        """
        import xarray as xr

        from radiosim import __version__

        fpa = self.camera.fpa
        rows, cols = self.shape
        y = fpa.origin[0] + (np.arange(rows) + 0.5) * fpa.pixel_pitch
        x = fpa.origin[1] + (np.arange(cols) + 0.5) * fpa.pixel_pitch
        flags = ("saturated", "under_range", "over_range")
        data = {}
        for name, unit in self.ARRAYS.items():
            values = np.asarray(getattr(self, name))
            values = values.astype(bool) if name in flags else values.astype(np.float64)
            data[name] = (("y", "x"), values, {"units": unit or self.signal_unit})
        attrs = {"radiosim_version": __version__, "camera": self.camera.to_toml(),
                 "camera_name": self.camera.name, "signal_unit": self.signal_unit,
                 "alignment": self.alignment, "integration_time_s": self.integration_time,
                 "t_start_s": self.t_start, "n_frames": self.n_frames}
        for key, value in self.scene.items():
            attrs[f"scene:{key}"] = value
        return xr.Dataset(data, coords={"y": ("y", y, {"units": "m"}),
                                        "x": ("x", x, {"units": "m"})}, attrs=attrs)

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
