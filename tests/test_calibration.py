"""Calibration and electronics against a forward model written out in the test.

The independent forward model of the nist-ir preset is built here from its parts only:

-   in-band photon radiance L_q(T) by :func:`radiosim.radiometry.band_radiance` (quadrature);
-   the étendue written out as G = A·π·sin²θ', with A the active area on the focal plane
    (fill factor × detector pitch²) and sin θ' = NA/m, the objective's image-side cone, which
    is narrower than the f/2.5 cold stop's 1/√(4N² + 1);
-   DN = K·(ε_a·L_q·G·t + I_dark·t) + offset; noise² = photo e⁻ + dark e⁻ + σ_read² + 1/(12K²);
-   roots by a bisection of our own.

The calibration evaluates radiance through a spline table whose relative error is ≤ 1e-7 at
T ≥ 150 K (the calibration range); tolerances below follow from that.
"""

import math
import re
import warnings
from dataclasses import replace

import numpy as np
import pytest

from conftest import blank_and_sigma, counts_table, one_line_message, photo, true_camera
from radiosim import Camera, FrameStack, UniformBlackbody
from radiosim.calibration import Calibration
from radiosim.characterization import fit_calibration, flat_fields, measurable_range
from radiosim.electronics import Electronics, Exposure
from radiosim.errors import RadiosimError, RadiosimWarning
from radiosim.radiometry import band_radiance

TABLE_RTOL = 1e-7  # relative accuracy of the radiance table at T ≥ 150 K


@pytest.fixture(scope="module")
def nist():
    return Camera.preset("nist-ir")


# -- the independent forward model ------------------------------------------------------------


def written_out_etendue(camera):
    """G = A·π·sin²θ' [m² sr], from the preset's numbers."""
    fpa, optics = camera.fpa, camera.optics
    area = fpa.fill_factor * fpa.detector_pitch**2  # active area on the focal plane [m²]
    magnification = fpa.detector_pitch / fpa.pixel_pitch
    sine_objective = optics.objective_na / magnification
    sine_cold_stop = 1.0 / math.sqrt(4 * optics.f_number**2 + 1)
    assert sine_objective < sine_cold_stop  # the objective limits the cone
    return area * math.pi * sine_objective**2


class Forward:
    """The nist-ir camera's noise-free forward model and noise, written out."""

    def __init__(self, camera, t_int):
        self.camera, self.t = camera, t_int
        self.el = camera.electronics
        self.G = written_out_etendue(camera)
        self.eps = camera.assumed_emissivity

    def radiance(self, temperature):
        return band_radiance(temperature, self.camera.optics.band, "photon",
                             self.camera.responsivity)

    def photo(self, temperature):  # photo-electrons [e⁻]
        return self.eps * self.radiance(temperature) * self.G * self.t

    def dark(self):  # dark electrons [e⁻]
        return self.el.dark_current * self.t

    def counts(self, temperature):  # noise-free DN
        return self.el.gain * (self.photo(temperature) + self.dark()) + self.el.offset

    def blank(self):  # mean counts with no object signal: dark only here (no background)
        return self.el.gain * self.dark() + self.el.offset

    def blank_sigma(self):  # EMVA 1288: σ²_y = K²(σ²_read + μ_e,dark) + 1/12 [DN]
        return math.sqrt(self.el.gain**2 * (self.el.read_noise**2 + self.dark()) + 1 / 12)

    def detection_limit(self, k=3.0):  # [DN]
        return self.blank() + k * self.blank_sigma()

    def noise(self, temperature):  # temporal noise [e⁻ rms]
        return math.sqrt(float(self.photo(temperature)) + self.dark() + self.el.read_noise**2
                         + 1 / (12 * self.el.gain**2))

    def dlnL_dT(self, temperature, h=1e-2):
        return float((np.log(self.radiance(temperature + h))
                      - np.log(self.radiance(temperature - h))) / (2 * h))

    def table_tolerance(self, temperature):
        """Temperature error [K] of a root found on the table instead of the quadrature:
        a relative radiance error δ shifts it by δ / (d ln L/dT); ×2 for safety."""
        return 2 * TABLE_RTOL / self.dlnL_dT(temperature)


def bisect(f, lo, hi, tol=1e-9):
    """Root of an increasing f in [lo, hi] by bisection."""
    assert f(lo) < 0 < f(hi)
    while hi - lo > tol:
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if f(mid) < 0 else (lo, mid)
    return 0.5 * (lo + hi)


# -- (a) the linear ideal camera ------------------------------------------------------------


@pytest.mark.parametrize("t_int", [1e-6, 3e-6, 10e-6, 73e-6, 1e-3])
def test_linear_counts_are_K_times_R_T_t_plus_dark_charge_plus_offset(t_int):
    # A linear camera with electronics that are not the identity: K = 0.37 DN/e⁻, dark current
    # 2.5e6 e⁻/s, offset 812 DN (no noise, no converter). The counts written out here:
    # DN = K (R T t + I_dark t) + offset, with R = 1e6 e⁻ s⁻¹ K⁻¹ (the linear response's).
    from radiosim.electronics import Electronics

    camera = Camera.linear_ideal(6e-6).replace(electronics=Electronics(
        shot_noise=False, gain=0.37, dark_current=2.5e6, offset=812.0))
    cal = camera.calibration(t_int)
    temperature = np.linspace(150.0, 3000.0, 1001)
    expected = 0.37 * (1e6 * temperature * t_int + 2.5e6 * t_int) + 812.0
    # The chain groups the same products differently: equal to a few units in the last place.
    np.testing.assert_allclose(cal.counts(temperature), expected, rtol=4e-16 * 8, atol=0)
    # The ideal camera's own electronics are the identity: DN = R T t exactly.
    ideal = Camera.linear_ideal(6e-6).calibration(t_int)
    np.testing.assert_array_equal(ideal.counts(temperature), 1e6 * temperature * t_int)


