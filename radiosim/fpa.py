"""
The focal-plane array's geometry, quantum efficiency and fixed pattern.

The integrator lays the array's pixel cells on the scene (:attr:`FocalPlaneArray.pixel_pitch`,
:attr:`~FocalPlaneArray.fill_factor`, :attr:`~FocalPlaneArray.origin`,
:attr:`~FocalPlaneArray.shape`); the optics use the active area on the focal plane for the
étendue; the quantum efficiency is one of the spectral factors of the Planck response.

The fixed pattern (EMVA 1288's spatial model) is what makes pixels differ: photo-response
non-uniformity (PRNU, a per-pixel gain 1 + PRNU·z on the photo-charge), dark-signal
non-uniformity (DSNU, a per-pixel offset of the readout [e⁻ equivalent], without shot noise), a per-pixel spread of the
non-linearity, dead pixels (no photo-response) and hot pixels (a stuck, full well). The maps
are drawn from the array's own ``pattern_seed`` for its full shape, so the same camera always
has the same pattern, or read from an NPZ file (:class:`FixedPattern`).

References
----------
-   EMVA Standard 1288, Release 4.0 Linear (2021), §4.5 (the spatial model: DSNU, PRNU).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from radiosim.checks import check_count, check_fraction, check_positive
from radiosim.config import edge_field
from radiosim.errors import RadiosimError
from radiosim.spectral import as_spectrum
from radiosim.units import MICRO

if TYPE_CHECKING:  # colour-science is imported when a curve is built
    from colour import SpectralDistribution

__all__ = ["FocalPlaneArray", "FixedPattern"]


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
    prnu : float
        Photo-response non-uniformity: rms of the per-pixel gain's deviation from 1 [1].
    dsnu : float
        Dark-signal non-uniformity: rms of the per-pixel dark offset [e⁻].
    nonlinearity_spread : float
        rms of the per-pixel non-linearity's relative deviation from the electronics'
        ``nonlinearity`` [1].
    dead_fraction, hot_fraction : float
        Fractions of dead (no photo-response) and hot (a stuck, full well) pixels [1].
    pattern_seed : int
        Seed of the fixed-pattern maps (the array's identity).
    pattern_file : str or None
        NPZ file of measured maps instead (arrays ``prnu`` [1], ``dsnu_e`` [e⁻], and optionally
        ``nonlinearity``, ``dead``, ``hot``), at least as large as the array.
    readout : str
        ``"itr"`` (integrate then read: the frame period is the integration plus the readout)
        or ``"iwr"`` (integrate while reading the previous frame: the longer of the two).
    row_time, pixel_time, readout_overhead : float
        The readout time of a window of r rows × c columns is r·row_time + r·c·pixel_time +
        overhead [s] (the form of FLIR's manuals).
    shutter : str
        ``"snapshot"`` (every pixel integrates over the same window) or ``"rolling"`` (row i's
        window starts i·row_time later).

    Examples
    --------
    >>> fpa = FocalPlaneArray(6e-6, detector_pitch=30e-6, fill_factor=0.85)
    >>> fpa.magnification, round(fpa.active_area * 1e12, 6)
    (5.0, 765.0)
    """

    pixel_pitch: float = edge_field(None, "pixel_pitch_um", MICRO,
                                    doc="object-space pixel pitch in µm")
    shape: tuple[int, int] | None = edge_field(None, "shape", kind="ints",
                                               doc="rows, columns")
    fill_factor: float = edge_field(1.0, "fill_factor", doc="active area fraction")
    detector_pitch: float | None = edge_field(None, "detector_pitch_um", MICRO,
                                              doc="focal-plane pixel pitch in µm")
    quantum_efficiency: float | SpectralDistribution = edge_field(
        1.0, "quantum_efficiency", kind="curve", doc="quantum efficiency curve or number")
    origin: tuple[float, float] = edge_field((0.0, 0.0), "origin_um", MICRO, kind="numbers",
                                             doc="offset (y, x) of the first pixel cell in µm")
    prnu: float = edge_field(0.0, "prnu", doc="photo-response non-uniformity, rms [1]")
    dsnu: float = edge_field(0.0, "dsnu_e", doc="dark-signal non-uniformity, rms [e⁻]")
    nonlinearity_spread: float = edge_field(0.0, "nonlinearity_spread",
                                            doc="rms relative spread of the non-linearity [1]")
    dead_fraction: float = edge_field(0.0, "dead_fraction", doc="fraction of dead pixels")
    hot_fraction: float = edge_field(0.0, "hot_fraction", doc="fraction of hot pixels")
    pattern_seed: int = edge_field(0, "pattern_seed", kind="int",
                                   doc="seed of the fixed-pattern maps")
    pattern_file: str | None = edge_field(None, "pattern_file", kind="str",
                                          doc="NPZ file of measured pattern maps")
    readout: str = edge_field("itr", "readout", kind="str", doc="'itr' or 'iwr'")
    row_time: float = edge_field(0.0, "row_time_us", MICRO, doc="readout time per row [µs]")
    pixel_time: float = edge_field(0.0, "pixel_time_us", MICRO,
                                   doc="readout time per pixel [µs]")
    readout_overhead: float = edge_field(0.0, "readout_overhead_us", MICRO,
                                         doc="readout overhead per frame [µs]")
    shutter: str = edge_field("snapshot", "shutter", kind="str", doc="'snapshot' or 'rolling'")

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
        for name in ("prnu", "dsnu", "nonlinearity_spread"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0):
                raise RadiosimError(f"{name} must be ≥ 0, got {value!r}")
        if not (0 <= self.dead_fraction and 0 <= self.hot_fraction
                and self.dead_fraction + self.hot_fraction <= 1):
            raise RadiosimError(f"dead_fraction and hot_fraction must be ≥ 0 with a sum ≤ 1, got "
                                f"{self.dead_fraction!r} and {self.hot_fraction!r}")
        object.__setattr__(self, "pattern_seed",
                           check_count(self.pattern_seed, "pattern_seed", 0))
        if self.readout not in ("itr", "iwr"):
            raise RadiosimError(f"readout must be 'itr' (integrate then read) or 'iwr' "
                                f"(integrate while read), got {self.readout!r}")
        if self.shutter not in ("snapshot", "rolling"):
            raise RadiosimError(f"shutter must be 'snapshot' or 'rolling', got {self.shutter!r}")
        for name in ("row_time", "pixel_time", "readout_overhead"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0):
                raise RadiosimError(f"{name} must be ≥ 0 [s], got {value!r}")

    def readout_time(self, shape: tuple[int, int]) -> float:
        """Time to read a window of ``shape`` (rows, columns) pixels [s]."""
        rows, cols = shape
        return rows * self.row_time + rows * cols * self.pixel_time + self.readout_overhead

    def frame_period(self, integration_time: float, shape: tuple[int, int]) -> float:
        """
        Shortest frame period [s] at ``integration_time`` [s] for a window of ``shape``:
        integration plus readout (``itr``), or the longer of the two (``iwr``).

        Examples
        --------
        >>> fpa = FocalPlaneArray(6e-6, row_time=10e-6, readout_overhead=100e-6)
        >>> round(fpa.frame_period(50e-6, (120, 160)) * 1e6, 6)  # 50 + 1200 + 100 µs
        1350.0
        """
        readout = self.readout_time(shape)
        if self.readout == "itr":
            return integration_time + readout
        return max(integration_time, readout)

    @property
    def magnification(self) -> float:
        """Image size over object size (dimensionless)."""
        return 1.0 if self.detector_pitch is None else self.detector_pitch / self.pixel_pitch

    @property
    def active_area(self) -> float:
        """Photosensitive area of one pixel on the focal plane [m²]."""
        return self.fill_factor * (self.pixel_pitch * self.magnification) ** 2

    @property
    def has_pattern(self) -> bool:
        """Whether the pixels differ at all (a fixed pattern, dead or hot pixels)."""
        return bool(self.prnu or self.dsnu or self.nonlinearity_spread or self.dead_fraction
                    or self.hot_fraction or self.pattern_file)

    def pattern(self, shape: tuple[int, int]) -> FixedPattern | None:
        """
        The fixed pattern of the first ``shape`` (rows, columns) pixels, or ``None`` if the
        pixels do not differ. Maps are drawn for the array's own shape (or ``shape`` when it
        has none) from :attr:`pattern_seed`, and cropped.

        Examples
        --------
        >>> fpa = FocalPlaneArray(6e-6, shape=(64, 64), prnu=0.01, pattern_seed=3)
        >>> a, b = fpa.pattern((64, 64)), fpa.pattern((8, 8))
        >>> bool(np.array_equal(a.gain[:8, :8], b.gain)), round(float(a.gain.std()), 2)
        (True, 0.01)
        """
        if not self.has_pattern:
            return None
        full = tuple(self.shape) if self.shape is not None else tuple(shape)
        if shape[0] > full[0] or shape[1] > full[1]:
            raise RadiosimError(f"{shape} pixels measured on a {full} array")
        if self.pattern_file is not None:
            pattern = FixedPattern.from_file(self.pattern_file, full)
        else:
            pattern = FixedPattern.draw(full, self.prnu, self.dsnu, self.nonlinearity_spread,
                                        self.dead_fraction, self.hot_fraction,
                                        self.pattern_seed)
        return pattern.crop(shape)


