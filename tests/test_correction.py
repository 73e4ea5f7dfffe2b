"""Correcting a reading toward the scene, in closed loop: scenes whose truth is known (a square
feature 8 pixels wide at 900 K on 400 K), blurred by a Gaussian PSF or moved during the window,
measured, corrected, and compared with that truth."""

import dataclasses

import numpy as np
import pytest

import radiosim as rs
from conftest import one_line_naming
from radiosim.correction import correct
from radiosim.errors import RadiosimError
from radiosim.psf import GaussianBlur
from radiosim.scenes import FrameStack

BASE = rs.Camera.preset("nist-ir")
PITCH = BASE.fpa.pixel_pitch  # 6 µm in object space
SUB, N = 3, 48  # scene samples per pixel and axis; pixels per side


def square(cx, cy=24.0, n=N):
    """The feature on the pixel grid's sample centres [K]: 900 K inside |x − cx|, |y − cy| < 4
    pixels, 400 K outside."""
    y, x = (np.mgrid[0:n * SUB, 0:n * SUB] + 0.5) / SUB
    return np.where((np.abs(x - cx) < 4) & (np.abs(y - cy) < 4), 900.0, 400.0)


def truth_on_pixels(cx, cy=24.0):
    centres = np.arange(N) + 0.5
    return np.where((np.abs(centres[None] - cx) < 4) & (np.abs(centres[:, None] - cy) < 4),
                    900.0, 400.0)


IDEAL = dataclasses.replace(BASE.electronics, read_noise=0.0, shot_noise=False, adc_bits=None)
FPA = dataclasses.replace(BASE.fpa, shape=None, fill_factor=1.0)
BLURRED = dataclasses.replace(BASE.optics, psf=(GaussianBlur(1.5 * PITCH),))
INNER = (slice(21, 27), slice(21, 27))  # the feature's pixels but its outer ring


def test_the_size_of_source_bias_of_an_8_pixel_feature_is_cut_over_3_times():
    """Noise-free electronics: a Gaussian PSF of σ = 1.5 pixels takes ~6 K off the feature's
    centre and ~35 K off its pixels but the outer ring on average; the correction leaves less
    than a third of each (the requirement), and its centre pixels are trusted."""
    camera = BASE.replace(fpa=FPA, optics=BLURRED, electronics=IDEAL)
    scene = FrameStack(square(24.0)[None].repeat(2, 0), dt=10e-6, dx=PITCH / SUB)
    m = camera.measure(scene, 10e-6)
    c = correct(m)
    centre = (slice(23, 25), slice(23, 25))
    assert not np.isnan(c.temperature[centre]).any()
    for region in (centre, INNER):
        raw = abs(np.mean(m.apparent_temperature[region]) - 900.0)
        fixed = abs(np.mean(c.temperature[region]) - 900.0)
        assert raw > 5 and fixed < raw / 3, (region, raw, fixed)


def test_with_the_real_electronics_the_uncertainty_covers_the_truth():
    """nist-ir's noise and converter: |corrected − truth| ≤ 3 u in at least 90 % of the pixels
    the correction trusts (the requirement), and it trusts at least half of the frame (the
    rest: within the PSF's reach of the frame's edge)."""
    camera = BASE.replace(fpa=FPA, optics=BLURRED)
    scene = FrameStack(square(24.0)[None].repeat(2, 0), dt=10e-6, dx=PITCH / SUB)
    c = correct(camera.measure(scene, 10e-6, rng=3))
    trusted = np.isfinite(c.temperature)
    z = np.abs(c.temperature - truth_on_pixels(24.0))[trusted] / c.uncertainty[trusted]
    assert trusted.mean() > 0.5 and np.mean(z <= 3) >= 0.9, (trusted.mean(), np.mean(z <= 3))


