"""Two-colour (ratio) thermography and multi-channel cameras (radiosim.ratio), against the test's
own quadrature of Planck's photon law."""

import math
import tomllib

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.optimize import brentq

from radiosim import Camera, Electronics, FocalPlaneArray, FrameStack, Optics, RadiosimError
from radiosim.ratio import INVERSION_ACCURACY, Channel, ratio_netd
from radiosim.scenes import UniformBlackbody

# The test's own constants (SI 2019, exact) and Planck's photon law.
H, C, KB = 6.62607015e-34, 299792458.0, 1.380649e-23
SHORT, LONG = (3.8e-6, 4.2e-6), (4.6e-6, 5.1e-6)


def photon_radiance(t, band):
    """∫ 2c/λ⁴ / (exp(hc/λkT) − 1) dλ over ``band`` [photons s⁻¹ m⁻² sr⁻¹]."""
    value, _ = quad(lambda lam: 2 * C / lam**4 / math.expm1(H * C / (lam * KB * t)), *band,
                    epsabs=0, epsrel=1e-12)
    return value


def ratio(t):
    return photon_radiance(t, SHORT) / photon_radiance(t, LONG)


def temperature_of_ratio(r):
    return brentq(lambda t: ratio(t) - r, 200.0, 3000.0, xtol=1e-10)


def flat_camera(shape=(2, 2), electronics=None, pitch=6e-6):
    """Unit filter, optics and quantum efficiency: the channels' signal is the test's law."""
    return Camera(fpa=FocalPlaneArray(pixel_pitch=pitch, shape=shape),
                  optics=Optics(band=(3.7e-6, 5.2e-6)),
                  electronics=electronics or Electronics.ideal(), response="planck",
                  name="flat").with_channels([SHORT, LONG])


def uniform(t, emissivity=1.0, shape=(4, 4)):
    return UniformBlackbody(t, shape=shape, dx=3e-6, dt=1e-6, emissivity=emissivity)


@pytest.mark.parametrize("emissivity", [1.0, 0.6, 0.2, 0.05])
def test_a_grey_body_reads_its_true_temperature_by_ratio_for_any_emissivity(emissivity):
    m = flat_camera().measure(uniform(900.0, emissivity), 2e-6)
    # Each channel alone reads low (emissivity 1 assumed) ...
    assert emissivity == 1 or np.all(m.channels[0].apparent_temperature < 899)
    # ... the ratio does not: the inversion's accuracy and the radiance tables' (1e-7).
    np.testing.assert_allclose(m.ratio_temperature, 900.0, rtol=1e-7)
    assert m.apparent_temperature is m.ratio_temperature or np.array_equal(
        m.apparent_temperature, m.ratio_temperature)


def test_a_wrong_assumed_ratio_biases_as_the_band_ratio_arithmetic():
    camera = flat_camera().replace(assumed_emissivity_ratio=1.1)
    m = camera.measure(uniform(900.0, 0.4), 2e-6)
    expected = temperature_of_ratio(ratio(900.0) / 1.1)
    assert 760 < expected < 790  # the "about 773 K"
    np.testing.assert_allclose(m.ratio_temperature, expected, rtol=1e-7)


def test_a_pixel_half_at_t1_and_half_at_t2_reads_the_area_weighted_signals_ratio():
    t1, t2 = 700.0, 1100.0
    # pixels of 2 × 2 samples: pixel 0 half at T1, half at T2; pixel 1 at T1
    frame = np.array([[t1, t2, t1, t1], [t1, t2, t1, t1]])
    scene = FrameStack(np.stack([frame] * 3), dt=1e-6, dx=3e-6, emissivity=0.3)
    m = flat_camera(shape=(1, 2)).measure(scene, 2e-6, t_start=0.0)
    signals = [0.5 * (photon_radiance(t1, b) + photon_radiance(t2, b)) for b in (SHORT, LONG)]
    expected = temperature_of_ratio(signals[0] / signals[1])
    assert (t1 + t2) / 2 + 50 < expected < t2  # biased toward the hot half
    assert m.ratio_temperature[0, 0] == pytest.approx(expected, rel=1e-7)
    assert m.ratio_temperature[0, 1] == pytest.approx(t1, rel=1e-7)