@pytest.mark.parametrize("t_int", [1e-6, 3e-6, 10e-6, 73e-6, 1e-3])
def test_linear_ideal_calibration_is_the_identity(t_int):
    cal = Camera.linear_ideal(6e-6).calibration(t_int)
    temperature = np.linspace(150.0, 3000.0, 1001)[1:-1]
    # counts = (T·R)·t, then T = counts / (R·t): two correctly rounded operations each way, so
    # the identity holds to one unit in the last place (not always bitwise: e.g. 3000·1e6·1e-5
    # / (1e6·1e-5) is 3000.0000000000005).
    np.testing.assert_array_max_ulp(cal.temperature(cal.counts(temperature)), temperature,
                                    maxulp=1)


@pytest.mark.parametrize("t_int", [5e-6, 10e-6, 20e-6])
def test_linear_ideal_reads_the_ends_of_its_calibration_range(t_int):
    # The calibration range is closed: 150 K and 3000 K are in it, and the ideal camera reads
    # every temperature of its range exactly (Camera.linear_ideal's docstring).
    cal = Camera.linear_ideal(6e-6).calibration(t_int)
    ends = np.array(cal.temperature_range)
    reading = cal.read(Exposure(electrons=cal.counts(ends), counts=cal.counts(ends),
                                saturated=np.zeros(2, bool), adc_floor=np.zeros(2, bool)))
    assert not reading.saturated.any() and not reading.under_range.any()
    np.testing.assert_array_max_ulp(reading.apparent_temperature, ends, maxulp=1)


def test_linear_ideal_flags_temperatures_outside_its_range():
    cal = Camera.linear_ideal(6e-6).calibration(10e-6)
    counts = np.array([100.0, 3100.0]) * 1e6 * 10e-6  # K·R·T·t for 100 K and 3100 K
    no = np.zeros(2, bool)
    reading = cal.read(Exposure(counts, counts, no, no))
    assert reading.under_range.tolist() == [True, False]
    assert reading.over_range.tolist() == [False, True]  # above the range, well not full
    assert not reading.saturated.any()
    assert np.isnan(reading.apparent_temperature).all()


# -- (b) nist-ir forward model --------------------------------------------------------------


@pytest.mark.parametrize("t_int", [1e-6, 10e-6, 1e-3])
def test_nist_counts_match_the_written_out_forward_model(nist, t_int):
    cal = nist.calibration(t_int)
    forward = Forward(nist, t_int)
    temperature = np.array([151.37, 287.91, 555.55, 1012.15, 2222.2, 2999.9])
    # The only difference is the radiance table (≤ 1e-7 relative in L, hence in the photo part
    # of the counts; the offset and dark parts are exact).
    np.testing.assert_allclose(cal.counts(temperature), forward.counts(temperature),
                               rtol=TABLE_RTOL)
    # The étendue the camera uses is the written-out one (sin θ' = NA/m, not the cold stop).
    assert nist.rate_per_signal == pytest.approx(forward.G, rel=1e-12)


def test_nist_calibration_inverts_the_written_out_forward_model(nist):
    t_int = 1e-6  # nothing saturates below 3000 K here
    cal = nist.calibration(t_int)
    forward = Forward(nist, t_int)
    temperature = np.array([400.0, 777.7, 1012.15, 2500.5])
    recovered = cal.temperature(forward.counts(temperature))
    tolerance = [forward.table_tolerance(t) for t in temperature]
    np.testing.assert_allclose(recovered, temperature, rtol=0, atol=max(tolerance))


# -- (c) measurable range --------------------------------------------------------------------


@pytest.mark.parametrize("t_int", [10e-6, 100e-6, 1e-3])
@pytest.mark.parametrize("k", [1.0, 3.0])
def test_lowest_measurable_temperature_by_bisection(nist, t_int, k):
    # Issue 20: the temperature whose mean counts reach the detection limit, blank + k σ_blank
    # (it was the SNR = k point of the photo-signal against its own noise).
    forward = Forward(nist, t_int)
    limit = forward.detection_limit(k)
    floor = bisect(lambda t: float(forward.counts(t)) - limit, 150.0, 3000.0)
    low = nist.calibration(t_int).lowest_measurable_temperature(k)
    # brentq's xtol (1e-6 K) plus the table's radiance error turned into kelvin.
    assert low == pytest.approx(floor, abs=1e-6 + forward.table_tolerance(floor))


def test_lowest_measurable_temperature_rises_with_the_snr(nist):
    cal = nist.calibration(10e-6)
    lows = [cal.lowest_measurable_temperature(s) for s in (0.5, 1.0, 3.0, 10.0)]
    assert np.all(np.diff(lows) > 0)


@pytest.mark.parametrize("t_int", [10e-6, 100e-6, 1e-3])
def test_saturation_temperature_by_bisection(nist, t_int):
    forward = Forward(nist, t_int)
    el = nist.electronics
    # Saturation: the well (full_well) or the converter's top code, which starts at
    # K·e⁻ + offset = 2^bits − 1 − ½; whichever comes first, photo plus dark charge.
    top_code_charge = (2**el.adc_bits - 1 - 0.5 - el.offset) / el.gain
    charge = min(el.full_well, top_code_charge)
    expected = bisect(lambda t: float(forward.photo(t)) + forward.dark() - charge, 150.0, 3000.0)
    saturation = nist.calibration(t_int).saturation_temperature
    assert saturation == pytest.approx(expected, abs=1e-6 + forward.table_tolerance(expected))


def test_saturation_temperature_beyond_the_range_is_infinite(nist):
    t_int = 1e-6
    forward = Forward(nist, t_int)
    # Independently: 3000 K does not fill the well at 1 µs...
    assert float(forward.photo(3000.0)) + forward.dark() < nist.electronics.full_well
    # ...so no temperature of the range saturates, and the NETD is defined up to its top.
    calibration = nist.calibration(t_int)
    assert calibration.saturation_temperature == math.inf
    assert np.isfinite(calibration.netd(2900.0))


