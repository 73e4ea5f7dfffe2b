"""
Measurements and study results as labelled xarray datasets, and CF-1.8 NetCDF files of them.

Both kinds of dataset follow the CF conventions 1.8: every variable and coordinate has a
UDUNITS-2 ``units`` (``K``, ``degC``, ``s``, ``m``, ``m2``, ``1`` for fractions and counts) and
a ``long_name``, a ``standard_name`` where the CF standard name table has one, and the dataset
states ``Conventions``, ``title``, ``history`` and ``source``. The field → unit table is
:data:`radiosim.measurement.FIELDS`, the one the EXR writer reads too. Files are written with
the ``h5netcdf`` engine, atomically (a temporary name, renamed), without ``_FillValue`` on
coordinates.

A measurement's dataset (:meth:`~radiosim.measurement.Measurement.to_xarray`) has dimensions
``y`` and ``x`` with the pixel centres' coordinates in metres (object space, from the array's
origin), one variable per array of the measurement, the flags as booleans (``status_flag``),
and as attributes the camera (its TOML, which rebuilds it exactly), the window, the scene's
description (``scene_<key>``; files of radiosim before CF-1.8 wrote ``scene:<key>``, read
as well) and radiosim's version. A multi-channel (two-colour) measurement adds a ``channel``
dimension (coordinates ``band_low``, ``band_high`` [m]) with each channel's arrays and window
(``channel_<field>``), and ``ratio_temperature`` and ``ratio_netd`` [K]; a single-channel one
is written as before.

A study's results (:func:`results_to_xarray`, the command's ``results.nc``) are the rows of
``results.csv`` along one record dimension, ``measurement``: the sweep parameters (``sweep``,
``camera``, ``response``, ``alignment``, ``integration_time``, ``pixel_pitch``) are coordinates
along it, every other column a variable along it (strings as strings). Values are those of
``results.csv`` (rounded to 10 significant digits by
:func:`radiosim.units.round_significant`); the columns in µs, µm and µm² are stored in
s, m and m² (exact decimal shifts: 90 µs is ``9e-05``) under their names without the unit
suffix (``integration_time``, ``pixel_pitch``, ``t_start``, ``sensor_area``), the others
under their own names (``peak_C`` in ``degC``, ``peak_bias_K`` in ``K``,
``saturated_fraction`` in ``1``). A column that is empty in every row is left out; the
attribute ``results_columns`` lists the table's columns, so :func:`read_results` gives back the
table's rows (an empty numeric cell and ``nan`` both read as NaN).
"""

from __future__ import annotations

import math
import os
import tomllib
from pathlib import Path

import numpy as np

from radiosim.errors import RadiosimError
from radiosim.files import atomic_path, why_not_a_file
from radiosim.measurement import FIELDS, FLAGS, Measurement, global_attributes
from radiosim.units import round_significant, shift

__all__ = ["to_xarray", "from_xarray", "write_netcdf", "read_netcdf", "results_to_xarray",
           "read_results", "RESULT_COORDINATES", "RESULT_LONG_NAMES",
           "column_variable"]

_ARRAYS = Measurement.ARRAYS


def to_xarray(measurement: Measurement, history: str | None = None):
    """The measurement as a CF-1.8 :class:`xarray.Dataset`
    (:meth:`Measurement.to_xarray`); ``history``: what made it (for instance the command)."""
    return measurement.to_xarray(history)


def _results_layout(dataset) -> str | None:
    """``"results"`` for a study's results dataset, ``"results (the old cube)"`` for one
    written before the CF-1.8 layout (the sweep parameters as dimensions), else ``None``."""
    if "results_columns" in dataset.attrs or "measurement" in dataset.dims and (
            "sweep" in dataset.variables):
        return "results"
    if {"sweep", "camera", "integration_time_us"} <= set(dataset.dims):
        return "results (the old cube)"
    return None


