"""Issue 20, readers: every reader checks what it reads against itself and against what the
user said (contradictions are one-line errors naming the file, the key and both values), the
FEA readers keep the file's own time origin, and valid input the readers used to refuse is
read. Expected values are closed forms, independent of the code under test."""

import os
from pathlib import Path

import meshio
import numpy as np
import OpenEXR
import pytest
from scipy.spatial import Delaunay

from radiosim import Camera, FrameStack
from radiosim.errors import RadiosimError, RadiosimIOError
from radiosim.io import read_fea_mesh, read_fea_nodes, read_frames


def one_line(info, *names):
    """The error is one line and names every one of ``names``."""
    text = str(info.value)
    assert "\n" not in text, text
    for name in names:
        assert str(name) in text, (name, text)
    return text


# -- EXR sequences -------------------------------------------------------------------------------


def double(value):
    return np.array([value], dtype=np.float64)


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
    one_line(info, "frame_0.exr", "frame_1.exr", key, first_value, second_value)


def test_exr_a_missing_frame_number_is_refused(tmp_path):
    folder = write_frames(tmp_path / "run", [GOOD] * 3,
                          ["frame_1.exr", "frame_2.exr", "frame_4.exr"])
    with pytest.raises(RadiosimError) as info:
        read_frames(folder)
    one_line(info, "frame_2.exr", "frame_4.exr", "frame number 3 is missing")


def test_exr_a_duplicate_frame_number_is_refused(tmp_path):
    folder = write_frames(tmp_path / "run", [GOOD] * 3,
                          ["frame_0.exr", "frame_1.exr", "frame_01.exr"])
    with pytest.raises(RadiosimError) as info:
        read_frames(str(folder / "frame_*.exr"))
    one_line(info, "frame_1.exr", "frame_01.exr", "frame number 1")


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
    one_line(info, "frame_0.exr", key, mine, theirs)


def test_exr_user_values_that_agree_with_the_headers_are_accepted(tmp_path):
    folder = write_frames(tmp_path / "run", [{**GOOD, "temperature_unit": "celsius"}] * 2)
    scene = read_frames(folder, units="C", dt=1e-6, dx=1e-6)
    assert scene.units == "C" and scene.dt == 1e-6
    assert scene.frame(1)[0, 0] == pytest.approx(501.0 + 273.15)


def test_exr_two_unit_attributes_that_disagree_are_refused(tmp_path):
    folder = write_frames(tmp_path / "run", [{**GOOD, "units": "C"}] * 2)
    with pytest.raises(RadiosimError) as info:
        read_frames(folder)
    one_line(info, "frame_0.exr", "temperature_unit", "units", "'K'", "'C'")


# -- FEA nodal CSV: contradictions, duplicates, BOM, NaN --------------------------------------


def rows(times=(0, 1, 2), value=lambda t: 500.0 + t, n=6, pitch=2.0):
    return "".join(f"{t},{x * pitch:g},{y * pitch:g},{value(t):.12g}\n"
                   for t in times for x in range(n) for y in range(n))


UNITS = "# units: time=us, length=um, temperature=C\n"


def write_csv(tmp_path, text, name="nodes.csv", encoding="utf-8"):
    path = tmp_path / name
    path.write_text(text, encoding=encoding)
    return path


def test_fea_a_column_suffix_that_contradicts_the_units_line_is_refused(tmp_path):
    path = write_csv(tmp_path, UNITS + "time,x,y,temperature_K\n" + rows())
    with pytest.raises(RadiosimError) as info:
        read_fea_nodes(path, dx=1e-6)
    one_line(info, "nodes.csv", "temperature_K", "temperature=C", "in K")