def test_a_uniformly_moving_feature_is_corrected_for_its_motion():
    """A perfect lens, the feature moving 4 pixels over a 20 µs window (in 0.5 µs frames):
    against the feature at mid-window, the smear's bias on its pixels is cut over 2 times
    (the requirement for the paper's longer windows)."""
    v = 4 * PITCH / 20e-6  # [m/s]
    dt = 0.5e-6
    frames = np.array([square(20.0 + v * (k + 0.5) * dt / PITCH) for k in range(40)])
    camera = BASE.replace(fpa=FPA, electronics=IDEAL)
    m = camera.measure(FrameStack(frames, dt=dt, dx=PITCH / SUB), 20e-6, t_start=0.0)
    c = correct(m, velocity=(v, 0.0))
    truth = truth_on_pixels(22.0)
    inner = (slice(21, 27), slice(19, 25))
    raw = np.max(np.abs(m.apparent_temperature[inner] - truth[inner]))
    fixed = np.nanmax(np.abs(c.temperature[inner] - truth[inner]))
    assert raw > 20 and fixed < raw / 2, (raw, fixed)


def test_a_rolling_shutters_rows_are_brought_to_its_first_rows_window():
    """A rolling shutter reading a smooth feature (a Gaussian blob, σ = 2.5 pixels) that moves
    2 pixels along the rows during the window: row r integrates r·row_time later, so the raw
    blob is sheared, its centre 0.05 pixel further a row (row 20: one pixel). With the
    velocity, every corrected row shows the blob where it was during the first row's window:
    its centre at 22 pixels (the scene's own position at that window's middle) within 0.01."""
    v = 2 * PITCH / 20e-6  # [m/s]
    row_time = 0.05 * PITCH / v  # [s]
    dt = 0.5e-6
    y, x = (np.mgrid[0:N * SUB, 0:N * SUB] + 0.5) / SUB

    def blob(cx):
        return 400.0 + 500.0 * np.exp(-((x - cx) ** 2 + (y - 24.0) ** 2) / (2 * 2.5 ** 2))

    n = int(round((20e-6 + N * row_time) / dt)) + 2
    frames = np.array([blob(21.0 + v * (k + 0.5) * dt / PITCH) for k in range(n)])
    fpa = dataclasses.replace(FPA, shutter="rolling", row_time=row_time)
    m = BASE.replace(fpa=fpa, electronics=IDEAL).measure(
        FrameStack(frames, dt=dt, dx=PITCH / SUB), 20e-6, t_start=0.0)
    c = correct(m, velocity=(v, 0.0))
    columns = np.arange(10, 36) + 0.5

    def centre(image, row):  # the blob's centre along a row: its excess's centroid
        excess = np.clip(image[row, 10:36] - 400.0, 0.0, None)
        return float(np.sum(excess * columns) / np.sum(excess))

    for row in range(19, 30):
        assert centre(m.apparent_temperature, row) == pytest.approx(22.0 + 0.05 * row,
                                                                    abs=0.01)
        assert centre(c.temperature, row) == pytest.approx(22.0, abs=0.01)


def test_a_scene_outrunning_the_rolling_shutter_is_named():
    fpa = dataclasses.replace(FPA, shutter="rolling", row_time=1e-6)
    scene = FrameStack(square(24.0)[None].repeat(60, 0), dt=1e-6, dx=PITCH / SUB)
    m = BASE.replace(fpa=fpa, electronics=IDEAL).measure(scene, 2e-6, t_start=0.0)
    with pytest.raises(RadiosimError) as info:
        correct(m, velocity=(0.0, 10.0))  # 10 µm/µs: 1.7 rows per row of delay
    one_line_naming(info, "rolling shutter", "10 m/s")


def test_saturated_pixels_are_flagged_not_invented():
    camera = BASE.replace(fpa=FPA, optics=BLURRED)
    hot = np.where(square(24.0) > 800, 3500.0, 400.0)  # saturates nist-ir at 10 µs
    with pytest.warns(rs.RadiosimWarning, match="saturated"):
        m = camera.measure(FrameStack(hot[None].repeat(2, 0), dt=10e-6, dx=PITCH / SUB),
                           10e-6, rng=1)
    assert m.saturated.any()
    c = correct(m)
    assert np.all(np.isnan(c.temperature[m.saturated])) and np.all(c.untrusted[m.saturated])