def from_xarray(dataset) -> Measurement:
    """The :class:`~radiosim.measurement.Measurement` of a dataset made by
    :func:`to_xarray` (values, flags, units, camera and scene), checked against itself and CF
    (:func:`_array`, :func:`_attribute`): a variable's dimensions by name, its ``units``
    converted where they are a CF unit of the field's quantity (``degC``, ``degree_Celsius``,
    ``Kelvin``…, by cf-units: UDUNITS-2 as CF prescribes), the window's attributes typed and
    in range; anything else refused in one line naming the variable or attribute and the
    value."""
    from radiosim.camera import Camera

    layout = _results_layout(dataset)
    if layout is not None:
        raise RadiosimError(f"not a radiosim measurement: a study's {layout} table; read it "
                            "with radiosim.io.netcdf.read_results")
    missing = [n for n in (*_ARRAYS, "camera") if n not in dataset.variables
               and n not in dataset.attrs]
    if missing:
        raise RadiosimError(f"not a radiosim measurement: missing {', '.join(missing)}")
    signal_unit = _attribute(dataset, "signal_unit", str)
    try:
        camera = Camera.from_dict(tomllib.loads(_attribute(dataset, "camera", str)))
    except tomllib.TOMLDecodeError as exc:
        raise RadiosimError(f"attribute camera is not the camera's TOML ({exc})") from None
    arrays = {name: _array(dataset, name, signal_unit) for name in _ARRAYS}
    attrs = dataset.attrs
    scene = {k[len("scene_"):]: (v.item() if isinstance(v, np.generic) else v)
             for k, v in attrs.items() if k.startswith(("scene_", "scene:"))}  # new, old
    extra = _channels_from(dataset, camera, scene) if "channel" in dataset.dims else {}
    return Measurement(**arrays, signal_unit=signal_unit, camera=camera,
                       integration_time=_attribute(dataset, "integration_time_s", "positive"),
                       t_start=_attribute(dataset, "t_start_s", "time"),
                       n_frames=_attribute(dataset, "n_frames", "count"),
                       scene=scene, alignment=_attribute(dataset, "alignment", str), **extra)


#: The fields that are temperature differences: their units convert by scale alone.
_DIFFERENCES = ("tensor_std",)


def _array(dataset, name: str, signal_unit: str, variable_name: str | None = None,
           dims=("y", "x")) -> np.ndarray:
    """Variable ``variable_name`` (default ``name``) of ``dataset`` as the measurement's field
    ``name``: its dimensions ``dims`` by name (transposed if stored in another order), flags
    as booleans, numbers as float64 in the field's units
    (:func:`~radiosim.measurement.field_attributes`)."""
    from radiosim.measurement import field_attributes

    name_in_file = variable_name or name
    variable = dataset[name_in_file]
    if sorted(variable.dims) != sorted(dims):
        raise RadiosimError(f"variable {name_in_file} has dimensions {variable.dims}; "
                            f"expected {dims}")
    values = np.asarray(variable.transpose(*dims).values)
    if name in FLAGS:
        return values.astype(bool)
    values = values.astype(np.float64)
    expected = field_attributes(name, signal_unit).get("units")
    own = next((f.unit for f in FIELDS if f.name == name), None)  # radiosim's name (DN, e-)
    stated = variable.attrs.get("units")
    if stated is None or expected is None or str(stated) in (expected, own, signal_unit):
        return values
    return _converted(values, name_in_file, str(stated), expected,
                      difference=name in _DIFFERENCES)


def _converted(values: np.ndarray, name: str, stated: str, expected: str,
               difference: bool = False) -> np.ndarray:
    """``values`` of variable ``name`` in CF units ``stated``, in ``expected`` (with
    ``difference``, a temperature difference: by scale alone)."""
    import cf_units

    try:
        unit = cf_units.Unit(stated)
    except ValueError:
        raise RadiosimError(f"variable {name} has units {stated!r}, which is no CF unit; "
                            f"expected {expected}") from None
    if not unit.is_convertible(expected):
        raise RadiosimError(f"variable {name} has units {stated!r}; expected {expected} (or a "
                            f"CF unit of the same quantity)")
    if difference:
        return values * (unit.convert(1.0, expected) - unit.convert(0.0, expected))
    return np.asarray(unit.convert(values, expected), dtype=np.float64)


