"""Scenes: validation, streaming, time windows, analytic expectations."""

from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import quad

import radiosim
from conftest import api_error, one_line_naming
from radiosim import Camera, FrameStack, MovingGaussianBand, UniformBlackbody
from radiosim.errors import RadiosimError
from radiosim.integrator import frame_weights


def test_framestack_reads_a_memory_mapped_stack_frame_by_frame(tmp_path):
    data = np.random.default_rng(0).uniform(300, 900, (6, 5, 7)).astype(np.float32)
    np.save(tmp_path / "stack.npy", data)
    stack = np.load(tmp_path / "stack.npy", mmap_mode="r")
    scene = FrameStack(stack, dt=0.2e-6, dx=1e-6)
    frame = scene.frame(4, (slice(1, 4), slice(2, 7)))
    assert frame.dtype == np.float64 and frame.shape == (3, 5)
    np.testing.assert_array_equal(frame, data[4, 1:4, 2:7].astype(np.float64))
    assert isinstance(scene._stack, np.memmap)  # not loaded whole


@pytest.mark.parametrize("value, message", [
    (np.nan, r"frame 2: temperature at row 3, column 1 is NaN"),
    (-4.0, r"frame 2: temperature at row 3, column 1 is -4 K"),
    (0.0, r"is 0 K; temperatures must be > 0 K"),
])
def test_bad_temperatures_are_named_when_read(value, message):
    data = np.full((4, 5, 6), 400.0)
    data[2, 3, 1] = value
    scene = FrameStack(data, dt=1.0, dx=1.0)
    scene.frame(1)
    with pytest.raises(RadiosimError, match=message):
        scene.frame(2)


@pytest.mark.parametrize("kwargs, message", [
    ({"temperature": np.ones((4, 5))}, "3-D array"),
    ({"temperature": np.ones((0, 4, 5))}, "empty"),
    ({"dt": 0.0}, "dt must be finite and > 0"),
    ({"dx": -1e-6}, "dx must be finite and > 0"),
    ({"dx": "wide"}, "dx must be a number"),
    ({"emissivity": np.ones((3, 3))}, "emissivity map has shape"),
    ({"emissivity": 1.5}, "emissivity"),
    ({"event_time": 1.0}, "event_time"),
])
def test_framestack_rejects_bad_input(kwargs, message):
    args = {"temperature": np.full((4, 5, 6), 300.0), "dt": 1e-6, "dx": 1e-6} | kwargs
    with pytest.raises(RadiosimError, match=message):
        FrameStack(**args)


def test_frame_index_outside_scene():
    scene = FrameStack(np.full((3, 2, 2), 300.0), dt=1.0, dx=1.0)
    with pytest.raises(RadiosimError, match="frame 3 is outside the scene"):
        scene.frame(3)


@pytest.mark.parametrize("start_frame", [0, 1, 17, 333, 1000])
@pytest.mark.parametrize("n", [5, 50, 125, 450])
def test_window_of_n_frames_covers_exactly_n_frames(start_frame, n):
    dt = 0.2e-6
    first, weights = frame_weights(start_frame * dt, n * dt, dt)
    assert first == start_frame
    assert weights.size == n
    np.testing.assert_allclose(weights, 1.0 / n, rtol=1e-12)


def test_fractional_window_weights_are_overlaps():
    first, weights = frame_weights(0.3, 2.0, 1.0)
    assert first == 0
    np.testing.assert_allclose(weights, [0.35, 0.5, 0.15])
    assert weights.sum() == pytest.approx(1.0)


@pytest.mark.parametrize("args, message", [
    ((-1e-6, 1e-6, 1e-7, 100), "before the scene's first frame"),
    ((0.0, 2e-5, 1e-7, 100), "runs past the scene's last frame"),
    ((0.0, 0.0, 1e-7, 100), "integration time must be"),
])
def test_windows_outside_the_scene_are_refused(args, message):
    with pytest.raises(RadiosimError, match=message):
        frame_weights(*args)


def test_moving_band_time_average_is_the_integral():
    band = MovingGaussianBand(300.0, 500.0, sigma=4e-6, velocity=3.0, x0=10e-6)
    x, t0, t1 = 37e-6, 1e-6, 12e-6
    numeric, _ = quad(lambda t: float(band.temperature(x, t)), t0, t1, epsrel=1e-12)
    assert band.time_average(x, t0, t1) == pytest.approx(numeric / (t1 - t0), rel=1e-12)


