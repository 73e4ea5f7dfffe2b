"""The camera end to end: presets, calibration round trip, flags, emissivity."""

import dataclasses
import math
import warnings
from pathlib import Path

import numpy as np
import pytest

from conftest import (api_error, blank_and_sigma, fea_rows, fea_text, gradient_frames,
                      one_line_message, write_file)
from radiosim import Camera, Electronics, FrameStack, MovingGaussianBand, UniformBlackbody
from radiosim.acquisition import is_rolling
from radiosim.errors import RadiosimError, RadiosimWarning
from radiosim.io import read_fea_nodes, read_frames
from radiosim.radiometry import band_radiance
from radiosim.spectral import read_spectrum

DX = 960e-6 / 1440


def nist(**electronics):
    """The nist-ir camera with the bare f/2.5 cold stop (no objective NA), the étendue these
    round-trip and flag cases were chosen for, and electronics overrides."""
    camera = Camera.preset("nist-ir")
    camera = camera.replace(optics=dataclasses.replace(camera.optics, objective_na=None))
    if electronics:
        fields = {k: getattr(camera.electronics, k) for k in
                  ("full_well", "dark_current", "read_noise", "shot_noise", "gain", "offset",
                   "adc_bits")}
        camera = camera.replace(electronics=Electronics(**(fields | electronics)))
    return camera


def blackbody(temperature, emissivity=1.0, shape=(27, 36)):
    return UniformBlackbody(temperature, shape=shape, dx=DX, dt=0.2e-6, emissivity=emissivity)


def test_nist_preset_matches_the_paper():
    cam = Camera.preset("nist-ir")
    assert cam.fpa.shape == (120, 160)
    assert cam.fpa.pixel_pitch * 160 == pytest.approx(0.96e-3)
    assert cam.fpa.pixel_pitch * 120 == pytest.approx(0.72e-3)
    assert cam.frame_rate == 600.0
    assert cam.electronics.adc_bits == 14
    assert 5e6 <= cam.electronics.full_well <= 18e6
    assert cam.response == "planck"
    assert cam.fpa.magnification == pytest.approx(5.0)


@pytest.mark.parametrize("t_int, temperature", [
    (1e-6, 420.0), (1e-6, 650.0), (1e-6, 900.0), (1e-6, 1200.0),
    (10e-6, 420.0), (10e-6, 520.0), (10e-6, 640.0), (90e-6, 330.0),
])
def test_uniform_blackbody_round_trip_within_one_quantisation_step(t_int, temperature):
    camera = nist(shot_noise=False, read_noise=0.0)
    cal = camera.calibration(t_int)
    assert temperature < cal.saturation_temperature
    m = camera.measure(blackbody(temperature), t_int, t_start=0.0)
    assert m.valid.all()
    # Half a DN of rounding, converted through the local slope of the calibration curve.
    slope = (cal.counts(temperature + 1e-3) - cal.counts(temperature - 1e-3)) / 2e-3
    assert np.max(np.abs(m.apparent_temperature - temperature)) <= 0.5 / slope * (1 + 1e-9)


def test_above_full_well_is_flagged_never_plausible():
    camera = nist()
    with pytest.warns(RadiosimWarning, match="saturated"):
        m = camera.measure(blackbody(1012.15), 90e-6, t_start=0.0, rng=0)
    assert m.saturated.all()
    assert np.isnan(m.apparent_temperature).all()
    assert np.all(m.electrons == camera.electronics.full_well)


def test_below_the_calibration_range_is_under_range():
    camera = nist()
    m = camera.measure(blackbody(155.0), 1e-6, t_start=0.0, rng=0)
    assert m.under_range.any()
    assert np.isnan(m.apparent_temperature[m.under_range]).all()
    assert not m.saturated.any()


def test_noise_scatter_matches_the_calibration_slope():
    camera = nist()
    t_int, temperature = 10e-6, 550.0
    m = camera.measure(blackbody(temperature, shape=(270, 360)), t_int, t_start=0.0, rng=3)
    cal = camera.calibration(t_int)
    el = camera.electronics
    mean_e = cal.electrons(temperature)
    sigma_dn = np.sqrt(el.gain**2 * (mean_e + el.read_noise**2) + 1 / 12)

    def slope(t):  # dDN/dT of the calibration [DN/K]
        return (cal.counts(t + 0.01) - cal.counts(t - 0.01)) / 0.02

    sigma_t = sigma_dn / slope(temperature)
    spread = np.std(m.apparent_temperature)
    n = m.apparent_temperature.size
    # Sampling error of a standard deviation, plus the change of slope across ±σ that the
    # linear propagation ignores.
    curvature = abs(slope(temperature + sigma_t) - slope(temperature - sigma_t)) / (
        2 * slope(temperature))
    assert spread == pytest.approx(sigma_t, rel=4 / np.sqrt(2 * n) + curvature)
    assert np.mean(m.apparent_temperature) == pytest.approx(temperature, abs=4 * spread / n**0.5)


