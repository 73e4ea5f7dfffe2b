"""Issue 20, what a reading is: the detection limit, camera-side input checks, calibration fits.

Expected values are written out here from the EMVA 1288 linear model and the preset's numbers:
the blank reading b = K·μ_e,dark + offset (nist-ir has no reflection, path or optics emission),
its noise σ² = K² (σ²_read + μ_e,dark) + 1/12 DN², in-band radiance by quadrature
(:func:`radiosim.radiometry.band_radiance`) and the étendue of the objective's image-side cone,
G = A·π·(NA/m)².
"""

import math
import warnings
from dataclasses import replace

import numpy as np
import pytest

from radiosim import Camera, FrameStack, UniformBlackbody
from radiosim.calibration import fit_calibration
from radiosim.calibration_table import calibrate_from_table, read_calibration_table
from radiosim.characterization import measurable_range
from radiosim.electronics import Exposure
from radiosim.errors import RadiosimError, RadiosimWarning
from radiosim.radiometry import band_radiance


@pytest.fixture(scope="module")
def nist():
    return Camera.preset("nist-ir")


def blank_and_sigma(camera, t_int):
    """(b [DN], σ_b [DN]) written out from the EMVA 1288 model."""
    el = camera.electronics
    dark = el.dark_current * t_int  # [e⁻]
    sigma = math.sqrt(el.gain**2 * (el.read_noise**2 + dark) + 1 / 12)
    return el.gain * dark + el.offset, sigma


def photo(camera, temperature, t_int):
    """Mean photo-electrons of a blackbody [e⁻], written out."""
    fpa, optics = camera.fpa, camera.optics
    etendue = fpa.fill_factor * fpa.detector_pitch**2 * math.pi * (
        optics.objective_na / (fpa.detector_pitch / fpa.pixel_pitch)) ** 2
    return float(band_radiance(temperature, optics.band, "photon", camera.responsivity)) \
        * etendue * t_int


def one_line(info):
    message = str(info.value)
    assert "\n" not in message and "Traceback" not in message
    return message


def _exposure(counts):
    counts = np.asarray(counts, dtype=float)
    none = np.zeros(counts.shape, dtype=bool)
    return Exposure(electrons=counts, counts=counts, saturated=none, adc_floor=none)


# -- 1. the detection limit -----------------------------------------------------------------------


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


@pytest.mark.parametrize("k", [0.0, -1.0, math.nan, math.inf, True, "3"])
def test_detection_sigma_must_be_positive_and_finite(nist, k):
    with pytest.raises(RadiosimError, match="detection_sigma") as info:
        nist.replace(detection_sigma=k)
    one_line(info)


def test_detection_sigma_from_a_camera_file(nist, tmp_path):
    path = tmp_path / "cam.toml"
    path.write_text(nist.to_toml().replace("detection_sigma = 3.0", "detection_sigma = 4.5"),
                    encoding="utf-8")
    camera = Camera.from_toml(path)
    assert camera.detection_sigma == 4.5
    b, sigma = blank_and_sigma(camera, 1e-5)
    assert camera.calibration(1e-5).detection_limit_counts == pytest.approx(b + 4.5 * sigma)
    path.write_text(nist.to_toml().replace("detection_sigma = 3.0", "detection_sigma = -2"),
                    encoding="utf-8")
    with pytest.raises(RadiosimError) as info:
        Camera.from_toml(path)
    message = one_line(info)
    assert str(path) in message and "detection_sigma = -2" in message


# -- 2. combinations that cannot give a reading ---------------------------------------------------


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
    message = one_line(info)
    assert "lin-real" in message and "0.5 µs" in message and "detection limit" in message
    assert f"{b + 3 * sigma:.6g}" in message


def test_a_range_wholly_saturated_is_refused(nist):
    camera = nist.replace(calibration_range=(2500.0, 3000.0))
    # Written out: 2500 K at 1.6 ms gives far more than the 1.1e7 e⁻ well.
    assert photo(camera, 2500.0, 1.6e-3) > camera.electronics.full_well
    scene = UniformBlackbody(2800.0, shape=(120, 160), dx=6e-6, dt=1.6e-3)
    with pytest.raises(RadiosimError, match="saturates") as info:
        camera.measure(scene, 1.6e-3, 0.0, rng=0)
    message = one_line(info)
    assert "nist-ir" in message and "1.6 ms" in message and "2500 K" in message


