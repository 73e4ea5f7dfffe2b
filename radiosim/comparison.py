"""
A recording beside a simulation: registration, the common region, the difference and its
statistics (:func:`compare`, what ``radiosim compare`` does).

Registration finds the shift that best lays the simulated image on the recorded one: the
whole-pixel peak of their correlation (the inverse transform of the cross-power spectrum
normalised by the square root of its magnitude, between phase correlation — Foroosh, Zerubia
& Berthod 2002 — and the plain cross-correlation; flagged pixels filled from their nearest
neighbours), refined to a fraction of a pixel by minimising the variance of their difference; the simulated image is moved by that shift (linear
interpolation) and only pixels that both images hold are compared. An optional ``scale``
first resamples the simulation to the recording's pixel (the ratio of their pixels in object
space).

The difference is recorded minus simulated [K]; its statistics say how far the simulation is
from what the camera read, and the share of pixels within the simulation's uncertainty
(``coverage`` × the hypot of the measurement's scene spread, :attr:`Measurement.uncertainty
<radiosim.measurement.Measurement.uncertainty>`, and its camera's temporal noise, the NETD)
says whether the difference is explained.

References
----------
Foroosh, H., Zerubia, J. B. & Berthod, M. (2002). Extension of phase correlation to subpixel
registration. IEEE Transactions on Image Processing 11(3), 188–200.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from radiosim.calibration import fill_from_nearest
from radiosim.errors import RadiosimError

__all__ = ["Comparison", "compare", "register"]


@dataclass(frozen=True)
class Comparison:
    """
    A recorded and a simulated image over their common region.

    Attributes
    ----------
    shift : tuple of float
        (rows, columns) [pixels] the simulated image was moved by to lie on the recorded one.
    recorded, simulated, difference, uncertainty : numpy.ndarray
        Over the recording's frame [K]; NaN outside the common region (``difference`` =
        recorded − simulated; ``uncertainty`` the simulation's standard uncertainty).
    coverage : float
        The factor on ``uncertainty`` a difference must stay within to be explained.
    """

    shift: tuple[float, float]
    recorded: np.ndarray
    simulated: np.ndarray
    difference: np.ndarray
    uncertainty: np.ndarray
    coverage: float = 2.0

    @property
    def common(self) -> np.ndarray:
        """The pixels both images hold."""
        return np.isfinite(self.difference)

    def statistics(self) -> dict:
        """Mean, standard deviation and the 5th, 50th and 95th percentiles of the difference
        [K], the pixels compared, and the share within ``coverage`` × the uncertainty."""
        d = self.difference[self.common]
        if d.size == 0:
            raise RadiosimError("the recorded and simulated images have no pixel in common")
        u = self.uncertainty[self.common]
        p5, p50, p95 = np.percentile(d, [5, 50, 95])
        return {"pixels": int(d.size), "mean_K": float(d.mean()), "std_K": float(d.std()),
                "p5_K": float(p5), "median_K": float(p50), "p95_K": float(p95),
                "within_uncertainty": float(np.mean(np.abs(d) <= self.coverage * u)),
                "shift_rows": self.shift[0], "shift_columns": self.shift[1]}

    def to_xarray(self, history: str | None = None):
        """The comparison as a CF dataset (y, x): the three images and the uncertainty [K],
        the statistics in the attributes."""
        import xarray as xr

        from radiosim._version import __version__

        dims = ("y", "x")
        names = {"recorded": "recorded temperature", "simulated": "simulated apparent "
                 "temperature, registered", "difference": "recorded minus simulated",
                 "uncertainty": "standard uncertainty of the simulation"}
        data = {name: (dims, getattr(self, name), {"units": "K", "long_name": text})
                for name, text in names.items()}
        attrs = {"Conventions": "CF-1.10", "title": "recording beside simulation",
                 "history": history or f"radiosim {__version__} compare",
                 "coverage_factor": self.coverage}
        attrs |= {key: value for key, value in self.statistics().items()}
        return xr.Dataset(data, attrs=attrs)

    def figure(self):
        """Side by side, the difference and its histogram: a matplotlib figure."""
        from radiosim.plotting import figure

        fig = figure(12.0, 3.4)
        axes = fig.subplots(1, 4)
        finite = np.concatenate([self.recorded[self.common], self.simulated[self.common]])
        low, high = (np.percentile(finite, [1, 99]) if finite.size else (0.0, 1.0))
        for ax, image, title in ((axes[0], self.recorded, "recorded [K]"),
                                 (axes[1], self.simulated, "simulated, registered [K]")):
            shown = ax.imshow(image, vmin=low, vmax=high, cmap="inferno")
            ax.set_title(title)
            fig.colorbar(shown, ax=ax, shrink=0.8)
        d = self.difference[self.common]
        reach = float(np.percentile(np.abs(d), 99)) if d.size else 1.0
        shown = axes[2].imshow(self.difference, vmin=-reach, vmax=reach, cmap="RdBu_r")
        axes[2].set_title("recorded − simulated [K]")
        fig.colorbar(shown, ax=axes[2], shrink=0.8)
        axes[3].hist(d, bins=60, color="0.3")
        axes[3].set_xlabel("difference [K]")
        axes[3].set_title(f"mean {d.mean():+.2f} K, σ {d.std():.2f} K" if d.size else "")
        for ax in axes[:3]:
            ax.set_xticks([])
            ax.set_yticks([])
        return fig


def register(reference: np.ndarray, moving: np.ndarray) -> tuple[float, float]:
    """
    The shift (rows, columns) [pixels] that lays ``moving`` on ``reference`` (both 2-D, of one
    shape; NaN where an image holds nothing): the whole-pixel peak of their correlation
    (module docstring), then refined to a fraction of a pixel by minimising the variance of their
    difference over the pixels both hold, ``moving`` shifted by cubic interpolation (the
    variance, not the mean square: a uniform bias between the images does not move them).

    Examples
    --------
    >>> y, x = np.mgrid[0:64, 0:64]
    >>> spot = lambda cy, cx: np.exp(-((y - cy) ** 2 + (x - cx) ** 2) / 18.0)
    >>> [round(v, 2) for v in register(spot(30.0, 33.0), spot(27.6, 35.3))]
    [2.4, -2.3]
    """
    from scipy import ndimage, optimize

    reference, moving = (np.asarray(v, dtype=float) for v in (reference, moving))
    for image, name in ((reference, "reference"), (moving, "moving")):
        if image.ndim != 2 or not np.isfinite(image).any():
            raise RadiosimError(f"register: the {name} image must be 2-D with finite pixels, "
                                f"got shape {image.shape}")
    if reference.shape != moving.shape:
        raise RadiosimError(f"register: the images differ in shape: {reference.shape} and "
                            f"{moving.shape}")
    a, b = (fill_from_nearest(v) for v in (reference, moving))
    a, b = a - a.mean(), b - b.mean()
    window = np.outer(np.hanning(a.shape[0]), np.hanning(a.shape[1]))  # no edge wrap-around
    spectrum = np.fft.fft2(a * window) * np.conj(np.fft.fft2(b * window))
    magnitude = np.abs(spectrum)
    if not magnitude.max() > 0:
        raise RadiosimError("register: an image without features (uniform) cannot be "
                            "registered; give shift=")
    # normalised by the square root of its magnitude: between phase correlation (sharp, but
    # led by edges: a hole of flagged pixels, a smooth scene's rounding) and the plain
    # cross-correlation (led by the broad features that a scene and its simulation share)
    surface = np.fft.ifft2(spectrum / np.sqrt(np.maximum(magnitude,
                                                         1e-12 * magnitude.max()))).real
    peak = np.unravel_index(int(np.argmax(surface)), surface.shape)
    start = [float(p - n if p > n / 2 else p) for p, n in zip(peak, surface.shape)]
    filled = fill_from_nearest(moving)
    holds = np.isfinite(moving).astype(float)
    ref_holds = np.isfinite(reference)

    def spread(shift):
        moved = ndimage.shift(filled, shift, order=3, mode="constant", cval=np.nan)
        both = ref_holds & (ndimage.shift(holds, shift, order=1, mode="constant",
                                          cval=0.0) > 1 - 1e-9) & np.isfinite(moved)
        if both.sum() < 16:
            return np.inf
        return float(np.var(reference[both] - moved[both]))

    if not np.isfinite(spread(start)):
        raise RadiosimError("register: the images share fewer than 16 pixels at their "
                            "correlation's peak; give shift= or images that overlap")
    best = optimize.minimize(spread, start, method="Powell",
                             bounds=[(v - 1.5, v + 1.5) for v in start],
                             options={"xtol": 1e-4, "ftol": 1e-12})
    return float(best.x[0]), float(best.x[1])


def compare(recorded, measurement, camera=None, frame: int = 0, shift=None,
            scale: float | None = None, coverage: float = 2.0,
            **object_parameters) -> Comparison:
    """
    Lay a simulated :class:`~radiosim.measurement.Measurement` on a recorded image.

    Parameters
    ----------
    recorded
        A :class:`~radiosim.io.recordings.Recording` (its ``frame``, in kelvin through its
        own calibration or ``camera``'s, with ``object_parameters``) or a 2-D array of
        temperatures [K].
    measurement
        The simulation; its apparent temperature is compared (NaN where flagged).
    shift
        (rows, columns) [pixels] to use instead of registering the images.
    scale
        The simulation's pixel over the recording's, in object space: the simulated image is
        resampled by it first (``None``: the same pixel).
    coverage
        The factor on the uncertainty within which a difference is explained.

    Returns
    -------
    Comparison
    """
    from scipy import ndimage

    if not hasattr(measurement, "apparent_temperature") or not hasattr(measurement, "valid"):
        raise RadiosimError(f"compare needs a simulated Measurement, got "
                            f"{type(measurement).__name__}")
    if isinstance(coverage, bool) or not isinstance(coverage, (int, float)) or \
            not (np.isfinite(coverage) and coverage > 0):
        raise RadiosimError(f"coverage must be a finite number > 0, got {coverage!r}")
    if hasattr(recorded, "temperature") and hasattr(recorded, "counts"):
        image = recorded.temperature(camera, [frame], **object_parameters)[0]
    else:
        if camera is not None or object_parameters or frame != 0:
            raise RadiosimError("camera=, frame= and object parameters apply to a Recording; "
                                "the recorded image given is already temperatures [K]")
        try:
            image = np.asarray(recorded, dtype=float)
        except (TypeError, ValueError):
            raise RadiosimError(f"the recorded image must be 2-D temperatures [K], got "
                                f"{type(recorded).__name__}") from None
        if image.ndim != 2:
            raise RadiosimError(f"the recorded image must be 2-D temperatures [K], got shape "
                                f"{image.shape}")
    simulated = np.where(measurement.valid, measurement.apparent_temperature, np.nan)
    noise = _netd(measurement)
    uncertainty = np.hypot(measurement.uncertainty, noise)
    if scale is not None:
        if isinstance(scale, bool) or not isinstance(scale, (int, float)) or \
                not (np.isfinite(scale) and scale > 0):
            raise RadiosimError(f"scale must be a finite number > 0, got {scale!r}")
        simulated, uncertainty = (ndimage.zoom(v, scale, order=1, mode="nearest",
                                               prefilter=False) for v in
                                  (simulated, uncertainty))
    # The simulation on the recording's frame (cut or padded with NaN, top-left aligned)
    rows, cols = image.shape
    placed = np.full((2, rows, cols), np.nan)
    r, c = min(rows, simulated.shape[0]), min(cols, simulated.shape[1])
    placed[0, :r, :c] = simulated[:r, :c]
    placed[1, :r, :c] = uncertainty[:r, :c]
    if shift is None:
        shift = register(image, placed[0])
    try:
        rows_shift, cols_shift = (float(v) for v in shift)
    except (TypeError, ValueError):
        raise RadiosimError(f"shift must be (rows, columns) in pixels, got {shift!r}") from None
    if not (np.isfinite(rows_shift) and np.isfinite(cols_shift)):
        raise RadiosimError(f"shift must be finite, got {shift!r}")
    shift = (rows_shift, cols_shift)
    moved = [ndimage.shift(np.nan_to_num(v, nan=0.0), shift, order=1, mode="constant",
                           cval=np.nan) for v in placed]
    inside = ndimage.shift(np.isfinite(placed[0]).astype(float), shift, order=1,
                           mode="constant", cval=0.0) > 1 - 1e-9
    common = inside & np.isfinite(image)
    simulated_here = np.where(common, moved[0], np.nan)
    return Comparison(shift, np.where(common, image, np.nan), simulated_here,
                      np.where(common, image - moved[0], np.nan),
                      np.where(common, moved[1], np.nan), float(coverage))


def _netd(measurement) -> np.ndarray:
    """The simulation's temporal noise [K] at its apparent temperature (0 where it has none)."""
    camera = measurement.camera
    if getattr(camera, "channels", None) is not None:
        netd = measurement.ratio_netd
    else:
        try:
            netd = camera.calibration(measurement.integration_time).netd(
                np.where(measurement.valid, measurement.apparent_temperature, np.nan))
        except (RadiosimError, AttributeError):
            return np.zeros(measurement.shape)
    return np.nan_to_num(np.asarray(netd, dtype=float), nan=0.0)