def test_noise_free_unquantised_electronics_have_no_saturation_or_floor():
    cal = Camera.linear_ideal(6e-6).calibration(10e-6)
    assert cal.saturation_temperature == math.inf
    assert cal.noise_floor_counts == -math.inf
    assert cal.lowest_measurable_temperature() == 150.0  # any signal beats zero noise


# -- (d) flags of Calibration.read -----------------------------------------------------------


def test_read_flags_hand_built_exposures(nist):
    t_int = 1e-6
    cal = nist.calibration(t_int)
    forward = Forward(nist, t_int)
    el = nist.electronics
    # Issue 20: the floor is the detection limit, blank + 3σ (it was SNR = 1).
    limit = forward.detection_limit()
    floor = bisect(lambda t: float(forward.counts(t)) - limit, 150.0, 3000.0)
    assert 160.0 < floor < 2900.0  # the noise floor lies inside the calibration range
    top = float(forward.counts(3000.0))
    assert top < el.max_count - 10  # "above the range" is reachable without saturating
    cases = {
        # name: (counts, exposure saturated, ADC floor) -> expected (saturated, under range,
        # over range)
        "valid": (float(forward.counts(1012.15)), False, False),
        # 1 K below the floor: inside the calibration range (> 150 K) but under the noise.
        "below noise floor": (float(forward.counts(floor - 1.0)), False, False),
        "below range": (float(forward.counts(150.0)) - 0.5, False, False),
        "code 0": (0.0, False, True),
        "above range": (top + 5.0, False, False),
        "saturated": (el.max_count, True, False),
        "full well in range": (float(forward.counts(1012.15)), True, False),
        "just above floor": (float(forward.counts(floor + 1.0)), False, False),
    }
    expected = {
        "valid": (False, False, False), "below noise floor": (False, True, False),
        "below range": (False, True, False), "code 0": (False, True, False),
        "above range": (False, False, True), "saturated": (True, False, False),
        "full well in range": (True, False, False), "just above floor": (False, False, False),
    }
    names = list(cases)
    counts = np.array([cases[n][0] for n in names])
    exposure = Exposure(electrons=(counts - el.offset) / el.gain, counts=counts,
                        saturated=np.array([cases[n][1] for n in names]),
                        adc_floor=np.array([cases[n][2] for n in names]))
    reading = cal.read(exposure)
    for k, name in enumerate(names):
        assert (bool(reading.saturated[k]), bool(reading.under_range[k]),
                bool(reading.over_range[k])) == expected[name], name
        flagged = any(expected[name])
        assert np.isnan(reading.apparent_temperature[k]) == flagged, name
    k = names.index("valid")
    assert reading.apparent_temperature[k] == pytest.approx(
        1012.15, abs=forward.table_tolerance(1012.15))
    k = names.index("just above floor")
    assert reading.apparent_temperature[k] == pytest.approx(
        floor + 1.0, abs=1e-6 + forward.table_tolerance(floor))


def test_noise_floor_counts_are_the_counts_of_the_floor(nist):
    t_int = 10e-6
    forward = Forward(nist, t_int)
    # Issue 20: the floor's counts are the detection limit itself, blank + 3σ_blank, written
    # out (it was the counts of the SNR = 1 temperature); only roundings separate them.
    assert nist.calibration(t_int).noise_floor_counts == pytest.approx(
        forward.detection_limit(), abs=1e-9)
    floor = nist.calibration(t_int).lowest_measurable_temperature()
    slope = float(forward.counts(floor + 0.01) - forward.counts(floor - 0.01)) / 0.02
    # The floor's mean counts are the limit: the table's 1e-7 on the photo part (≈ 2 DN here)
    # plus dDN/dT × brentq's 1e-6 K.
    assert float(forward.counts(floor)) == pytest.approx(forward.detection_limit(),
                                                         abs=1e-6 + slope * 2e-6)


# -- (e) a near-zero integration time ---------------------------------------------------------


def _measure_600K_at_1ns(camera):
    scene = UniformBlackbody(600.0, shape=(12, 12), dx=6e-6, dt=1e-6)
    # 1 ns spans a few DN over the whole calibration range: the camera says so.
    with pytest.warns(RadiosimWarning, match="spans only"):
        return camera.measure(scene, 1e-9, t_start=0.0, rng=0)


def test_near_zero_integration_is_not_saturated(nist):
    m = _measure_600K_at_1ns(nist)
    forward = Forward(nist, 1e-9)
    # Independently: the 600 K photo-charge (≈ 27 e⁻) is a few % of the read noise (600 e⁻):
    # the reading is noise, whose upward excursions must not count as "above the range".
    assert float(forward.photo(600.0)) < 0.1 * nist.electronics.read_noise
    assert not m.saturated.any()
    assert np.isnan(m.apparent_temperature[m.under_range]).all()


def test_near_zero_integration_applies_the_noise_floor_rule(nist):
    # The documented rule: a reading below the counts of the SNR = 1 noise floor is under range;
    # pure noise passes it only by an upward excursion of about one σ or more.
    m = _measure_600K_at_1ns(nist)
    floor = nist.calibration(1e-9).noise_floor_counts
    np.testing.assert_array_equal(m.under_range, m.counts < floor)
    passed = float(np.mean(~m.under_range))
    # P(reading ≥ floor) for noise around the dark level: the floor is ≈ 1σ above it, and the
    # 1 DN codes round it; allow the binomial spread of 144 pixels (±4σ).
    el = nist.electronics
    sigma = float(el.temporal_noise(el.dark_current * 1e-9)) * el.gain  # [DN]
    from math import erf, sqrt
    code = np.ceil(floor - 0.5)  # the lowest code that rounds at or above the floor
    p = 0.5 * (1 - erf((code - 0.5 - el.offset) / (sigma * sqrt(2))))
    assert abs(passed - p) <= 4 * sqrt(p * (1 - p) / m.under_range.size) + 1e-9