def test_the_coarse_resolution_warning_stays_a_warning(nist):
    camera = nist.replace(response="linear")
    scene = UniformBlackbody(1013.55, shape=(120, 160), dx=6e-6, dt=10e-6)
    with pytest.warns(RadiosimWarning, match="spans only"):
        m = camera.measure(scene, 10e-6, 0.0, rng=0)
    assert m.shape == (120, 160)


# -- 3. what measure accepts ----------------------------------------------------------------------


@pytest.mark.parametrize("scene", [np.full((3, 12, 12), 600.0), [[600.0]], None])
def test_measure_refuses_what_is_not_a_scene(scene):
    camera = Camera.linear_ideal(3e-6)
    with pytest.raises(RadiosimError, match="Scene") as info:
        camera.measure(scene, 1e-6)
    if isinstance(scene, (np.ndarray, list)):
        assert "FrameStack(frames, dt=" in one_line(info)


@pytest.mark.parametrize("t_int, t_start, name", [
    ("1us", None, "integration_time"), (True, None, "integration_time"),
    (math.nan, None, "integration_time"), (-1e-6, None, "integration_time"),
    (1e-6, "0", "t_start"), (1e-6, math.nan, "t_start"), (1e-6, -1e-6, "t_start"),
])
def test_measure_refuses_bad_times_in_one_line(t_int, t_start, name):
    camera = Camera.linear_ideal(3e-6)
    scene = UniformBlackbody(600.0, shape=(6, 6), dx=1e-6, dt=1e-6)
    with pytest.raises(RadiosimError, match=name) as info:
        camera.measure(scene, t_int, t_start)
    one_line(info)


# -- 4. fitting a calibration table ---------------------------------------------------------------


def _true_camera(nist):
    """nist-ir without temporal noise (the table is a mean of many frames), quantising."""
    return nist.replace(electronics=replace(nist.electronics, read_noise=0.0,
                                            shot_noise=False), fpa=replace(nist.fpa, shape=(2, 2)))


def _table(camera, temperatures, t_int):
    el = camera.electronics
    return np.array([el.gain * (photo(camera, t, t_int) + el.dark_current * t_int) + el.offset
                     for t in temperatures])


def test_a_fitted_camera_reproduces_its_own_table(nist):
    true = _true_camera(nist)
    t_int = 10e-6
    temperatures = np.array([350.0, 450.0, 550.0, 650.0, 800.0])
    counts = _table(true, temperatures, t_int)
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
        back = _table(true, m.apparent_temperature.ravel(), t_int)
        assert np.all(np.abs(back - c) <= 0.5 + 1e-3)


def test_points_beyond_the_full_well_are_refused_and_named(nist):
    true = _true_camera(nist).replace(
        electronics=replace(_true_camera(nist).electronics, adc_bits=18))
    t_int = 100e-6
    temperatures = np.array([400.0, 500.0, 600.0, 900.0, 1200.0])
    counts = _table(true, temperatures, t_int)  # unclipped: the last two overfill the well
    over = [t for t in temperatures if photo(true, t, t_int) > true.electronics.full_well]
    assert over == [900.0, 1200.0]
    with pytest.raises(RadiosimError, match="full well") as info:
        fit_calibration(true, temperatures, counts, t_int)
    message = one_line(info)
    assert "900 K" in message and "1200 K" in message and "1.1e+07 e⁻" in message
    assert f"{counts[3]:g} DN" in message and "400 K" not in message


def test_points_at_the_top_code_or_zero_are_refused(nist):
    true = _true_camera(nist)
    t_int = 10e-6
    temperatures = np.array([350.0, 450.0, 550.0, 650.0, 800.0])
    counts = _table(true, temperatures, t_int)
    counts[-1] = 16383.0
    with pytest.raises(RadiosimError, match="top code 16383") as info:
        fit_calibration(true, temperatures, counts, t_int)
    assert "800 K (16383 DN)" in one_line(info)
    counts = _table(true, temperatures, t_int)
    counts[0] = 0.0
    with pytest.raises(RadiosimError, match="code 0"):
        fit_calibration(true, temperatures, counts, t_int)