@pytest.mark.parametrize("given, key, mine, theirs", [
    ({"temperature": "K"}, "temperature", "K", "temperature=C"),
    ({"time": "ms"}, "time", "ms", "time=us"),
    ({"length": "mm"}, "length", "mm", "length=um"),
])
def test_fea_user_units_that_contradict_the_file_are_refused(tmp_path, given, key, mine,
                                                             theirs):
    path = write_csv(tmp_path, UNITS + "time,x,y,temperature\n" + rows())
    with pytest.raises(RadiosimError) as info:
        read_fea_nodes(path, dx=1e-6, units=given)
    one_line(info, "nodes.csv", f"{key} unit {mine}", theirs)


def test_fea_user_units_that_agree_with_the_file_are_accepted(tmp_path):
    path = write_csv(tmp_path, UNITS + "time,x,y,temperature\n" + rows())
    scene = read_fea_nodes(path, dx=1e-6, units={"time": "µs", "length": "um",
                                                 "temperature": "C"})
    assert scene.dt == pytest.approx(1e-6)
    assert scene.frame(1)[3, 3] == pytest.approx(501.0 + 273.15)


def test_fea_a_suffix_that_contradicts_a_user_unit_is_refused(tmp_path):
    path = write_csv(tmp_path, "time_us,x_um,y_um,temperature_C\n" + rows())
    with pytest.raises(RadiosimError) as info:
        read_fea_nodes(path, dx=1e-6, units={"temperature": "K"})
    one_line(info, "nodes.csv", "temperature unit K", "temperature=C")


@pytest.mark.parametrize("header, both", [
    ("time,x,y,temperature,temperature", ("'temperature'", "columns 4", "5")),
    ("time,x,x_um,y,temperature", ("'x'", "'x_um'", "both read as x")),
    ("time,t,y,x,temperature,time_us", ("'time'", "'time_us'", "both read as time")),
])
def test_fea_two_columns_for_one_quantity_are_refused(tmp_path, header, both):
    extra = len(header.split(",")) - 4
    body = "".join(line + ",1" * extra + "\n" for line in rows().splitlines())
    path = write_csv(tmp_path, UNITS + header + "\n" + body)
    with pytest.raises(RadiosimError) as info:
        read_fea_nodes(path, dx=1e-6)
    one_line(info, "nodes.csv", "line 2", *both)


def test_fea_a_mapped_column_name_that_appears_twice_is_refused(tmp_path):
    body = "".join(line + ",1\n" for line in rows().splitlines())
    path = write_csv(tmp_path, UNITS + "time,x,y,NT11,NT11\n" + body)
    with pytest.raises(RadiosimError) as info:
        read_fea_nodes(path, dx=1e-6, columns={"temperature": "NT11"})
    one_line(info, "nodes.csv", "'NT11'", "columns 4 and 5")


def test_fea_two_units_lines_that_disagree_are_refused(tmp_path):
    path = write_csv(tmp_path, UNITS + "# units: temperature=K\ntime,x,y,temperature\n" + rows())
    with pytest.raises(RadiosimError) as info:
        read_fea_nodes(path, dx=1e-6)
    one_line(info, "nodes.csv", "line 2", "temperature=K", "temperature=C")


@pytest.mark.parametrize("text", [UNITS + "time,x,y,temperature\n" + rows(),
                                  "time_us,x_um,y_um,temperature_C\n" + rows()])
def test_fea_a_file_with_a_byte_order_mark_is_read(tmp_path, text):
    path = write_csv(tmp_path, text, encoding="utf-8-sig")
    assert path.read_bytes()[:3] == b"\xef\xbb\xbf"
    scene = read_fea_nodes(path, dx=1e-6)
    assert scene.n_frames == 3
    assert scene.frame(2)[3, 3] == pytest.approx(502.0 + 273.15)