def test_sequential_channels_on_a_static_scene_equal_simultaneous_ones_bit_for_bit():
    rng = np.random.default_rng(4)
    frame = 600.0 + 500.0 * rng.random((4, 6))
    scene = FrameStack(np.stack([frame] * 8), dt=1e-6, dx=3e-6)
    nist = Camera.preset("nist-ir")
    base = flat_camera(shape=(2, 3), electronics=nist.electronics)
    together = base.measure(scene, 3e-6, t_start=0.0, rng=7)
    wheel = base.with_channels([SHORT, LONG], slot_time=4e-6)
    apart = wheel.measure(scene, 3e-6, t_start=0.0, rng=7)
    assert apart.channels[1].t_start == 4e-6 and together.channels[1].t_start == 0.0
    for a, b in zip(together.channels, apart.channels):
        assert np.array_equal(a.counts, b.counts)
    assert np.array_equal(together.ratio_temperature, apart.ratio_temperature, equal_nan=True)
    assert np.isfinite(together.ratio_temperature).any()


def test_each_channel_is_the_single_band_camera_bit_for_bit():
    nist = Camera.preset("nist-ir")
    camera = nist.replace(fpa=FocalPlaneArray(pixel_pitch=6e-6, shape=(2, 2)))
    scene = uniform(1000.0, 0.5, shape=(5, 5))
    one = camera.with_channels([SHORT]).measure(scene, 2e-6, rng=3)
    alone = camera.replace(optics=Optics(**{**vars(camera.optics), "band": SHORT}))
    reference = alone.measure(scene, 2e-6, rng=3)
    assert one.ratio_temperature is None and len(one.channels) == 1
    for name in ("counts", "electrons", "apparent_temperature", "signal_mean"):
        assert np.array_equal(getattr(one, name), getattr(reference, name), equal_nan=True)
    two = camera.with_channels([SHORT, LONG]).measure(scene, 2e-6, rng=3)
    assert np.array_equal(two.channels[0].counts, reference.counts)


def test_the_ratio_netd_matches_the_scatter_of_noisy_readings():
    nist = Camera.preset("nist-ir")
    camera = flat_camera(shape=(24, 24), electronics=nist.electronics, pitch=3e-6)
    m = camera.measure(uniform(900.0, 1.0, shape=(24, 24)), 5e-6, rng=11)
    predicted = float(ratio_netd(camera, 900.0, 5e-6))
    assert np.nanstd(m.ratio_temperature) == pytest.approx(predicted, rel=0.15)
    assert np.nanmedian(m.ratio_netd) == pytest.approx(predicted, rel=0.05)
    assert INVERSION_ACCURACY <= 1e-8


def test_flagged_channels_give_no_ratio():
    camera = flat_camera().replace(calibration_range=(300.0, 850.0))
    m = camera.measure(uniform(900.0), 2e-6)  # above the range in both channels
    assert np.all(np.isnan(m.ratio_temperature)) and m.over_range.all() and not m.valid.any()


def test_camera_files_round_trip_channels_and_the_emissivity_ratio(tmp_path):
    camera = Camera.preset("nist-ir").with_channels([SHORT, LONG]).replace(
        assumed_emissivity_ratio=1.25)
    channels = (Channel(band=SHORT, spectral_filter=0.5, registration_offset=(1e-6, 2.5e-6),
                        integration_time=3e-6),
                Channel(band=LONG, time_offset=7e-6))
    camera = camera.replace(channels=channels)
    path = tmp_path / "two.toml"
    path.write_text(camera.to_toml(), encoding="utf-8")
    data = tomllib.loads(path.read_text(encoding="utf-8"))
    assert data["assumed_emissivity_ratio"] == 1.25
    assert data["channels"][0]["registration_offset_um"] == [1.0, 2.5]
    assert data["channels"][1]["time_offset_us"] == 7.0
    back = Camera.from_toml(path)
    assert back.to_dict() == camera.to_dict()
    assert back.channels[0].registration_offset == (1e-6, 2.5e-6)
    assert back.assumed_emissivity_ratio == 1.25
    # a single-channel camera's file is as before: no new keys
    assert "assumed_emissivity_ratio" not in Camera.preset("nist-ir").to_toml()
    assert Camera.preset("two-colour").channels[1].band == LONG


