"""
Camera characterisation after EMVA 1288: the photon-transfer curve and what it recovers.

A flat field (a uniform blackbody) is recorded twice at each exposure level; the mean of the
pair gives μ_y [DN] and half the variance of their difference gives the temporal variance σ²_y
[DN²] free of fixed-pattern noise. Below saturation σ²_y − σ²_y,dark = K (μ_y − μ_y,dark), so a
line fitted over the linear range (up to 70 % of saturation, as the standard prescribes) gives
the system gain K [DN/e⁻]; the dark variance gives the dark noise σ_d = √(σ²_y,dark − 1/12)/K
[e⁻]; and the saturation capacity is the charge (μ_y − μ_y,dark)/K where the variance peaks.

References
----------
-   EMVA Standard 1288, Release 4.0 Linear (2021), sections 6 and 8.
"""

from __future__ import annotations

import dataclasses
import warnings
from dataclasses import dataclass

import numpy as np

from radiosim.errors import RadiosimError, RadiosimWarning
from radiosim.scenes.analytic import UniformBlackbody

__all__ = ["PhotonTransfer", "photon_transfer", "EmvaResult", "fit_emva1288"]


@dataclass(frozen=True)
class PhotonTransfer:
    """
    A photon-transfer curve.

    Attributes
    ----------
    temperature : numpy.ndarray
        Blackbody temperature of each level [K].
    mean : numpy.ndarray
        Mean digital signal μ_y of each level [DN].
    variance : numpy.ndarray
        Temporal variance σ²_y of each level [DN²].
    dark_mean, dark_variance : float
        The same without light [DN], [DN²].
    """

    temperature: np.ndarray
    mean: np.ndarray
    variance: np.ndarray
    dark_mean: float
    dark_variance: float


def photon_transfer(camera, integration_time: float, temperatures, pixels=(64, 64),
                    rng=None) -> PhotonTransfer:
    """
    Record flat-field pairs of a camera at blackbody ``temperatures`` [K].

    The dark level is a pair taken with no light (photo-electrons set to zero through the
    electronics alone). Frames go through the full chain (:meth:`Camera.measure`).
    """
    rng = np.random.default_rng(rng)
    temperatures = np.asarray(temperatures, dtype=float)
    pitch = camera.fpa.pixel_pitch
    shape = (pixels[0], pixels[1])
    camera = camera.replace(fpa=dataclasses.replace(camera.fpa, shape=shape))
    dark_pair = [camera.electronics.expose(np.zeros(shape), integration_time, rng).counts
                 for _ in range(2)]
    means, variances = [], []
    for t in temperatures:
        scene = UniformBlackbody(t, shape=shape, dx=pitch, dt=integration_time)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RadiosimWarning)
            pair = [camera.measure(scene, integration_time, t_start=0.0, rng=rng).counts
                    for _ in range(2)]
        means.append(0.5 * (pair[0].mean() + pair[1].mean()))
        variances.append(np.var(pair[0] - pair[1]) / 2)
    return PhotonTransfer(temperatures, np.array(means), np.array(variances),
                          float(0.5 * (dark_pair[0].mean() + dark_pair[1].mean())),
                          float(np.var(dark_pair[0] - dark_pair[1]) / 2))


@dataclass(frozen=True)
class EmvaResult:
    """
    What the photon-transfer curve recovers.

    Attributes
    ----------
    gain : float
        System gain K [DN/e⁻].
    dark_noise : float
        Temporal dark noise σ_d [e⁻ rms] (read noise and dark-current shot noise).
    saturation_capacity : float
        Charge at the variance peak [e⁻].
    linear_range : numpy.ndarray of bool
        Levels used for the gain fit.
    """

    gain: float
    dark_noise: float
    saturation_capacity: float
    linear_range: np.ndarray


def fit_emva1288(ptc: PhotonTransfer, linear_fraction: float = 0.7) -> EmvaResult:
    """Gain, dark noise and saturation capacity from a photon-transfer curve."""
    signal = ptc.mean - ptc.dark_mean
    noise = ptc.variance - ptc.dark_variance
    peak = int(np.argmax(ptc.variance))
    if peak == 0 or peak == ptc.mean.size - 1:
        raise RadiosimError("the variance does not peak inside the levels: extend them past "
                            "saturation")
    linear = (signal > 0) & (signal <= linear_fraction * signal[peak])
    linear[peak:] = False
    if linear.sum() < 3:
        raise RadiosimError("fewer than 3 levels in the linear range: add lower levels")
    gain = float(np.sum(signal[linear] * noise[linear]) / np.sum(signal[linear] ** 2))
    dark_noise = float(np.sqrt(max(ptc.dark_variance - 1 / 12, 0.0)) / gain)
    return EmvaResult(gain=gain, dark_noise=dark_noise,
                      saturation_capacity=float(signal[peak] / gain), linear_range=linear)