def _attribute(dataset, key: str, kind):
    """Global attribute ``key``: a ``str``, or a number (not text) that is ``"positive"``
    (finite, > 0), a ``"time"`` (finite, ≥ 0), ``"finite"``, or a ``"count"`` (a whole number
    ≥ 1); else one line naming it."""
    if key not in dataset.attrs:
        raise RadiosimError(f"attribute {key} is missing")
    value = dataset.attrs[key]
    value = value.item() if isinstance(value, np.generic) else value
    if kind is str:
        if not isinstance(value, str):
            raise RadiosimError(f"attribute {key} is {value!r}; expected text")
        return value
    try:
        if isinstance(value, (str, bytes)):  # a number written as text is no CF number
            raise TypeError
        number = float(np.asarray(value).item())
    except (TypeError, ValueError):
        raise RadiosimError(f"attribute {key} is {value!r}; expected a number") from None
    if (not math.isfinite(number) or (kind == "positive" and number <= 0)
            or (kind == "time" and number < 0)):
        raise RadiosimError(f"attribute {key} is {value!r}; expected a finite number"
                            + {"positive": " > 0", "time": " ≥ 0"}.get(kind, ""))
    if kind == "count":
        if number != int(number) or number < 1:
            raise RadiosimError(f"attribute {key} is {value!r}; expected a whole number ≥ 1")
        return int(number)
    return number


def _channels_from(dataset, camera, scene) -> dict:
    """A multi-channel measurement's ``channels`` (and ratio temperature and its noise) from
    the ``channel_*`` variables of :meth:`Measurement.to_xarray`."""
    from radiosim.ratio import channel_cameras

    attrs = dataset.attrs
    cameras = channel_cameras(camera)
    channels = []
    for k in range(dataset.sizes["channel"]):
        arrays = {name: _array(dataset.isel(channel=k), name, str(attrs["signal_unit"]),
                               f"channel_{name}") for name in _ARRAYS}
        channels.append(Measurement(
            **arrays, signal_unit=str(attrs["signal_unit"]), camera=cameras[k],
            integration_time=float(dataset["channel_integration_time"].values[k]),
            t_start=float(dataset["channel_t_start"].values[k]),
            n_frames=int(dataset["channel_n_frames"].values[k]), scene=scene,
            alignment=str(attrs["alignment"])))
    out = {"channels": tuple(channels)}
    if "ratio_temperature" in dataset.variables:
        out["ratio_temperature"] = np.asarray(dataset["ratio_temperature"].values, np.float64)
        out["ratio_netd"] = np.asarray(dataset["ratio_netd"].values, np.float64)
    return out


def write_netcdf(path, measurement_or_dataset, history: str | None = None) -> Path:
    """
    Write a measurement (or a dataset) to a NetCDF-4 file, atomically, with no
    ``_FillValue`` on its coordinates.

    Parameters
    ----------
    path
        Destination ``.nc`` path; its folder must exist.
    measurement_or_dataset
        A :class:`~radiosim.measurement.Measurement` (written as :func:`to_xarray` makes
        it) or an :class:`xarray.Dataset` (written as it is).
    history
        For a measurement: what made it, in the ``history`` attribute.

    Returns
    -------
    pathlib.Path
        The path written.
    """
    import xarray as xr

    if not isinstance(path, (str, os.PathLike)):
        swapped = " (the path comes first)" if isinstance(measurement_or_dataset,
                                                          (str, os.PathLike)) else ""
        raise RadiosimError(f"write_netcdf: path must be a file path (str or os.PathLike), "
                            f"got a {type(path).__name__}{swapped}")
    if not isinstance(measurement_or_dataset, (Measurement, xr.Dataset)):
        raise RadiosimError(f"write_netcdf: expected a Measurement or an xarray.Dataset to "
                            f"write to {path}, got a {type(measurement_or_dataset).__name__}")
    path = Path(path)
    dataset = (to_xarray(measurement_or_dataset, history)
               if isinstance(measurement_or_dataset, Measurement) else measurement_or_dataset)
    encoding = {name: {"_FillValue": None} for name in dataset.coords}
    with atomic_path(path) as temporary:
        dataset.to_netcdf(temporary, engine="h5netcdf", encoding=encoding)
    return path


