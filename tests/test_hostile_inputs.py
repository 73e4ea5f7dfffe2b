"""Issue 40's classes, case by case, over the readers a user feeds by hand: each case is either
refused in one line naming the file and what is wrong (never a traceback, never a wrong
number), or read with the value it states (valid input is not refused)."""

import numpy as np
import pytest

from conftest import one_line_naming
from radiosim import Camera
from radiosim.calibration_table import read_calibration_table
from radiosim.errors import RadiosimError
from radiosim.io import read_scene

# -- calibration tables ---------------------------------------------------------------------------

TABLE_REFUSED = {
    # name: (text, what the one line must name)
    "empty": ("", "no header and no rows"),
    "header only": ("temperature_K,counts\n", "header but no rows"),
    "a word for a number": ("temperature_K,counts\n500,abc\n600,2000\n", "counts = 'abc'"),
    "nan counts": ("temperature_K,counts\n500,nan\n600,2000\n", "expected a finite number"),
    "infinite counts": ("temperature_K,counts\n500,inf\n600,2000\n", "expected a finite number"),
    "negative kelvin": ("temperature_K,counts\n-5,1000\n600,2000\n", "-5 K is not above 0 K"),
    "below absolute zero in °C": ("temperature_C,counts\n-300,1000\n600,2000\n",
                                  "-300 °C is below absolute zero"),
    "no counts column": ("temperature_K,dl\n500,1000\n600,2000\n", "found temperature_K, dl"),
    "kelvin and celsius disagree": (
        "temperature_K,temperature_C,counts\n500,100,1000\n600,326.85,2000\n", "disagree"),
    "a short row": ("temperature_K,counts\n500\n600,2000\n", "line 2 has 1 values"),
    "a long row": ("temperature_K,counts\n500,1000,7\n600,2000\n", "line 2 has 3 values"),
    "counts falling": ("temperature_K,counts\n500,2000\n600,1000\n", "not monotonic"),
    "semicolons": ("temperature_K;counts\n500;1000\n600;2000\n", "separated by semicolons"),
    "tabs": ("temperature_K\tcounts\n500\t1000\n600\t2000\n", "separated by tabs"),
    "a column twice": ("temperature_K,counts,counts\n500,1,1\n", "appears 2 times"),
    "units line against the suffix": ("# units: temperature=C\ntemperature_K,counts\n500,1\n",
                                      "units line says"),
    "units line in fahrenheit": ("# units: temperature=F\ntemperature_F,counts\n500,1\n",
                                 "expected K or C"),
}


@pytest.mark.parametrize("name", sorted(TABLE_REFUSED))
def test_a_bad_calibration_table_is_refused_in_one_line(tmp_path, name):
    text, said = TABLE_REFUSED[name]
    path = tmp_path / "table.csv"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(RadiosimError) as info:
        read_calibration_table(path)
    one_line_naming(info, "table.csv", said)


TABLE_READ = {
    # name: (bytes, temperatures [K] it states)
    "crlf line ends": (b"temperature_K,counts\r\n500,1000\r\n600,2000\r\n", [500.0, 600.0]),
    "spaces around values": (b"temperature_K , counts\n 500 , 1000 \n600,2000\n",
                             [500.0, 600.0]),
    "blank lines at the end": (b"temperature_K,counts\n500,1000\n600,2000\n\n\n",
                               [500.0, 600.0]),
    "a byte order mark": ("\ufefftemperature_K,counts\n500,1000\n".encode(), [500.0]),
    "celsius": (b"temperature_C,counts\n226.85,1000\n326.85,2000\n", [500.0, 600.0]),
    "kelvin and celsius agreeing": (
        b"temperature_K,temperature_C,counts\n500,226.85,1000\n", [500.0]),
    "comments": (b"# blackbody run 3\ntemperature_K,counts\n# warm-up\n500,1000\n", [500.0]),
    "units line agreeing": (b"# units: temperature=C\ntemperature_C,counts\n226.85,1\n",
                            [500.0]),
    "repeated points": (b"temperature_K,counts\n500,1000\n500,1001\n600,2000\n",
                        [500.0, 500.0, 600.0]),
}