@pytest.mark.parametrize("velocity, said", [
    ((1.0, 2.0, 3.0), "two finite numbers"),
    ((float("nan"), 0.0), "two finite numbers"),
    ((1.2e6, 0.0), "is it in µm/s or mm/s?"),
    ("fast", "(vx, vy) in m/s"),
])
def test_a_bad_velocity_is_named(velocity, said):
    camera = BASE.replace(fpa=FPA, optics=BLURRED, electronics=IDEAL)
    m = camera.measure(FrameStack(square(24.0)[None].repeat(2, 0), dt=10e-6, dx=PITCH / SUB),
                       10e-6)
    with pytest.raises(RadiosimError) as info:
        correct(m, velocity=velocity)
    one_line_naming(info, said)


def test_nothing_to_correct_or_no_camera_is_named():
    camera = BASE.replace(fpa=FPA, electronics=IDEAL)  # a perfect lens, and no velocity
    m = camera.measure(FrameStack(square(24.0)[None].repeat(2, 0), dt=10e-6, dx=PITCH / SUB),
                       10e-6)
    with pytest.raises(RadiosimError) as info:
        correct(m)
    one_line_naming(info, "perfect lens", "velocity=")
    with pytest.raises(RadiosimError) as info:
        correct(np.zeros((4, 4)))
    one_line_naming(info, "measurement.camera")