def _open(path):
    """The dataset of the NetCDF file ``path``, loaded; a missing or broken file raises one
    line naming it."""
    import xarray as xr

    path = Path(path)
    why = why_not_a_file(path)
    if why is not None:
        raise RadiosimError(f"{path} {why}")
    try:
        with xr.open_dataset(path, engine="h5netcdf", decode_timedelta=False) as dataset:
            return dataset.load()
    except Exception as exc:  # a broken file: one line naming it
        raise RadiosimError(f"cannot read NetCDF file {path}: {exc}") from None


def read_netcdf(path) -> Measurement:
    """Read a measurement written by :func:`write_netcdf` (a study's ``results.nc`` is
    refused, naming :func:`read_results`)."""
    dataset = _open(path)
    try:
        return from_xarray(dataset)
    except RadiosimError as exc:
        raise RadiosimError(f"{path}: {exc}") from None


# -- a study's results ---------------------------------------------------------------------

#: The results table's columns that label a measurement: coordinates along ``measurement``.
RESULT_COORDINATES = ("sweep", "camera", "response", "alignment", "integration_time_us",
                      "pixel_pitch_um")

#: ``long_name`` of the results table's columns (:data:`radiosim.study.RESULT_COLUMNS`); other
#: columns (a summary hook's) are named after their column, or by ``long_names``.
RESULT_LONG_NAMES = {
    "study": "study",
    "sweep": "sweep of the study that measured the case",
    "camera": "camera, by its name in the study",
    "response": "camera response: linear (the signal is temperature) or planck (in-band "
                "photon radiance)",
    "integration_time_us": "integration time",
    "n_frames": "number of scene frames the integration window touched",
    "pixel_pitch_um": "pixel pitch in object space",
    "pixel_samples": "pixel pitch in scene samples (p of p x p samples)",
    "sensor_area_um2": "active area of one pixel in object space (fill factor times pitch "
                       "squared)",
    "alignment": "alignment of the integration window on the scene's event",
    "t_start_us": "start of the integration window (scene time)",
    "peak_scene_C": "peak scene temperature (the largest tensor maximum)",
    "peak_C": "peak reading: the highest valid apparent temperature",
    "peak_bias_K": "peak bias: peak reading minus peak scene temperature (negative when the "
                   "camera reads low)",
    "peak_uncertainty_K": "standard deviation of scene temperature over the tensor of the "
                          "peak reading's pixel",
    "saturated_fraction": "fraction of pixels saturated",
    "under_range_fraction": "fraction of pixels under range",
    "over_range_fraction": "fraction of pixels over range",
    "warnings": "warnings raised while measuring, joined by ' | '",
    "exr": "EXR file of the measurement, relative to the run's folder",
}

#: A column name's unit suffix → (UDUNITS units, power of ten from the column's unit to SI).
_SUFFIXES = {"us": ("s", -6), "um": ("m", -6), "um2": ("m2", -12), "s": ("s", 0),
             "m": ("m", 0), "C": ("degC", 0), "K": ("K", 0), "fraction": ("1", 0)}

#: Columns that hold text, whatever their cells look like.
_STRINGS = ("study", "sweep", "camera", "response", "alignment", "warnings", "exr")

