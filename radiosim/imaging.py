"""
Image formation: the radiance the optics bring to the focal plane from a scene that reflects
its surroundings, through a path, and blurred by the optics' point-spread function.

The integrator's fast path (:func:`radiosim.integrator.integrate`) averages each sample's own
emission over a pixel's footprint and the window. This stage is taken instead when the light
reaching a pixel also depends on other samples or on the environment:

1.  per sample and per spectral sub-band, the window mean of the surface's radiance
    ε L(T) + (1 − ε) L(T_refl) (emission and reflection of an opaque surface, Kirchhoff's law),
    all sub-bands from one table lookup per sample (:class:`SubBandSignals`), in one pass over
    the frames with the integrator's (:class:`~radiosim.integrator.EnginePass`) where the
    statistics are wanted too (:func:`image_statistics`);
2.  the path: τ · (that) + (1 − τ) · L(T_path) (:func:`radiosim.response.observed_signal`);
3.  the point-spread function on the window mean, all sub-bands in one inverse transform
    (:func:`radiosim.psf.blur_bands`,
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

import dataclasses
import math

import numpy as np

from radiosim.interrupts import raise_if_interrupted
from radiosim.frame_reading import IMAGE_BLOCK, frame_blocks
from radiosim.integrator import (EnginePass, FootprintIntegrator, Job, TensorStatistics,
                                 Window)
from radiosim.kernels.engines import Engine, get_engine, using_engine
from radiosim.psf import PSF, blur_bands
from radiosim.response import LinearResponse, Response, observed_signal, reflectance
from radiosim.scenes.base import Scene, SceneFrame

__all__ = ["forms_image", "sub_band_count", "SubBandSignals", "sample_signals", "form_image",
           "image_signal", "image_statistics"]


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


class SubBandSignals:
    """
    The window mean of each sample's surface signal per response (sub-band), fed frame by
    frame or by blocks of consecutive frames sharing their maps (:meth:`add`): the running sums
    of :func:`sample_signals`, fed beside the integrator's pass in :func:`image_statistics` so
    that one pass over the frames gives the tensor statistics and the image. The radiometric responses' signals come
    from the engine's ``accumulate_bands`` (the compiled one: one table lookup per sample for
    all sub-bands, :func:`radiosim.kernels.bands.accumulate_bands`).
    """

    def __init__(self, scene: Scene, window: Window, responses: list[Response],
                 engine: str | Engine | None = None):
        self.first, self.weights = scene.window_frames(window)
        self.stop = self.first + self.weights.size
        self.responses = list(responses)
        #: The region of the scene it reads: the whole frame.
        self.region = (slice(0, scene.shape[0]), slice(0, scene.shape[1]))
        #: (responses, rows, columns): Σ w_t S per sample [each response's unit].
        self.out = np.zeros((len(self.responses), *scene.shape))
        self.engine = get_engine(engine)
        self._complement = _Reflectances()

    def add(self, temperature: np.ndarray, frame: SceneFrame, start: int) -> None:
        """Frames ``start``, ``start + 1``, … (``temperature``: one 2-D frame or a 3-D block
        of consecutive frames sharing their maps, over the whole scene; ``frame``: the first
        one's scene frame, for its emissivity and reflections)."""
        block = temperature if temperature.ndim == 3 else temperature[None]
        lo, hi = max(start, self.first), min(start + block.shape[0], self.stop)
        if lo >= hi:
            return
        block = block[lo - start:hi - start]
        weights = self.weights[lo - self.first:lo - self.first + block.shape[0]]
        self._add(block, weights, frame, lo)
        if frame.reflected_temperature is not None:
            radiometric = [n for n, r in enumerate(self.responses) if r.radiometric]
            if radiometric and not self._add_uniform(block.shape[0], weights, frame, lo,
                                                     radiometric):
                reflection = _reflection(frame, self._complement)
                t = np.broadcast_to(reflection.temperature, block.shape)
                self._add(t, weights, reflection, lo, radiometric)

    def _add_uniform(self, n_frames, weights, frame, index, which) -> bool:
        """The reflected part of a grey frame (one scalar emissivity, no regions, one
        reflected temperature) is the same at every sample: the engine's sums for one sample
        (the same operations as at each of the frame's samples) added to every sample.
        Returns whether it was taken (else the caller takes the pass over the frame)."""
        t_refl = frame.reflected_temperature
        if frame.regions is not None or isinstance(frame.emissivity, np.ndarray) \
                or isinstance(t_refl, np.ndarray):
            return False
        one = SceneFrame(np.full((1, 1), t_refl, dtype=float), self._complement(frame.emissivity),
                         None, None, frame.index)
        tables = [self.responses[n].signal_table(one) for n in which]
        if any(t is None or t.grey_scalar is None or t.index is not None for t in tables):
            return False
        block = np.full((n_frames, 1, 1), t_refl, dtype=float)
        sums = np.zeros((len(tables), 1, 1))
        self.engine.accumulate_bands(block, weights, tables, sums, frame_index=index)
        for row, n in enumerate(which):
            self.out[n] += sums[row, 0, 0]
        return True

    def _add(self, block, weights, frame, index, which=None):
        which = range(len(self.responses)) if which is None else which
        tables, rows = [], []
        for n in which:
            table = self.responses[n].signal_table(frame)
            if table is None:  # the signal is T: its mean is Σ w T
                for f in range(block.shape[0]):
                    self.out[n] += float(weights[f]) * block[f]
            else:
                tables.append(table)
                rows.append(n)
        if not tables:
            return
        every = len(rows) == self.out.shape[0]
        out = self.out if every else np.zeros((len(rows), *self.out.shape[1:]))
        self.engine.accumulate_bands(block, weights, tables, out, frame_index=index)
        if not every:
            self.out[rows] += out

    def signals(self) -> np.ndarray:
        """(responses, rows, columns): the window mean of each response's signal."""
        return self.out


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
    signals = SubBandSignals(scene, window, responses, engine)
    _one_pass(scene, range(signals.first, signals.stop), signals, [], progress)
    return signals.signals()


def _one_pass(scene: Scene, frames, signals: SubBandSignals, passes: list, progress) -> None:
    """Each block of ``frames`` over the whole scene (large frames stacked too: the sub-band
    sums are read and written once per block) to the sub-band sums ``signals`` and to each
    :class:`~radiosim.integrator.EnginePass` of ``passes``, in the engine of ``signals``
    (a scene's own terms follow it); ``progress(done, total)`` after each block."""
    frames = list(frames)
    done = 0
    with using_engine(signals.engine):
        for sample, temperature, n in frame_blocks(scene, frames, signals.region, IMAGE_BLOCK,
                                                   reflections=True):
            raise_if_interrupted()  # one the work swallowed: raised again, block by block
            for engine_pass in passes:
                engine_pass.add(temperature, sample, signals.region)
            signals.add(temperature, sample, sample.index)
            done += n
            if progress is not None:
                progress(done, len(frames))


def form_image(scene: Scene, integrator: FootprintIntegrator, bands, maps: np.ndarray,
               psfs, band: tuple[float, float], object_na: float,
               engine: str | Engine | None = None) -> np.ndarray:
    """
    The mean signal per pixel of the image of the window-mean sub-band signals ``maps``
    (:func:`sample_signals`, one per ``(response, wavelength)`` of ``bands``): the path, the
    blur of all sub-bands (:func:`radiosim.psf.blur_bands`, one inverse transform) and each
    pixel's footprint (steps 2–4 of the module docstring); the blur's transforms are the
    engine's (``fft``).
    """
    tau, path_temperature = scene.path_transmission, scene.path_temperature
    fields, surroundings, wavelengths = [], [], []
    for (sub, wavelength), field in zip(bands, maps):
        if math.isnan(wavelength):
            wavelength = 0.5 * (band[0] + band[1])
        if sub.radiometric:
            around = float(sub.grey_signal(scene.surroundings_temperature))
            if tau < 1.0:
                path = float(sub.grey_signal(path_temperature))
                field = observed_signal(field, 0.0, tau, path)
                around = observed_signal(around, 0.0, tau, path)
        else:
            around = scene.surroundings_temperature
        fields.append(field)
        surroundings.append(around)
        wavelengths.append(wavelength)
    if psfs:
        total = blur_bands(fields, surroundings, psfs, scene.dx, wavelengths, object_na,
                           engine=engine)
    else:
        total = np.zeros(scene.shape)
        for field in fields:
            total += field
    rows, cols = integrator.region
    return integrator.pixel_mean(integrator.expand(total[rows, cols]))


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
    return form_image(scene, integrator, bands, maps, psfs, band, object_na, engine)


def image_statistics(scene: Scene, integrator: FootprintIntegrator, window: Window,
                     response: Response, psfs: tuple[PSF, ...] | None,
                     band: tuple[float, float], object_na: float, progress=None,
                     engine: str | None = None) -> TensorStatistics:
    """
    The tensor statistics of the scene truth (T over footprint × window, as
    :func:`radiosim.integrator.integrate`) with ``signal_mean`` the image's
    (:func:`image_signal`), from ONE pass over the frames: each block of frames goes to the
    scene truth's moments (:class:`~radiosim.integrator.EnginePass`) and to the sub-band
    signals at sample resolution (:class:`SubBandSignals`). Arguments as
    :func:`image_signal`; returns the same ``signal_mean`` and the same mean, std and max as
    the two passes.
    """
    bands = response.sub_bands(sub_band_count(psfs))
    signals = SubBandSignals(scene, window, [r for r, _ in bands], engine)
    # The statistics are the scene truth's T moments: the job's own signal is not needed
    # (the linear response's is T itself, formed with the moments).
    truth = EnginePass(scene, [Job(integrator, window, _TRUTH)], engine)
    frames = sorted(set(truth.frames) | set(range(signals.first, signals.stop)))
    _one_pass(scene, frames, signals, [truth], progress)
    image = form_image(scene, integrator, bands, signals.signals(), psfs, band, object_na,
                       engine)
    return dataclasses.replace(truth.statistics()[0], signal_mean=image)


#: The response of the statistics' job in :func:`image_statistics` (its signal is T).
_TRUTH = LinearResponse()
