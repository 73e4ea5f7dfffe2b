"""EMVA 1288 characterisation recovers the configured electronics; measurable range."""

import dataclasses as _dc
import math

import numpy as np
import pytest

from radiosim import Camera
from radiosim.characterization import (fit_emva1288, fit_scatter_halo, photon_transfer,
                                       size_of_source)
from radiosim.psf import ScatterHalo, halo_encircled_energy
from radiosim.radiometry import band_radiance


# The nist-ir camera at f/12.5 (its objective's NA 0.2 at 5×) fills its well at ≈ 660 K in
# 240 µs: the levels span the linear range and saturation.
T_INT = 240e-6


@pytest.fixture(scope="module")
def result():
    camera = Camera.preset("nist-ir")
    ptc = photon_transfer(camera, T_INT, np.linspace(300.0, 700.0, 41), pixels=(64, 64), rng=1)
    return camera, ptc, fit_emva1288(ptc)


def test_gain_and_dark_noise_are_recovered(result):
    camera, ptc, fit = result
    el = camera.electronics
    n = 64 * 64
    # Each variance has a relative standard error √(2/n); the fit averages ≥ 10 levels.
    levels = fit.linear_range.sum()
    assert levels >= 10
    assert fit.gain == pytest.approx(el.gain, rel=4 * math.sqrt(2 / n / levels) + 1e-3)
    expected_dark = math.sqrt(el.read_noise**2 + el.dark_current * T_INT)
    assert fit.dark_noise == pytest.approx(expected_dark, rel=4 * math.sqrt(2 / n) / 2)


def test_saturation_capacity_is_at_the_variance_peak_below_the_well(result):
    camera, ptc, fit = result
    full = camera.electronics.full_well
    # Clipping shrinks the variance as the brightest pixels reach the well: the peak comes
    # below it, by a few shot-noise widths at most (here 1 level step ≈ 10 K).
    assert 0.85 * full < fit.saturation_capacity < full


def test_levels_past_the_well_are_flagged_not_warned(result):
    """The curve's levels past the full well are part of it: each level says what fraction of
    its pixels saturated (none where the mean charge is five shot-noise widths below the well,
    all where the mean is clipped at the well), and no saturation warning reaches the caller
    (pytest turns RadiosimWarning into an error)."""
    camera, ptc, fit = result
    full = camera.electronics.full_well
    charge = (ptc.mean - ptc.dark_mean) / fit.gain  # [e⁻] per level, mean
    spread = 5 * np.sqrt(ptc.variance) / fit.gain  # five temporal noise widths [e⁻]
    clipped = charge > 0.995 * full  # a mean at the well: the most a pixel holds
    assert ptc.saturated.shape == ptc.temperature.shape
    assert np.all(ptc.saturated[(charge + spread < full) & ~clipped] == 0.0)
    assert clipped.sum() >= 3 and np.all(ptc.saturated[clipped] == 1.0)


def _independent_range(camera, t_int):
    """The noise floor and the saturation temperature from the radiometry alone: band radiance by
    quadrature, the étendue of the working cone written out, a bisection of our own."""
    el, fpa = camera.electronics, camera.fpa
    sine = camera.optics.objective_na / fpa.magnification  # image-side sin θ' = NA / m
    etendue = fpa.fill_factor * (fpa.detector_pitch) ** 2 * math.pi * sine**2

    def photo(t):  # photo-electrons of a blackbody at t [K]
        return float(band_radiance(t, camera.optics.band, "photon", camera.responsivity)) \
            * etendue * t_int

    def noise(t):  # shot (photo + dark), read, quantisation, in e⁻
        return math.sqrt((photo(t) if t > 0 else 0.0) + el.dark_current * t_int + el.read_noise**2
                         + 1 / 12 / el.gain**2)

    def bisect(f, lo, hi):
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if f(mid) < 0 else (lo, mid)
        return 0.5 * (lo + hi)

    # The detection limit (issue 20): the blank's noise in DN, EMVA 1288 σ²_y = K²(σ²_read +
    # μ_e,dark) + 1/12, three times over the blank; the floor is where the mean photo-charge
    # reaches it (noise(0) is the blank's noise in e⁻, the same σ over K).
    floor = bisect(lambda t: photo(t) - 3 * noise(0.0), 150.0, 3000.0)
    # The converter's top code begins at K·e⁻ + offset = 2^bits − 1 − ½: with the dark charge.
    top = (el.max_count - 0.5 - el.offset) / el.gain
    limit = min(top, el.full_well) - el.dark_current * t_int
    saturation = bisect(lambda t: photo(t) - limit, 150.0, 3000.0)
    return floor, saturation


def test_noise_floor_and_saturation_bound_the_measurable_range():
    camera = Camera.preset("nist-ir")
    lows, highs = [], []
    for t in (10e-6, 90e-6, 1e-3, 1.6e-3):
        cal = camera.calibration(t)
        low, high = cal.lowest_measurable_temperature(), cal.saturation_temperature
        floor, saturation = _independent_range(camera, t)
        # Quadrature vs the 2 K table: 1e-7 in radiance, far below 1e-6 K here.
        assert low == pytest.approx(floor, abs=1e-4)
        assert high == pytest.approx(saturation, abs=1e-4)
        lows.append(low)
        highs.append(high)
    # Longer integration: both ends move down.
    assert np.all(np.diff(lows) < 0) and np.all(np.diff(highs) < 0)
    assert all(lo < hi for lo, hi in zip(lows, highs))


# -- size-of-source effect -------------------------------------------------------------------