@pytest.mark.parametrize("bands, words", [
    ([(5e-6, 4e-6)], ["channel 1", "band", "5e-06"]),
    ([SHORT, (4e-6, 2e-3)], ["channel 2", "band", "0.002"]),
    ([], ["at least one", "[]"]),
])
def test_bad_bands_are_refused_in_one_line(bands, words):
    with pytest.raises(RadiosimError) as info:
        Camera.preset("nist-ir").with_channels(bands)
    message = str(info.value)
    assert "\n" not in message and all(w in message for w in words), message


def test_bad_channel_tables_name_the_key_and_the_value(tmp_path):
    text = (Camera.preset("nist-ir").with_channels([SHORT, LONG]).to_toml()
            .replace("band_um = [4.6, 5.1]", "band_um = [4.6, 5.1]\nslot_um = 3"))
    path = tmp_path / "bad.toml"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(RadiosimError) as info:
        Camera.from_toml(path)
    message = str(info.value)
    assert "\n" not in message and "slot_um = 3" in message and "[[channels]] 2" in message
    path.write_text(text.replace("slot_um = 3", "").replace("[3.8, 4.2]", "[4.2, 3.8]"),
                    encoding="utf-8")
    with pytest.raises(RadiosimError) as info:
        Camera.from_toml(path)
    assert "band_um = [4.2, 3.8]" in str(info.value), str(info.value)
    with pytest.raises(RadiosimError, match="assumed_emissivity_ratio"):
        Camera.preset("nist-ir").replace(assumed_emissivity_ratio=0.0)
    with pytest.raises(RadiosimError, match="response = 'planck'"):
        Camera.linear_ideal(3e-6).with_channels([SHORT, LONG])


def test_a_two_colour_measurement_round_trips_through_netcdf(tmp_path):
    from radiosim.io.netcdf import read_netcdf, write_netcdf

    camera = flat_camera().with_channels([SHORT, LONG], slot_time=1e-6)
    m = camera.measure(uniform(900.0, 0.5), 2e-6, t_start=0.0)
    ds = m.to_xarray()
    assert ds.channel_counts.dims == ("channel", "y", "x") and ds.ratio_temperature.units == "K"
    assert ds.band_low.values.tolist() == [SHORT[0], LONG[0]]
    back = read_netcdf(write_netcdf(tmp_path / "two.nc", m))
    assert np.array_equal(back.ratio_temperature, m.ratio_temperature)
    assert [c.t_start for c in back.channels] == [0.0, 1e-6]
    assert np.array_equal(back.channels[1].counts, m.channels[1].counts)
    assert back.camera.channels[1].time_offset == 1e-6


def test_the_ratio_calibration_fits_each_channels_gain_and_offset():
    import dataclasses

    from radiosim.ratio import channel_cameras, fit_ratio_calibration

    camera = Camera.preset("two-colour")
    temperatures = np.array([500.0, 600.0, 700.0, 800.0])
    truth = [(1.2e-3, 900.0), (1.6e-3, 1100.0)]  # (gain [DN/e⁻], offset [DN]) per channel
    counts = [channel_cameras(camera.replace(electronics=dataclasses.replace(
        camera.electronics, gain=g, offset=o)))[k].calibration(10e-6).counts(temperatures)
        for k, (g, o) in enumerate(truth)]
    fitted, residuals = fit_ratio_calibration(camera, temperatures, counts, 10e-6)
    for channel, own, (g, o) in zip(fitted.channels, channel_cameras(fitted), truth):
        assert channel.electronics.gain == pytest.approx(g, rel=1e-9)
        assert channel.electronics.offset == pytest.approx(o, rel=1e-9)
        assert own.electronics is channel.electronics
    assert np.all(np.abs(residuals) < 1e-6)
    assert Camera.from_dict(tomllib.loads(fitted.to_toml())).channels[1].electronics.gain == \
        pytest.approx(1.6e-3, rel=1e-12)


