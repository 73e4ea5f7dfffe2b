"""The FEA nodal reader (radiosim.io.fea.read_fea_nodes): contradictions between the file and
the user are one-line errors naming the file, the key and both values; valid variants are read;
the file's own time origin is kept; random input is a RadiosimError or a correct read. Expected
values are closed forms, independent of the code under test."""

import tempfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import example, given
from hypothesis import strategies as st

from conftest import (BOUNDED, FEA_HEADER, FEA_UNITS, api_error, conflicting_fea, consume,
                      fea_rows, fea_text, one_line_naming)
from radiosim import Camera
from radiosim.errors import RadiosimError
from radiosim.io import read_fea_nodes


# -- FEA nodal CSV: contradictions, duplicates, BOM, NaN -------------------------------------------


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
    one_line_naming(info, "nodes.csv", "temperature_K", "temperature=C", "in K")


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
    one_line_naming(info, "nodes.csv", f"{key} unit {mine}", theirs)


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
    one_line_naming(info, "nodes.csv", "temperature unit K", "temperature=C")


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
    one_line_naming(info, "nodes.csv", "line 2", *both)


def test_fea_a_mapped_column_name_that_appears_twice_is_refused(tmp_path):
    body = "".join(line + ",1\n" for line in rows().splitlines())
    path = write_csv(tmp_path, UNITS + "time,x,y,NT11,NT11\n" + body)
    with pytest.raises(RadiosimError) as info:
        read_fea_nodes(path, dx=1e-6, columns={"temperature": "NT11"})
    one_line_naming(info, "nodes.csv", "'NT11'", "columns 4 and 5")


def test_fea_two_units_lines_that_disagree_are_refused(tmp_path):
    path = write_csv(tmp_path, UNITS + "# units: temperature=K\ntime,x,y,temperature\n" + rows())
    with pytest.raises(RadiosimError) as info:
        read_fea_nodes(path, dx=1e-6)
    one_line_naming(info, "nodes.csv", "line 2", "temperature=K", "temperature=C")


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
    one_line_naming(info, "nodes.csv", "line 10", ("time", "x", "y")[column], repr(bad))


@pytest.mark.parametrize("mu", ["\u00b5", "\u03bc"])
def test_fea_units_with_either_micro_character_are_read(tmp_path, mu):
    """``µs`` (micro sign) and ``μs`` (Greek mu) are both microseconds."""
    path = write_csv(tmp_path, f"# units: time={mu}s, length={mu}m, temperature=C\n"
                     f"time,x [{mu}m],y,temperature\n" + rows())
    scene = read_fea_nodes(path, dx=1e-6, units={"time": f"{mu}s"})
    assert scene.dt == pytest.approx(1e-6) and scene.shape == (10, 10)


def assert_linear_fea_field(scene):
    """``fea_rows``' field, T = 500 °C + x/2 + y/2 + t [µm, µs], is linear in x and y, so
    linear interpolation over the mesh reproduces it exactly at every pixel centre
    (x = j + ½, y = 7½ − i µm on the 1 µm grid of the 8 µm × 8 µm mesh, row 0 on top)."""
    assert scene.n_frames == 3 and scene.dt == pytest.approx(1e-6, rel=1e-12)
    i, j = np.mgrid[0:8, 0:8]
    for t in range(3):
        expected = 273.15 + 500.0 + t + ((j + 0.5) + (7.5 - i)) / 2
        np.testing.assert_allclose(scene.frame(t), expected, rtol=0, atol=1e-9)


@pytest.mark.usefixtures("in_tmp")
def test_fea_csv_with_byte_order_mark_is_read(tmp_path):
    path = tmp_path / "excel.csv"
    path.write_text(fea_text(fea_rows()), encoding="utf-8-sig")
    assert_linear_fea_field(read_fea_nodes(path, dx=1e-6))


