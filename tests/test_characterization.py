"""EMVA 1288 characterisation recovers the configured electronics; measurable range."""

import math

import numpy as np
import pytest

from radiosim import Camera
from radiosim.characterization import fit_emva1288, photon_transfer


@pytest.fixture(scope="module")
def result():
    camera = Camera.preset("nist-ir")
    ptc = photon_transfer(camera, 10e-6, np.linspace(300.0, 700.0, 41), pixels=(64, 64), rng=1)
    return camera, ptc, fit_emva1288(ptc)


def test_gain_and_dark_noise_are_recovered(result):
    camera, ptc, fit = result
    el = camera.electronics
    n = 64 * 64
    # Each variance has a relative standard error √(2/n); the fit averages ≥ 10 levels.
    levels = fit.linear_range.sum()
    assert levels >= 10
    assert fit.gain == pytest.approx(el.gain, rel=4 * math.sqrt(2 / n / levels) + 1e-3)
    expected_dark = math.sqrt(el.read_noise**2 + el.dark_current * 10e-6)
    assert fit.dark_noise == pytest.approx(expected_dark, rel=4 * math.sqrt(2 / n) / 2)


def test_saturation_capacity_is_at_the_variance_peak_below_the_well(result):
    camera, ptc, fit = result
    full = camera.electronics.full_well
    # Clipping shrinks the variance as the brightest pixels reach the well: the peak comes
    # below it, by a few shot-noise widths at most (here 1 level step ≈ 10 K).
    assert 0.85 * full < fit.saturation_capacity < full


def test_noise_floor_and_saturation_bound_the_measurable_range():
    camera = Camera.preset("nist-ir")
    lows, highs = [], []
    for t in (1e-6, 10e-6, 90e-6, 1e-3):
        cal = camera.calibration(t)
        low = cal.lowest_measurable_temperature()
        dark = camera.electronics.dark_current * t
        assert cal.electrons(low) - dark == pytest.approx(float(cal.noise(low)), rel=1e-6)
        lows.append(low)
        highs.append(cal.saturation_temperature)
    # Longer integration: both ends move down.
    assert np.all(np.diff(lows) < 0) and np.all(np.diff(highs) < 0)
    assert all(lo < hi for lo, hi in zip(lows, highs))