def test_a_two_colour_exr_holds_each_channel_and_the_ratio(tmp_path):
    import OpenEXR

    from radiosim.io.exr import read_exr, write_exr

    m = flat_camera().measure(uniform(900.0, 0.5), 2e-6)
    path = write_exr(tmp_path / "two.exr", m)
    with OpenEXR.File(str(path)) as exr:
        pixels = {name: np.array(ch.pixels) for name, ch in exr.channels().items()}
        header = dict(exr.header())
    assert np.array_equal(pixels["ch2.counts"], m.channels[1].counts.astype(np.float32))
    assert np.array_equal(pixels["ratio_temperature"], m.ratio_temperature.astype(np.float32))
    assert header["radiosim:unit:ratio_netd"] == "K"
    assert list(header["radiosim:band_m:ch1"]) == list(SHORT)
    assert np.array_equal(read_exr(path).apparent_temperature,
                          m.apparent_temperature.astype(np.float32).astype(np.float64))


# -- a multi-channel camera through the laboratory procedures ---------------------------------


def test_netd_and_measurable_range_of_a_two_colour_camera_are_its_ratio_readings():
    # The camera reads the ratio temperature: its NETD is the ratio's (not the full band's
    # 0.2 K), and it reads where both channels do (the highest of their lowest measurable
    # temperatures, the lowest of their saturation temperatures), each channel's range from
    # its own calibration.
    from radiosim.characterization import measurable_range, netd

    camera = Camera.preset("two-colour")
    t_int = 10e-6
    np.testing.assert_array_equal(netd(camera, 1000.0, t_int), ratio_netd(camera, 1000.0, t_int))
    full_band = netd(camera.replace(channels=None), 1000.0, t_int)
    assert float(netd(camera, 1000.0, t_int)) > 5 * float(full_band)
    lows, highs = [], []
    for own in camera.channel_cameras:
        calibration = own.calibration(t_int)
        lows.append(calibration.lowest_measurable_temperature())
        highs.append(calibration.saturation_temperature)
    assert measurable_range(camera, t_int) == (max(lows), min(highs))
    assert measurable_range(camera, t_int) != measurable_range(camera.replace(channels=None),
                                                                t_int)


@pytest.mark.parametrize("procedure", ["fit_calibration", "size_of_source", "flat_fields",
                                       "datasheet_plan"])
def test_one_band_procedures_refuse_a_two_colour_camera_naming_its_channels(procedure):
    # A procedure that measures one band is refused for a camera of several, in one line
    # naming the channels and what to give instead (it fitted the whole band before).
    from radiosim import characterization

    camera = Camera.preset("two-colour")
    calls = {
        "fit_calibration": lambda: characterization.fit_calibration(
            camera, [400.0, 500.0, 600.0], [1100.0, 1500.0, 2500.0], 10e-6),
        "size_of_source": lambda: characterization.size_of_source(camera, [12e-6, 60e-6]),
        "flat_fields": lambda: characterization.flat_fields(camera, 500.0, 10e-6),
        "datasheet_plan": lambda: characterization.datasheet_plan(camera, 10e-6),
    }
    with pytest.raises(RadiosimError, match=r"channel") as info:
        calls[procedure]()
    text = str(info.value)
    assert "\n" not in text and "channel_cameras[k]" in text, text