def test_grey_emissivity_and_the_cameras_setting():
    t_int, temperature = 5e-6, 800.0
    scene = blackbody(temperature, emissivity=0.4)
    exact = nist(shot_noise=False, read_noise=0.0, adc_bits=None)
    right = exact.replace(assumed_emissivity=0.4).measure(scene, t_int, t_start=0.0)
    np.testing.assert_allclose(right.apparent_temperature, temperature, rtol=1e-9)
    wrong = exact.measure(scene, t_int, t_start=0.0)  # camera set to ε = 1
    table = exact.response_model.table()
    expected = table.temperature(0.4 * table(temperature))
    np.testing.assert_allclose(wrong.apparent_temperature, expected, rtol=1e-9)
    assert expected < temperature - 100


def test_spectral_emissivity_uses_its_own_band_integral():
    t_int, temperature = 5e-6, 900.0
    steel = read_spectrum("emissivity_steel_clean")
    camera = nist(shot_noise=False, read_noise=0.0, adc_bits=None, dark_current=0.0)
    m = camera.measure(blackbody(temperature, emissivity=steel), t_int, t_start=0.0)
    radiance = band_radiance(temperature, camera.optics.band, responsivity=camera.responsivity,
                             emissivity=steel)
    expected_e = radiance * camera.etendue * t_int
    np.testing.assert_allclose(m.electrons, expected_e, rtol=1e-7)


def test_emissivity_map_weights_each_sample():
    stack = np.full((3, 18, 18), 700.0)
    emissivity = np.ones((18, 18))
    emissivity[:, 9:] = 0.5
    camera = nist(shot_noise=False, read_noise=0.0, adc_bits=None)
    m = camera.measure(FrameStack(stack, 0.2e-6, DX, emissivity=emissivity), 0.6e-6,
                       t_start=0.0)
    assert m.shape == (2, 2)
    full, half = m.signal_mean[0, 0], m.signal_mean[0, 1]
    assert half == pytest.approx(0.5 * full, rel=1e-12)


def test_linear_ideal_calibration_is_the_identity():
    cal = Camera.linear_ideal(6e-6).calibration(90e-6)
    t = np.array([293.15, 567.0 + 273.15, 1012.15])
    np.testing.assert_allclose(cal.temperature(cal.counts(t)), t, rtol=1e-14)
    assert cal.saturation_temperature == np.inf


def test_window_is_centred_on_the_event_by_default():
    band = MovingGaussianBand(shape=(9, 90), dx=1e-6, dt=0.2e-6, event_time=10e-6)
    m = Camera.linear_ideal(3e-6).measure(band, 2e-6)
    assert m.t_start == pytest.approx(9e-6) and m.t_stop == pytest.approx(11e-6)
    with pytest.raises(RadiosimError, match="would start before the first frame"):
        Camera.linear_ideal(3e-6).measure(band, 30e-6)


def test_integration_longer_than_the_frame_period_is_refused():
    with pytest.raises(RadiosimError, match="exceeds the frame period"):
        Camera.preset("nist-ir").measure(blackbody(500.0), 2e-3, t_start=0.0)


def test_presets_and_toml_errors(tmp_path):
    with pytest.raises(RadiosimError, match="unknown camera preset"):
        Camera.preset("hubble")
    bad = tmp_path / "cam.toml"
    bad.write_text('response = "planck"\n[fpa]\npixel_pitch_um = 6.0\nfill_factr = 0.8\n')
    with pytest.raises(RadiosimError, match=r"\[fpa\]: unknown key\(s\) fill_factr \(did you "
                                            r"mean fill_factor\?\)"):
        Camera.from_toml(bad)
    bad.write_text("[fpa\n")
    with pytest.raises(RadiosimError, match="not valid TOML"):
        Camera.from_toml(bad)
    bad.write_text('[fpa]\nshape = [4, 4]\n')
    with pytest.raises(RadiosimError, match="pixel_pitch_um"):
        Camera.from_toml(bad)