@pytest.mark.parametrize("column, bad", [(1, "nan"), (2, "inf"), (0, "nan"), (0, "-inf")])
def test_fea_nan_or_infinite_coordinates_or_times_name_the_line(tmp_path, column, bad):
    lines = rows().splitlines()
    fields = lines[7].split(",")
    fields[column] = bad
    lines[7] = ",".join(fields)
    path = write_csv(tmp_path, UNITS + "time,x,y,temperature\n" + "\n".join(lines) + "\n")
    with pytest.raises(RadiosimError) as info:
        read_fea_nodes(path, dx=1e-6)
    one_line(info, "nodes.csv", "line 10", ("time", "x", "y")[column], repr(bad))


# -- FEA meshes: vector fields, NaN nodes and times, unit contradictions ----------------------


def mesh_files(folder, times, values=None, point_data=None, points=None):
    g = np.arange(0.0, 10.0 + 1e-9, 2.0)
    x, y = np.meshgrid(g, g)
    xy = np.column_stack([x.ravel(), y.ravel()]) if points is None else points
    triangles = Delaunay(np.column_stack([x.ravel(), y.ravel()])).simplices
    files = []
    for k, t in enumerate(times):
        data = point_data(k) if point_data else {
            "temperature": np.full(len(xy), values(t) if values else 500.0)}
        path = Path(folder) / f"step_{k}.vtu"
        meshio.write(path, meshio.Mesh(np.column_stack([xy, np.zeros(len(xy))]),
                                       [("triangle", triangles)], point_data=data))
        files.append(path)
    return files


def test_mesh_a_vector_field_as_temperature_is_refused(tmp_path):
    files = mesh_files(tmp_path, [0.0, 1.0],
                       point_data=lambda k: {"temperature": np.full((36, 3), 500.0)})
    with pytest.raises(RadiosimError) as info:
        read_fea_mesh(files, dx=1e-6, times=[0.0, 1e-6],
                      units={"length": "um", "temperature": "K"})
    one_line(info, "'temperature'", "(36, 3)", "3 components")


def test_mesh_nan_coordinates_are_refused(tmp_path):
    g = np.arange(0.0, 10.0 + 1e-9, 2.0)
    x, y = np.meshgrid(g, g)
    points = np.column_stack([x.ravel(), y.ravel()])
    points[7, 0] = np.nan
    files = mesh_files(tmp_path, [0.0, 1.0], points=points)
    with pytest.raises(RadiosimError) as info:
        read_fea_mesh(files, dx=1e-6, times=[0.0, 1e-6],
                      units={"length": "um", "temperature": "K"})
    one_line(info, "step 0", "node 7", "nan")


def test_mesh_a_nan_time_is_refused(tmp_path):
    files = mesh_files(tmp_path, [0.0, 1.0])
    with pytest.raises(RadiosimError) as info:
        read_fea_mesh(files, dx=1e-6, times=[0.0, float("nan")],
                      units={"length": "um", "temperature": "K"})
    one_line(info, "step 1", "nan")


def test_mesh_a_unit_that_contradicts_the_fields_name_is_refused(tmp_path):
    files = mesh_files(tmp_path, [0.0, 1.0],
                       point_data=lambda k: {"temperature_C": np.full(36, 500.0)})
    with pytest.raises(RadiosimError) as info:
        read_fea_mesh(files, dx=1e-6, times=[0.0, 1e-6], field="temperature_C",
                      units={"length": "um", "temperature": "K"})
    one_line(info, "temperature=K", "'temperature_C'", "in C")


# -- FEA time origin and interpolation ---------------------------------------------------------


def ramp(t_us):
    """A field linear in time: 300 K + 100 K/µs · t, the same at every node [K]."""
    return 300.0 + 100.0 * t_us


K_UNITS = "# units: time=us, length=um, temperature=K\n"


def ramp_csv(tmp_path, times):
    return write_csv(tmp_path, K_UNITS + "time,x,y,temperature\n" + rows(times, ramp))