def test_a_channels_registration_offset_is_y_then_x():
    # Channel 2 registered one pixel further down (offset (y, x) = (pitch, 0)) on a scene that
    # varies along y only: its pixel rows see the first channel's next rows (an offset taken
    # as (x, y) would shift columns, which see the same values here).
    import dataclasses

    camera = Camera.preset("two-colour")
    pitch = camera.fpa.pixel_pitch
    first, second = camera.channels
    camera = camera.replace(
        channels=(first, dataclasses.replace(second, registration_offset=(pitch, 0.0))),
        fpa=dataclasses.replace(camera.fpa, shape=(6, 5)))
    rows = np.arange(60)
    stack = np.broadcast_to((600.0 + 10.0 * rows)[None, :, None], (3, 60, 50)).copy()
    m = camera.measure(FrameStack(stack, dt=1e-6, dx=pitch / 10), 2e-6, t_start=0.0, rng=0)
    a, b = m.channels
    # Each pixel averages 10 sample rows: row i of channel 1 is 600 + 10 (10 i + 4.5) K.
    np.testing.assert_allclose(a.tensor_mean[:, 0], 645.0 + 100.0 * np.arange(5), rtol=1e-12)
    np.testing.assert_allclose(b.tensor_mean[:, 0], 745.0 + 100.0 * np.arange(5), rtol=1e-12)


# -- why a two-colour measurement read nothing, cause by cause (issue 40) -------------------------


def test_an_under_range_two_colour_reading_names_each_channel_and_the_ratio():
    """A 330 K scene: channel 0 (3.8–4.2 µm) reads nothing, channel 1 part of it; each line
    names its channel's own lowest temperature (the full band's 36.7 °C was quoted before).
    With an assumed emissivity ratio of 50 at 1000 K both channels read but the ratio falls
    off the curve: the line says so instead of blaming the noise."""
    from radiosim.characterization import measurable_range
    from radiosim.reporting import under_range_lines
    from radiosim.scenes import UniformBlackbody

    camera = Camera.preset("two-colour")
    m = camera.measure(UniformBlackbody(330.0, shape=(40, 40)), 10e-6)
    assert m.under_range.all()
    lines = under_range_lines(camera, 10e-6, 56.85, m)
    for k, own in enumerate(camera.channel_cameras):
        low = measurable_range(own, 10e-6)[0] - 273.15
        assert f"channel {k}" in lines[k + 1] and f"{low:.1f} °C" in lines[k + 1], lines
    full_band = measurable_range(Camera.preset("nist-ir"), 10e-6)[0] - 273.15
    assert f"{full_band:.1f} °C" not in "\n".join(lines)
    absurd = camera.replace(assumed_emissivity_ratio=50.0)
    m = absurd.measure(UniformBlackbody(1000.0, shape=(40, 40)), 10e-6)
    assert m.under_range.all() and not m.channels[0].under_range.any()
    lines = under_range_lines(absurd, 10e-6, 726.85, m)
    assert "0 of 36 pixels under range" in lines[1] and "emissivity ratio 50" in lines[-1]


def test_an_under_range_reading_below_the_calibration_range_names_the_range():
    """A camera calibrated from 700 K on, a 500 K scene: the limit is the range's start
    (426.9 °C), not the 3 σ detection limit (nist-ir's reaches 310 K)."""
    from radiosim.characterization import measurable_range
    from radiosim.reporting import under_range_lines
    from radiosim.scenes import UniformBlackbody

    camera = Camera.preset("nist-ir").replace(calibration_range=(700.0, 3000.0))
    assert measurable_range(Camera.preset("nist-ir"), 10e-6)[0] < 500.0
    m = camera.measure(UniformBlackbody(500.0, shape=(40, 40)), 10e-6)
    assert m.under_range.all()
    (line,) = under_range_lines(camera, 10e-6, 226.85, m)
    assert "426.9 °C: the calibration range starts there" in line and "σ" not in line