def test_toml_camera_with_a_relative_csv_curve(tmp_path):
    (tmp_path / "qe.csv").write_text("# quantity: qe\n# wavelength_unit: um\n# source: lab\n"
                                     "# idealised: no\nw,q\n3.0,0.5\n6.0,0.5\n")
    (tmp_path / "cam.toml").write_text(
        'name = "mine"\n[fpa]\npixel_pitch_um = 10.0\nquantum_efficiency = "qe.csv"\n'
        '[optics]\nband_um = [3.8, 5.1]\nf_number = 2.0\n')
    cam = Camera.from_toml(tmp_path / "cam.toml")
    assert cam.name == "mine" and cam.fpa.quantum_efficiency[4e-6] == pytest.approx(0.5)
    assert cam.to_dict()["fpa"]["quantum_efficiency"]["name"] == "qe"


def test_with_pixel_pitch_keeps_magnification_origin_and_curves():
    cam = Camera.preset("nist-ir").replace(
        fpa=dataclasses.replace(Camera.preset("nist-ir").fpa, origin=(1e-6, 2e-6)))
    bigger = cam.with_pixel_pitch(14e-6)
    assert bigger.fpa.pixel_pitch == 14e-6
    assert bigger.fpa.magnification == pytest.approx(cam.fpa.magnification, rel=1e-15)
    assert bigger.fpa.origin == cam.fpa.origin and bigger.fpa.shape == cam.fpa.shape
    assert bigger.fpa.quantum_efficiency is cam.fpa.quantum_efficiency
    # Étendue scales with the active area: (14/6)².
    assert bigger.etendue / cam.etendue == pytest.approx((14 / 6) ** 2, rel=1e-12)


def test_a_rolling_shutter_delays_each_row_by_its_row_time():
    """Row i of a rolling shutter reads what a snapshot camera reads with its window started
    i·row_time later; a vertical band moving in x then leans (its peak column shifts with the
    row by v·row_time / pitch)."""
    band = MovingGaussianBand(300.0, 600.0, sigma=6e-6, velocity=2.0, x0=10e-6,
                              shape=(48, 160), dx=1e-6, dt=0.5e-6, n_frames=200)
    snapshot = Camera.linear_ideal(4e-6)
    rolling = snapshot.replace(fpa=dataclasses.replace(snapshot.fpa, shutter="rolling",
                                                       row_time=2e-6))
    m = rolling.measure(band, 5e-6, t_start=10e-6)
    for i in (0, 5, 11):
        row = snapshot.measure(band, 5e-6, t_start=10e-6 + i * 2e-6).apparent_temperature[i]
        np.testing.assert_allclose(m.apparent_temperature[i], row, rtol=1e-12)
    assert is_rolling(rolling) and not is_rolling(snapshot)
    peak = np.argmax(m.apparent_temperature, axis=1)
    assert peak[-1] > peak[0]  # 11 rows × 2 µs × 2 m/s = 44 µm: the band leans by 11 pixels


def test_a_rolling_shutter_past_the_scene_end_is_refused():
    band = MovingGaussianBand(shape=(48, 64), dx=1e-6, dt=1e-6, n_frames=20)
    camera = Camera.linear_ideal(4e-6)
    camera = camera.replace(fpa=dataclasses.replace(camera.fpa, shutter="rolling",
                                                    row_time=2e-6))
    with pytest.raises(RadiosimError, match="rolling shutter's last row"):
        camera.measure(band, 5e-6, t_start=0.0)


def test_reprs_are_one_line_with_the_key_settings():
    # print(camera) once dumped every spectral curve's values (43 kB); now one line each.
    from radiosim.scenes import FrameStack, UniformBlackbody

    camera = Camera.preset("nist-ir")
    lines = {
        "camera": (repr(camera), ["nist-ir", "planck", "160 × 120 px", "6 µm", "3.75–5.15 µm",
                                  "f/2.5", "14-bit"]),
        "channels": (repr(Camera.preset("two-colour")), ["3.8–4.2 µm + 4.6–5.1 µm"]),
        "optics": (repr(Camera.preset("nist-ir-psf").optics),
                   ["f/2.5", "optics_mwir_lens", "Diffraction", "ScatterHalo"]),
        "scene": (repr(FrameStack(np.full((7, 4, 5), 600.0), dt=2e-6, dx=3e-6)),
                  ["FrameStack", "4 × 5 samples of 3 µm", "7 frames of 2 µs"]),
    }
    scene = UniformBlackbody(800.0, shape=(12, 16), dx=6e-6, dt=1e-6)
    m = Camera.linear_ideal(6e-6).measure(scene, 10e-6)
    lines["measurement"] = (repr(m), ["linear-ideal", "12 × 16 px", "10 µs",
                                      "800.0–800.0 K", "0 saturated"])
    for what, (text, parts) in lines.items():
        assert "\n" not in text and len(text) < 200, (what, text)
        for part in parts:
            assert part in text, (what, part, text)