def test_fea_a_file_starting_at_5us_is_measured_in_its_own_time(tmp_path):
    """Times 5, 6, 7 µs: the window [5, 6) µs is the first snapshot, 800 K, exactly."""
    scene = read_fea_nodes(ramp_csv(tmp_path, (5, 6, 7)), dx=1e-6)
    assert scene.t0 == pytest.approx(5e-6) and scene.first_frame == 5
    assert scene.n_frames == 8 and scene.describe()["t0_s"] == pytest.approx(5e-6)
    m = Camera.linear_ideal(2e-6).measure(scene, 1e-6, t_start=5e-6)
    np.testing.assert_allclose(m.apparent_temperature, ramp(5.0), rtol=1e-12)
    assert m.t_start == 5e-6 and m.scene["t0_s"] == pytest.approx(5e-6)
    m = Camera.linear_ideal(2e-6).measure(scene, 1e-6, t_start=7e-6)
    np.testing.assert_allclose(m.apparent_temperature, ramp(7.0), rtol=1e-12)


def test_fea_a_window_before_the_first_time_stamp_is_refused(tmp_path):
    scene = read_fea_nodes(ramp_csv(tmp_path, (5, 6, 7)), dx=1e-6)
    with pytest.raises(RadiosimError) as info:
        Camera.linear_ideal(2e-6).measure(scene, 1e-6, t_start=4e-6)
    one_line(info, "nodes.csv", "first time stamp 5 µs", "frame 4 covers 4–5 µs")
    # No start given: the window starts at the data's first time stamp (the file's own time),
    # not at t = 0 before it, and reads the first snapshot.
    m = Camera.linear_ideal(2e-6).measure(scene, 1e-6)
    assert m.t_start == pytest.approx(5e-6, rel=1e-12)
    np.testing.assert_allclose(m.apparent_temperature, ramp(5.0), rtol=1e-12)


def test_fea_hold_reproduces_the_previous_snapshot(tmp_path):
    scene = read_fea_nodes(ramp_csv(tmp_path, (5, 6, 7)), dx=1e-6)
    assert scene.interpolation == "hold"
    for k, t in ((5, 5.0), (6, 6.0), (7, 7.0)):
        np.testing.assert_allclose(scene.frame(k), ramp(t), rtol=1e-12)
    # A 0.5 µs window inside [6, 7) µs reads the 6 µs snapshot, not the mid-time value.
    m = Camera.linear_ideal(2e-6).measure(scene, 0.5e-6, t_start=6.25e-6)
    np.testing.assert_allclose(m.apparent_temperature, ramp(6.0), rtol=1e-12)


def test_fea_linear_interpolation_reproduces_the_field_at_mid_times(tmp_path):
    """Frames of 0.25 µs between snapshots 1 µs apart: each is the ramp at its mid-time."""
    scene = read_fea_nodes(ramp_csv(tmp_path, (5, 6, 7)), dx=1e-6, dt=0.25e-6,
                           interpolation="linear")
    assert scene.first_frame == 20 and scene.n_frames == 28  # 5 µs to 7 µs
    for k in range(20, 28):
        np.testing.assert_allclose(scene.frame(k), ramp((k + 0.5) * 0.25), rtol=1e-12)


def test_fea_linear_interpolation_gives_the_exact_window_average(tmp_path):
    """The average of a linear ramp over [5.5, 6.5] µs is its value at 6 µs; over [5, 7] µs
    its value at 6 µs too; hold gives (800 + 900)/2 over [5.5, 6.5] µs."""
    path = ramp_csv(tmp_path, (5, 6, 7))
    linear = read_fea_nodes(path, dx=1e-6, dt=0.5e-6, interpolation="linear")
    camera = Camera.linear_ideal(2e-6)
    for start, duration in ((5.5e-6, 1e-6), (5e-6, 2e-6)):
        m = camera.measure(linear, duration, t_start=start)
        np.testing.assert_allclose(m.apparent_temperature, ramp(6.0), rtol=1e-12)
    hold = read_fea_nodes(path, dx=1e-6)
    m = camera.measure(hold, 1e-6, t_start=5.5e-6)
    np.testing.assert_allclose(m.apparent_temperature, (ramp(5.0) + ramp(6.0)) / 2, rtol=1e-12)