def test_unusable_points_are_excluded_on_request_with_a_warning(nist):
    true = _true_camera(nist)
    t_int = 10e-6
    temperatures = np.array([350.0, 450.0, 550.0, 650.0, 800.0, 3000.0])
    counts = np.append(_table(true, temperatures[:-1], t_int), 16383.0)
    with pytest.warns(RadiosimWarning, match="3000 K"):
        fitted, residuals = fit_calibration(true, temperatures, counts, t_int,
                                                 exclude_unusable=True)
    assert np.isnan(residuals[-1]) and np.all(np.abs(residuals[:-1]) < 1e-3)
    assert fitted.electronics.gain == pytest.approx(true.electronics.gain, rel=1e-6)


def test_the_well_is_widened_on_request(nist):
    true = _true_camera(nist).replace(
        electronics=replace(_true_camera(nist).electronics, adc_bits=18))
    t_int = 100e-6
    temperatures = np.array([400.0, 500.0, 600.0, 900.0])
    counts = _table(true, temperatures, t_int)
    fitted, _ = fit_calibration(true, temperatures, counts, t_int, fit_full_well=True)
    assert fitted.electronics.full_well >= photo(true, 900.0, t_int)


@pytest.mark.parametrize("frames", [0, -3, 1.5, True])
def test_frames_must_be_a_whole_number(nist, frames):
    true = _true_camera(nist)
    temperatures = np.array([350.0, 450.0, 550.0])
    with pytest.raises(RadiosimError, match="frames") as info:
        fit_calibration(true, temperatures, _table(true, temperatures, 1e-5), 1e-5, frames)
    one_line(info)


def test_counts_that_fall_with_temperature_are_refused(nist):
    true = _true_camera(nist)
    temperatures = np.array([350.0, 450.0, 550.0, 650.0])
    counts = _table(true, temperatures, 1e-5)[[0, 2, 1, 3]]
    with pytest.raises(RadiosimError, match="fall"):
        fit_calibration(true, temperatures, counts, 1e-5)


# -- the table read by radiosim calibrate ---------------------------------------------------------


def _write(tmp_path, text, name="table.csv", encoding="utf-8"):
    path = tmp_path / name
    path.write_text(text, encoding=encoding)
    return path


def test_a_table_in_both_units_that_disagree_is_refused(tmp_path):
    path = _write(tmp_path, "temperature_K,temperature_C,counts\n400,126.85,1100\n"
                  "500,300,1200\n600,326.85,1300\n")
    with pytest.raises(RadiosimError) as info:
        read_calibration_table(path)
    message = one_line(info)
    assert str(path) in message and "temperature_K" in message and "temperature_C" in message
    assert "line 3" in message


def test_a_table_in_both_units_that_agree_is_read(tmp_path):
    path = _write(tmp_path, "temperature_K,temperature_C,counts\n400,126.85,1100\n"
                  "500,226.85,1200\n")
    table = read_calibration_table(path)
    np.testing.assert_allclose(table.temperature, [400.0, 500.0])


def test_a_duplicate_column_is_refused(tmp_path):
    path = _write(tmp_path, "temperature_K,counts,counts\n400,1100,1\n500,1200,2\n")
    with pytest.raises(RadiosimError, match="column counts appears 2 times"):
        read_calibration_table(path)


def test_a_units_line_contradicting_the_column_is_refused(tmp_path):
    path = _write(tmp_path, "# units: temperature=C\ntemperature_K,counts\n400,1100\n")
    with pytest.raises(RadiosimError, match="temperature_K") as info:
        read_calibration_table(path)
    assert "temperature=C" in one_line(info)


def test_counts_not_monotonic_in_temperature_are_refused(tmp_path):
    path = _write(tmp_path, "temperature_K,counts\n400,1100\n500,1050\n600,1300\n")
    with pytest.raises(RadiosimError, match="column counts is not monotonic") as info:
        read_calibration_table(path)
    assert "line 3" in one_line(info)


