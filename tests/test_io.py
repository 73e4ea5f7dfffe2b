"""Importers: NumPy stacks, EXR sequences, FEA nodal CSV."""

import io
import os
import tempfile
import warnings
from pathlib import Path

import numpy as np
import OpenEXR
import pytest
from hypothesis import given
from hypothesis import strategies as st

from conftest import (BOUNDED, api_error, consume, double, one_line_naming, without_paths,
                      write_exr_frames)
from radiosim import Camera, FrameStack, RadiosimWarning
from radiosim.errors import RadiosimError, RadiosimIOError
from radiosim.io import read_exr, read_fea_nodes, read_frames


@pytest.fixture
def stack():
    return np.random.default_rng(0).uniform(20.0, 700.0, (5, 6, 8)).astype(np.float32)


def test_npy_in_celsius_is_memory_mapped_and_converted(tmp_path, stack):
    np.save(tmp_path / "s.npy", stack)
    scene = read_frames(tmp_path / "s.npy", dt=0.2e-6, dx=1e-6, units="C")
    assert isinstance(scene._stack, np.memmap)
    np.testing.assert_allclose(scene.frame(3), stack[3].astype(np.float64) + 273.15)
    assert scene.describe()["source_units"] == "C"


def test_uncompressed_npz_is_memory_mapped_compressed_is_loaded_with_warning(tmp_path, stack):
    np.savez(tmp_path / "a.npz", temperature=stack, other=np.zeros(3))
    scene = read_frames(tmp_path / "a.npz", dt=1e-6, dx=1e-6, units="K", key="temperature")
    assert isinstance(scene._stack, np.memmap)
    np.testing.assert_array_equal(scene.frame(4), stack[4].astype(np.float64))
    np.savez_compressed(tmp_path / "b.npz", stack)
    with pytest.warns(RadiosimWarning, match="compressed"):
        scene = read_frames(tmp_path / "b.npz", dt=1e-6, dx=1e-6, units="K")
    np.testing.assert_array_equal(scene.frame(1), stack[1].astype(np.float64))


@pytest.mark.parametrize("kwargs, message", [
    ({"units": None}, "carry no unit"),
    ({"units": "F"}, "not K or C"),
    ({"dt": None}, "carries no grid; give the frame interval"),
])
def test_numpy_files_need_units_and_steps(tmp_path, stack, kwargs, message):
    np.save(tmp_path / "s.npy", stack)
    args = {"dt": 1e-6, "dx": 1e-6, "units": "K"} | kwargs
    with pytest.raises(RadiosimError, match=message):
        read_frames(tmp_path / "s.npy", **args)


def test_npz_errors(tmp_path, stack):
    np.savez(tmp_path / "two.npz", a=stack, b=stack)
    with pytest.raises(RadiosimError, match="say which with key"):
        read_frames(tmp_path / "two.npz", dt=1e-6, dx=1e-6, units="K")
    (tmp_path / "bad.npz").write_bytes(b"not a zip")
    with pytest.raises(RadiosimError, match="bad.npz is not a readable .npz"):
        read_frames(tmp_path / "bad.npz", dt=1e-6, dx=1e-6, units="K")


def write_exr(path, image, **attributes):
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    header.update(attributes)
    with OpenEXR.File(header, {"temperature": image.astype(np.float32)}) as exr:
        exr.write(str(path))


def test_exr_sequence_in_natural_order_with_header_units(tmp_path, stack):
    # frame_10 must come after frame_9 (issue 20: the numbers may not skip one, so the
    # sequence is 8-11 rather than 0, 1, 2, 10; the frames hold stack 0, 1, 2 and 4 as before)
    for k, i in zip((8, 9, 10, 11), (0, 1, 2, 4)):
        write_exr(tmp_path / f"frame_{k}.exr", stack[i], temperature_unit="C",
                  dt_s=0.2e-6, dx_m=0.5e-6)
    scene = read_frames(tmp_path)
    assert scene.n_frames == 4 and scene.shape == (6, 8)
    assert scene.dt == pytest.approx(0.2e-6, rel=1e-6) and scene.units == "C"
    np.testing.assert_allclose(scene.frame(3), stack[4] + 273.15, rtol=1e-6)
    same = read_frames(str(tmp_path / "frame_*.exr"))
    np.testing.assert_array_equal(same.frame(2), scene.frame(2))