@dataclass(frozen=True, eq=False)
class FixedPattern:
    """
    Per-pixel maps of the fixed pattern.

    Attributes
    ----------
    gain : numpy.ndarray
        Photo-response of each pixel relative to the array's, 1 + PRNU·z [1].
    dark : numpy.ndarray
        Dark-charge offset of each pixel [e⁻].
    nonlinearity : numpy.ndarray
        Each pixel's non-linearity relative to the electronics' ``nonlinearity`` [1].
    dead, hot : numpy.ndarray of bool
        Pixels with no photo-response, and pixels whose well is stuck full.
    """

    gain: np.ndarray
    dark: np.ndarray
    nonlinearity: np.ndarray
    dead: np.ndarray
    hot: np.ndarray

    @classmethod
    def draw(cls, shape, prnu: float, dsnu: float, spread: float, dead: float, hot: float,
             seed: int) -> FixedPattern:
        """Maps drawn from independent normal deviates z (and uniform ones for dead and hot
        pixels) of a generator seeded with ``seed``."""
        rng = np.random.default_rng(seed)
        z = rng.standard_normal((3, *shape))
        u = rng.random(shape)
        return cls(1.0 + prnu * z[0], dsnu * z[1], 1.0 + spread * z[2], u < dead,
                   (u >= dead) & (u < dead + hot))

    @classmethod
    def from_file(cls, path, shape) -> FixedPattern:
        """Maps from an NPZ file (``prnu`` [1], ``dsnu_e`` [e⁻]; optional ``nonlinearity``,
        ``dead``, ``hot``), cropped to ``shape``."""
        path = Path(path)
        try:
            with np.load(path) as data:
                maps = {k: np.asarray(data[k]) for k in data.files}
        except (OSError, ValueError) as exc:
            raise RadiosimError(f"cannot read the pattern file {path}: {exc}") from None
        missing = {"prnu", "dsnu_e"} - set(maps)
        if missing:
            raise RadiosimError(f"pattern file {path} lacks {sorted(missing)}")
        out = {}
        for key, name, default in (("prnu", "gain", None), ("dsnu_e", "dark", None),
                                   ("nonlinearity", "nonlinearity", 1.0),
                                   ("dead", "dead", False), ("hot", "hot", False)):
            value = maps.get(key)
            if value is None:
                value = np.full(shape, default)
            if value.ndim != 2 or value.shape[0] < shape[0] or value.shape[1] < shape[1]:
                raise RadiosimError(f"pattern file {path}: {key} has shape {value.shape}, "
                                    f"expected at least {tuple(shape)}")
            value = value[:shape[0], :shape[1]]
            if value.dtype != bool and not np.all(np.isfinite(value)):
                raise RadiosimError(f"pattern file {path}: {key} holds NaN or infinite values")
            out[name] = value
        return cls(1.0 + out["gain"].astype(float), out["dark"].astype(float),
                   out["nonlinearity"].astype(float), out["dead"].astype(bool),
                   out["hot"].astype(bool))

    def crop(self, shape) -> FixedPattern:
        """The maps of the first ``shape`` pixels."""
        rows, cols = shape
        return FixedPattern(*(m[:rows, :cols] for m in (self.gain, self.dark, self.nonlinearity,
                                                        self.dead, self.hot)))