@pytest.mark.usefixtures("in_tmp")
@pytest.mark.parametrize("variant", ["crlf", "reordered-extra-column", "spaced-capitals"])
def test_fea_csv_variants_are_read(tmp_path, variant):
    rows = fea_rows()
    if variant == "crlf":
        text = fea_text(rows).replace("\n", "\r\n")
    elif variant == "reordered-extra-column":
        text = FEA_UNITS + "node,temperature,y,x,time\n" + "".join(
            f"{i},{T:g},{y:g},{x:g},{t:g}\n" for i, (t, x, y, T) in enumerate(rows))
    else:
        text = fea_text(rows, header=" Time , X , Y , Temperature \n")
    path = tmp_path / "nodes.csv"
    path.write_bytes(text.encode())
    scene = read_fea_nodes(path, dx=1e-6)
    assert scene.n_frames == 3
    consume(scene)


@pytest.mark.usefixtures("in_tmp")
def test_fea_conflicting_temperatures_for_one_node(tmp_path):
    path = conflicting_fea(tmp_path)
    with pytest.raises(RadiosimError) as info:
        consume(read_fea_nodes(path, dx=1e-6))
    message = api_error(info, path.name)
    assert ("x = 2" in message and "y = 4" in message) or "line" in message, message


@pytest.mark.usefixtures("in_tmp")
def test_fea_identical_duplicate_node_is_merged(tmp_path):
    rows = fea_rows()
    rows.append(list(rows[30]))  # the same node, the same temperature: harmless
    path = tmp_path / "dup.csv"
    path.write_text(fea_text(rows))
    assert_linear_fea_field(read_fea_nodes(path, dx=1e-6))


@pytest.mark.usefixtures("in_tmp")
@pytest.mark.parametrize("column", ["time", "x", "y", "temperature"])
@pytest.mark.parametrize("how", ["column-removed", "values-removed"])
def test_fea_csv_with_a_column_removed(tmp_path, column, how):
    names = ["time", "x", "y", "temperature"]
    i = names.index(column)
    rows = [[f"{v:g}" for v in row] for row in fea_rows()]
    header = names if how == "values-removed" else names[:i] + names[i + 1:]
    body = [row[:i] + row[i + 1:] for row in rows]
    path = tmp_path / "nodes.csv"
    path.write_text(FEA_UNITS + ",".join(header) + "\n" + "".join(",".join(r) + "\n"
                                                                    for r in body))
    with pytest.raises(RadiosimError) as info:
        consume(read_fea_nodes(path, dx=1e-6))
    message = api_error(info, path.name)
    assert (column in message) if how == "column-removed" else ("field" in message), message


@pytest.mark.usefixtures("in_tmp")
def test_fea_coordinates_in_the_wrong_length_unit_are_named(tmp_path):
    # µm coordinates declared as metres: a grid of 10¹⁸ samples, refused before any allocation.
    rows = ["# units: time=us, length=m, temperature=C", "time,x,y,temperature"]
    rows += [f"{t},{x},{y},{500 + x / 10}" for t in (0, 1) for x in (0, 500, 960)
             for y in (0, 400, 742)]
    (tmp_path / "n.csv").write_text("\n".join(rows) + "\n")
    with pytest.raises(RadiosimError, match=r"length unit right \(µm data read as m\?\)"):
        read_fea_nodes(tmp_path / "n.csv", dx=0.5e-6)


@pytest.mark.usefixtures("in_tmp")
@pytest.mark.parametrize("step", [0, 2])
def test_api_fea_collinear_step_is_a_radiosim_error(tmp_path, capfd, step):
    rows = [r for r in fea_rows() if r[0] != step]
    rows += [[step, 2.0 * i, 0.0, 500.0] for i in range(5)]  # on one line y = 0
    rows.sort(key=lambda r: r[0])
    path = tmp_path / "nodes.csv"
    path.write_text(fea_text(rows))
    with pytest.raises(RadiosimError) as info:
        consume(read_fea_nodes(path, dx=1e-6))
    message = api_error(info, path.name, f"step {step}")
    assert "\n" not in message and "QH" not in message, message
    out, err = capfd.readouterr()
    assert "QH" not in out + err and "qhull" not in (out + err).lower()