@pytest.mark.parametrize("name", sorted(TABLE_READ))
def test_a_valid_calibration_table_is_read_as_it_states(tmp_path, name):
    data, kelvin = TABLE_READ[name]
    path = tmp_path / "table.csv"
    path.write_bytes(data)
    table = read_calibration_table(path)
    np.testing.assert_allclose(table.temperature, kelvin, rtol=0, atol=1e-9)


def test_a_table_that_is_not_utf8_is_named(tmp_path):
    path = tmp_path / "table.csv"
    path.write_bytes("temperature_K,counts # é\n500,1000\n".encode("latin-1"))
    with pytest.raises(RadiosimError) as info:
        read_calibration_table(path)
    one_line_naming(info, "table.csv", "not UTF-8")


# -- temperature stacks (.npy) --------------------------------------------------------------------

NPY_REFUSED = {
    "2-D": (np.full((8, 8), 500.0), "must be a 3-D array"),
    "1-D": (np.full(8, 500.0), "got 1-D"),
    "4-D": (np.full((2, 3, 8, 8), 500.0), "got 4-D"),
    "complex": (np.full((3, 8, 8), 500.0 + 1j), "real numbers, got dtype complex128"),
    "bool": (np.ones((3, 8, 8), bool), "got dtype bool"),
    "strings": (np.full((3, 8, 8), "a"), "got dtype <U1"),
    "structured": (np.zeros((3, 8, 8), dtype=[("a", "f8")]), "real numbers"),
    "no frames": (np.zeros((0, 8, 8)), "empty: shape (0, 8, 8)"),
    "no columns": (np.zeros((3, 8, 0)), "empty: shape (3, 8, 0)"),
    "objects": (np.array([[1, 2], [3]], dtype=object), "holds Python objects"),
}


@pytest.mark.parametrize("name", sorted(NPY_REFUSED))
def test_a_stack_of_the_wrong_kind_is_refused_in_one_line(tmp_path, name):
    array, said = NPY_REFUSED[name]
    path = tmp_path / "stack.npy"
    np.save(path, array, allow_pickle=True)
    with pytest.raises(RadiosimError) as info:
        read_scene(path, dx=1e-6, dt=1e-6, units="K")
    one_line_naming(info, "stack.npy", said)


@pytest.mark.parametrize("damage, said", [
    (lambda b: b[:300], "is truncated"),
    (lambda b: b[:10] + b"xxxxxxxxxx" + b[20:], "header is damaged"),
    (lambda b: b"hello", "not a NumPy .npy file"),
    (lambda b: b"", "is empty (0 bytes)"),
    (lambda b: b[:8], "header is damaged"),
])
def test_a_damaged_stack_file_is_named_in_one_line(tmp_path, damage, said):
    good = tmp_path / "good.npy"
    np.save(good, np.full((3, 8, 8), 500.0))
    path = tmp_path / "stack.npy"
    path.write_bytes(damage(good.read_bytes()))
    with pytest.raises(RadiosimError) as info:
        read_scene(path, dx=1e-6, dt=1e-6, units="K")
    one_line_naming(info, "stack.npy", said)


@pytest.mark.parametrize("array", [
    np.full((3, 8, 8), 500, np.int16), np.full((3, 8, 8), 500, np.float16),
    np.full((3, 8, 8), 250, np.uint8), np.asfortranarray(np.full((3, 8, 8), 500.0)),
    np.full((3, 8, 8), 500.0, ">f8"), np.full((3, 8, 8), 500.0, np.float32),
], ids=["int16", "float16", "uint8", "fortran order", "big-endian", "float32"])
def test_a_numeric_stack_of_any_layout_reads_its_values(tmp_path, array):
    path = tmp_path / "stack.npy"
    np.save(path, array)
    scene = read_scene(path, dx=1e-6, dt=1e-6, units="K")
    np.testing.assert_array_equal(scene.frame(2), np.asarray(array[2], dtype=float))


@pytest.mark.parametrize("value, said", [
    (np.nan, "is NaN"), (-5.0, "-5 K"), (0.0, "0 K"), (np.inf, "is inf"),
])
def test_a_bad_sample_is_refused_when_measured_naming_frame_row_and_column(tmp_path, value,
                                                                         said):
    frames = np.full((3, 8, 8), 500.0)
    frames[1, 2, 5] = value
    path = tmp_path / "stack.npy"
    np.save(path, frames)
    scene = read_scene(path, dx=1e-6, dt=1e-6, units="K")
    with pytest.raises(RadiosimError) as info:
        Camera.linear_ideal(2e-6).measure(scene, 3e-6)
    one_line_naming(info, "frame 1", "row 2, column 5", said)