#: Numeric columns without a unit suffix that count things (UDUNITS ``1``).
_NUMBERS = ("n_frames", "pixel_samples")


def column_variable(column: str) -> tuple[str, str | None, int]:
    """
    The variable that holds the results table's ``column``: (its name, UDUNITS units or
    ``None`` where the name states none, power of ten from the column's unit to SI).

    Examples
    --------
    >>> column_variable("integration_time_us"), column_variable("peak_C")
    (('integration_time', 's', -6), ('peak_C', 'degC', 0))
    >>> column_variable("sensor_area_um2"), column_variable("n_frames")
    (('sensor_area', 'm2', -12), ('n_frames', '1', 0))
    """
    stem, _, suffix = column.rpartition("_")
    if stem and suffix in _SUFFIXES:
        units, exponent = _SUFFIXES[suffix]
        return (stem if exponent else column), units, exponent
    return column, ("1" if column in _NUMBERS else None), 0


def _number(value):
    """A cell as an int or float (numeric text too), or ``None`` if it is not a number."""
    if isinstance(value, (bool, np.bool_)):
        return None
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        return float(value)
    if isinstance(value, str):
        try:
            return int(value)
        except ValueError:
            try:
                return float(value)
            except ValueError:
                return None
    return None


def _column_values(column: str, cells: list):
    """A column's cells as one array: numbers (ints where every cell is a whole number,
    floats rounded as results.csv rounds them, NaN where empty, shifted to SI) or strings."""
    exponent = column_variable(column)[2]
    present = [c for c in cells if c != "" and c is not None]
    numbers = [_number(c) for c in present]
    if column in _STRINGS or any(n is None for n in numbers):
        return np.array(["" if c is None else str(c) for c in cells], dtype=object)
    if not exponent and len(present) == len(cells) and all(isinstance(n, int)
                                                            for n in numbers):
        if all(abs(n) < 2**31 for n in numbers):  # CF-1.8 has no 64-bit integers
            return np.array(numbers, dtype=np.int32)
    out = []
    for cell in cells:
        n = _number(cell) if cell != "" and cell is not None else math.nan
        out.append(shift(round_significant(float(n)), exponent))
    return np.array(out, dtype=np.float64)


