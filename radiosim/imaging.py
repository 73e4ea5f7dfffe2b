"""
Image formation: the radiance the optics bring to the focal plane from a scene that reflects
its surroundings, through a path, and blurred by the optics' point-spread function.

The integrator's fast path (:func:`radiosim.integrator.integrate`) averages each sample's own
emission over a pixel's footprint and the window. This stage is taken instead when the light
reaching a pixel also depends on other samples or on the environment:

1.  per sample and per spectral sub-band, the window mean of the surface's radiance
    ε L(T) + (1 − ε) L(T_refl) (emission and reflection of an opaque surface, Kirchhoff's law),
    one compiled pass per frame and sub-band (the engine's ``accumulate`` with one
    piece per sample);
2.  the path: τ · (that) + (1 − τ) · L(T_path) (:func:`radiosim.response.observed_signal`);
3.  the point-spread function, once per sub-band on the window mean (:func:`radiosim.psf.blur`,
    with the surroundings beyond the frame's edges as a blackbody at the scene's
    ``surroundings_temperature``). The PSF and the time average are both linear in radiance,
    so blurring the window's mean equals blurring every frame and averaging;
4.  the sub-bands add, and each pixel averages the result over its footprint.

Polychromatic diffraction needs the sub-bands: each sample's radiance is split by wavelength,
and a hot and a cold sample spread their light differently. The linear response (the paper's
ideal camera, whose signal is the temperature) has no spectrum: its one band uses the band's
centre wavelength, and it neither reflects nor sees a path.
"""

from __future__ import annotations

import math

import numpy as np

from radiosim.integrator import (FootprintIntegrator, Window, _prefetched, axis_footprints,
                                 frame_weights)
from radiosim.kernels.engines import get_engine
from radiosim.psf import PSF, blur
from radiosim.response import Response, observed_signal, reflectance
from radiosim.scenes.base import Scene, SceneFrame

__all__ = ["forms_image", "sub_band_count", "sample_signals", "image_signal"]


def forms_image(scene: Scene, response: Response, psfs) -> bool:
    """Whether a measurement needs this stage: a PSF, or a radiometric response on a scene that
    reflects or lies behind a path."""
    if psfs:
        return True
    return response.radiometric and (scene.reflected_temperature is not None
                                     or scene.path_transmission < 1.0)


def sub_band_count(psfs) -> int:
    """The spectral sub-bands a blur needs: the most any chromatic PSF asks for, else 1."""
    return max([p.sub_bands for p in psfs or () if p.chromatic], default=1)


class _Reflectances:
    """1 − ε of the emissivities met, kept so that the kernels' table caches recognise them."""

    def __init__(self):
        self._cache: dict[int, tuple] = {}

    def __call__(self, emissivity):
        if isinstance(emissivity, np.ndarray):
            return reflectance(emissivity)
        key = id(emissivity)
        if key not in self._cache:
            self._cache[key] = (emissivity, reflectance(emissivity))
        return self._cache[key][1]


def _reflection(frame: SceneFrame, complement: _Reflectances) -> SceneFrame:
    """The frame's reflected part as a frame: temperature T_refl, 'emissivity' 1 − ε."""
    temperature = np.empty(np.shape(frame.temperature))
    temperature[...] = frame.reflected_temperature
    regions = frame.region_emissivity
    return SceneFrame(temperature, complement(frame.emissivity), frame.regions,
                      None if regions is None else {c: complement(v) for c, v in
                                                    regions.items()}, frame.index)