def test_analytic_scenes_sample_mid_time_and_centres():
    band = MovingGaussianBand(300.0, 500.0, sigma=4e-6, velocity=3.0, x0=0.0, shape=(2, 30),
                              dx=1e-6, dt=1e-6)
    frame = band.frame(2)
    x = (np.arange(30) + 0.5) * 1e-6
    np.testing.assert_allclose(frame[1], band.temperature(x, 2.5e-6), rtol=1e-15)
    uniform = UniformBlackbody(700.0, shape=(3, 4))
    assert uniform.frame(10**6).tolist() == np.full((3, 4), 700.0).tolist()
    assert band.describe()["velocity_m_per_s"] == 3.0


SPECTRA = Path(__file__).resolve().parents[1] / "spectra"


def shipped_curve(name):
    """A shipped spectral curve as (wavelength [m], value): its CSV file read here, not by
    radiosim (comment lines, a header line, then µm and the value)."""
    lines = [line for line in (SPECTRA / f"{name}.csv").read_text().splitlines()
             if line.strip() and not line.startswith("#")]
    data = np.array([[float(v) for v in line.split(",")] for line in lines[1:]])
    return data[:, 0] * 1e-6, data[:, 1]


def in_band_photon_radiance(temperature, band, curves):
    """∫ Π curves(λ) · L_q,λ(λ, T) dλ [photons s⁻¹ m⁻² sr⁻¹] by scipy quad: Planck's photon
    radiance L_q,λ = 2c / (λ⁴ (exp(hc/λkT) − 1)) times the curves, each interpolated linearly
    and zero outside its table; the curves' nodes are quad's break points."""
    import scipy.constants as sc

    def integrand(lam):
        weight = 1.0
        for x, y in curves:
            weight *= np.interp(lam, x, y, left=0.0, right=0.0)
        return weight * 2 * sc.c / lam**4 / np.expm1(sc.h * sc.c / (lam * sc.k * temperature))

    lo, hi = band
    nodes = np.unique(np.concatenate([x for x, _ in curves]))
    value, _ = quad(integrand, lo, hi, points=nodes[(nodes > lo) & (nodes < hi)], limit=2000,
                    epsabs=0.0, epsrel=1e-12)
    return value


def test_step_edge_readings_are_area_fractions_linear_and_planck():
    from scipy.optimize import brentq

    from radiosim import Camera
    from radiosim.scenes import StepEdge

    pitch = 4e-6
    # Linear: exact for any edge position, even inside a sample. Pixel j covers
    # [4j, 4j + 4] µm, the hot side is x < 13.3 µm: pixels 0–2 are wholly hot, pixel 3 holds
    # 1.3 µm of hot over its 4 µm (f = 0.325), the rest are wholly cold. Rounding only.
    edge = StepEdge(1000.0, 300.0, edge=13.3e-6, shape=(8, 40), dx=1e-6, dt=1e-6)
    m = Camera.linear_ideal(pitch).measure(edge, 1e-6, t_start=0.0)
    expected = np.array([1000.0] * 3 + [300.0 + 700.0 * 1.3 / 4] + [300.0] * 6)
    np.testing.assert_allclose(m.apparent_temperature[0], expected, rtol=1e-14)
    # Planck, edge on a sample boundary: the temperature of the mean radiance, hotter than
    # the mean temperature. nist-ir's band (3.75–5.15 µm) through its filter and lens; the
    # replaced FPA has a flat quantum efficiency (1), so the QE curve is not in the band.
    # The in-band radiance L and its inverse are computed here (quad, brentq), not by
    # radiosim's tables.
    base = Camera.preset("nist-ir")
    camera = base.replace(fpa=base.fpa.__class__(pixel_pitch=pitch, shape=(2, 10)),
                          electronics=Camera.linear_ideal(pitch).electronics)
    band = (3.75e-6, 5.15e-6)
    curves = [shipped_curve("filter_mwir_3.8-5.1um"), shipped_curve("optics_mwir_lens")]

    def radiance(t):
        return in_band_photon_radiance(t, band, curves)

    hot, cold = radiance(1000.0), radiance(300.0)
    # Tolerance: both sides compute L to ~1e-9 relative or better (quad to 1e-12; radiosim's
    # radiance table is a cubic spline of a few hundred nodes per octave); a relative radiance
    # error δ moves a reading by δ / (d ln L/dT), and d ln L/dT ≈ c2/(λT²) ≥ 14388 µm K /
    # (5.15 µm · (1000 K)²) = 2.8e-3 K⁻¹ here: ≤ 4e-7 K for δ = 1e-9; 1e-6 K asserted. Leaving
    # the QE curve in the band moves the straddling pixel by 0.09–0.28 K; the mean temperature
    # instead of the mean radiance, by 96–231 K.
    for microns in (13, 14, 15):  # pixel 3 (12–16 µm) holds f = 1/4, 1/2, 3/4 of hot
        f = (microns - 12) / 4
        edge = StepEdge(1000.0, 300.0, edge=microns * 1e-6, shape=(8, 40), dx=1e-6,
                        dt=1e-6)
        m = Camera.linear_ideal(pitch).measure(edge, 1e-6, t_start=0.0)
        planck = camera.measure(edge, 1e-6, t_start=0.0)
        mixed = f * hot + (1 - f) * cold
        straddling = brentq(lambda t: radiance(t) - mixed, 300.0, 1000.0, xtol=1e-10,
                            rtol=1e-15)
        expected = np.array([1000.0] * 3 + [straddling] + [300.0] * 6)
        np.testing.assert_allclose(planck.apparent_temperature[0], expected, rtol=0,
                                   atol=1e-6)
        np.testing.assert_allclose(m.apparent_temperature[0][3], 300.0 + 700.0 * f,
                                   rtol=1e-14)
        assert planck.apparent_temperature[0][3] > m.apparent_temperature[0][3]