def test_the_command_writes_the_corrected_reading(tmp_path, capsys):
    import xarray as xr

    from radiosim.cli import main
    from radiosim.io.netcdf import write_netcdf

    camera = BASE.replace(fpa=FPA, optics=BLURRED, electronics=IDEAL)
    m = camera.measure(FrameStack(square(24.0)[None].repeat(2, 0), dt=10e-6, dx=PITCH / SUB),
                       10e-6)
    write_netcdf(tmp_path / "m.nc", m)
    assert main(["correct", str(tmp_path / "m.nc"), "--out", str(tmp_path / "c.nc")]) == 0
    out = capsys.readouterr().out
    assert "pixels corrected" in out and "wrote" in out
    with xr.open_dataset(tmp_path / "c.nc", engine="h5netcdf") as d:
        np.testing.assert_allclose(d.corrected_temperature.values, correct(m).temperature,
                                   rtol=1e-9, equal_nan=True)
    code = main(["correct", str(tmp_path / "m.nc"), "--out", str(tmp_path / "d.nc"),
                 "--velocity", "3e7,0"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "m/s" in err[0], err


def test_the_command_corrects_a_recording_through_its_camera(tmp_path, capsys):
    """A 16-bit TIFF stack of the counts nist-ir-psf recorded (a camera's file, no window
    stated) corrected through that camera: the same corrected reading as the measurement's."""
    import xarray as xr
    from PIL import Image

    from radiosim.cli import main

    camera = rs.Camera.preset("nist-ir-psf")
    rows, cols = camera.fpa.shape
    y, x = (np.mgrid[0:rows * SUB, 0:cols * SUB] + 0.5) / SUB
    frame = np.where(np.hypot(x - 80, y - 60) < 12, 900.0, 500.0)
    m = camera.measure(FrameStack(frame[None].repeat(2, 0), dt=10e-6, dx=PITCH / SUB), 10e-6,
                       rng=5)
    pages = [Image.fromarray(m.counts.astype(np.uint16)) for _ in range(2)]
    pages[0].save(tmp_path / "rec.tif", save_all=True, append_images=pages[1:])
    args = ["correct", str(tmp_path / "rec.tif"), "--camera", "nist-ir-psf", "--frame", "1",
            "--out", str(tmp_path / "c.nc")]
    assert main(args) == 2  # the file states no integration time
    assert "integration time" in capsys.readouterr().err
    assert main(args + ["--integration-time", "10us"]) == 0
    # The recording's charge is its counts' (within the converter's step of the simulation's
    # own), which sets the filter's noise level: the readings agree within a hundredth of
    # their stated uncertainty, not to the bit.
    reference = correct(m)
    with xr.open_dataset(tmp_path / "c.nc", engine="h5netcdf") as d:
        got = d.corrected_temperature.values
    assert np.array_equal(np.isnan(got), np.isnan(reference.temperature))
    trusted = np.isfinite(got)
    assert trusted.mean() > 0.5
    assert np.max(np.abs(got - reference.temperature)[trusted]
                  / reference.uncertainty[trusted]) < 0.01
    capsys.readouterr()
    assert main(["correct", str(tmp_path / "rec.tif"), "--out", str(tmp_path / "d.nc")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--camera" in err[0], err


def test_the_noise_part_of_the_uncertainty_matches_monte_carlo_draws():
    """40 draws of nist-ir's noise on the same scene: the spread of each trusted pixel's
    corrected temperature against the noise part of the uncertainty the correction states.
    With 40 draws a standard deviation is known to ±11 % (1/√(2·39)); the median ratio over
    the pixels must be within 25 % of 1."""
    camera = BASE.replace(fpa=FPA, optics=BLURRED)
    scene = FrameStack(square(24.0)[None].repeat(2, 0), dt=10e-6, dx=PITCH / SUB)
    draws = [correct(camera.measure(scene, 10e-6, rng=seed)) for seed in range(40)]
    temperatures = np.array([c.temperature for c in draws])
    trusted = np.sum(np.isfinite(temperatures), axis=0) >= 30  # pixels trusted in most draws
    stated = np.nanmedian(np.array([c.noise_uncertainty for c in draws])[:, trusted], axis=0)
    spread = np.nanstd(temperatures[:, trusted], axis=0, ddof=1)
    ratio = spread / stated
    assert trusted.sum() > 500 and abs(np.median(ratio) - 1) < 0.25, np.median(ratio)


@pytest.mark.parametrize("level", [500.0, 900.0])
def test_a_uniform_scene_keeps_its_level(level):
    """A uniform frame (its variance the noise's): the filter gives up the detail but never the
    mean, which every pixel's noise averages down (a 500 K frame was read 154–311 K)."""
    camera = BASE.replace(fpa=dataclasses.replace(BASE.fpa, shape=(32, 32)))
    m = camera.measure(FrameStack(np.full((2, 32, 32), level), dt=10e-6, dx=PITCH), 10e-6,
                       rng=1)
    c = correct(m, velocity=(0.0, 0.0))
    np.testing.assert_allclose(np.nanmean(c.temperature), level, atol=0.1)


def test_corrected_signals_turn_into_temperatures_within_10_microkelvin():
    # The inversion through a table of exact inversions, interpolated in ln S, against the
    # temperatures whose Planck signals were inverted (more values than the table has nodes,
    # so the table is used): its bound, h²/8 · d²T/d(ln S)², is below 5e-6 K — also with a
    # ringing pixel's signal far below the radiance table (the nodes stay within it).
    from radiosim.correction import _INVERSION_NODES, _signal_temperature

    calibration = BASE.calibration(10e-6)
    truth = np.random.default_rng(3).uniform(300.0, 2500.0, 2 * _INVERSION_NODES)
    signal = calibration.response.grey_signal(truth, calibration.emissivity)
    signal[:4] = (np.nan, 0.0, -1.0, 1e-300 * signal.min())  # no temperature: NaN
    temperature, per_signal = _signal_temperature(signal, calibration)
    assert np.isnan(temperature[:4]).all() and np.isnan(per_signal[:4]).all()
    assert np.max(np.abs(temperature[4:] - truth[4:])) < 1e-5
    # dT/dS, the interval's secant, against the response's own derivative (a 1 mK central
    # difference) at the true temperatures: the secant over h = 1.3e-4 in ln S differs by
    # about h/2 · (d²T/d(ln S)²)/(dT/d(ln S)), below 1e-4 relative
    exact = 1.0 / calibration.response.slope(truth[4:], calibration.emissivity)
    np.testing.assert_allclose(per_signal[4:], exact, rtol=1e-4)