def sample_signals(scene: Scene, window: Window, responses: list[Response],
                   progress=None, engine: str | None = None) -> np.ndarray:
    """
    Window mean of each sample's surface signal, ε L(T) + (1 − ε) L(T_refl), per response.

    Parameters
    ----------
    scene
        The scene (read over its whole frame).
    window
        The integration window [s].
    responses
        Response models (e.g. spectral sub-bands); a non-radiometric one gives the mean T.
    progress
        Called as ``progress(done, total)`` after each frame.
    engine
        The engine's name (:func:`radiosim.kernels.engines.get_engine`; ``None``: the chosen
        one).

    Returns
    -------
    numpy.ndarray
        (len(responses), rows, columns) [each response's unit].
    """
    accumulate = get_engine(engine).accumulate
    first, weights = frame_weights(window.start, window.duration, scene.dt, scene.n_frames)
    rows_n, cols_n = scene.shape
    rows = axis_footprints(rows_n, scene.dx, scene.dx, 1.0, rows_n, axis="y (rows)")
    cols = axis_footprints(cols_n, scene.dx, scene.dx, 1.0, cols_n, axis="x (columns)")
    out = np.zeros((len(responses), rows_n, cols_n))
    zero = np.zeros((rows_n, cols_n))
    # The kernels' temperature moments are not needed here: scratch accumulators.
    dev, sq, t_max = np.zeros_like(zero), np.zeros_like(zero), np.full_like(zero, -np.inf)
    complement = _Reflectances()
    full = (slice(0, rows_n), slice(0, cols_n))
    frames = range(first, first + weights.size)
    for done, frame in enumerate(_prefetched(scene, frames, full, checked=False), start=1):
        weight = float(weights[frame.index - first])
        reflection = (None if frame.reflected_temperature is None
                      else _reflection(frame, complement))
        for n, response in enumerate(responses):
            table = response.signal_table(frame)
            if table is None:  # the signal is T: its mean is the first moment about 0
                accumulate(frame.temperature, rows, cols, weight, zero, out[n], sq, t_max,
                           frame_index=frame.index)
                continue
            accumulate(frame.temperature, rows, cols, weight, zero, dev, sq, t_max, out[n],
                       table, frame_index=frame.index)
            if reflection is not None and response.radiometric:
                accumulate(reflection.temperature, rows, cols, weight, zero, dev, sq, t_max,
                           out[n], response.signal_table(reflection), frame_index=frame.index)
        if progress is not None:
            progress(done, weights.size)
    return out


def image_signal(scene: Scene, integrator: FootprintIntegrator, window: Window,
                 response: Response, psfs: tuple[PSF, ...] | None, band: tuple[float, float],
                 object_na: float, progress=None, engine: str | None = None) -> np.ndarray:
    """
    Mean signal per pixel [response unit] of the image the optics form (module docstring).

    Parameters
    ----------
    scene, integrator, window, response
        As for :func:`radiosim.integrator.integrate`.
    psfs
        The optics' PSFs (their convolution), or ``None`` for a perfect lens.
    band
        The optics' band (λ1, λ2) [m]: the linear response's blur uses its centre.
    object_na
        Object-side numerical aperture of the working cone [1] (for diffraction).
    progress
        Called as ``progress(done, total)`` after each frame.
    engine
        As for :func:`sample_signals`.

    Returns
    -------
    numpy.ndarray
        Mean signal per pixel.
    """
    bands = response.sub_bands(sub_band_count(psfs))
    maps = sample_signals(scene, window, [r for r, _ in bands], progress, engine)
    tau, path_temperature = scene.path_transmission, scene.path_temperature
    total = np.zeros(scene.shape)
    for (sub, wavelength), field in zip(bands, maps):
        if math.isnan(wavelength):
            wavelength = 0.5 * (band[0] + band[1])
        if sub.radiometric:
            surroundings = float(sub.grey_signal(scene.surroundings_temperature))
            if tau < 1.0:
                path = float(sub.grey_signal(path_temperature))
                field = observed_signal(field, 0.0, tau, path)
                surroundings = observed_signal(surroundings, 0.0, tau, path)
        else:
            surroundings = scene.surroundings_temperature
        total += blur(field, surroundings, psfs, scene.dx, wavelength, object_na) if psfs \
            else field
    rows, cols = integrator.region
    return integrator.pixel_mean(integrator.expand(total[rows, cols]))
