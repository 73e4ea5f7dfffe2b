"""CF-1.8 NetCDF files of measurements and of a study's results (radiosim.io.netcdf).

The CF checks here are an independent, small checker written in this file (the IOOS compliance
checker is not a dependency): every variable and coordinate has a ``long_name`` and, if it is a
number that is not a flag, a ``units`` from a list of UDUNITS-2 strings; the global attributes
CF asks for are there; no coordinate has a ``_FillValue``; no variable is NaN everywhere; only
CF-1.8's data types. The expected values of the results file are the text of ``results.csv``,
shifted by powers of ten with :mod:`decimal` in the test.
"""

import csv
import json
import math
import re
from decimal import Decimal

import h5netcdf
import numpy as np
import pytest
import xarray as xr

from radiosim import Camera, UniformBlackbody, __version__
from radiosim.errors import RadiosimError
from radiosim.io import read_netcdf, results_to_xarray, write_netcdf
from radiosim.io.netcdf import read_results
from radiosim.study import Study

#: UDUNITS-2 strings radiosim may write (each parses with UDUNITS-2; none is "C", the
#: coulomb, nor a micro-prefixed unit).
UDUNITS = {"K", "degC", "s", "m", "m2", "1", "s-1 m-2 sr-1", "W m-2 sr-1"}

#: The results table's columns in µs, µm, µm²: the variable, its units and the power of ten.
SHIFTED = {"integration_time_us": ("integration_time", "s", -6),
           "pixel_pitch_um": ("pixel_pitch", "m", -6),
           "t_start_us": ("t_start", "s", -6),
           "sensor_area_um2": ("sensor_area", "m2", -12)}

#: Units of the other numeric columns of results.csv.
UNITS = {"n_frames": "1", "pixel_samples": "1", "peak_scene_C": "degC", "peak_C": "degC",
         "peak_bias_K": "K", "peak_uncertainty_K": "K", "saturated_fraction": "1",
         "under_range_fraction": "1", "over_range_fraction": "1"}

STUDY = """name = "small"
[scene]
type = "frames"
path = "frames.npy"
dt_us = 1.0
dx_um = 0.6666666666666666
units = "K"
[cameras.lin]
preset = "linear-ideal"
pixel_pitch_um = 4.0
[[sweeps]]
name = "t"
cameras = ["lin"]
integration_time_us = [1, 2, 3]
[[sweeps]]
name = "p"
cameras = ["lin"]
pixel_samples = [3, 9]
integration_time_frames = [1]
"""


def cf_problems(path) -> list[str]:
    """What in the NetCDF file ``path`` breaks the CF-1.8 rules radiosim follows."""
    problems = []
    name = re.compile(r"[A-Za-z][A-Za-z0-9_]*\Z")
    with h5netcdf.File(path, "r") as f:
        attrs = dict(f.attrs)
        if attrs.get("Conventions") != "CF-1.8":
            problems.append(f"Conventions is {attrs.get('Conventions')!r}")
        problems += [f"no global {a}" for a in ("title", "history", "source") if not attrs.get(a)]
        problems += [f"global attribute {a} is not a CF name" for a in attrs
                     if not name.match(a)]
        for var_name, var in f.variables.items():
            a = dict(var.attrs)
            is_coordinate = var.dimensions == (var_name,)
            numeric = var.dtype.kind in "iufb"
            if var.dtype in (np.int64, np.uint64):
                problems.append(f"{var_name} is 64-bit integer (not a CF-1.8 type)")
            if not a.get("long_name"):
                problems.append(f"{var_name} has no long_name")
            if is_coordinate and "_FillValue" in a:
                problems.append(f"coordinate {var_name} has a _FillValue")
            if a.get("standard_name") == "status_flag":
                if "flag_values" not in a or "flag_meanings" not in a:
                    problems.append(f"flag {var_name} lacks flag_values or flag_meanings")
            elif numeric and a.get("units") not in UDUNITS:
                problems.append(f"{var_name} has units {a.get('units')!r}")
            if a.get("standard_name") not in (None, "status_flag"):
                problems.append(f"{var_name}: standard name {a['standard_name']!r} not expected")
            if var.dtype.kind == "f" and var.shape and np.isnan(var[...]).all():
                problems.append(f"{var_name} is NaN everywhere")
    return problems