def test_frame_stack_blocks_are_views_of_the_stored_frames(tmp_path):
    from radiosim.scenes.base import Scene

    path = tmp_path / "stack.npy"
    np.save(path, np.arange(5 * 4 * 6, dtype=np.float32).reshape(5, 4, 6) + 300)
    stored = np.load(path, mmap_mode="r")
    scene = FrameStack(stored, dt=1e-6, dx=1e-6)
    block = scene.block_unchecked(1, 4, (slice(1, 3), slice(2, 6)))
    assert block.shape == (3, 2, 4) and np.shares_memory(block, stored)
    np.testing.assert_array_equal(block[2], scene.frame(3, (slice(1, 3), slice(2, 6))))
    # Converted on reading (Celsius, integers) or made by another scene: no blocks.
    assert FrameStack(stored, dt=1e-6, dx=1e-6, units="C").block_unchecked(0, 2) is None
    assert FrameStack(stored.astype(np.int32), dt=1e-6, dx=1e-6).block_unchecked(0, 2) is None
    assert Scene.block_unchecked(scene, 0, 2) is None
    for start, stop in ((3, 3), (4, 6), (-1, 2)):
        with pytest.raises(RadiosimError, match="frame"):
            scene.block_unchecked(start, stop)


# -- the registry of scene types (radiosim.io.scenes) -----------------------------------------


def test_every_scene_type_is_registered_with_what_it_reads():
    import radiosim.scenes as scenes
    from radiosim.io import SCENE_TYPES
    from radiosim.io.scenes import scene_type, scene_type_of
    from radiosim.scenes.base import Scene

    built = {t.scene for t in SCENE_TYPES.values()}
    public = {getattr(scenes, n) for n in scenes.__all__ if isinstance(getattr(scenes, n), type)
              and issubclass(getattr(scenes, n), Scene) and n not in ("Scene", "CroppedScene")}
    assert built == public  # a scene class without a record (or the reverse) fails here
    for name, entry in SCENE_TYPES.items():
        assert entry.name == name and entry.reads
        assert bool(entry.suffixes) == (entry.reader is not None)
    assert scene_type("fea").suffixes == (".csv",)
    assert {scene_type_of(f"x{s}").name for s in (".npy", ".NPZ")} == {"frames"}
    assert scene_type_of("run/frame_*.exr").name == "exr-sequence"
    assert scene_type_of("case.vtu").name == "fea-mesh"
    with pytest.raises(RadiosimError, match="unknown scene type 'fea-node'.*fea-mesh"):
        scene_type("fea-node")


