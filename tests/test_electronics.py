"""FPA electronics: the EMVA 1288 linear camera model."""

import math

import numpy as np
import pytest

from radiosim.electronics import Electronics, quantise
from radiosim.errors import RadiosimError


def _variance_and_error(samples):
    """Sample variance and its standard error for a near-Gaussian population."""
    var = samples.var(ddof=1)
    return var, var * math.sqrt(2.0 / (samples.size - 1))


@pytest.mark.parametrize("mean_electrons", [2e3, 5e4, 2e5])
def test_photon_transfer_relation(mean_electrons):
    el = Electronics(full_well=1e6, dark_current=1e5, read_noise=30.0, gain=0.05,
                     offset=100.0, adc_bits=14)
    shape = (300, 300)
    t_int = 1e-3
    dark = el.expose(np.zeros(shape), t_int, rng=1).counts.ravel()
    light = el.expose(np.full(shape, mean_electrons), t_int, rng=2).counts.ravel()
    var_d, err_d = _variance_and_error(dark)
    var_l, err_l = _variance_and_error(light)
    mean_d, mean_l = dark.mean(), light.mean()
    # Mean: μ_y − μ_y,dark = K μ_e (up to the mean's sampling error).
    assert mean_l - mean_d == pytest.approx(el.gain * mean_electrons,
                                            abs=5 * math.sqrt(var_l / light.size))
    # Photon transfer: σ²_y − σ²_y,dark = K (μ_y − μ_y,dark), within 4 standard errors.
    lhs, rhs = var_l - var_d, el.gain * (mean_l - mean_d)
    assert abs(lhs - rhs) < 4 * math.hypot(err_d, err_l)
    # and the dark variance is K²(σ_d² + μ_dark) + 1/12
    expected_dark = el.gain**2 * (el.read_noise**2 + el.dark_current * t_int) + 1 / 12
    assert abs(var_d - expected_dark) < 4 * err_d


def test_full_well_clip_and_flags():
    el = Electronics(full_well=1e5, gain=0.1, offset=10.0, adc_bits=16, shot_noise=False)
    exp = el.expose(np.array([5e4, 1e5, 3e5]), 1e-6)
    assert exp.electrons.tolist() == [5e4, 1e5, 1e5]
    assert exp.saturated.tolist() == [False, True, True]
    assert exp.counts.tolist() == [5010.0, 10010.0, 10010.0]


def test_adc_rounds_and_clips_to_its_range():
    counts, low, high = quantise(np.array([-500.0, 12.26, 12.74, 1e9]), gain=1.0, offset=0.0,
                                 bits=12)
    assert counts.tolist() == [0.0, 12.0, 13.0, 4095.0]
    assert low.tolist() == [True, False, False, False]
    assert high.tolist() == [False, False, False, True]
    ideal, low, high = quantise(np.array([1.25]), 2.0, 0.5, None)
    assert ideal.tolist() == [3.0] and not low.any() and not high.any()


def test_noise_comes_only_from_the_rng():
    el = Electronics(read_noise=10.0)
    a = el.expose(np.full((50, 50), 1e4), 1e-3, rng=7).counts
    b = el.expose(np.full((50, 50), 1e4), 1e-3, rng=np.random.default_rng(7)).counts
    c = el.expose(np.full((50, 50), 1e4), 1e-3, rng=8).counts
    assert np.array_equal(a, b) and not np.array_equal(a, c)
    assert Electronics.ideal().is_noise_free


@pytest.mark.parametrize("kwargs, message", [
    ({"full_well": -1.0}, "full_well"), ({"gain": 0.0}, "gain"),
    ({"read_noise": -2.0}, "read_noise"), ({"adc_bits": 40}, "adc_bits"),
    ({"dark_current": float("nan")}, "dark_current"),
])
def test_bad_electronics_are_named(kwargs, message):
    with pytest.raises(RadiosimError, match=message):
        Electronics(**kwargs)