# -- (f) a linear response with real electronics -----------------------------------------------


def test_linear_response_with_real_electronics_warns_coarse(nist):
    camera = nist.replace(response="linear")
    t_int = 10e-6
    el = camera.electronics
    span = el.gain * camera.linear_responsivity * (3000.0 - 150.0) * t_int  # DN
    assert span < 100  # independently: ~40 DN across 2850 K
    scene = UniformBlackbody(1000.0, shape=(12, 12), dx=6e-6, dt=1e-6)
    with pytest.warns(RadiosimWarning, match="spans only") as record:
        camera.measure(scene, t_int, t_start=0.0, rng=0)
    assert any(f"{span:.3g} DN" in str(w.message) for w in record)


def test_planck_response_at_10us_does_not_warn(nist):
    scene = UniformBlackbody(1000.0, shape=(12, 12), dx=6e-6, dt=1e-6)
    with warnings.catch_warnings():
        warnings.simplefilter("error", RadiosimWarning)
        m = nist.measure(scene, 10e-6, t_start=0.0, rng=0)
    assert m.valid.all()


# -- (g) scenes colder than the radiance table --------------------------------------------------


def _cold_stack():
    return FrameStack(np.full((3, 12, 12), 140.0), dt=1e-6, dx=6e-6)


def test_cold_scene_is_measured_not_raised(nist):
    m = nist.measure(_cold_stack(), 2e-6, t_start=0.0, rng=0)
    assert m.shape == (12, 12)  # 6 µm pixels on 6 µm samples
    assert np.isfinite(m.counts).all()
    assert not m.saturated.any()
    np.testing.assert_array_equal(m.tensor_max, 140.0)
    # The signal is the quadrature radiance of 140 K (photon units).
    expected = band_radiance(140.0, nist.optics.band, "photon", nist.responsivity)
    np.testing.assert_allclose(m.signal_mean, expected, rtol=TABLE_RTOL)


def test_cold_scene_is_under_range_without_noise(nist):
    camera = nist.replace(electronics=replace(nist.electronics, shot_noise=False,
                                              read_noise=0.0))
    m = camera.measure(_cold_stack(), 2e-6, t_start=0.0, rng=0)
    assert m.under_range.all() and not m.saturated.any()
    assert np.isnan(m.apparent_temperature).all()


def test_cold_scene_below_the_floor_is_flagged(nist):
    m = nist.measure(_cold_stack(), 2e-6, t_start=0.0, rng=0)
    floor = nist.calibration(2e-6).noise_floor_counts
    np.testing.assert_array_equal(m.under_range, m.counts < floor)
    assert m.under_range.mean() > 0.5  # most of a 140 K scene reads as what it is: noise


# -- (h) electronics: mean counts and their inverse ---------------------------------------------


@pytest.fixture(scope="module")
def electronics():
    return Electronics(full_well=None, dark_current=6e4, read_noise=0.0, shot_noise=False,
                       gain=0.0014, offset=1000.0, adc_bits=None)


def test_mean_counts_and_photoelectrons_invert_each_other(electronics):
    t_int = 37e-6
    photo = np.array([0.0, 1.0, 1234.5, 3.3e6, 1.1e7])
    counts = electronics.mean_counts(photo, t_int)
    # Written out: K·(e⁻ + I_dark·t) + offset.
    np.testing.assert_allclose(counts, 0.0014 * (photo + 6e4 * t_int) + 1000.0, rtol=1e-15)
    # A few roundings each way on numbers ≤ 1.6e4 DN: 1e-8 e⁻ is ~1e5 ulp of a count of 1.
    np.testing.assert_allclose(electronics.photoelectrons(counts, t_int), photo, rtol=0,
                               atol=1e-8)
    codes = np.array([1000.0, 1000.5, 5000.0, 16383.0])
    np.testing.assert_allclose(electronics.mean_counts(
        electronics.photoelectrons(codes, t_int), t_int), codes, rtol=1e-14)


def test_mean_counts_equals_a_noise_free_exposure(electronics):
    t_int = 37e-6
    photo = np.linspace(0.0, 2e6, 35).reshape(5, 7)
    exposure = electronics.expose(photo, t_int, rng=1)
    np.testing.assert_array_equal(exposure.counts, electronics.mean_counts(photo, t_int))
    assert not exposure.saturated.any() and not exposure.adc_floor.any()


def test_mean_counts_is_the_mean_of_noisy_exposures():
    el = Electronics(full_well=None, dark_current=6e4, read_noise=600.0, shot_noise=True,
                     gain=0.0014, offset=1000.0, adc_bits=None)
    t_int = 37e-6
    photo = np.full(200_000, 4.0e5)
    counts = el.expose(photo, t_int, rng=7).counts
    mean = float(el.mean_counts(4.0e5, t_int))
    # σ per pixel = K·√(μ_e + σ_read²); the mean of n draws is within 5 σ/√n (p ≈ 6e-7).
    sigma = 0.0014 * math.sqrt(4.0e5 + 6e4 * t_int + 600.0**2)
    assert abs(counts.mean() - mean) < 5 * sigma / math.sqrt(photo.size)
    assert counts.std() == pytest.approx(sigma, rel=0.01)  # 1 % ≫ √(2/n) ≈ 0.3 %


def test_calibration_counts_use_the_electronics_mean_counts(nist):
    cal = Calibration(nist.response_model, nist.electronics, nist.rate_per_signal, 10e-6)
    temperature = np.array([300.0, 900.0])
    np.testing.assert_array_equal(
        cal.counts(temperature),
        nist.electronics.mean_counts(cal.photoelectrons(temperature), 10e-6))


