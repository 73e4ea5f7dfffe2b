"""Measuring a PSF from a disc's image, in closed loop: discs measured through radiosim's own
imaging (the PSF applied on the scene's samples, then each pixel's footprint integrated — a
different path from the fit's pixel-grid model) with a known Gaussian core and scatter halo."""

import dataclasses

import numpy as np
import pytest

import radiosim as rs
from conftest import one_line_naming
from radiosim.errors import RadiosimError
from radiosim.psf import GaussianBlur, ScatterHalo
from radiosim.psf_measurement import fit_disc_psf
from radiosim.scenes import FrameStack

BASE = rs.Camera.preset("nist-ir")
PITCH = BASE.fpa.pixel_pitch
SUB, N = 3, 72
IDEAL = dataclasses.replace(BASE.electronics, read_noise=0.0, shot_noise=False, adc_bits=None)


def disc_measurement(psf, fill_factor=1.0, electronics=IDEAL, rng=None):
    y, x = (np.mgrid[0:N * SUB, 0:N * SUB] + 0.5) / SUB
    scene = np.where(np.hypot(y - 35.3, x - 36.6) < 17.0, 900.0, 500.0)
    camera = BASE.replace(optics=dataclasses.replace(BASE.optics, psf=psf),
                          fpa=dataclasses.replace(BASE.fpa, shape=None, fill_factor=fill_factor),
                          electronics=electronics)
    # beyond the frame, the surround goes on (the fit's model of the world outside the frame)
    stack = FrameStack(scene[None].repeat(2, 0), dt=10e-6, dx=PITCH / SUB).set_environment(
        surroundings_temperature=500.0)
    m = camera.measure(stack, 10e-6, rng=rng)
    signal = camera.calibration(10e-6).object_signal(m.counts)
    return signal, camera


@pytest.mark.parametrize("fill_factor", [1.0, 0.7])
def test_a_gaussian_core_and_halo_are_recovered_from_a_disc(fill_factor):
    psf = (GaussianBlur(1.5 * PITCH), ScatterHalo(0.1, 5 * PITCH))
    signal, _ = disc_measurement(psf, fill_factor)
    fit = fit_disc_psf(signal, PITCH, fill_factor)
    # The disc's own geometry, in pixels: its centre and radius as the scene drew them.
    assert fit.centre == pytest.approx((35.3, 36.6), abs=0.02)
    assert fit.radius == pytest.approx(17.0, abs=0.02)
    # Noise-free: what remains is the scene's disc drawn on samples a third of a pixel apart,
    # the pixel-grid model's aliasing (the Gaussian's transfer at the pixels' Nyquist
    # frequency is 1e-2) and its straight-edge share of a pixel (within 1 % of a pixel's
    # area): a per cent or two on the PSF's parameters.
    assert fit.sigma == pytest.approx(1.5, rel=0.02)
    assert fit.halo_fraction == pytest.approx(0.1, rel=0.03)
    assert fit.halo_width == pytest.approx(5.0, rel=0.03)
    assert fit.psf[0].sigma == pytest.approx(fit.sigma * PITCH)


def test_noise_and_hot_pixels_do_not_pull_the_fit():
    psf = (GaussianBlur(1.5 * PITCH),)
    signal, camera = disc_measurement(psf, electronics=BASE.electronics, rng=4)
    signal = signal.copy()
    signal[20:23, 52] *= 3.0  # hot pixels beside the edge
    fit = fit_disc_psf(signal, PITCH)
    assert fit.sigma == pytest.approx(1.5, rel=0.05)
    assert fit.halo_fraction < 0.01


def test_what_is_no_disc_is_named():
    with pytest.raises(RadiosimError) as info:
        fit_disc_psf(np.ones((40, 40)), PITCH)
    one_line_naming(info, "no disc")
    with pytest.raises(RadiosimError) as info:
        fit_disc_psf(np.ones((8, 40)), PITCH)
    one_line_naming(info, "16 × 16", "(8, 40)")
    with pytest.raises(RadiosimError) as info:
        fit_disc_psf(np.ones((40, 40)), -1.0)
    one_line_naming(info, "pixel_pitch", "-1.0")


@pytest.mark.parametrize("kwargs, said", [
    ({"reach": 2.0}, ("reach", "2.0")),
    ({"reach": float("nan")}, ("reach", "nan")),
    ({"valid": np.ones((10, 10), bool)}, ("valid", "(10, 10)")),
    ({"valid": np.ones(72, bool)}, ("valid", "(72,)")),
    ({"fill_factor": 1.5}, ("fill_factor", "1.5")),
])
def test_bad_fit_arguments_are_named(kwargs, said):
    signal, _ = disc_measurement((GaussianBlur(1.5 * PITCH),))
    with pytest.raises(RadiosimError) as info:
        fit_disc_psf(signal, PITCH, **kwargs)
    one_line_naming(info, *said)


def test_a_numpy_pitch_and_a_short_reach_are_taken():
    signal, _ = disc_measurement((GaussianBlur(1.5 * PITCH),))
    fit = fit_disc_psf(signal, np.float32(PITCH), reach=8)
    assert fit.sigma == pytest.approx(1.5, rel=0.05)