@pytest.fixture(scope="module")
def study_run(tmp_path_factory):
    """A small study run (two sweeps: integration times, and p × p samples of 2/3 µm, whose
    pitch for p = 9 is 5.999999999999999 µm in floats), its results.nc and results.csv."""
    folder = tmp_path_factory.mktemp("study")
    frames = 600.0 + np.arange(24)[None, None, :] * np.ones((6, 24, 1)) * 1.25
    np.save(folder / "frames.npy", frames)
    (folder / "s.toml").write_text(STUDY)
    study = Study.from_toml(folder / "s.toml")
    result = study.run(folder / "out")
    path = write_netcdf(folder / "results.nc", results_to_xarray(
        result.rows, study.name, history="radiosim run s.toml --format netcdf"))
    with open(result.table, newline="", encoding="utf-8") as handle:
        table = list(csv.DictReader(handle))
    return path, table, result


def test_results_are_one_record_dimension_not_a_cube(study_run):
    path, table, _ = study_run
    with xr.open_dataset(path, engine="h5netcdf") as ds:
        assert dict(ds.sizes) == {"measurement": len(table)} == {"measurement": 5}
        assert all(v.dims == ("measurement",) for v in ds.variables.values())
        assert set(ds.coords) == {"sweep", "camera", "response", "alignment",
                                  "integration_time", "pixel_pitch"}
        assert ds.sweep.values.tolist() == ["t", "t", "t", "p", "p"]


def test_results_read_back_are_the_csv_values(study_run):
    """Every column of results.csv from the file as xarray reads it: strings equal, numbers
    equal to the CSV's decimal text (times 10⁻⁶ or 10⁻¹² for µs, µm, µm²), NaN where the
    CSV cell is empty or nan."""
    path, table, _ = study_run
    columns = list(table[0])
    with xr.open_dataset(path, engine="h5netcdf") as ds:
        assert ds.attrs["results_columns"].split(",") == columns
        assert ds.attrs["study"] == "small"
        for column in columns:
            cells = [row[column] for row in table]
            if column in SHIFTED:
                variable, units, exponent = SHIFTED[column]
            else:
                variable, units, exponent = column, UNITS.get(column), 0
            if variable not in ds.variables:  # left out: empty in every row, or the study
                assert all(c in ("", "small") for c in cells), column
                continue
            values = ds[variable].values.tolist()
            assert ds[variable].attrs.get("units") == units, column
            for cell, value in zip(cells, values):
                if units is None:  # a string column
                    assert value == cell, column
                elif cell in ("", "nan"):
                    assert math.isnan(value), column
                else:
                    assert value == float(Decimal(cell).scaleb(exponent)), (column, cell)
                    assert type(value) is (int if column == "n_frames" else float)


def test_coordinates_are_exact_and_selectable(study_run):
    """9 × 2/3 µm is 5.999999999999999 µm in floats: the file says 6e-06 m, as the CSV says
    6.0, so selecting 6 µm finds it."""
    path, table, result = study_run
    assert result.rows[4]["pixel_pitch_um"] == 5.999999999999999  # the noise to round
    assert table[4]["pixel_pitch_um"] == "6.0"
    with xr.open_dataset(path, engine="h5netcdf") as ds:
        assert ds.pixel_pitch.values.tolist() == [4e-06, 4e-06, 4e-06, 2e-06, 6e-06]
        assert ds.set_xindex("pixel_pitch").sel(pixel_pitch=6e-06).sweep.item() == "p"
        assert ds.integration_time.values.tolist()[:3] == [1e-06, 2e-06, 3e-06]


def test_results_file_passes_the_cf_checks(study_run):
    path, _, _ = study_run
    assert cf_problems(path) == []
    with xr.open_dataset(path, engine="h5netcdf") as ds:
        history = ds.attrs["history"]
        assert f"radiosim {__version__}" in history and "study small" in history
        assert history.endswith("radiosim run s.toml --format netcdf")
        assert "institution" not in ds.attrs
        units = {str(v.attrs.get("units")) for v in ds.variables.values()}
        assert not units & {"C", "us", "um", "um2"}


def ioos_cf_report(path, tmp_path) -> dict:
    """The IOOS compliance checker's CF-1.8 report on a file (its JSON output, as the
    ``compliance-checker --test=cf:1.8 --criteria=strict`` command writes it): an
    implementation of the conventions independent of this project's writer and of
    :func:`cf_problems`."""
    from compliance_checker import runner  # a test dependency (pyproject's [test] extra)
    from compliance_checker.cf.cf import CF1_8Check

    runner.CheckSuite.checkers["cf:1.8"] = CF1_8Check  # the CF suite alone (the others
    # are the IOOS profiles, some deprecated: loading them all warns)
    report = tmp_path / "cf-report.json"
    runner.ComplianceChecker.run_checker(str(path), ["cf:1.8"], 2, "strict",
                                         output_filename=str(report), output_format="json")
    return json.loads(report.read_text(encoding="utf-8"))["cf:1.8"]