# -- fitting a camera to a measured calibration table ------------------------------------------


def _measured_table(camera, temperatures, t_int, frames, seed):
    """Mean counts of one pixel over ``frames`` read-outs of blackbodies (radiosim's chain)."""
    small = camera.replace(fpa=replace(camera.fpa, shape=(4, 4)))
    rng = np.random.default_rng(seed)
    return np.array([flat_fields(small, t, t_int, frames, rng)[0][:, 0, 0].mean()
                     for t in temperatures])


def test_fit_calibration_recovers_gain_and_offset_within_the_noise_of_the_counts():
    """Counts simulated at K = 1.5e-3 DN/e⁻ and offset 800 DN; the fit's standard errors come
    from the weighted least-squares covariance (AᵀWA)⁻¹ with the counts' temporal noise; the
    fitted values lie within four of them."""
    camera = Camera.preset("nist-ir")
    truth = camera.replace(electronics=replace(camera.electronics, gain=1.5e-3,
                                                  offset=800.0))
    t = np.linspace(300.0, 600.0, 16)
    frames = 4
    counts = _measured_table(truth, t, 100e-6, frames, seed=1)
    fitted, residuals = fit_calibration(camera, t, counts, 100e-6, frames=frames)
    ideal = truth.replace(electronics=replace(truth.electronics, gain=1.0, offset=0.0,
                                                 adc_bits=None))
    charge = ideal.calibration(100e-6).electrons(t)
    sigma = 1.5e-3 * truth.electronics.temporal_noise(charge) / np.sqrt(frames)  # [DN]
    design = np.column_stack([charge, np.ones_like(charge)]) / sigma[:, None]
    errors = np.sqrt(np.diag(np.linalg.inv(design.T @ design)))
    assert abs(fitted.electronics.gain - 1.5e-3) < 4 * errors[0]
    assert abs(fitted.electronics.offset - 800.0) < 4 * errors[1]
    assert np.sqrt(np.mean((residuals / sigma) ** 2)) < 2  # χ²/dof about 1


def test_fit_calibration_warns_of_model_error():
    """A table measured through a different filter is not what the camera's curves predict:
    the residuals exceed the noise and the fit says by how many kelvin."""
    camera = Camera.preset("nist-ir")
    other = camera.replace(optics=replace(camera.optics, spectral_filter=0.7,
                                             band=(3.0e-6, 5.0e-6)))
    t = np.linspace(300.0, 600.0, 12)
    counts = _measured_table(other, t, 100e-6, 4, seed=2)
    with pytest.warns(RadiosimWarning, match="K of model error"):
        fit_calibration(camera, t, counts, 100e-6, frames=4)


def test_the_calibrate_command_writes_the_fitted_camera(tmp_path, capsys):
    from radiosim.cli import main

    camera = Camera.preset("nist-ir")
    truth = camera.replace(electronics=replace(camera.electronics, gain=1.45e-3))
    t = np.linspace(320.0, 580.0, 8)
    counts = _measured_table(truth, t, 100e-6, 8, seed=3)
    table = tmp_path / "table.csv"
    table.write_text("# blackbody calibration\ntemperature_C,counts\n" + "".join(
        f"{a - 273.15:.2f},{c:.3f}\n" for a, c in zip(t, counts)))
    out = tmp_path / "fitted.toml"
    assert main(["calibrate", str(table), "--camera", "nist-ir", "--integration-time", "100us",
                 "--frames", "8", "--out", str(out)]) == 0
    assert Camera.from_toml(out).electronics.gain == pytest.approx(1.45e-3, rel=2e-3)
    capsys.readouterr()
    (tmp_path / "bad.csv").write_text("T,counts\n300,1000\n")
    assert main(["calibrate", str(tmp_path / "bad.csv"), "--camera", "nist-ir",
                 "--integration-time", "100us"]) == 2
    assert "temperature_K" in capsys.readouterr().err


def test_fit_calibration_measures_the_optics_emission_from_several_instrument_temperatures():
    """A table taken at instrument temperatures of 285–325 K by a camera whose optics emit
    with a grey emissivity of 0.06: the fit recovers gain, offset and that emissivity (the
    emission adds up to ~0.3 % of the signal here, so ε_o is resolved to a few 0.1 %)."""
    camera = Camera.preset("nist-ir").replace(name="lab")
    truth = camera.replace(optics=replace(camera.optics, emissivity=0.06),
                           electronics=replace(camera.electronics, gain=1.5e-3))
    t = np.tile(np.linspace(300.0, 520.0, 6), 3)
    t_i = np.repeat([285.0, 305.0, 325.0], 6)
    rng = np.random.default_rng(5)
    counts = []
    for scene_t, instrument_t in zip(t, t_i):
        at = truth.replace(optics=replace(truth.optics, instrument_temperature=instrument_t),
                           fpa=replace(truth.fpa, shape=(2, 2)))
        counts.append(flat_fields(at, scene_t, 200e-6, 64, rng)[0][:, 0, 0].mean())
    fitted, residuals = fit_calibration(camera, t, counts, 200e-6, frames=64,
                                               instrument_temperatures=t_i)
    assert fitted.electronics.gain == pytest.approx(1.5e-3, rel=2e-3)
    assert fitted.optics.instrument_factor == pytest.approx(0.06, abs=0.01)
    assert fitted.optics.emissivity is None  # the lens's own emission is not what was fitted
    with pytest.raises(RadiosimError, match="two different instrument temperatures"):
        fit_calibration(camera, t, counts, 200e-6, instrument_temperatures=np.full(18, 300.0))


# -- the detection limit: blank + k·σ_blank (EMVA 1288), written out -------------------------------