@pytest.mark.parametrize("kwargs, said", [
    ({"dx": float("nan")}, "dx must be finite and > 0 [m], got nan"),
    ({"dx": -1e-6}, "got -1e-06"),
    ({"dt": 0}, "dt must be finite and > 0 [s], got 0"),
    ({"units": "F"}, "temperature unit 'F' is not K or C"),
    ({"dx": "1um"}, "got the string '1um'"),
])
def test_bad_arguments_for_a_stack_name_the_argument(tmp_path, kwargs, said):
    path = tmp_path / "stack.npy"
    np.save(path, np.full((3, 8, 8), 500.0))
    with pytest.raises(RadiosimError) as info:
        read_scene(path, **({"dx": 1e-6, "dt": 1e-6, "units": "K"} | kwargs))
    one_line_naming(info, "stack.npy", said)


def test_a_stack_in_celsius_reads_as_kelvin(tmp_path):
    path = tmp_path / "stack.npy"
    np.save(path, np.full((3, 8, 8), 226.85))
    scene = read_scene(path, dx=1e-6, dt=1e-6, units="C")
    np.testing.assert_allclose(scene.frame(0), 500.0, rtol=0, atol=1e-9)


# -- a measurement's NetCDF file whose attributes another tool changed ---------------------------


@pytest.fixture(scope="module")
def dataset():
    from radiosim.scenes import UniformBlackbody

    m = Camera.preset("nist-ir").measure(UniformBlackbody(800.0, shape=(20, 20)), 10e-6, rng=1)
    return m, m.to_xarray()


@pytest.mark.parametrize("change, said", [
    (lambda d: d.attrs.update(integration_time_s="10us"), "'10us'; expected a number"),
    (lambda d: d.attrs.update(integration_time_s=float("nan")), "expected a finite number > 0"),
    (lambda d: d.attrs.update(integration_time_s=float("inf")), "expected a finite number > 0"),
    (lambda d: d.attrs.update(integration_time_s=0.0), "is 0.0; expected a finite number > 0"),
    (lambda d: d.attrs.update(n_frames=0), "n_frames is 0; expected a whole number ≥ 1"),
    (lambda d: d.attrs.update(n_frames="3"), "n_frames is '3'; expected a number"),
    (lambda d: d.attrs.update(t_start_s=-1.0), "t_start_s is -1.0; expected a finite number ≥ 0"),
    (lambda d: d.__delitem__("counts"), "missing counts"),
    (lambda d: d.__setitem__("apparent_temperature",
                             d["apparent_temperature"].rename({"x": "col"})),
     "dimensions ('y', 'col'); expected ('y', 'x')"),
], ids=["time as text", "time nan", "time inf", "time zero", "no frames", "frames as text",
        "negative start", "no counts", "a dimension renamed"])
def test_a_netcdf_attribute_changed_by_another_tool_is_refused(tmp_path, dataset, change,
                                                                said):
    from radiosim.io.netcdf import read_netcdf, write_netcdf

    changed = dataset[1].copy(deep=True)
    change(changed)
    path = write_netcdf(tmp_path / "m.nc", changed)
    with pytest.raises(RadiosimError) as info:
        read_netcdf(path)
    one_line_naming(info, "m.nc", said)


@pytest.mark.parametrize("unit, scale, offset", [
    ("degF", 5 / 9, 459.67 * 5 / 9), ("mK", 1e-3, 0.0), ("degree_Celsius", 1.0, 273.15),
])
def test_a_netcdf_temperature_in_another_cf_unit_is_converted(tmp_path, dataset, unit, scale,
                                                              offset):
    """The value v stored in ``unit`` is v·scale + offset kelvin (CF's own definitions of the
    degree Fahrenheit, the millikelvin and the degree Celsius)."""
    from radiosim.io.netcdf import read_netcdf, write_netcdf

    m, original = dataset
    changed = original.copy(deep=True)
    changed["tensor_max"].attrs.update(units=unit)
    back = read_netcdf(write_netcdf(tmp_path / "m.nc", changed))
    np.testing.assert_allclose(back.tensor_max, m.tensor_max * scale + offset, rtol=1e-12)