def _failed_checks(report: dict) -> list[str]:
    """Every check that lost points, as "name: messages" (errors are priority 3, warnings 2,
    information 1)."""
    return [f"{check['name']}: {check['msgs']}" for check in report["all_priorities"]
            if check["value"][0] < check["value"][1]]


def test_results_file_passes_the_ioos_compliance_checker(study_run, tmp_path):
    """No error, no warning, no information from the IOOS checker's CF-1.8 suite."""
    path, _, _ = study_run
    report = ioos_cf_report(path, tmp_path)
    assert _failed_checks(report) == []
    assert (report["high_count"], report["medium_count"], report["low_count"]) == (0, 0, 0)
    assert report["scored_points"] == report["possible_points"] > 100


def test_read_results_gives_the_studys_rows(study_run):
    path, table, _ = study_run
    rows = read_results(path)
    assert [list(r) for r in rows] == [list(r) for r in table]
    for row, expected in zip(rows, table):
        for column, text in expected.items():
            value = row[column]
            if isinstance(value, float) and math.isnan(value):
                assert text in ("", "nan"), column
            else:
                assert (value if isinstance(value, str) else repr(value)) == text, column


def test_gaps_strings_noise_and_hook_columns():
    """Rows as a study with a pixel sweep and a summary hook writes them: empty cells, NaN,
    warnings, float noise, a column empty in every row, a column without a unit suffix."""
    base = {"study": "s", "sweep": "a", "camera": "c", "response": "linear",
            "integration_time_us": 90.00000000000001, "n_frames": 450,
            "pixel_pitch_um": 5.999999999999999, "alignment": "centred",
            "peak_C": 899.4000000000002, "warnings": "", "exr": "exr/a.exr",
            "column_I_C": 567.0, "never": "", "gain": 2.5}
    rows = [base, dict(base, sweep="b", peak_C=math.nan, warnings="saturated", exr="",
                       column_I_C="")]
    ds = results_to_xarray(rows, "s", institution="a laboratory")
    assert ds.integration_time.values.tolist() == [9e-05, 9e-05]
    assert ds.pixel_pitch.values.tolist() == [6e-06, 6e-06]
    assert ds.peak_C.values[0] == 899.4 and math.isnan(ds.peak_C.values[1])
    assert ds.warnings.values.tolist() == ["", "saturated"]
    assert ds.exr.values.tolist() == ["exr/a.exr", ""]
    assert ds.column_I_C.units == "degC" and math.isnan(ds.column_I_C.values[1])
    assert ds.column_I_C.long_name == "column I (results.csv column column_I_C)"
    assert "never" not in ds and "study" not in ds  # empty / the dataset's own name
    assert "units" not in ds.gain.attrs and "unit not stated" in ds.gain.long_name
    assert ds.n_frames.dtype == np.int32 and ds.attrs["institution"] == "a laboratory"


def test_two_columns_for_one_variable_are_refused():
    rows = [{"sweep": "a", "t_start_us": 1.0, "t_start": 1e-6}]
    with pytest.raises(RadiosimError, match="'t_start_us' and 't_start'.*'t_start'"):
        results_to_xarray(rows)


@pytest.fixture(scope="module")
def measurement():
    return Camera.preset("nist-ir").measure(UniformBlackbody(900.0, (12, 16), 6e-6, 1e-6),
                                            10e-6, rng=0)


def test_a_measurement_file_passes_the_cf_checks(tmp_path, measurement):
    path = write_netcdf(tmp_path / "m.nc", measurement, history="radiosim measure m.npy")
    assert cf_problems(path) == []
    with xr.open_dataset(path, engine="h5netcdf") as ds:
        assert ds.counts.units == "1" and "DN" in ds.counts.long_name
        assert ds.signal_mean.units == "s-1 m-2 sr-1"  # photons s-1 m-2 sr-1
        assert ds.saturated.standard_name == "status_flag"
        assert ds.apparent_temperature.ancillary_variables == ("saturated under_range "
                                                               "over_range")
        assert ds.attrs["history"].endswith("radiosim measure m.npy")


def test_a_measurement_file_passes_the_ioos_compliance_checker(tmp_path, measurement):
    path = write_netcdf(tmp_path / "m.nc", measurement, history="radiosim measure m.npy")
    report = ioos_cf_report(path, tmp_path)
    assert _failed_checks(report) == []
    assert (report["high_count"], report["medium_count"], report["low_count"]) == (0, 0, 0)