def test_a_cameras_toml_is_written_once_and_a_changed_copy_has_its_own(tmp_path):
    # Every EXR file of a study carries its camera's TOML: it is made once per camera (frozen)
    # and kept; a copy with a field changed is another camera, with its own text.
    camera = Camera.preset("nist-ir")
    text = camera.to_toml()
    assert camera.to_toml() is text
    (tmp_path / "camera.toml").write_text(text, encoding="utf-8")
    assert Camera.from_toml(tmp_path / "camera.toml").to_toml() == text
    other = camera.replace(name="renamed", assumed_emissivity=0.5)
    assert other.to_toml() != text
    assert 'name = "renamed"' in other.to_toml() and "assumed_emissivity = 0.5" in other.to_toml()
    assert 'name = "renamed"' not in camera.to_toml()


# -- what measure and the camera's settings accept, named in one line ------------------------------


def test_camera_replace_with_an_unknown_field_names_the_likely_one():
    camera = Camera.linear_ideal(3e-6)
    with pytest.raises(RadiosimError, match=r"nmae.*did you mean name"):
        camera.replace(nmae="x")


def test_camera_replace_with_a_known_field_still_works():
    camera = Camera.linear_ideal(3e-6).replace(name="mine")
    assert camera.name == "mine"


@pytest.mark.parametrize("rng", ["abc", 1.5, -1, [1, 2], True,
                                 np.random.RandomState(0)])
def test_measure_with_an_rng_of_the_wrong_type_is_one_error(rng):
    scene = FrameStack(np.full((4, 6, 6), 500.0), dt=1e-6, dx=1e-6)
    with pytest.raises(RadiosimError, match="rng must be a seed"):
        Camera.linear_ideal(3e-6).measure(scene, 2e-6, rng=rng)


@pytest.mark.parametrize("scene", [np.full((3, 12, 12), 600.0), [[600.0]], None])
def test_measure_refuses_what_is_not_a_scene(scene):
    camera = Camera.linear_ideal(3e-6)
    with pytest.raises(RadiosimError, match="Scene") as info:
        camera.measure(scene, 1e-6)
    if isinstance(scene, (np.ndarray, list)):
        assert "FrameStack(frames, dt=" in one_line_message(info)


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
    one_line_message(info)


def _scene():
    return FrameStack(np.full((5, 12, 12), 500.0), dt=1e-6, dx=1e-6)


@pytest.mark.usefixtures("in_tmp")
@pytest.mark.parametrize("rng", [
    pytest.param(-1),
    pytest.param(1.5),
    pytest.param("abc"),
])
def test_api_bad_seed(rng):
    with pytest.raises(RadiosimError) as info:
        Camera.linear_ideal(3e-6).measure(_scene(), 2e-6, rng=rng)
    api_error(info, repr(rng) if isinstance(rng, str) else rng)


@pytest.mark.usefixtures("in_tmp")
@pytest.mark.parametrize("call, name", [
    pytest.param(lambda: Camera.linear_ideal(3e-6).measure(_scene(), 1e-6, t_start="1us"),
                 "'1us'", id="t_start-string"),
    pytest.param(lambda: FrameStack(np.full((5, 12, 12), 500.0), dt=1e-6, dx=1e-6,
                                    event_time="a"), "event_time", id="event_time-string"),
    pytest.param(lambda: read_fea_nodes(_fea_file(), dx=1e-6, fill="20C"), "fill",
                 id="fea-fill-string"),
    pytest.param(lambda: read_fea_nodes(_fea_file(), dx=1e-6, dt="1us"), "dt",
                 id="fea-dt-string"),
    pytest.param(lambda: Camera.linear_ideal("6"), "'6'", id="pixel_pitch-string"),
    pytest.param(lambda: Camera.linear_ideal(3e-6).measure(_scene(), "10us"), "'10us'",
                 id="integration_time-string"),
    pytest.param(lambda: FrameStack(np.full((5, 12, 12), 500.0), dt="0.2", dx=1e-6), "'0.2'",
                 id="dt-string"),
    pytest.param(lambda: read_frames("nope.npy", dt=1e-6, dx=1e-6, units="K"), "nope.npy",
                 id="missing-npy"),
    pytest.param(lambda: read_fea_nodes("nope.csv", dx=1e-6), "nope.csv", id="missing-csv"),
])
def test_api_bad_argument_is_a_radiosim_error(tmp_path, call, name):
    with pytest.raises(RadiosimError) as info:
        call()
    api_error(info, name)