def _with_psf(camera, psf):
    return camera.replace(optics=_dc.replace(camera.optics, psf=psf))


def test_sse_of_a_perfect_lens_is_one():
    from radiosim.camera import Camera

    curve = size_of_source(Camera.linear_ideal(6e-6), [12e-6, 60e-6, 300e-6])
    np.testing.assert_allclose(curve.sse, 1.0, rtol=1e-12)
    np.testing.assert_allclose(curve.apparent_temperature, 1273.15, rtol=1e-12)


def test_sse_of_a_halo_follows_its_encircled_energy_and_the_fit_recovers_it():
    """A linear camera with a halo alone: the centre pixel's excess signal is
    (1 − β) + β·EE_halo(R). The pixel (6 µm) and the staircase disc (dx ≤ 2 µm) perturb it by
    O((p/a)²·β) and O(dx/R·β) ≲ 1e-3; the fit over discs ≥ 10 pixels then recovers β and a to
    a few per cent."""
    from radiosim.camera import Camera

    halo = ScatterHalo(0.08, 80e-6)
    camera = _with_psf(Camera.linear_ideal(6e-6), halo)
    d = 6e-6 * np.geomspace(10, 200, 8)
    curve = size_of_source(camera, d, 1273.15, 293.15)
    expected = (1 - halo.fraction) + halo.fraction * halo_encircled_energy(d / 2, halo.width)
    excess = (curve.signal - curve.background_signal) / (1273.15 - 293.15)
    np.testing.assert_allclose(excess, expected, atol=1.5e-3)
    fit = fit_scatter_halo(d, curve.sse)
    assert fit.halo.fraction == pytest.approx(0.08, rel=0.05)
    assert fit.halo.width == pytest.approx(80e-6, rel=0.05)
    assert np.abs(fit.residuals).max() < 1e-3


@pytest.mark.parametrize("diameters, sse", [([1e-4, 2e-4, 3e-4], [0.9, 0.95, 1.0]),
                                            ([1e-4, -2e-4, 3e-4, 4e-4], [0.9, 0.95, 1, 1]),
                                            ([1e-4, 2e-4, 3e-4, 4e-4], [0.9, np.nan, 1, 1])])
def test_fit_scatter_halo_refuses_bad_curves(diameters, sse):
    from radiosim.errors import RadiosimError

    with pytest.raises(RadiosimError):
        fit_scatter_halo(diameters, sse)


def test_datasheet_figures_show_the_fit_the_saturation_and_celsius(result):
    # The photon-transfer figure carries its fit line (slope K) and marks the variance peak;
    # the NETD and range figures speak °C as the study's figures do; where saturation lies
    # above the calibration's top, the drawn top is the calibration's, dashed and said so.
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from radiosim.characterization import Datasheet

    camera, ptc, fit = result
    times = np.array([1e-6, 1e-5, 1e-4])
    sheet = Datasheet(rows=[], ptc=ptc, netd=(np.array([400.0, 500.0]), np.array([0.5, 0.2])),
                      range=(times, np.array([300.0, 250.0, 200.0]),
                             np.array([3500.0, 1500.0, 700.0])))
    fig, axes = plt.subplots(1, 3)
    sheet.draw(axes, "nist-ir", T_INT, highest=3000.0)
    measured, line, peak = axes[0].get_lines()
    x, y = line.get_data()
    assert y[-1] == pytest.approx(fit.gain * x[-1], rel=1e-12)  # σ² = K μ
    variance = ptc.variance - ptc.dark_variance
    assert peak.get_ydata()[0] == variance.max()
    assert "°C" in axes[1].get_xlabel() and "°C" in axes[2].get_ylabel()
    np.testing.assert_allclose(axes[1].get_lines()[0].get_xdata(), [126.85, 226.85])
    low, top, dashed = axes[2].get_lines()
    np.testing.assert_allclose(top.get_ydata(), [3000.0 - 273.15, 1500.0 - 273.15,
                                                 700.0 - 273.15])
    assert dashed.get_linestyle() == "--" and list(dashed.get_xdata()) == [1.0]
    assert "calibration's top" in axes[2].get_legend().get_texts()[1].get_text()
    plt.close(fig)


def test_the_dark_noise_has_the_quantisation_variance_removed():
    # A dark noise of 0.7 DN, where the converter's 1/12 DN² is 17 % of the variance: the
    # EMVA 1288 dark noise (σ_y,dark² − 1/12)^½ / K recovers the electrons' noise within 4
    # standard errors of a variance from 128 × 128 pixels; leaving the 1/12 DN² in would be 8 %
    # high, twice and more that tolerance (the effect the test guards is seen).
    camera = Camera.preset("nist-ir")
    el = camera.electronics
    read = 0.7 / el.gain  # [e⁻]: 0.7 DN
    camera = camera.replace(electronics=_dc.replace(el, read_noise=read))
    ptc = photon_transfer(camera, T_INT, np.linspace(300.0, 700.0, 21), pixels=(128, 128),
                          rng=2)
    fit = fit_emva1288(ptc)
    truth = math.sqrt(read**2 + el.dark_current * T_INT)  # [e⁻]
    tolerance = 4 * math.sqrt(1 / (2 * 128 * 128)) + 4 * math.sqrt(2 / (128 * 128)) / 4
    assert fit.dark_noise == pytest.approx(truth, rel=tolerance)
    unremoved = math.sqrt(ptc.dark_variance) / fit.gain
    assert abs(unremoved / truth - 1) > 2 * tolerance