# -- FEA time origin and interpolation -------------------------------------------------------------


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
    one_line_naming(info, "nodes.csv", "t_start = 4 µs", "start at 5 µs", "first time stamp")
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


def test_fea_hold_with_an_origin_between_frame_edges_keeps_each_snapshot_whole(tmp_path):
    """Snapshots at 0.5, 1.5, 2.5 µs, steps of 1 µs: the frames are aligned to them (frame 0
    covers [0.5, 1.5) µs and is the 0.5 µs snapshot). Issue 40 changed this: frame 1 covered
    [1, 2) µs and mixed two snapshots half and half."""
    scene = read_fea_nodes(ramp_csv(tmp_path, (0.5, 1.5, 2.5)), dx=1e-6)
    assert scene.first_frame == 0 and scene.n_frames == 3
    assert scene.frame_origin == pytest.approx(0.5e-6)
    for k, t in enumerate((0.5, 1.5, 2.5)):
        np.testing.assert_allclose(scene.frame(k), ramp(t), rtol=1e-12)
    with pytest.raises(RadiosimError, match="before the scene's data, which start at 0.5 µs .the first time stamp of .*nodes.csv"):
        Camera.linear_ideal(2e-6).measure(scene, 1e-6, t_start=0.2e-6)


@pytest.mark.parametrize("call, name", [
    (lambda p: read_fea_nodes(p, dx=1e-6, interpolation="cubic"), "'cubic'"),
    (lambda p: read_fea_nodes(p, dx=1e-6, dt=0.5e-6), "does not match"),
])
def test_fea_bad_interpolation_or_a_finer_hold_is_refused(tmp_path, call, name):
    with pytest.raises(RadiosimError) as info:
        call(ramp_csv(tmp_path, (0, 1, 2)))
    one_line_naming(info, "nodes.csv", name)


# -- the reader under random input (hypothesis) ----------------------------------------------------
# A RadiosimError or a correct read, never another exception.


def _read_csv_or_error(data: bytes):
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "nodes.csv"
        path.write_bytes(data)
        try:
            consume(read_fea_nodes(path, dx=1e-6))
        except RadiosimError:
            pass


@pytest.mark.usefixtures("in_tmp")
@BOUNDED
@given(data=st.binary(max_size=512))
@example(data=b"# units: time=us, length=um, temperature=\xb0C\ntime,x,y,temperature\n")
def test_random_bytes_as_csv(data):
    _read_csv_or_error(data)


@pytest.mark.usefixtures("in_tmp")
@BOUNDED
@given(text=st.text(max_size=400))
def test_random_text_as_csv(text):
    _read_csv_or_error(text.encode("utf-8"))


@pytest.mark.usefixtures("in_tmp")
@BOUNDED
@given(cells=st.lists(st.one_of(st.floats(allow_nan=True, allow_infinity=True),
                                st.text(max_size=6), st.integers(-10**30, 10**30)),
                      min_size=4, max_size=4),
       where=st.integers(0, 74))
def test_garbage_cells_in_a_valid_csv(cells, where):
    rows = [[f"{v:g}" for v in row] for row in fea_rows()]
    rows[where] = [str(c) for c in cells]
    text = FEA_UNITS + FEA_HEADER + "".join(",".join(row) + "\n" for row in rows)
    _read_csv_or_error(text.encode("utf-8"))


VALID_CSV = fea_text(fea_rows()).encode()


@pytest.mark.usefixtures("in_tmp")
@BOUNDED
@given(cut=st.integers(0, len(VALID_CSV) - 1))
def test_truncated_csv(cut):
    _read_csv_or_error(VALID_CSV[:cut])