def test_a_study_scene_table_is_built_by_its_registered_type(tmp_path):
    from radiosim.io import SCENE_TYPES
    from radiosim.study_spec import SCENE_KEYS, scene_from_table

    assert SCENE_KEYS["fea"] == ("type", "path", "dx_um", "dt_us", "units", "fill_K",
                                 "emissivity")
    assert {t.table for t in SCENE_TYPES.values() if t.table} == set(SCENE_KEYS)
    np.save(tmp_path / "s.npy", np.full((3, 4, 5), 400.0))
    scene = scene_from_table({"type": "frames", "path": "s.npy", "dt_us": 0.5, "dx_um": 2,
                              "units": "K", "path_transmission": 0.5,
                              "path_temperature_K": 300.0}, tmp_path)
    assert (scene.dt, scene.dx, scene.n_frames) == (0.5e-6, 2e-6, 3)
    assert scene.path_transmission == 0.5
    with pytest.raises(RadiosimError, match="is not segmented-chip, frames or fea"):
        scene_from_table({"type": "uniform-blackbody"}, tmp_path)


# -- FrameStack and from_xarray: what is refused, named --------------------------------------------


def test_an_emissivity_map_outside_0_1_names_the_value_and_where():
    emissivity = np.full((4, 4), 0.5)
    emissivity[2, 3] = 1.5
    with pytest.raises(RadiosimError, match=r"got 1\.5 at row 2, column 3 \(1 value"):
        FrameStack(np.full((2, 4, 4), 500.0), dt=1e-6, dx=1e-6, emissivity=emissivity)


def test_framestack_ragged_lists_name_the_shapes():
    with pytest.raises(RadiosimError) as info:
        FrameStack([[[500.0, 500.0], [500.0]]], dt=1e-6, dx=1e-6)
    one_line_naming(info, "temperature[0][0] has 2 values", "temperature[0][1] has 1 values")
    with pytest.raises(RadiosimError) as info:
        FrameStack([[[500.0, 500.0]], [[500.0, 500.0], [500.0, 500.0]]], dt=1e-6, dx=1e-6)
    one_line_naming(info, "temperature[0] has 1 values", "temperature[1] has 2 values")


@pytest.mark.parametrize("emissivity", [True, False, np.bool_(True)])
def test_framestack_a_bool_emissivity_is_refused(emissivity):
    with pytest.raises(RadiosimError) as info:
        FrameStack(np.full((2, 4, 4), 500.0), dt=1e-6, dx=1e-6, emissivity=emissivity)
    one_line_naming(info, "emissivity", repr(emissivity), "bool")


@pytest.mark.usefixtures("in_tmp")
def test_infinite_temperature_through_linear_camera():
    scene = radiosim.FrameStack(np.full((3, 12, 12), np.inf), dt=1e-6, dx=1e-6)
    with pytest.raises(RadiosimError) as info:
        Camera.linear_ideal(3e-6).measure(scene, 2e-6)
    api_error(info, "frame 0", "row 0", "column 0", "inf")


@pytest.mark.usefixtures("in_tmp")
@pytest.mark.parametrize("value, word", [(np.inf, "inf"), (-np.inf, "inf"), (np.nan, "NaN"),
                                         (0.0, "0 K"), (-5.0, "-5 K")])
def test_bad_temperature_names_frame_row_column(value, word):
    stack = np.full((4, 12, 12), 500.0)
    stack[2, 7, 3] = value
    scene = FrameStack(stack, dt=1e-6, dx=1e-6)
    with pytest.raises(RadiosimError) as info:
        Camera.linear_ideal(3e-6).measure(scene, 4e-6)
    api_error(info, "frame 2", "row 7", "column 3", word)


def _cube():
    """Frames k, rows i, columns j with T = 300 + 100 k + 10 i + j [K]."""
    k, i, j = np.meshgrid(np.arange(4), np.arange(5), np.arange(6), indexing="ij")
    return 300.0 + 100.0 * k + 10.0 * i + j