def test_exr_errors_name_the_file_and_frame(tmp_path, stack):
    write_exr(tmp_path / "f_0.exr", stack[0])
    with pytest.raises(RadiosimError, match="states no temperature unit"):
        read_frames(tmp_path, dt=1e-6, dx=1e-6)
    (tmp_path / "f_1.exr").write_bytes(b"garbage")
    scene = read_frames(tmp_path, dt=1e-6, dx=1e-6, units="K")
    with pytest.raises(RadiosimError, match=r"frame 1: cannot read EXR file .*f_1.exr"):
        scene.frame(1)
    write_exr(tmp_path / "f_1.exr", stack[0][:3])
    with pytest.raises(RadiosimError, match=r"frame 1: .*is \(3, 8\), the first frame is"):
        read_frames(tmp_path, dt=1e-6, dx=1e-6, units="K").frame(1)
    with pytest.raises(RadiosimError, match="no frames found"):
        read_frames(tmp_path / "nothing_*.exr")


def fea_csv(path, steps, header="# units: time=us, length=um, temperature=C"):
    lines = [header, "x,y,time,temperature"]
    for t, (xy, temp) in steps.items():
        lines += [f"{float(x)!r},{float(y)!r},{float(t)!r},{float(v)!r}"
                  for (x, y), v in zip(xy, temp)]
    path.write_text("\n".join(lines) + "\n")


def linear_field(xy, t):
    return 100.0 + 2.0 * xy[:, 0] - 0.5 * xy[:, 1] + 10.0 * t  # °C, µm, µs


def test_fea_nodes_moving_and_remeshed_reproduce_a_linear_field(tmp_path):
    rng = np.random.default_rng(5)
    steps = {}
    g = np.linspace(0, 100, 21)
    xx, yy = np.meshgrid(g, g)
    grid = np.column_stack([xx.ravel(), yy.ravel()])
    boundary = (grid == 0) | (grid == 100)
    for t in (0.0, 0.5, 1.0):
        # A remeshed, moving mesh: interior nodes jittered differently at every step.
        xy = grid + np.where(boundary, 0.0, rng.uniform(-2.0, 2.0, grid.shape))
        steps[t] = (xy, linear_field(xy, t))
    fea_csv(tmp_path / "run.csv", steps)
    scene = read_fea_nodes(tmp_path / "run.csv", dx=5e-6)
    assert scene.n_frames == 3 and scene.dt == pytest.approx(0.5e-6)
    assert scene.shape == (20, 20)
    x = (np.arange(20) + 0.5) * 5.0
    y = 100.0 - (np.arange(20) + 0.5) * 5.0
    xx, yy = np.meshgrid(x, y)
    expected = linear_field(np.column_stack([xx.ravel(), yy.ravel()]), 1.0).reshape(20, 20)
    # Linear interpolation is exact for a linear field.
    np.testing.assert_allclose(scene.frame(2), expected + 273.15, rtol=1e-12)


def test_fea_outside_a_concave_mesh_gets_the_fill(tmp_path):
    # An L-shaped body: the notch x > 50, y > 50 has no material.
    g = np.arange(0, 101, 5.0)
    xx, yy = np.meshgrid(g, g)
    xy = np.column_stack([xx.ravel(), yy.ravel()])
    xy = xy[~((xy[:, 0] > 50) & (xy[:, 1] > 50))]
    steps = {0.0: (xy, np.full(len(xy), 500.0)), 1.0: (xy, np.full(len(xy), 500.0))}
    fea_csv(tmp_path / "l.csv", steps)
    scene = read_fea_nodes(tmp_path / "l.csv", dx=10e-6, fill=293.15)
    frame = scene.frame(0)
    assert frame[0, -1] == pytest.approx(293.15)  # top right: the notch
    assert frame[-1, 0] == pytest.approx(773.15)  # bottom left: material
    m = Camera.linear_ideal(20e-6).measure(scene, 1e-6, t_start=0.0)
    assert m.shape == (5, 5)