def _fea_file() -> Path:
    path = Path("nodes.csv")  # in the test's folder (see _in_tmp)
    path.write_text(fea_text(fea_rows()))
    return path


@pytest.mark.usefixtures("in_tmp")
@pytest.mark.parametrize("t_start, word", [
    pytest.param(float("nan"), "NaN", id="nan"),
    pytest.param(float("inf"), "inf", id="inf"),
])
def test_non_finite_t_start_is_named_as_such(t_start, word):
    with pytest.raises(RadiosimError) as info:
        Camera.linear_ideal(3e-6).measure(_scene(), 1e-6, t_start=t_start)
    message = api_error(info)
    assert word.lower() in message.lower(), message
    assert "before the" not in message and "first frame" not in message, message


@pytest.mark.usefixtures("in_tmp")
@pytest.mark.parametrize("dx, dt, t_int, word", [
    (0.667, 0.2e-6, 0.2e-6, "dx"),    # metres where µm were meant
    (0.667e-6, 0.2, 1e-6, "dt"),      # seconds where µs were meant
])
def test_unit_slip_is_named(dx, dt, t_int, word):
    scene = FrameStack(np.full((3, 30, 30), 500.0), dt=dt, dx=dx)
    with pytest.raises(RadiosimError) as info:
        Camera.linear_ideal(6e-6).measure(scene, t_int)
    message = api_error(info, word)
    assert "µ" in message and "as" in message  # "was dx given in µm as metres?"


@pytest.mark.usefixtures("in_tmp")
def test_near_zero_integration_time_does_not_saturate():
    camera = Camera.preset("nist-ir")
    scene = FrameStack(gradient_frames(), dt=0.1e-6, dx=1e-6)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RadiosimWarning)  # coarse calibration: expected
        m = camera.measure(scene, 1e-9, rng=0)
    assert m.electrons.max() < 1e-3 * camera.electronics.full_well
    assert not m.saturated.any(), f"{int(m.saturated.sum())} pixels reported saturated"


# -- detection_sigma, camera files -----------------------------------------------------------------


@pytest.fixture(scope="module")
def nist_preset():
    return Camera.preset("nist-ir")


@pytest.mark.parametrize("k", [0.0, -1.0, math.nan, math.inf, True, "3"])
def test_detection_sigma_must_be_positive_and_finite(nist_preset, k):
    with pytest.raises(RadiosimError, match="detection_sigma") as info:
        nist_preset.replace(detection_sigma=k)
    one_line_message(info)


def test_detection_sigma_from_a_camera_file(nist_preset, tmp_path):
    path = tmp_path / "cam.toml"
    path.write_text(nist_preset.to_toml().replace("detection_sigma = 3.0", "detection_sigma = 4.5"),
                    encoding="utf-8")
    camera = Camera.from_toml(path)
    assert camera.detection_sigma == 4.5
    b, sigma = blank_and_sigma(camera, 1e-5)
    assert camera.calibration(1e-5).detection_limit_counts == pytest.approx(b + 4.5 * sigma)
    path.write_text(nist_preset.to_toml().replace("detection_sigma = 3.0", "detection_sigma = -2"),
                    encoding="utf-8")
    with pytest.raises(RadiosimError) as info:
        Camera.from_toml(path)
    message = one_line_message(info)
    assert str(path) in message and "detection_sigma = -2" in message


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
    path = write_file(tmp_path, text.replace(old, new), "my.toml")
    with pytest.raises(RadiosimError) as info:
        Camera.from_toml(path)
    message = one_line_message(info)
    assert message.startswith(f"{path}: {key}: "), message


def test_a_camera_file_with_a_byte_order_mark_is_read(tmp_path):
    from radiosim.presets import PRESET_DIRECTORY

    text = (PRESET_DIRECTORY / "nist-ir.toml").read_text(encoding="utf-8")
    path = write_file(tmp_path, text, "bom.toml", encoding="utf-8-sig")
    assert path.read_bytes()[:3] == b"\xef\xbb\xbf"
    assert Camera.from_toml(path).to_dict() == Camera.preset("nist-ir").to_dict()