def _exposure(counts):
    counts = np.asarray(counts, dtype=float)
    none = np.zeros(counts.shape, dtype=bool)
    return Exposure(electrons=counts, counts=counts, saturated=none, adc_floor=none)


@pytest.mark.parametrize("t_int", [1e-6, 20e-6, 1e-3])
def test_detection_limit_is_blank_plus_three_emva_sigmas(nist, t_int):
    b, sigma = blank_and_sigma(nist, t_int)
    cal = nist.calibration(t_int)
    assert cal.blank_counts == pytest.approx(b, abs=1e-9)
    assert cal.blank_noise_counts == pytest.approx(sigma, rel=1e-12)
    assert cal.detection_limit_counts == pytest.approx(b + 3 * sigma, abs=1e-9)


@pytest.mark.parametrize("excess, flagged", [(2.9, True), (3.1, False)])
def test_a_pixel_below_three_sigma_is_under_range(nist, excess, flagged):
    t_int = 20e-6
    b, sigma = blank_and_sigma(nist, t_int)
    reading = nist.calibration(t_int).read(_exposure([b + excess * sigma]))
    assert bool(reading.under_range[0]) == flagged
    assert np.isnan(reading.apparent_temperature[0]) == flagged
    assert not reading.saturated[0] and not reading.over_range[0]


@pytest.mark.parametrize("excess, flagged", [(3.1, True), (4.9, True), (5.1, False)])
def test_k5_moves_the_limit(nist, excess, flagged):
    t_int = 20e-6
    camera = nist.replace(detection_sigma=5.0)
    b, sigma = blank_and_sigma(camera, t_int)
    reading = camera.calibration(t_int).read(_exposure([b + excess * sigma]))
    assert bool(reading.under_range[0]) == flagged


def test_lowest_measurable_temperature_reaches_the_limit(nist):
    t_int = 20e-6
    b, sigma = blank_and_sigma(nist, t_int)
    el = nist.electronics
    lows = []
    for k in (3.0, 5.0):
        low = measurable_range(nist.replace(detection_sigma=k), t_int)[0]
        # Its mean counts, written out, are the limit (radiance table 1e-7 of ≈ 3 DN).
        counts = el.gain * (photo(nist, low, t_int) + el.dark_current * t_int) + el.offset
        assert counts == pytest.approx(b + k * sigma, abs=1e-5)
        lows.append(low)
    assert lows[1] > lows[0]


@pytest.mark.parametrize("temperature", [140.0, 293.15])
@pytest.mark.parametrize("t_int", [1e-6, 2e-6])
def test_a_cold_scene_at_short_integration_reads_under_range(nist, temperature, t_int):
    # Before issue 20 a third of these pixels read 330–387 K unflagged (SNR = 1 floor).
    scene = UniformBlackbody(temperature, shape=(120, 160), dx=nist.fpa.pixel_pitch, dt=t_int)
    m = nist.measure(scene, t_int, 0.0, rng=np.random.default_rng(20))
    reported = float(np.mean(np.isfinite(m.apparent_temperature)))
    # The bound: a pixel is reported when its code reaches ⌈L⌉, i.e. when the analogue count
    # (Gaussian, mean b + K·photo, σ_a² = K²(σ²_read + μ_e), no quantisation) exceeds ⌈L⌉ − ½.
    el = nist.electronics
    b, sigma = blank_and_sigma(nist, t_int)
    mean_e = photo(nist, temperature, t_int) + el.dark_current * t_int
    mean = el.gain * mean_e + el.offset
    sigma_a = el.gain * math.sqrt(el.read_noise**2 + mean_e)
    code = math.ceil(b + 3 * sigma)
    p = 0.5 * math.erfc((code - 0.5 - mean) / (sigma_a * math.sqrt(2)))
    assert p < 0.005  # the 3σ rule: a few pixels per thousand at most
    n = m.apparent_temperature.size
    assert reported < 0.01
    assert abs(reported - p) <= 5 * math.sqrt(p * (1 - p) / n) + 1 / n


def test_flags_are_exclusive_and_flagged_pixels_are_nan(nist):
    frame = np.full((240, 320), 450.0)
    frame[:, :80] = 150.0  # cold: under range
    frame[:, 240:] = 2500.0  # saturates at 320 µs
    scene = FrameStack(np.repeat(frame[None], 3, axis=0), dt=1e-3, dx=3e-6)
    with pytest.warns(RadiosimWarning, match="saturated"):
        m = nist.measure(scene, 320e-6, 0.0, rng=3)
    flags = m.saturated.astype(int) + m.under_range + m.over_range
    assert flags.max() == 1 and m.saturated.any() and m.under_range.any()
    np.testing.assert_array_equal(np.isnan(m.apparent_temperature), flags == 1)


def test_noise_free_quantised_electronics_keep_the_quantisation_in_the_limit(nist):
    camera = nist.replace(electronics=replace(nist.electronics, read_noise=0.0,
                                              shot_noise=False))
    cal = camera.calibration(20e-6)
    el = camera.electronics
    assert cal.detection_limit_counts == pytest.approx(
        el.gain * el.dark_current * 20e-6 + el.offset + 3 * math.sqrt(1 / 12), abs=1e-9)


def test_the_ideal_linear_camera_detects_any_signal():
    cal = Camera.linear_ideal(6e-6).calibration(1e-6)
    assert cal.detection_limit_counts == -math.inf


# -- combinations that cannot give a reading -------------------------------------------------------


def test_a_range_wholly_below_the_detection_limit_is_refused(nist):
    camera = nist.replace(response="linear", name="lin-real")
    # Written out: 3000 K gives K·(R·T·t) = 0.0014 × 1500 e⁻ ≈ 2.1 DN over the blank at 0.5 µs,
    # under 3σ ≈ 2.66 DN.
    b, sigma = blank_and_sigma(camera, 0.5e-6)
    el = camera.electronics
    assert el.gain * camera.linear_responsivity * 3000.0 * 0.5e-6 < 3 * sigma
    scene = UniformBlackbody(2000.0, shape=(120, 160), dx=6e-6, dt=0.5e-6)
    with pytest.raises(RadiosimError) as info:
        camera.measure(scene, 0.5e-6, 0.0, rng=0)
    message = one_line_message(info)
    assert "lin-real" in message and "0.5 µs" in message and "detection limit" in message
    assert f"{b + 3 * sigma:.6g}" in message