@pytest.mark.parametrize("body, message", [
    ("x,y,time\n1,2,3\n", "lacks column"),
    ("# units: time=us, length=um, temperature=C\nx,y,time,temperature\n1,2,0,abc\n",
     "line 3: a value is not a number"),
    ("# units: time=us, length=um, temperature=C\nx,y,time,temperature\n1,2,0\n",
     "line 3: expected 4 fields"),
    ("x,y,time,temperature\n0,0,0,1\n1,0,0,1\n0,1,0,1\n", "time unit is stated nowhere"),
    ("# units: time=fortnight, length=um, temperature=C\nx,y,time,temperature\n0,0,0,1\n",
     "time unit 'fortnight'"),
    ("# units: time=us, length=um, temperature=K\nx,y,time,temperature\n0,0,0,-5\n0,1,0,5\n"
     "1,0,0,5\n", "temperature -5 K"),
    ("# units: time=us, length=um, temperature=C\nx,y,time,temperature\n0,0,0,1\n1,1,0,1\n",
     "at least 3"),
])
def test_fea_errors_name_the_line_and_problem(tmp_path, body, message):
    path = tmp_path / "bad.csv"
    path.write_text(body)
    with pytest.raises(RadiosimError, match=message):
        read_fea_nodes(path, dx=1e-6, dt=1e-6)


def test_fea_uneven_steps_are_refused(tmp_path):
    xy = np.array([[0, 0], [10, 0], [0, 10], [10, 10]], dtype=float)
    steps = {t: (xy, np.full(4, 300.0)) for t in (0.0, 1.0, 2.5)}
    fea_csv(tmp_path / "u.csv", steps)
    with pytest.raises(RadiosimError, match="not evenly spaced"):
        read_fea_nodes(tmp_path / "u.csv", dx=1e-6)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        steps = {t: (xy, np.full(4, 300.0)) for t in (0.0, 1.0, 2.0)}
        fea_csv(tmp_path / "e.csv", steps)
        with pytest.raises(RadiosimError, match="does not match"):
            read_fea_nodes(tmp_path / "e.csv", dx=1e-6, dt=3e-6)


# -- labelled results: xarray and NetCDF -----------------------------------------------------


def test_a_measurement_survives_xarray_and_netcdf_losslessly(tmp_path):
    """to_xarray → NetCDF → back: every array bit for bit (NaN where flagged), the flags as
    booleans, the units, the camera (its TOML) and the scene's description."""
    from radiosim import UniformBlackbody
    from radiosim.io import from_xarray, read_netcdf, write_netcdf

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        m = Camera.preset("nist-ir").measure(UniformBlackbody(2500.0, (60, 80), 6e-6, 1e-6),
                                             10e-6, rng=0)
    assert m.saturated.any()  # flags and NaN readings are in the round trip
    ds = m.to_xarray()
    assert ds.saturated.dtype == bool and ds.y.units == "m"
    assert ds.counts.units == "1" and "DN" in ds.counts.long_name
    back = read_netcdf(write_netcdf(tmp_path / "m.nc", m))
    for name in m.ARRAYS:
        assert np.array_equal(getattr(m, name), getattr(back, name), equal_nan=True), name
        assert getattr(back, name).dtype == getattr(m, name).dtype
    assert back.camera.to_toml() == m.camera.to_toml()
    assert back.scene == m.scene and back.signal_unit == m.signal_unit
    assert (back.integration_time, back.t_start, back.n_frames) == (m.integration_time,
                                                                   m.t_start, m.n_frames)
    assert np.array_equal(from_xarray(ds).counts, m.counts)


def test_netcdf_errors_are_one_line(tmp_path):
    from radiosim.io import read_netcdf

    (tmp_path / "broken.nc").write_bytes(b"not a netcdf file")
    with pytest.raises(RadiosimError, match="cannot read NetCDF file"):
        read_netcdf(tmp_path / "broken.nc")
    with pytest.raises(RadiosimError, match="does not exist"):
        read_netcdf(tmp_path / "missing.nc")


def test_study_results_are_one_record_per_measurement(tmp_path):
    import xarray as xr
    from conftest import frames_study

    from radiosim.cli import main

    np.save(tmp_path / "frames.npy", np.full((6, 24, 24), 650.0))
    (tmp_path / "s.toml").write_text(frames_study([1, 2, 3], 4.0))
    assert main(["run", str(tmp_path / "s.toml"), "--out", str(tmp_path / "out"),
                 "--format", "netcdf", "--no-figures", "-q"]) == 0

    with xr.open_dataset(tmp_path / "out" / "results.nc", engine="h5netcdf") as ds:
        assert set(ds.dims) == {"measurement"}
        assert ds.integration_time.units == "s"
        assert ds.integration_time.values.tolist() == [1e-06, 2e-06, 3e-06]
        np.testing.assert_allclose(ds.peak_C.values, 650.0 - 273.15)


# -- the nodal CSV's column names --------------------------------------------------------------