@pytest.mark.parametrize("order", [("x", "y", "time"), ("time", "x", "y"), ("y", "time", "x")])
def test_from_xarray_puts_dimensions_in_order_by_name(order):
    import xarray as xr

    cube = _cube()
    axes = [("time", "y", "x").index(d) for d in order]
    coords = {"time": np.arange(4) * 1e-6, "y": np.arange(5) * 2e-6, "x": np.arange(6) * 2e-6}
    variable = xr.DataArray(np.transpose(cube, axes), dims=order, coords=coords)
    scene = FrameStack.from_xarray(variable)
    assert scene.n_frames == 4 and scene.shape == (5, 6)
    assert scene.dt == pytest.approx(1e-6) and scene.dx == pytest.approx(2e-6)
    np.testing.assert_array_equal(scene.frame(3), cube[3])


@pytest.mark.parametrize("times", [
    np.datetime64("2024-01-01T00:00:00") + np.arange(4) * np.timedelta64(200, "ns"),
    np.datetime64("2024-01-01T00:00:00", "us") + np.arange(4) * np.timedelta64(1, "us"),
    np.arange(4) * np.timedelta64(5, "ms"),
])
def test_from_xarray_reads_datetime_coordinates_in_seconds(times):
    import xarray as xr

    variable = xr.DataArray(_cube(), dims=("time", "y", "x"),
                            coords={"time": times, "x": np.arange(6) * 1e-6})
    expected = (times[1] - times[0]) / np.timedelta64(1, "ns") * 1e-9
    assert FrameStack.from_xarray(variable).dt == pytest.approx(expected, rel=1e-12)


@pytest.mark.parametrize("coords, names", [
    ({"time": np.arange(4) * 1e-6, "y": np.arange(5) * 2e-6, "x": np.arange(6) * 1e-6},
     ("'y' spacing 2e-06", "'x' spacing 1e-06")),
    ({"time": np.arange(4) * 1e-6, "x": np.array([0, 1, 2, 3, 5, 6]) * 1e-6},
     ("'x'", "not evenly spaced", "2e-06")),
    ({"time": np.array([0, 1, 3, 4]) * 1e-6, "x": np.arange(6) * 1e-6},
     ("'time'", "not evenly spaced", "2e-06")),
])
def test_from_xarray_refuses_uneven_or_unequal_spacing(coords, names):
    import xarray as xr

    variable = xr.DataArray(_cube(), dims=("time", "y", "x"), coords=coords, name="T")
    with pytest.raises(RadiosimError) as info:
        FrameStack.from_xarray(variable)
    one_line_naming(info, "'T'", *names)


def test_from_xarray_refuses_a_dt_that_contradicts_the_coordinate():
    import xarray as xr

    variable = xr.DataArray(_cube(), dims=("time", "y", "x"), name="T",
                            coords={"time": np.arange(4) * 1e-6, "x": np.arange(6) * 1e-6})
    with pytest.raises(RadiosimError) as info:
        FrameStack.from_xarray(variable, dt=2e-6)
    one_line_naming(info, "'T'", "dt=2e-06", "1e-06")


@pytest.mark.parametrize("unit, kelvin", [("degree_Celsius", 273.15), ("Celsius", 273.15),
                                          ("degC", 273.15), ("Kelvin", 0.0), ("K", 0.0)])
def test_from_xarray_reads_cf_temperature_units_and_a_decreasing_y(unit, kelvin):
    # CF's spellings of kelvin and degrees Celsius are read as such, and a y coordinate that
    # decreases with the row (an image's rows counted from the top) is evenly spaced too.
    import xarray as xr

    frames = np.full((3, 4, 5), 500.0)
    da = xr.DataArray(frames, dims=("time", "y", "x"), attrs={"units": unit},
                      coords={"time": np.arange(3) * 1e-6, "y": 3e-6 - np.arange(4) * 1e-6,
                              "x": np.arange(5) * 1e-6})
    scene = FrameStack.from_xarray(da)
    assert scene.dx == pytest.approx(1e-6) and scene.dt == pytest.approx(1e-6)
    np.testing.assert_allclose(scene.sample(1).temperature, 500.0 + kelvin)


def test_from_xarray_refuses_a_unit_that_is_no_temperature_naming_it():
    import xarray as xr

    da = xr.DataArray(np.full((2, 3, 3), 500.0), dims=("time", "y", "x"),
                      attrs={"units": "degF"}, coords={"time": [0.0, 1e-6]})
    with pytest.raises(RadiosimError, match="units 'degF' are neither kelvin nor degrees"):
        FrameStack.from_xarray(da, dx=1e-6)
