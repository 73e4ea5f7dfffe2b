"""Response models against independent references.

References: :func:`radiosim.radiometry.band_radiance` (direct Gauss–Legendre quadrature, exact to
rounding for the piecewise-linear curves) for every radiance, and finite differences of it for the
slope. The Planck response evaluates through a table of L, cubic in T on a grid of 1024
intervals per octave (c·ΔT/T² ≤ 0.03 at its coldest node, c = c₂/λ₁), whose relative accuracy
is about 1e-9 (the tests assert the documented 1e-7, ``PLANCK_TABLE_RANGE``): that is the
tolerance of every comparison that goes through the table. Temperatures are chosen off the
table's nodes (multiples of 2⁻¹⁰ of their octave, e.g. 300.0 K: a node would make the
comparison prove nothing).
"""

import numpy as np
import pytest

from radiosim import Camera
from radiosim.errors import RadiosimError
from radiosim.radiometry import band_radiance
from radiosim.response import PLANCK_TABLE_RANGE, LinearResponse, PlanckResponse
from radiosim.scenes import SceneFrame
from radiosim.spectral import read_spectrum

#: The table's documented relative accuracy (radiosim.response.PLANCK_TABLE_RANGE).
TABLE_RTOL = 1e-7

#: Temperatures [K] inside the calibration range, off round values.
T_GRID = np.array([[151.37, 287.91, 433.33], [1012.15, 1777.77, 2999.9]])


@pytest.fixture(scope="module")
def camera():
    return Camera.preset("nist-ir")


@pytest.fixture(scope="module")
def planck(camera):
    return PlanckResponse(camera.optics.band, camera.responsivity)


def quadrature(camera, temperature, emissivity=1.0):
    """ε·L_q(T) by direct quadrature through the camera's filter × lens × QE."""
    return band_radiance(temperature, camera.optics.band, "photon", camera.responsivity,
                         emissivity)


# -- linear -------------------------------------------------------------------------------------


def test_linear_signal_is_the_temperature_array_itself():
    temperature = np.array([[300.0, 900.0], [1200.0, 151.5]])
    frame = SceneFrame(temperature, emissivity=0.2)
    signal = LinearResponse(3.5e5).signal(frame)
    # The same object: no copy of a frame that may be large (and emissivity plays no part).
    assert signal is temperature
    assert signal is frame.temperature


def test_linear_rate_per_signal_is_the_responsivity_for_any_etendue():
    response = LinearResponse(3.5e5)
    assert response.rate_per_signal(1e-12) == 3.5e5
    assert response.rate_per_signal(7.0) == 3.5e5


def test_linear_temperature_has_no_value_for_non_positive_signal():
    out = LinearResponse().temperature(np.array([-1.0, 0.0, 412.5]))
    assert np.isnan(out[:2]).all() and out[2] == 412.5


# -- Planck: signal of scene frames -----------------------------------------------------------


def test_planck_signal_of_a_grey_scalar(camera, planck):
    signal = planck.signal(SceneFrame(T_GRID, emissivity=0.37))
    np.testing.assert_allclose(signal, 0.37 * quadrature(camera, T_GRID), rtol=TABLE_RTOL)


def test_planck_signal_of_a_blackbody(camera, planck):
    signal = planck.signal(SceneFrame(T_GRID))
    np.testing.assert_allclose(signal, quadrature(camera, T_GRID), rtol=TABLE_RTOL)


def test_planck_signal_of_a_grey_map(camera, planck):
    emissivity = np.array([[0.1, 0.25, 1.0], [0.5, 0.0, 0.93]])
    signal = planck.signal(SceneFrame(T_GRID, emissivity=emissivity))
    expected = emissivity * quadrature(camera, T_GRID)
    np.testing.assert_allclose(signal, expected, rtol=TABLE_RTOL)
    assert signal[1, 1] == 0.0  # ε = 0 emits nothing


def test_planck_signal_of_a_spectral_emissivity(camera, planck):
    steel = read_spectrum("emissivity_steel_clean")
    signal = planck.signal(SceneFrame(T_GRID, emissivity=steel))
    # The curve is inside the integral: ∫ ε(λ) R(λ) L_q,λ dλ, not ε̄ × ∫ R L_q,λ dλ.
    expected = quadrature(camera, T_GRID, steel)
    np.testing.assert_allclose(signal, expected, rtol=TABLE_RTOL)
    # ...and it is not a grey body: the band-averaged emissivity changes with temperature
    # (the Planck peak moves across the curve), by far more than the tolerance.
    ratio = expected / quadrature(camera, T_GRID)
    assert np.ptp(ratio) > 100 * TABLE_RTOL