def _nodal_rows():
    return [f"{t},{x},{y},{500 + x}" for t in (0.0, 1.0) for x in range(0, 20, 2)
            for y in range(0, 20, 2)]


@pytest.mark.parametrize("header", ["time_us, x_um, y_um, temperature_C",
                                    "time [us],x (um),y [µm],temperature [C]",
                                    "Time_us,X_um,Y_um,Temperature_C"])
def test_unit_suffixes_in_column_names_state_the_units(tmp_path, header):
    """A header such as time_s, x_um, y_um, temperature_C needs no other unit: the nodes at
    x µm carry 500 + x °C, so the sample at x = 5.5 µm reads 505.5 °C (linear in x)."""
    path = tmp_path / "nodes.csv"
    path.write_text(header + "\n" + "\n".join(_nodal_rows()) + "\n")
    scene = read_fea_nodes(path, dx=1e-6)
    assert scene.dt == pytest.approx(1e-6)
    np.testing.assert_allclose(scene.frame(0)[4, 5], 505.5 + 273.15, rtol=1e-12)


def test_a_column_mapping_names_a_solvers_columns(tmp_path):
    path = tmp_path / "abaqus.csv"
    path.write_text("Frame time,COORD1,COORD2,NT11\n" + "\n".join(_nodal_rows()) + "\n")
    scene = read_fea_nodes(path, dx=1e-6, units={"time": "us", "length": "um",
                                                 "temperature": "C"},
                           columns={"time": "Frame time", "x": "COORD1", "y": "COORD2",
                                    "temperature": "NT11"})
    np.testing.assert_allclose(scene.frame(1)[4, 5], 505.5 + 273.15, rtol=1e-12)
    with pytest.raises(RadiosimError, match="no column 'NT12'"):
        read_fea_nodes(path, dx=1e-6, columns={"temperature": "NT12"})
    path.write_text("time_us,x_um,y_mm,temperature_C\n" + "\n".join(_nodal_rows()) + "\n")
    with pytest.raises(RadiosimError, match="two length units"):
        read_fea_nodes(path, dx=1e-6)


# -- read_scene: a scene file by its suffix (the registry of scene types) --------------------


def _nodes_csv(path, header="# units: time=us, length=um, temperature=C"):
    rows = [f"{x},{y},{t},{20.0 + x}" for t in (0, 1) for x, y in ((0, 0), (4, 0), (0, 4),
                                                                       (4, 4))]
    path.write_text("\n".join(([header] if header else []) + ["x,y,time,temperature", *rows])
                    + "\n")
    return path


def test_read_scene_reads_each_suffix_with_its_reader(tmp_path, stack):
    from radiosim.io import read_scene
    from radiosim.scenes import ExrSequence, FeaNodes, FrameStack

    np.save(tmp_path / "s.npy", stack)
    scene = read_scene(tmp_path / "s.npy", dt=1e-6, dx=2e-6, units="C")
    assert isinstance(scene, FrameStack) and scene.dt == 1e-6 and scene.dx == 2e-6
    np.testing.assert_allclose(scene.frame(1), stack[1] + 273.15, rtol=1e-6)
    np.savez(tmp_path / "s.npz", t=stack)
    assert read_scene(str(tmp_path / "s.npz"), dt=1e-6, dx=2e-6, units="K").n_frames == 5
    (tmp_path / "exr").mkdir()
    for k in range(2):
        write_exr(tmp_path / "exr" / f"f{k}.exr", stack[k], temperature_unit="K", dt_s=1e-6,
                  dx_m=2e-6)
    scene = read_scene(tmp_path / "exr")
    assert isinstance(scene, ExrSequence) and scene.n_frames == 2
    assert isinstance(read_scene(str(tmp_path / "exr" / "f*.exr")), ExrSequence)
    scene = read_scene(_nodes_csv(tmp_path / "n.csv"), dx=1e-6)
    assert isinstance(scene, FeaNodes) and scene.dt == 1e-6  # the file's step, 1 µs
    # no header: the units as keywords; fill (20 °C by default) applies outside the mesh
    bare = _nodes_csv(tmp_path / "bare.csv", header=None)
    scene = read_scene(bare, dx=1e-6, units="C", time_unit="us", length_unit="um",
                       fill=250.0)
    assert scene.dt == 1e-6 and scene.fill == 250.0
    assert read_scene(bare, dx=1e-6, units="C", time_unit="us", length_unit="um").fill == 293.15


