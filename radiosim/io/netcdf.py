"""
Measurements and study results as labelled xarray datasets, and NetCDF files of them.

A measurement's dataset has dimensions ``y`` and ``x`` with the pixel centres' coordinates in
metres (object space, from the array's origin), one variable per array of the
:class:`~radiosim.measurement.Measurement` with its unit in ``attrs["units"]``, flags as
booleans, and as attributes the camera (its TOML, which rebuilds it exactly), the window, the
scene's description (``scene:<key>``) and radiosim's version. NetCDF files are written with the
``h5netcdf`` engine, atomically (a temporary name, renamed).

Study results become one dataset whose dimensions are the sweep parameters (sweep, camera,
integration time, pixel pitch) and whose variables are the results table's numeric columns.
"""

from __future__ import annotations

import tomllib
from pathlib import Path

import numpy as np

from radiosim.errors import RadiosimError
from radiosim.files import atomic_path
from radiosim.measurement import Measurement

__all__ = ["to_xarray", "from_xarray", "write_netcdf", "read_netcdf", "results_to_xarray"]

_ARRAYS = Measurement.ARRAYS
_FLAGS = ("saturated", "under_range", "over_range")


def to_xarray(measurement: Measurement):
    """The measurement as an :class:`xarray.Dataset` (:meth:`Measurement.to_xarray`)."""
    return measurement.to_xarray()


def from_xarray(dataset) -> Measurement:
    """The :class:`~radiosim.measurement.Measurement` of a dataset made by
    :func:`to_xarray` (values, flags, units, camera and scene)."""
    from radiosim.camera import Camera

    missing = [n for n in (*_ARRAYS, "camera") if n not in dataset.variables
               and n not in dataset.attrs]
    if missing:
        raise RadiosimError(f"not a radiosim measurement: missing {', '.join(missing)}")
    attrs = dataset.attrs
    camera = Camera.from_dict(tomllib.loads(attrs["camera"]))
    arrays = {}
    for name in _ARRAYS:
        values = np.asarray(dataset[name].values)
        arrays[name] = values.astype(bool) if name in _FLAGS else values.astype(np.float64)
    scene = {k[len("scene:"):]: (v.item() if isinstance(v, np.generic) else v)
             for k, v in attrs.items() if k.startswith("scene:")}
    return Measurement(**arrays, signal_unit=str(attrs["signal_unit"]), camera=camera,
                       integration_time=float(attrs["integration_time_s"]),
                       t_start=float(attrs["t_start_s"]), n_frames=int(attrs["n_frames"]),
                       scene=scene, alignment=str(attrs["alignment"]))


def write_netcdf(path, measurement_or_dataset) -> Path:
    """Write a measurement (or a dataset) to a NetCDF-4 file, atomically."""
    path = Path(path)
    dataset = (to_xarray(measurement_or_dataset)
               if isinstance(measurement_or_dataset, Measurement) else measurement_or_dataset)
    with atomic_path(path) as temporary:
        dataset.to_netcdf(temporary, engine="h5netcdf")
    return path


def read_netcdf(path) -> Measurement:
    """Read a measurement written by :func:`write_netcdf`."""
    import xarray as xr

    path = Path(path)
    if not path.is_file():
        raise RadiosimError(f"{path} does not exist")
    try:
        with xr.open_dataset(path, engine="h5netcdf") as dataset:
            dataset.load()
            return from_xarray(dataset)
    except RadiosimError:
        raise
    except Exception as exc:  # a broken file: one line naming it
        raise RadiosimError(f"cannot read NetCDF file {path}: {exc}") from None


#: The results table's columns that label a measurement: the dataset's dimensions.
RESULT_DIMENSIONS = ("sweep", "camera", "response", "alignment", "integration_time_us",
                     "pixel_pitch_um")


def results_to_xarray(rows: list[dict], name: str = "study"):
    """
    A study's results table as one dataset: dimensions ``sweep``, ``camera``, ``response``,
    ``alignment``, ``integration_time_us`` and ``pixel_pitch_um``, a variable per numeric
    column (NaN where a combination was not measured). Two rows with the same labels (a study
    that measured a case twice) are refused rather than merged.
    """
    import pandas as pd

    if not rows:
        raise RadiosimError("no results to label")
    frame = pd.DataFrame(rows)
    for column in frame.columns:  # numbers with gaps ("" where a summary has no value)
        if column not in RESULT_DIMENSIONS and frame[column].dtype == object:
            converted = pd.to_numeric(frame[column].replace("", np.nan), errors="coerce")
            if converted.notna().sum() == (frame[column] != "").sum():
                frame[column] = converted
    numeric = [c for c in frame.columns if c not in RESULT_DIMENSIONS
               and pd.api.types.is_numeric_dtype(frame[c])]
    frame = frame.set_index(list(RESULT_DIMENSIONS))[numeric]
    if frame.index.has_duplicates:
        twice = frame.index[frame.index.duplicated()][0]
        raise RadiosimError(f"two results share the labels {dict(zip(RESULT_DIMENSIONS, twice))}:"
                            " a dataset can hold each case once")
    dataset = frame.to_xarray()
    dataset.attrs["study"] = name
    for dim, unit in (("integration_time_us", "us"), ("pixel_pitch_um", "um")):
        dataset[dim].attrs["units"] = unit
    for column in numeric:
        unit = column.rsplit("_", 1)[-1] if "_" in column else ""
        if unit in ("K", "C", "us", "um", "um2"):
            dataset[column].attrs["units"] = unit
    return dataset