def test_a_value_that_is_not_a_number_names_line_and_column(tmp_path):
    path = _write(tmp_path, "temperature_K,counts\n400,1100\n500,n/a\n")
    with pytest.raises(RadiosimError, match="line 3, column counts = 'n/a'"):
        read_calibration_table(path)


def test_a_table_with_a_byte_order_mark_is_read(tmp_path):
    path = _write(tmp_path, "temperature_C,counts\n100,1100\n200,1200\n", encoding="utf-8-sig")
    table = read_calibration_table(path)
    np.testing.assert_allclose(table.temperature, [373.15, 473.15])


@pytest.mark.parametrize("frames", [0, -1, 2.5])
def test_calibrate_frames_are_checked_before_the_table_is_read(nist, tmp_path, frames):
    with pytest.raises(RadiosimError, match="frames") as info:
        calibrate_from_table(nist, tmp_path / "missing.csv", 1e-5, frames=frames)
    one_line(info)


def test_calibrate_from_table_names_the_file_and_the_points(nist, tmp_path):
    true = _true_camera(nist)
    temperatures = [350.0, 450.0, 550.0, 650.0]
    counts = list(_table(true, temperatures, 1e-5)) + [16383.0]
    rows = "".join(f"{t},{float(c)!r}\n" for t, c in zip(temperatures + [3000.0], counts))
    path = _write(tmp_path, "temperature_K,counts\n" + rows)
    with pytest.raises(RadiosimError) as info:
        calibrate_from_table(true, path, 1e-5)
    message = one_line(info)
    assert str(path) in message and "3000 K (16383 DN)" in message
    with pytest.warns(RadiosimWarning, match="3000 K"):
        fitted, residuals, table = calibrate_from_table(true, path, 1e-5, exclude_unusable=True)
    assert fitted.electronics.gain == pytest.approx(true.electronics.gain, rel=1e-6)


# -- 5. camera files ------------------------------------------------------------------------------


@pytest.mark.parametrize("old, new, key", [
    ("full_well_e = 1.1e7", "full_well_e = -5", "[electronics] full_well_e = -5"),
    ("f_number = 2.5", "f_number = -2", "[optics] f_number = -2"),
    ("fill_factor = 0.85", "fill_factor = 1.5", "[fpa] fill_factor = 1.5"),
    ("calibration_range_K = [150.0, 3000.0]", "calibration_range_K = [3000.0, 150.0]",
     "calibration_range_K = [3000.0, 150.0]"),
    ('quantum_efficiency = "qe_insb_77K"', 'quantum_efficiency = "nope"',
     '[fpa] quantum_efficiency = "nope"'),
    ("assumed_emissivity = 1.0", "assumed_emissivity = 2.0", "assumed_emissivity = 2.0"),
])
def test_camera_file_errors_name_the_file_and_the_key(tmp_path, old, new, key):
    from radiosim.presets import PRESET_DIRECTORY

    text = (PRESET_DIRECTORY / "nist-ir.toml").read_text(encoding="utf-8")
    assert old in text
    path = _write(tmp_path, text.replace(old, new), "my.toml")
    with pytest.raises(RadiosimError) as info:
        Camera.from_toml(path)
    message = one_line(info)
    assert message.startswith(f"{path}: {key}: "), message


def test_a_camera_file_with_a_byte_order_mark_is_read(tmp_path):
    from radiosim.presets import PRESET_DIRECTORY

    text = (PRESET_DIRECTORY / "nist-ir.toml").read_text(encoding="utf-8")
    path = _write(tmp_path, text, "bom.toml", encoding="utf-8-sig")
    assert path.read_bytes()[:3] == b"\xef\xbb\xbf"
    assert Camera.from_toml(path).to_dict() == Camera.preset("nist-ir").to_dict()


def test_no_warning_is_silenced_by_fit(nist):
    # A table the model cannot fit (counts off by a 2 % scale slope) warns; nothing hides it.
    true = _true_camera(nist)
    temperatures = np.array([350.0, 450.0, 550.0, 650.0, 800.0])
    counts = _table(true, temperatures, 1e-5) * (1 + 0.02 * np.linspace(0, 1, 5))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        fit_calibration(true, temperatures, counts, 1e-5)
    assert any("residuals exceed" in str(w.message) for w in caught)