@pytest.mark.parametrize("name,kwargs,reason,keywords", [
    ("s.npy", {"dx": 1e-6}, "missing", ("dt", "units")),
    ("s.npy", {"dt": 1e-6, "dx": 1e-6}, "missing", ("units",)),
    ("s.npy", {"dt": 1e-6, "dx": 1e-6, "units": "K", "fill": 300.0}, "not-taken", ("fill",)),
    ("s.npy", {"dt": 1e-6, "dx": 1e-6, "units": "K", "time_unit": "us", "length_unit": "mm"},
     "not-taken", ("time_unit", "length_unit")),
    ("exr", {"length_unit": "mm"}, "not-taken", ("length_unit",)),
    ("case.vtu", {"dx": 1e-6}, "mesh", ()),
    ("n.csv", {}, "missing", ("dx",)),
    ("bare.csv", {"dx": 1e-6}, "units", ("time_unit", "length_unit", "units")),
])
def test_read_scene_refusals_name_the_keywords(tmp_path, stack, name, kwargs, reason,
                                               keywords):
    from radiosim.io import SceneArgumentError, read_scene

    np.save(tmp_path / "s.npy", stack)
    (tmp_path / "exr").mkdir()
    (tmp_path / "case.vtu").write_text("")
    _nodes_csv(tmp_path / "n.csv")
    _nodes_csv(tmp_path / "bare.csv", header=None)
    with pytest.raises(SceneArgumentError) as info:
        read_scene(tmp_path / name, **kwargs)
    error = info.value
    assert (error.reason, error.keywords, error.path) == (reason, keywords, tmp_path / name)
    assert str(tmp_path / name) in str(error) and "\n" not in str(error)
    assert all(k in str(error) for k in keywords)
    assert "--" not in str(error)  # the library names keywords, not the command's options
    if reason == "mesh":
        assert "read_fea_mesh" in str(error)


def test_read_scene_of_a_missing_file(tmp_path):
    from radiosim.io import SceneArgumentError, read_scene

    with pytest.raises(RadiosimError, match="does not exist") as info:
        read_scene(tmp_path / "gone.npy", dt=1e-6, dx=1e-6, units="K")
    assert not isinstance(info.value, SceneArgumentError)
    with pytest.raises(RadiosimError, match="no frames found"):  # a glob: the reader says
        read_scene(str(tmp_path / "*.exr"))


# -- EXR frame sequences: headers checked against each other and against the user ------------------