def test_fea_hold_with_an_origin_between_frame_edges_averages_the_held_field(tmp_path):
    """Snapshots at 0.5, 1.5, 2.5 µs, frames of 1 µs on the file's time: frame 1 ([1, 2) µs)
    holds the 0.5 µs snapshot for half of it and the 1.5 µs one for the other half."""
    scene = read_fea_nodes(ramp_csv(tmp_path, (0.5, 1.5, 2.5)), dx=1e-6)
    assert scene.first_frame == 1 and scene.n_frames == 3
    np.testing.assert_allclose(scene.frame(1), (ramp(0.5) + ramp(1.5)) / 2, rtol=1e-12)
    with pytest.raises(RadiosimError, match="before .*first time stamp 0.5 µs"):
        scene.frame(0)


@pytest.mark.parametrize("call, name", [
    (lambda p: read_fea_nodes(p, dx=1e-6, interpolation="cubic"), "'cubic'"),
    (lambda p: read_fea_nodes(p, dx=1e-6, dt=0.5e-6), "does not match"),
])
def test_fea_bad_interpolation_or_a_finer_hold_is_refused(tmp_path, call, name):
    with pytest.raises(RadiosimError) as info:
        call(ramp_csv(tmp_path, (0, 1, 2)))
    one_line(info, "nodes.csv", name)


def test_mesh_keeps_its_origin_and_interpolates_linearly(tmp_path):
    files = mesh_files(tmp_path, [5.0, 6.0, 7.0], values=ramp)
    scene = read_fea_mesh(files, dx=1e-6, times=[5e-6, 6e-6, 7e-6],
                          units={"length": "um", "temperature": "K"}, interpolation="linear",
                          dt=0.5e-6)
    assert scene.t0 == pytest.approx(5e-6) and scene.first_frame == 10
    np.testing.assert_allclose(scene.frame(11), ramp(5.75), rtol=1e-12)
    m = Camera.linear_ideal(2e-6).measure(scene, 1e-6, t_start=5.5e-6)
    np.testing.assert_allclose(m.apparent_temperature, ramp(6.0), rtol=1e-12)


# -- FrameStack and from_xarray ------------------------------------------------------------------


def test_framestack_ragged_lists_name_the_shapes():
    with pytest.raises(RadiosimError) as info:
        FrameStack([[[500.0, 500.0], [500.0]]], dt=1e-6, dx=1e-6)
    one_line(info, "temperature[0][0] has 2 values", "temperature[0][1] has 1 values")
    with pytest.raises(RadiosimError) as info:
        FrameStack([[[500.0, 500.0]], [[500.0, 500.0], [500.0, 500.0]]], dt=1e-6, dx=1e-6)
    one_line(info, "temperature[0] has 1 values", "temperature[1] has 2 values")


@pytest.mark.parametrize("emissivity", [True, False, np.bool_(True)])
def test_framestack_a_bool_emissivity_is_refused(emissivity):
    with pytest.raises(RadiosimError) as info:
        FrameStack(np.full((2, 4, 4), 500.0), dt=1e-6, dx=1e-6, emissivity=emissivity)
    one_line(info, "emissivity", repr(emissivity), "bool")


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
    one_line(info, "'T'", *names)


def test_from_xarray_refuses_a_dt_that_contradicts_the_coordinate():
    import xarray as xr

    variable = xr.DataArray(_cube(), dims=("time", "y", "x"), name="T",
                            coords={"time": np.arange(4) * 1e-6, "x": np.arange(6) * 1e-6})
    with pytest.raises(RadiosimError) as info:
        FrameStack.from_xarray(variable, dt=2e-6)
    one_line(info, "'T'", "dt=2e-06", "1e-06")


