"""A recording beside a simulation: registration to a fraction of a pixel, the difference and
its statistics, and the command."""

from pathlib import Path

import numpy as np
import pytest

import radiosim as rs
from radiosim import Camera
from radiosim.comparison import compare, register
from radiosim.scenes import FrameStack

Y, X = np.mgrid[0:160, 0:200] + 0.5  # sample centres [µm]


def spot(cy, cx):
    """A hot spot on a 400 K background [K], centre (cy, cx) [µm], σ = 15 µm."""
    return 400.0 + 500.0 * np.exp(-((Y - cy) ** 2 + (X - cx) ** 2) / (2 * 15.0**2))


def measured(field):
    return Camera.linear_ideal(4e-6).measure(
        FrameStack(field[None].repeat(2, 0), dt=1e-6, dx=1e-6), 1e-6)


@pytest.mark.parametrize("dy, dx", [(3.4, -2.7), (0.0, 0.0), (-5.25, 1.5), (0.3, 0.6)])
def test_registration_finds_a_sub_pixel_shift_the_scenes_state(dy, dx):
    """The recorded scene is the simulated one moved by (dy, dx) pixels of 4 µm, both drawn
    from the analytic spot (not one shifted from the other by interpolation): the shift is
    found within 0.01 pixel, and the images then agree to the linear interpolation's error
    of a spot σ = 3.75 px wide (≤ h²/8 · max|f''| = 500 K / 3.75² / 8 ≈ 4.4 K at a pixel)."""
    simulation = measured(spot(80.0, 100.0))
    recorded = measured(spot(80.0 + 4 * dy, 100.0 + 4 * dx)).apparent_temperature
    result = compare(recorded, simulation)
    assert result.shift == pytest.approx((dy, dx), abs=0.01)
    stats = result.statistics()
    assert abs(stats["mean_K"]) < 0.2 and max(abs(stats["p5_K"]), abs(stats["p95_K"])) < 4.4
    assert stats["pixels"] > 0.8 * 40 * 50 - 50 * (abs(dy) + 1) - 40 * (abs(dx) + 1)


def test_the_difference_and_its_share_within_the_uncertainty():
    """A recording 2 K warmer everywhere than a simulation whose stated uncertainty is the
    scene's spread within each pixel: the difference is +2 K, and the pixels within 2 × the
    uncertainty are those whose uncertainty reaches 1 K (counted here)."""
    simulation = measured(spot(80.0, 100.0))
    recorded = simulation.apparent_temperature + 2.0
    result = compare(recorded, simulation, shift=(0.0, 0.0))
    np.testing.assert_allclose(result.difference, 2.0, atol=1e-9)
    u = np.hypot(simulation.uncertainty, 0.0)  # the linear ideal camera has no noise
    assert result.statistics()["within_uncertainty"] == pytest.approx(np.mean(2 * u >= 2.0))


def test_a_recording_compared_with_a_simulation_of_its_own_temperatures():
    """A real FLIR frame, in kelvin through its own calibration, against the linear ideal
    camera's measurement of that very image as a scene (one sample a pixel): no shift, no
    difference."""
    recording = rs.read_recording(Path(__file__).parent / "data" / "flir" /
                                  "frame_000000_le.fff")
    image = recording.temperature()[0]
    simulation = Camera.linear_ideal(1e-6).measure(
        FrameStack(image[None].repeat(2, 0), dt=1e-6, dx=1e-6), 1e-6)
    result = rs.compare(recording, simulation)
    assert result.shift == pytest.approx((0.0, 0.0), abs=0.01)
    assert np.nanmax(np.abs(result.difference)) < 0.05


def test_the_command_writes_the_comparison_and_prints_its_statistics(tmp_path, capsys):
    import xarray as xr

    from radiosim.cli import main
    from radiosim.io.netcdf import write_netcdf

    flir = Path(__file__).parent / "data" / "flir" / "frame_000000_le.fff"
    image = rs.read_recording(flir).temperature()[0]
    simulation = Camera.linear_ideal(1e-6).measure(
        FrameStack(image[None].repeat(2, 0) - 1.5, dt=1e-6, dx=1e-6), 1e-6)
    write_netcdf(tmp_path / "sim.nc", simulation)
    code = main(["compare", str(flir), str(tmp_path / "sim.nc"), "--out", str(tmp_path / "c")])
    out = capsys.readouterr().out
    assert code == 0 and "mean +1.50 K" in out, out
    with xr.open_dataset(tmp_path / "c" / "comparison.nc", engine="h5netcdf") as d:
        assert d.difference.attrs["units"] == "K"
        assert d.attrs["mean_K"] == pytest.approx(1.5, abs=1e-3)
    assert (tmp_path / "c" / "comparison.png").stat().st_size > 10_000
    code = main(["compare", str(flir), str(tmp_path / "sim.txt"), "--out", str(tmp_path / "d")])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and ".nc or .exr" in err[0]


def test_register_on_an_image_with_holes():
    """NaN where the simulation flagged pixels: registration uses the pixels both hold."""
    a = spot(80.0, 100.0)
    b = spot(80.0 - 7.0, 100.0 + 5.0)
    b[60:70, 90:120] = np.nan
    assert register(a, b) == pytest.approx((7.0, -5.0), abs=0.01)


@pytest.mark.parametrize("call, said", [
    (lambda m: compare(np.pad(m.apparent_temperature[18:21, 23:26], ((18, 19), (23, 24)),
                              constant_values=np.nan), m), "fewer than 16 pixels"),
    (lambda m: compare(np.full(m.shape, 650.0), m), "without features"),
    (lambda m: compare(m.apparent_temperature, m, shift=1.0), "shift must be (rows, columns)"),
    (lambda m: compare(m.apparent_temperature, m, scale="2"), "scale must be"),
    (lambda m: compare(m.apparent_temperature, None), "needs a simulated Measurement"),
    (lambda m: compare(m.apparent_temperature, m, coverage=-1), "coverage must be"),
    (lambda m: compare(m.apparent_temperature, m, frame=5), "apply to a Recording"),
])
def test_bad_comparisons_are_named_in_one_line(call, said):
    from radiosim.errors import RadiosimError

    from conftest import one_line_naming

    simulation = measured(spot(80.0, 100.0))
    with pytest.raises(RadiosimError) as info:
        call(simulation)
    one_line_naming(info, said)