def results_to_xarray(rows: list[dict], name: str = "study", *, columns=None,
                      history: str | None = None, institution: str | None = None,
                      long_names: dict | None = None):
    """
    A study's results table as one CF-1.8 dataset: the rows along the record dimension
    ``measurement``, the sweep parameters (:data:`RESULT_COORDINATES`) coordinates along it,
    every other column a variable (see the module's docstring for the names and units).

    Parameters
    ----------
    rows
        The table's rows (:attr:`radiosim.study.StudyResult.rows`, or read from
        ``results.csv``: numeric text becomes numbers), ``""`` where a cell is empty.
    name
        The study's name (attributes ``study`` and ``title``).
    columns
        The table's columns in order; ``None``: the first row's keys.
    history
        What made the table, for instance the command line (``history``'s line ends with
        it); ``None``: this function.
    institution
        Where the data were produced (the CF ``institution``), if stated.
    long_names
        ``long_name`` of columns that :data:`RESULT_LONG_NAMES` does not describe (a summary
        hook's).

    Returns
    -------
    xarray.Dataset
        With ``Conventions``, ``title``, ``history``, ``source``, ``study`` and
        ``results_columns`` (the table's columns, comma-separated).

    Examples
    --------
    >>> rows = [{"study": "s", "sweep": "t", "camera": "lin", "response": "linear",
    ...          "integration_time_us": 90.0, "pixel_pitch_um": 5.999999999999999,
    ...          "alignment": "centred", "peak_C": 899.4000000000002, "warnings": ""}]
    >>> ds = results_to_xarray(rows, "s")
    >>> ds.integration_time.values.tolist(), ds.integration_time.units
    ([9e-05], 's')
    >>> ds.pixel_pitch.values.tolist(), ds.peak_C.values.tolist(), ds.peak_C.units
    ([6e-06], [899.4], 'degC')
    """
    import xarray as xr

    if not rows:
        raise RadiosimError("no results to label")
    columns = list(rows[0] if columns is None else columns)
    names = dict(RESULT_LONG_NAMES, **(long_names or {}))
    coords, data, seen = {}, {}, {}
    for column in columns:
        cells = [row.get(column, "") for row in rows]
        if all(c == "" or c is None for c in cells):
            continue  # empty in every row: listed in results_columns only
        if column == "study" and all(c == name for c in cells):
            continue  # the dataset's own name: the attribute ``study``
        variable, units, exponent = column_variable(column)
        if variable in seen:
            raise RadiosimError(f"results columns {seen[variable]!r} and {column!r} would "
                                f"both be the variable {variable!r}; rename one of them")
        seen[variable] = column
        values = _column_values(column, cells)
        attrs = {"long_name": names.get(column, _default_long_name(column))}
        if values.dtype != object:
            if units is None:
                attrs["long_name"] += f" (results.csv column {column}; unit not stated)"
            else:
                attrs["units"] = units
        target = coords if column in RESULT_COORDINATES else data
        target[variable] = ("measurement", values, attrs)
    attrs = global_attributes(f"radiosim study {name}: results",
                              f"study {name}: {history or 'radiosim.io.results_to_xarray'}")
    if institution:
        attrs["institution"] = institution
    attrs.update(study=name, results_columns=",".join(columns), comment=(
        "One record per measurement (the rows of results.csv, in order). Columns in us, um "
        "and um2 are stored in s, m and m2 under their names without the unit suffix; values "
        "are rounded to 10 significant digits as in results.csv; columns empty in every row "
        "are left out (listed in results_columns)."))
    return xr.Dataset(data, coords=coords, attrs=attrs)


def _default_long_name(column: str) -> str:
    """A column's name in words, without its unit suffix, and the column it comes from
    (``column_I_bias_K``: ``column I bias (results.csv column column_I_bias_K)``)."""
    stem = column.rpartition("_")[0] if column_variable(column)[1] is not None and (
        column not in _NUMBERS) else column
    return f"{stem.replace('_', ' ')} (results.csv column {column})"


def read_results(path) -> list[dict]:
    """
    The rows of a study's results table from its NetCDF file (:func:`results_to_xarray`, the
    command's ``results.nc``), as the study wrote them: the columns of ``results.csv`` in its
    order and units (µs, µm, µm² shifted back exactly), strings as strings, NaN where a
    numeric cell is empty or NaN, ``""`` for a column empty in every row. A file of the old
    layout (a cube with the sweep parameters as dimensions) gives its measured cells, one row
    each, with the columns it holds.
    """
    dataset = _open(path)
    layout = _results_layout(dataset)
    if layout is None:
        raise RadiosimError(f"{path} is not a study's results table (no results_columns "
                            "attribute, no measurement dimension)")
    if layout != "results":
        frame = dataset.to_dataframe().dropna(how="all").reset_index()
        return [{k: (v.item() if isinstance(v, np.generic) else v) for k, v in row.items()}
                for row in frame.to_dict("records")]
    columns = str(dataset.attrs.get("results_columns", "")).split(",")
    count = dataset.sizes["measurement"]
    rows = [{} for _ in range(count)]
    for column in columns:
        variable, _, exponent = column_variable(column)
        if variable not in dataset.variables:
            fill = dataset.attrs.get("study", "") if column == "study" else ""
            for row in rows:
                row[column] = fill
            continue
        for row, value in zip(rows, dataset[variable].values.tolist()):
            if isinstance(value, bytes):
                value = value.decode("utf-8")
            row[column] = shift(value, -exponent) if exponent else value
    return rows