def test_planck_signal_per_region(camera, planck):
    steel = read_spectrum("emissivity_steel_clean")
    regions = np.array([[0, 1, 2], [2, 1, 0]])
    region_emissivity = {0: 1.0, 1: 0.3, 2: steel}
    frame = SceneFrame(T_GRID, emissivity=0.77, regions=regions,
                       region_emissivity=region_emissivity)
    signal = planck.signal(frame)
    expected = np.empty(T_GRID.shape)
    for (i, j), code in np.ndenumerate(regions):
        expected[i, j] = quadrature(camera, T_GRID[i, j], region_emissivity[code])
    # The per-region values override the frame's scalar emissivity (0.77 must play no part).
    np.testing.assert_allclose(signal, expected, rtol=TABLE_RTOL)


def test_planck_signal_below_the_table_is_exact_not_an_error(camera, planck):
    low, _ = PLANCK_TABLE_RANGE
    assert low == 130.0
    cold = np.array([[60.0, 80.0, 129.5]])
    signal = planck.signal(SceneFrame(cold, emissivity=0.6))
    # Below the table the response integrates by the same quadrature as the reference: the
    # two agree to rounding, far tighter than the table's 1e-7.
    np.testing.assert_allclose(signal, 0.6 * quadrature(camera, cold), rtol=1e-9)


def test_planck_signal_mixing_cold_and_tabulated_samples(camera, planck):
    temperature = np.array([[60.0, 140.0], [129.9, 1012.15]])
    steel = read_spectrum("emissivity_steel_clean")
    for emissivity in (1.0, steel):
        signal = planck.signal(SceneFrame(temperature, emissivity=emissivity))
        expected = quadrature(camera, temperature, emissivity)
        cold = temperature < PLANCK_TABLE_RANGE[0]
        # Cold samples: quadrature (rounding); tabulated ones: the table's 1e-7.
        np.testing.assert_allclose(signal[cold], expected[cold], rtol=1e-9)
        np.testing.assert_allclose(signal[~cold], expected[~cold], rtol=TABLE_RTOL)


def test_planck_table_meets_its_documented_accuracy_over_its_range(camera, planck):
    # PLANCK_TABLE_RANGE's docstring: "Its relative error ... stays below 1e-7 over the range."
    temperature = np.arange(PLANCK_TABLE_RANGE[0] + 0.03, 160.0, 0.35)
    np.testing.assert_allclose(planck.grey_signal(temperature), quadrature(camera, temperature),
                               rtol=TABLE_RTOL)


# -- Planck: inverse and slope ----------------------------------------------------------------


@pytest.mark.parametrize("emissivity", [1.0, 0.42])
def test_planck_temperature_inverts_grey_signal(planck, emissivity):
    temperature = np.array([151.37, 287.91, 1012.15, 2999.9, 3777.7])
    recovered = planck.temperature(planck.grey_signal(temperature, emissivity), emissivity)
    # Newton steps on the same spline converge to rounding: |δT| ~ ε·|ln L| / (d ln L/dT)
    # ≈ 2e-16 · 60 / 1e-3 K⁻¹ ≈ 1e-11 K at worst; 1e-8 K leaves room.
    np.testing.assert_allclose(recovered, temperature, rtol=0, atol=1e-8)


def test_planck_temperature_is_nan_outside_the_table(planck):
    inside = planck.grey_signal(np.array([500.0]))[0]
    below = planck.grey_signal(np.array([100.0]))[0] * 0.5
    out = planck.temperature(np.array([below, inside, -1.0]))
    assert np.isnan(out[0]) and np.isnan(out[2])
    assert out[1] == pytest.approx(500.0, abs=1e-8)


def test_planck_temperature_refuses_an_impossible_emissivity(planck):
    with pytest.raises(RadiosimError, match="emissivity"):
        planck.temperature(1e20, 0.0)
    with pytest.raises(RadiosimError, match="emissivity"):
        planck.temperature(1e20, 1.5)


@pytest.mark.parametrize("emissivity", [1.0, 0.5])
def test_planck_slope_matches_a_finite_difference_of_the_quadrature(camera, planck, emissivity):
    temperature = np.array([201.3, 523.7, 1012.15, 2500.5])
    h = 1e-2  # K
    reference = (quadrature(camera, temperature + h, emissivity)
                 - quadrature(camera, temperature - h, emissivity)) / (2 * h)
    # Error budget, relative to dL/dT, with d ln L/dT ≈ b/T² (b = c₂/λ ≈ 3300 K):
    # - reference truncation h²/6 · (b/T²)² ≤ 1e-4/6 · 0.08² ≈ 1e-7 at 200 K;
    # - the code's 1 mK central difference on the spline: the spline's derivative error
    #   ~ step³ f⁗/24 = 8·b/T⁵ K⁻¹ in d ln L/dT, i.e. 8/T³ relative: 1e-6 at 200 K;
    # - rounding ε/(2 mK · b/T²) ≈ 1e-12.
    # 3e-6 covers the sum with margin; a wrong slope (factor, sign, ε missed) is off by O(1).
    np.testing.assert_allclose(planck.slope(temperature, emissivity), reference, rtol=3e-6)


def test_planck_rate_per_signal_is_the_etendue(planck):
    assert planck.rate_per_signal(3.8453e-12) == 3.8453e-12