def test_a_range_wholly_saturated_is_refused(nist):
    camera = nist.replace(calibration_range=(2500.0, 3000.0))
    # Written out: 2500 K at 1.6 ms gives far more than the 1.1e7 e⁻ well.
    assert photo(camera, 2500.0, 1.6e-3) > camera.electronics.full_well
    scene = UniformBlackbody(2800.0, shape=(120, 160), dx=6e-6, dt=1.6e-3)
    with pytest.raises(RadiosimError, match="saturates") as info:
        camera.measure(scene, 1.6e-3, 0.0, rng=0)
    message = one_line_message(info)
    assert "nist-ir" in message and "1.6 ms" in message and "2500 K" in message


def test_the_coarse_resolution_warning_stays_a_warning(nist):
    camera = nist.replace(response="linear")
    scene = UniformBlackbody(1013.55, shape=(120, 160), dx=6e-6, dt=10e-6)
    with pytest.warns(RadiosimWarning, match="spans only"):
        m = camera.measure(scene, 10e-6, 0.0, rng=0)
    assert m.shape == (120, 160)


# -- fitting a calibration table, written out ------------------------------------------------------


def test_a_fitted_camera_reproduces_its_own_table(nist):
    true = true_camera(nist)
    t_int = 10e-6
    temperatures = np.array([350.0, 450.0, 550.0, 650.0, 800.0])
    counts = counts_table(true, temperatures, t_int)
    assert counts.max() < true.electronics.max_count  # inside the converter (written out)
    start = true.replace(electronics=replace(true.electronics, gain=0.0011, offset=900.0))
    fitted, residuals = fit_calibration(start, temperatures, counts, t_int)
    assert fitted.electronics.gain == pytest.approx(true.electronics.gain, rel=1e-6)
    assert fitted.electronics.offset == pytest.approx(1000.0, abs=1e-3)
    np.testing.assert_allclose(residuals, 0.0, atol=1e-3)
    for t, c in zip(temperatures, counts):
        scene = UniformBlackbody(t, shape=(2, 2), dx=true.fpa.pixel_pitch, dt=t_int)
        m = fitted.measure(scene, t_int, 0.0, rng=0)
        assert np.all(np.abs(m.counts - c) <= 0.5 + 1e-3)  # the 1 DN quantisation
        # The reading is the temperature whose written-out counts are the rounded code:
        # within half a DN of the table's counts (the quantisation).
        back = counts_table(true, m.apparent_temperature.ravel(), t_int)
        assert np.all(np.abs(back - c) <= 0.5 + 1e-3)


def test_points_beyond_the_full_well_are_refused_and_named(nist):
    true = true_camera(nist).replace(
        electronics=replace(true_camera(nist).electronics, adc_bits=18))
    t_int = 100e-6
    temperatures = np.array([400.0, 500.0, 600.0, 900.0, 1200.0])
    counts = counts_table(true, temperatures, t_int)  # unclipped: the last two overfill the well
    over = [t for t in temperatures if photo(true, t, t_int) > true.electronics.full_well]
    assert over == [900.0, 1200.0]
    with pytest.raises(RadiosimError, match="full well") as info:
        fit_calibration(true, temperatures, counts, t_int)
    message = one_line_message(info)
    assert "900 K" in message and "1200 K" in message and "1.1e+07 e⁻" in message
    assert f"{counts[3]:g} DN" in message and "400 K" not in message


def test_points_at_the_top_code_or_zero_are_refused(nist):
    true = true_camera(nist)
    t_int = 10e-6
    temperatures = np.array([350.0, 450.0, 550.0, 650.0, 800.0])
    counts = counts_table(true, temperatures, t_int)
    counts[-1] = 16383.0
    with pytest.raises(RadiosimError, match="top code 16383") as info:
        fit_calibration(true, temperatures, counts, t_int)
    assert "800 K (16383 DN)" in one_line_message(info)
    counts = counts_table(true, temperatures, t_int)
    counts[0] = 0.0
    with pytest.raises(RadiosimError, match="code 0"):
        fit_calibration(true, temperatures, counts, t_int)


def test_unusable_points_are_excluded_on_request_with_a_warning(nist):
    true = true_camera(nist)
    t_int = 10e-6
    temperatures = np.array([350.0, 450.0, 550.0, 650.0, 800.0, 3000.0])
    counts = np.append(counts_table(true, temperatures[:-1], t_int), 16383.0)
    with pytest.warns(RadiosimWarning, match="3000 K"):
        fitted, residuals = fit_calibration(true, temperatures, counts, t_int,
                                                 exclude_unusable=True)
    assert np.isnan(residuals[-1]) and np.all(np.abs(residuals[:-1]) < 1e-3)
    assert fitted.electronics.gain == pytest.approx(true.electronics.gain, rel=1e-6)


def test_the_well_is_widened_on_request(nist):
    true = true_camera(nist).replace(
        electronics=replace(true_camera(nist).electronics, adc_bits=18))
    t_int = 100e-6
    temperatures = np.array([400.0, 500.0, 600.0, 900.0])
    counts = counts_table(true, temperatures, t_int)
    fitted, _ = fit_calibration(true, temperatures, counts, t_int, fit_full_well=True)
    assert fitted.electronics.full_well >= photo(true, 900.0, t_int)