def write_frames(folder, headers, names=None, shape=(8, 8)):
    """EXR frames (one per header) holding 500 + k [header unit]."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    names = names or [f"frame_{k}.exr" for k in range(len(headers))]
    for k, (name, attributes) in enumerate(zip(names, headers)):
        header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage,
                  **attributes}
        OpenEXR.File(header, {"temperature": np.full(shape, 500.0 + k, np.float32)}).write(
            str(folder / name))
    return folder


GOOD = dict(dt_s=double(1e-6), dx_m=double(1e-6), temperature_unit="K")


@pytest.mark.parametrize("key, second, first_value, second_value", [
    ("temperature unit", {"temperature_unit": "C"}, "'K'", "'C'"),
    ("dt_s", {"dt_s": double(2e-6)}, "1e-06", "2e-06"),
    ("dx_m", {"dx_m": double(0.5e-6)}, "1e-06", "5e-07"),
])
def test_exr_headers_that_disagree_across_frames_are_refused(tmp_path, key, second,
                                                             first_value, second_value):
    folder = write_frames(tmp_path / "run", [GOOD, {**GOOD, **second}, GOOD])
    with pytest.raises(RadiosimError) as info:
        read_frames(folder)
    one_line_naming(info, "frame_0.exr", "frame_1.exr", key, first_value, second_value)


def test_exr_a_missing_frame_number_is_refused(tmp_path):
    folder = write_frames(tmp_path / "run", [GOOD] * 3,
                          ["frame_1.exr", "frame_2.exr", "frame_4.exr"])
    with pytest.raises(RadiosimError) as info:
        read_frames(folder)
    one_line_naming(info, "frame_2.exr", "frame_4.exr", "frame number 3 is missing")


def test_exr_a_duplicate_frame_number_is_refused(tmp_path):
    folder = write_frames(tmp_path / "run", [GOOD] * 3,
                          ["frame_0.exr", "frame_1.exr", "frame_01.exr"])
    with pytest.raises(RadiosimError) as info:
        read_frames(str(folder / "frame_*.exr"))
    one_line_naming(info, "frame_1.exr", "frame_01.exr", "frame number 1")


def test_exr_frames_numbered_in_even_steps_are_read(tmp_path):
    """Every tenth frame written (0, 10, 20): an even numbering, nothing missing."""
    folder = write_frames(tmp_path / "run", [GOOD] * 3,
                          ["frame_0.exr", "frame_10.exr", "frame_20.exr"])
    scene = read_frames(folder)
    assert scene.n_frames == 3
    assert scene.frame(2)[0, 0] == 502.0  # the order is by number: frame_20 is the last


@pytest.mark.parametrize("given, key, mine, theirs", [
    (dict(units="C"), "temperature_unit", "'C'", "'K'"),
    (dict(dt=2e-6), "dt_s", "2e-06", "1e-06"),
    (dict(dx=3e-6), "dx_m", "3e-06", "1e-06"),
])
def test_exr_a_user_value_that_contradicts_the_headers_is_refused(tmp_path, given, key, mine,
                                                                  theirs):
    folder = write_frames(tmp_path / "run", [GOOD] * 2)
    with pytest.raises(RadiosimError) as info:
        read_frames(folder, **given)
    one_line_naming(info, "frame_0.exr", key, mine, theirs)


def test_exr_user_values_that_agree_with_the_headers_are_accepted(tmp_path):
    folder = write_frames(tmp_path / "run", [{**GOOD, "temperature_unit": "celsius"}] * 2)
    scene = read_frames(folder, units="C", dt=1e-6, dx=1e-6)
    assert scene.units == "C" and scene.dt == 1e-6
    assert scene.frame(1)[0, 0] == pytest.approx(501.0 + 273.15)


def test_exr_two_unit_attributes_that_disagree_are_refused(tmp_path):
    folder = write_frames(tmp_path / "run", [{**GOOD, "units": "C"}] * 2)
    with pytest.raises(RadiosimError) as info:
        read_frames(folder)
    one_line_naming(info, "frame_0.exr", "temperature_unit", "units", "'K'", "'C'")


def test_exr_a_32_bit_header_value_agrees_with_the_same_given_value(tmp_path):
    """A plain float attribute is stored in 32 bits (1e-6 becomes 9.99999997e-07): the same
    value given on the command line agrees with it."""
    folder = write_frames(tmp_path / "run", [dict(dt_s=1e-6, dx_m=0.5e-6,
                                                  temperature_unit="K")] * 2)
    scene = read_frames(folder, dt=1e-6, dx=0.5e-6, units="K")
    assert scene.dt == 1e-6 and scene.dx == 0.5e-6


@pytest.mark.usefixtures("in_tmp")
@pytest.mark.parametrize("given", [
    pytest.param({}, id="both-doubles"),
    pytest.param({"dx": 0.5e-6}, id="dt_s-double"),
    pytest.param({"dt": 0.2e-6}, id="dx_m-double"),
])
def test_exr_frames_with_double_attributes_are_read(tmp_path, given):
    write_exr_frames(tmp_path / "folder", n=3, dt_s=double(0.2e-6), dx_m=double(0.5e-6),
                     temperature_unit="C")
    scene = read_frames(str(tmp_path / "folder" / "frame_*.exr"), **given)
    assert scene.dt == 0.2e-6 and scene.dx == 0.5e-6
    assert scene.n_frames == 3 and scene.shape == (12, 12)
    assert scene.frame(2)[0, 0] == pytest.approx(502.0 + 273.15)


@pytest.mark.usefixtures("in_tmp")
def test_exr_frames_with_float_attributes_are_read(tmp_path):
    write_exr_frames(tmp_path / "folder", n=3, dt_s=1e-6, dx_m=1e-6, units="K")
    scene = read_frames(tmp_path / "folder")
    assert scene.dt == pytest.approx(1e-6) and scene.dx == pytest.approx(1e-6)
    consume(scene)


@pytest.mark.usefixtures("in_tmp")
@pytest.mark.parametrize("channel", ["temperature", "T", "Y"])
def test_exr_frames_in_any_temperature_channel_are_read(tmp_path, channel):
    write_exr_frames(tmp_path / "folder", n=2, channel=channel, dt_s=1e-6, dx_m=1e-6,
                     temperature_unit="K")
    assert read_frames(tmp_path / "folder").frame(1)[0, 0] == 501.0


@pytest.mark.usefixtures("in_tmp")
def test_exr_frames_are_ordered_by_the_numbers_in_their_names(tmp_path):
    write_exr_frames(tmp_path / "folder", n=11, dt_s=1e-6, dx_m=1e-6, temperature_unit="K")
    scene = read_frames(str(tmp_path / "folder" / "frame_*.exr"))
    assert [scene.frame(k)[0, 0] for k in (2, 9, 10)] == [502.0, 509.0, 510.0]


@pytest.mark.usefixtures("in_tmp")
@pytest.mark.parametrize("missing, flag", [("dx_m", "--dx"), ("dt_s", "--dt")])
def test_exr_missing_grid_attribute_names_attribute_file_and_flag(tmp_path, missing, flag):
    attributes = {"dt_s": 1e-6, "dx_m": 1e-6, "temperature_unit": "K"}
    del attributes[missing]
    write_exr_frames(tmp_path / "folder", n=2, **attributes)
    with pytest.raises(RadiosimError) as info:
        read_frames(str(tmp_path / "folder" / "frame_*.exr"))
    api_error(info, missing, "frame_0.exr", flag)


# -- NumPy stacks: folders, time units, truncation, dtypes, unit spellings -------------------------


def test_read_frames_on_a_folder_named_npy_says_it_is_a_folder(tmp_path):
    (tmp_path / "x.npy").mkdir()
    with pytest.raises(RadiosimError, match=r"x\.npy is a folder, not a \.npy file"):
        read_frames(tmp_path / "x.npy", dt=1e-6, dx=1e-6, units="K")


@pytest.mark.parametrize("kind", ["npy", "exr"])
def test_a_time_unit_for_a_format_without_a_time_axis_is_refused(tmp_path, kind):
    if kind == "npy":
        np.save(tmp_path / "s.npy", np.full((3, 4, 4), 500.0))
        path, kwargs = tmp_path / "s.npy", dict(dt=1e-6, dx=1e-6, units="K")
    else:
        path, kwargs = write_frames(tmp_path / "run", [GOOD] * 2), {}
    with pytest.raises(RadiosimError) as info:
        read_frames(path, time_unit="us", **kwargs)
    one_line_naming(info, str(path), "--time-unit us", "--dt")


def test_a_npy_shorter_than_its_header_says_is_refused_at_open(tmp_path):
    np.save(tmp_path / "s.npy", np.full((4, 6, 6), 500.0))
    whole = (tmp_path / "s.npy").read_bytes()
    (tmp_path / "s.npy").write_bytes(whole[:-100])
    with pytest.raises(RadiosimError) as info:
        read_frames(tmp_path / "s.npy", dt=1e-6, dx=1e-6, units="K")
    one_line_naming(info, "s.npy", f"{len(whole)} bytes", f"{len(whole) - 100} bytes")


def test_a_npy_cut_short_during_a_run_is_one_line_not_sigbus(tmp_path):
    np.save(tmp_path / "s.npy", np.full((20, 16, 16), 500.0))
    scene = read_frames(tmp_path / "s.npy", dt=1e-6, dx=1e-6, units="K")
    scene.frame(0)
    os.truncate(tmp_path / "s.npy", 16 * 16 * 8 * 4)
    with pytest.raises(RadiosimIOError) as info:
        Camera.linear_ideal(4e-6).measure(scene, 15e-6, t_start=0.0)
    one_line_naming(info, "s.npy", "cut short", f"{16 * 16 * 8 * 4} bytes")


@pytest.mark.usefixtures("in_tmp")
@pytest.mark.parametrize("dtype", ["float32", "int16", "uint16", ">f8"])
def test_numeric_npy_dtypes_are_read(tmp_path, dtype):
    np.save(tmp_path / "s.npy", np.full((4, 6, 6), 500, dtype=dtype))
    assert read_frames(tmp_path / "s.npy", dt=1e-6, dx=1e-6, units="K").frame(3)[0, 0] == 500.0


@pytest.mark.usefixtures("in_tmp")
@pytest.mark.parametrize("unit, kelvin", [("K", 500.0), ("kelvin", 500.0), ("C", 773.15),
                                          ("celsius", 773.15), ("°C", 773.15)])
def test_temperature_unit_spellings_are_read(tmp_path, unit, kelvin):
    np.save(tmp_path / "s.npy", np.full((4, 6, 6), 500.0))
    frame = read_frames(tmp_path / "s.npy", dt=1e-6, dx=1e-6, units=unit).frame(0)
    assert frame[0, 0] == pytest.approx(kelvin)


@pytest.mark.usefixtures("in_tmp")
def test_compressed_npz_warns_in_one_line(tmp_path):
    np.savez_compressed(tmp_path / "c.npz", a=np.full((6, 12, 12), 500.0))
    with pytest.warns(RadiosimWarning) as record:
        scene = read_frames(tmp_path / "c.npz", dt=1e-6, dx=1e-6, units="K")
    ours = [w for w in record if issubclass(w.category, RadiosimWarning)]
    assert len(ours) == 1
    message = str(ours[0].message)
    assert "\n" not in message and "c.npz" in message and "compressed" in message
    consume(scene)


@pytest.mark.usefixtures("in_tmp")
def test_timedelta_stack_is_refused(tmp_path):
    values = np.full((3, 6, 6), 500, dtype="timedelta64[s]")
    with pytest.raises(RadiosimError) as info:
        consume(FrameStack(values, dt=1e-6, dx=1e-6))
    api_error(info, "timedelta64")
    np.save(tmp_path / "s.npy", values)
    with pytest.raises(RadiosimError) as info:
        consume(read_frames(tmp_path / "s.npy", dt=1e-6, dx=1e-6, units="K"))
    api_error(info, "timedelta64")


# -- the readers under random input (hypothesis) ---------------------------------------------------
# A RadiosimError or a correct read, never another exception.


def valid_npy_bytes() -> bytes:
    buffer = io.BytesIO()
    np.save(buffer, np.full((4, 6, 6), 500.0))
    return buffer.getvalue()


def valid_exr_bytes() -> bytes:
    with tempfile.TemporaryDirectory() as folder:
        path = write_exr_frames(folder, n=1, dt_s=1e-6, dx_m=1e-6,
                                temperature_unit="K") / "frame_0.exr"
        return path.read_bytes()


def _read_npy_or_error(data: bytes):
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "s.npy"
        path.write_bytes(data)
        try:
            consume(read_frames(path, dt=1e-6, dx=1e-6, units="K"))
        except RadiosimError:
            pass


def _read_exr_or_error(data: bytes):
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "frames" / "frame_0.exr"
        path.parent.mkdir()
        path.write_bytes(data)
        try:
            consume(read_frames(path.parent))
        except RadiosimError:
            pass
        try:
            read_exr(path)
        except RadiosimError:
            pass


@pytest.mark.usefixtures("in_tmp")
@BOUNDED
@given(data=st.binary(max_size=512), magic=st.booleans())
def test_random_bytes_as_npy(data, magic):
    _read_npy_or_error((b"\x93NUMPY" if magic else b"") + data)


@pytest.mark.usefixtures("in_tmp")
@BOUNDED
@given(data=st.binary(max_size=512))
def test_random_bytes_as_exr(data):
    _read_exr_or_error(data)


VALID_NPY = valid_npy_bytes()


VALID_EXR = valid_exr_bytes()


@pytest.mark.usefixtures("in_tmp")
@BOUNDED
@given(cut=st.integers(0, len(VALID_NPY) - 1))
def test_truncated_npy(cut):
    _read_npy_or_error(VALID_NPY[:cut])


@pytest.mark.usefixtures("in_tmp")
@BOUNDED
@given(cut=st.integers(0, len(VALID_EXR) - 1))
def test_truncated_exr(cut):
    _read_exr_or_error(VALID_EXR[:cut])


WRONG_DTYPES = ["complex64", "complex128", "object", "U5", "S5", "bool", "datetime64[s]"]


@pytest.mark.usefixtures("in_tmp")
@BOUNDED
@given(dtype=st.sampled_from(WRONG_DTYPES),
       shape=st.tuples(st.integers(1, 4), st.integers(1, 6), st.integers(1, 6)))
def test_wrong_dtypes_in_npy_and_framestack(dtype, shape):
    values = np.ones(shape).astype(dtype) if dtype != "object" else np.full(shape, None)
    with pytest.raises(RadiosimError) as info:
        consume(FrameStack(values, dt=1e-6, dx=1e-6))
    message = without_paths(str(info.value))
    assert "object" in message.lower() or np.dtype(dtype).name in message \
        or str(np.dtype(dtype)) in message, message
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "s.npy"
        np.save(path, values, allow_pickle=True)
        with pytest.raises(RadiosimError) as info:
            consume(read_frames(path, dt=1e-6, dx=1e-6, units="K"))
        message = without_paths(str(info.value))
        assert "object" in message.lower() or np.dtype(dtype).name in message \
            or str(np.dtype(dtype)) in message, message
