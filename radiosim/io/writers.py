"""
Output formats by name, as the readers are (:data:`radiosim.io.SCENE_TYPES`):

-   :data:`MEASUREMENT_WRITERS`: one measurement to one file, by the file's suffix
    (``radiosim measure --out``): ``.exr`` (:func:`radiosim.io.exr.write_exr`, multi-channel
    EXR) and ``.nc`` (:func:`radiosim.io.netcdf.write_netcdf`, CF-1.8 NetCDF);
-   :data:`RESULTS_FORMATS`: what a study's run writes beside ``results.csv`` and its EXR files
    (``radiosim run --format``): ``exr`` (nothing more) and ``netcdf`` (``results.nc``, one
    record per measurement).

A new format is one module with its writer and one entry here. The writers load their module
when they write: naming the formats (``radiosim --help``) imports nothing heavy.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from pathlib import Path

__all__ = ["MeasurementWriter", "MEASUREMENT_WRITERS", "ResultsFormat", "RESULTS_FORMATS",
           "measurement_writer", "write_measurement", "write_exr_file", "write_results_netcdf"]


def _function(spec: str):
    """The function ``module:name``, its module imported now."""
    module, name = spec.split(":")
    return getattr(importlib.import_module(module), name)


@dataclass(frozen=True)
class MeasurementWriter:
    """Writes one measurement to a file of its suffix: ``function(path, measurement,
    history)`` (``module:name``; ``history``: what made it, or ``None``) returns the path
    written."""

    suffix: str
    description: str
    function: str

    def write(self, path, measurement, history: str | None = None) -> Path:
        """Write ``measurement`` to ``path`` (complete or absent); returns the path."""
        return _function(self.function)(path, measurement, history)


#: Measurement writers by suffix (lower case, with its dot).
MEASUREMENT_WRITERS: dict[str, MeasurementWriter] = {
    ".exr": MeasurementWriter(".exr", "multi-channel OpenEXR",
                              "radiosim.io.writers:write_exr_file"),
    ".nc": MeasurementWriter(".nc", "CF-1.8 NetCDF-4", "radiosim.io.netcdf:write_netcdf"),
}


def write_exr_file(path, measurement, history: str | None = None) -> Path:
    """:func:`radiosim.io.exr.write_exr` (its header records the measurement; ``history`` is
    not kept)."""
    from radiosim.io.exr import write_exr

    return write_exr(path, measurement)


def measurement_writer(path) -> MeasurementWriter | None:
    """The writer of ``path``'s suffix, or ``None``."""
    return MEASUREMENT_WRITERS.get(Path(path).suffix.lower())


def write_measurement(path, measurement, history: str | None = None) -> Path:
    """Write ``measurement`` to ``path`` in the format its suffix names
    (:data:`MEASUREMENT_WRITERS`)."""
    from radiosim.errors import RadiosimError

    writer = measurement_writer(path)
    if writer is None:
        raise RadiosimError(f"{path}: no measurement format for suffix "
                            f"{Path(path).suffix!r}; give one of "
                            f"{', '.join(MEASUREMENT_WRITERS)}")
    return writer.write(path, measurement, history)


@dataclass(frozen=True)
class ResultsFormat:
    """What a study's run writes beside ``results.csv`` and its EXR files: ``function(folder,
    result, history)`` (``module:name``, or ``None`` for nothing more) returns the paths it
    wrote into ``folder``."""

    name: str
    description: str
    function: str | None = None

    def write(self, folder, result, history: str | None = None) -> list[Path]:
        """Write ``result`` (a :class:`~radiosim.study.StudyResult`) into ``folder``."""
        if self.function is None:
            return []
        return list(_function(self.function)(Path(folder), result, history))


def write_results_netcdf(folder: Path, result, history: str | None = None) -> list[Path]:
    """``results.nc``: the study's results as one CF-1.8 dataset, one record per
    measurement."""
    from radiosim.io.netcdf import write_netcdf

    return [write_netcdf(folder / "results.nc", result.to_xarray(result.study,
                                                                 history=history))]


#: A run's output formats by name.
RESULTS_FORMATS: dict[str, ResultsFormat] = {
    "exr": ResultsFormat("exr", "CSV and EXR only"),
    "netcdf": ResultsFormat("netcdf", "also results.nc, the results as a CF-1.8 NetCDF file, "
                            "one record per measurement",
                            "radiosim.io.writers:write_results_netcdf"),
}