def test_old_files_read_or_name_the_difference(tmp_path, measurement, study_run):
    """A measurement file written before CF-1.8 (scene attributes ``scene:<key>``, units
    DN) still reads; a results file, old cube or new, is named as such in one line."""
    old = measurement.to_xarray().copy(deep=True)
    old.attrs = {k.replace("scene_", "scene:", 1): v for k, v in old.attrs.items()}
    old["counts"].attrs = {"units": "DN"}
    back = read_netcdf(write_netcdf(tmp_path / "old.nc", old))
    assert back.scene == measurement.scene
    assert np.array_equal(back.counts, measurement.counts)

    path, _, _ = study_run
    with pytest.raises(RadiosimError, match=r"a study's results table; read it with "
                                            r"radiosim.io.netcdf.read_results") as info:
        read_netcdf(path)
    assert "\n" not in str(info.value)
    cube = xr.Dataset({"peak_C": (("sweep", "camera", "integration_time_us"),
                                  [[[600.0, np.nan]]])},
                      coords={"sweep": ["t"], "camera": ["lin"],
                              "integration_time_us": [1.0, 2.0]})
    write_netcdf(tmp_path / "cube.nc", cube)
    with pytest.raises(RadiosimError, match="old cube"):
        read_netcdf(tmp_path / "cube.nc")
    assert read_results(tmp_path / "cube.nc") == [
        {"sweep": "t", "camera": "lin", "integration_time_us": 1.0, "peak_C": 600.0}]


def test_write_netcdf_refuses_swapped_or_wrong_arguments_in_one_line(tmp_path, measurement):
    with pytest.raises(RadiosimError, match=r"got a Measurement \(the path comes first\)"):
        write_netcdf(measurement, tmp_path / "m.nc")
    with pytest.raises(RadiosimError, match=r"Measurement or an xarray.Dataset .* got a dict"):
        write_netcdf(tmp_path / "m.nc", {"a": 1})
    assert list(tmp_path.iterdir()) == []


# -- a file read as it states itself: CF units, dimensions by name, checked attributes ---------

_KELVIN_FIELDS = ("apparent_temperature", "tensor_max", "tensor_mean")


@pytest.mark.parametrize("unit, offset", [("degC", 273.15), ("degree_Celsius", 273.15),
                                          ("Celsius", 273.15), ("Kelvin", 0.0), ("K", 0.0)])
def test_temperatures_in_any_cf_unit_are_read_as_kelvin(tmp_path, measurement, unit, offset):
    # A file whose temperatures another tool converted (to degC, say) reads back in kelvin:
    # 800 K stored as 526.85 degC is 800 K again, not 526.85 K. The standard deviation is a
    # difference: the same number in kelvin and in degrees Celsius.
    converted = measurement.to_xarray().copy(deep=True)
    for name in (*_KELVIN_FIELDS, "tensor_std"):
        shift = offset if name != "tensor_std" else 0.0
        converted[name] = converted[name] - shift
        converted[name].attrs = {"units": unit}
    back = read_netcdf(write_netcdf(tmp_path / "c.nc", converted))
    for name in (*_KELVIN_FIELDS, "tensor_std"):
        np.testing.assert_allclose(getattr(back, name), getattr(measurement, name),
                                   rtol=0, atol=1e-9, err_msg=name)


def test_dimensions_are_read_by_name(tmp_path, measurement):
    # Stored (x, y) by another tool: read back (y, x), not transposed.
    swapped = measurement.to_xarray().transpose("x", "y")
    back = read_netcdf(write_netcdf(tmp_path / "t.nc", swapped))
    assert back.counts.shape == measurement.counts.shape
    np.testing.assert_array_equal(back.counts, measurement.counts)
    np.testing.assert_array_equal(back.saturated, measurement.saturated)


@pytest.mark.parametrize("change, said", [
    (lambda ds: ds["tensor_max"].attrs.update(units="m"),
     "variable tensor_max has units 'm'; expected K"),
    (lambda ds: ds["tensor_max"].attrs.update(units="kelvins please"),
     "variable tensor_max has units 'kelvins please', which is no CF unit; expected K"),
    (lambda ds: ds.attrs.update(integration_time_s=-1e-5),
     "attribute integration_time_s is -1e-05; expected a finite number > 0"),
    (lambda ds: ds.attrs.pop("integration_time_s"), "attribute integration_time_s is missing"),
    (lambda ds: ds.attrs.update(n_frames=2.5),
     "attribute n_frames is 2.5; expected a whole number ≥ 1"),
    (lambda ds: ds.attrs.update(camera="[fpa\npixel_pitch_um = "),
     "attribute camera is not the camera's TOML"),
])
def test_a_file_contradicting_itself_or_cf_is_refused_naming_what(tmp_path, measurement,
                                                                   change, said):
    broken = measurement.to_xarray().copy(deep=True)
    change(broken)
    path = write_netcdf(tmp_path / "b.nc", broken)
    with pytest.raises(RadiosimError) as info:
        read_netcdf(path)
    text = str(info.value)
    assert "\n" not in text and text.startswith(f"{path}: ") and said in text, text