@pytest.mark.parametrize("frames", [0, -3, 1.5, True])
def test_frames_must_be_a_whole_number(nist, frames):
    true = true_camera(nist)
    temperatures = np.array([350.0, 450.0, 550.0])
    with pytest.raises(RadiosimError, match="frames") as info:
        fit_calibration(true, temperatures, counts_table(true, temperatures, 1e-5), 1e-5, frames)
    one_line_message(info)


def test_counts_that_fall_with_temperature_are_refused(nist):
    true = true_camera(nist)
    temperatures = np.array([350.0, 450.0, 550.0, 650.0])
    counts = counts_table(true, temperatures, 1e-5)[[0, 2, 1, 3]]
    with pytest.raises(RadiosimError, match="fall"):
        fit_calibration(true, temperatures, counts, 1e-5)


def test_no_warning_is_silenced_by_fit(nist):
    # A table the model cannot fit (counts off by a 2 % scale slope) warns; nothing hides it.
    true = true_camera(nist)
    temperatures = np.array([350.0, 450.0, 550.0, 650.0, 800.0])
    counts = counts_table(true, temperatures, 1e-5) * (1 + 0.02 * np.linspace(0, 1, 5))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        fit_calibration(true, temperatures, counts, 1e-5)
    assert any("residuals exceed" in str(w.message) for w in caught)


@pytest.mark.parametrize("noise", [0.0, 1.5])
def test_a_table_of_dark_frames_is_refused_not_fitted(noise):
    # Counts that do not rise with temperature (every row a dark frame: the offset and the
    # dark charge, with or without a little noise) give a gain indistinguishable from 0
    # (7.6e-20 DN/e⁻ was fitted and the command exited 0); it is refused in one line naming
    # the gain and its uncertainty. A real table of the same camera still fits.
    camera = Camera.preset("nist-ir")
    temperatures = np.linspace(350.0, 650.0, 8)
    t_int = 100e-6
    el = camera.electronics
    dark = el.gain * el.dark_current * t_int + el.offset
    # A micro-DN rise: a fitted gain > 0, but nothing next to the counts' noise.
    counts = dark + noise * np.sin(np.arange(8.0)) + 1e-6 * np.arange(8.0)
    with pytest.raises(RadiosimError, match=r"the counts do not rise with temperature") as info:
        fit_calibration(camera, temperatures, counts, t_int)
    if noise == 0.0:
        assert re.search(r"beyond their noise: the fitted gain is \S+ ± \S+ DN/e⁻",
                         str(info.value)), str(info.value)
    assert "\n" not in str(info.value)
    real = counts_table(camera, temperatures, t_int)  # the radiometry written out (conftest)
    fitted, _ = fit_calibration(camera, temperatures, real, t_int)
    assert fitted.electronics.gain == pytest.approx(el.gain, rel=1e-3)


def test_the_share_reported_at_the_lowest_measurable_temperature_is_the_documented_one():
    # Counts are whole numbers: a pixel is reported where rint(analogue) ≥ L, i.e. where its
    # analogue counts reach ⌈L⌉ − 0.5 DN (docs/physics.md). At the lowest measurable
    # temperature (mean counts = L) that share is Φ((L − ⌈L⌉ + 0.5) / σ_a), σ_a the analogue
    # noise (the temporal noise less the 1/12 DN² of rounding): not the 50 % a threshold at L
    # would give. 40 000 pixels of nist-ir at 10 µs: within 4 binomial standard deviations.
    from scipy.stats import norm

    camera = Camera.preset("nist-ir")
    t_int = 10e-6
    calibration = camera.calibration(t_int)
    low = calibration.lowest_measurable_temperature()
    limit = calibration.detection_limit_counts
    electrons = float(calibration.electrons(low))
    sigma = math.sqrt(float(camera.electronics.temporal_noise_counts(electrons)) ** 2 - 1 / 12)
    expected = norm.cdf((limit - math.ceil(limit) + 0.5) / sigma)
    scene = UniformBlackbody(low, (400, 400), dx=camera.fpa.pixel_pitch, dt=1e-6)
    m = camera.replace(fpa=replace(camera.fpa, shape=(200, 200))).measure(scene, t_int, rng=1)
    share = float(np.mean(~m.under_range))
    assert abs(share - expected) < 4 * math.sqrt(expected * (1 - expected) / m.counts.size)
    assert abs(expected - 0.5) > 4 * math.sqrt(0.25 / m.counts.size)  # the effect is seen


def test_an_instrument_factor_above_one_is_fitted_not_clipped():
    """A camera whose detector sees 6.5 × a black cone's radiance at the housing temperature
    (warm parts beyond the cone): tables at 290 and 310 K give back 6.5 (it was clipped at 1,
    and the fitted camera then read a 150 °C blackbody at 281 °C); the fitted camera's counts
    at a third housing temperature are the truth's, and its file keeps the factor."""
    camera = Camera.preset("nist-ir").replace(name="lab")
    truth = camera.replace(optics=replace(camera.optics, instrument_factor=6.5))
    t = np.tile(np.linspace(350.0, 600.0, 5), 2)
    t_i = np.repeat([290.0, 310.0], 5)
    counts = [float(truth.replace(optics=replace(truth.optics, instrument_temperature=ti))
                    .calibration(100e-6).counts(x)) for x, ti in zip(t, t_i)]
    fitted, _ = fit_calibration(camera, t, counts, 100e-6, instrument_temperatures=t_i)
    assert fitted.optics.instrument_factor == pytest.approx(6.5, rel=1e-6)
    at = {c: c.replace(optics=replace(c.optics, instrument_temperature=300.0))
          for c in (truth, fitted)}
    assert float(at[fitted].calibration(100e-6).counts(450.0)) == pytest.approx(
        float(at[truth].calibration(100e-6).counts(450.0)), rel=1e-9)
    assert Camera.from_dict(fitted.to_dict()).optics.instrument_factor == pytest.approx(6.5)