# -- NumPy stacks: time units, truncation --------------------------------------------------------


@pytest.mark.parametrize("kind", ["npy", "exr"])
def test_a_time_unit_for_a_format_without_a_time_axis_is_refused(tmp_path, kind):
    if kind == "npy":
        np.save(tmp_path / "s.npy", np.full((3, 4, 4), 500.0))
        path, kwargs = tmp_path / "s.npy", dict(dt=1e-6, dx=1e-6, units="K")
    else:
        path, kwargs = write_frames(tmp_path / "run", [GOOD] * 2), {}
    with pytest.raises(RadiosimError) as info:
        read_frames(path, time_unit="us", **kwargs)
    one_line(info, str(path), "--time-unit us", "--dt")


def test_a_npy_shorter_than_its_header_says_is_refused_at_open(tmp_path):
    np.save(tmp_path / "s.npy", np.full((4, 6, 6), 500.0))
    whole = (tmp_path / "s.npy").read_bytes()
    (tmp_path / "s.npy").write_bytes(whole[:-100])
    with pytest.raises(RadiosimError) as info:
        read_frames(tmp_path / "s.npy", dt=1e-6, dx=1e-6, units="K")
    one_line(info, "s.npy", f"{len(whole)} bytes", f"{len(whole) - 100} bytes")


def test_a_npy_cut_short_during_a_run_is_one_line_not_sigbus(tmp_path):
    np.save(tmp_path / "s.npy", np.full((20, 16, 16), 500.0))
    scene = read_frames(tmp_path / "s.npy", dt=1e-6, dx=1e-6, units="K")
    scene.frame(0)
    os.truncate(tmp_path / "s.npy", 16 * 16 * 8 * 4)
    with pytest.raises(RadiosimIOError) as info:
        Camera.linear_ideal(4e-6).measure(scene, 15e-6, t_start=0.0)
    one_line(info, "s.npy", "cut short", f"{16 * 16 * 8 * 4} bytes")


def test_exr_a_32_bit_header_value_agrees_with_the_same_given_value(tmp_path):
    """A plain float attribute is stored in 32 bits (1e-6 becomes 9.99999997e-07): the same
    value given on the command line agrees with it."""
    folder = write_frames(tmp_path / "run", [dict(dt_s=1e-6, dx_m=0.5e-6,
                                                  temperature_unit="K")] * 2)
    scene = read_frames(folder, dt=1e-6, dx=0.5e-6, units="K")
    assert scene.dt == 1e-6 and scene.dx == 0.5e-6


def test_a_written_exr_recording_with_a_file_removed_is_refused(tmp_path):
    from radiosim.io import read_exr_sequence, write_exr_sequence

    scene = FrameStack(np.full((4, 6, 6), 500.0), dt=1e-6, dx=1e-6)
    m = Camera.linear_ideal(3e-6).measure(scene, 1e-6, t_start=0.0)
    files = write_exr_sequence(tmp_path / "rec", [m, m, m, m])
    assert len(read_exr_sequence(tmp_path / "rec")) == 4
    files[2].unlink()
    with pytest.raises(RadiosimError) as info:
        read_exr_sequence(tmp_path / "rec")
    one_line(info, "frame_0003.exr", "frame number 2 is missing", "frame_0001.exr")


@pytest.mark.parametrize("mu", ["\u00b5", "\u03bc"])
def test_fea_units_with_either_micro_character_are_read(tmp_path, mu):
    """``µs`` (micro sign) and ``μs`` (Greek mu) are both microseconds."""
    path = write_csv(tmp_path, f"# units: time={mu}s, length={mu}m, temperature=C\n"
                     f"time,x [{mu}m],y,temperature\n" + rows())
    scene = read_fea_nodes(path, dx=1e-6, units={"time": f"{mu}s"})
    assert scene.dt == pytest.approx(1e-6) and scene.shape == (10, 10)
