"""
Camera presets: the TOML schema of a camera, and the shipped preset files.

A camera file has top-level keys (``name``, ``response``, ``frame_rate_hz``,
``assumed_emissivity``, ``linear_responsivity_e_per_s_per_K``, ``calibration_range_K``) and
``[optics]``, ``[fpa]`` and ``[electronics]`` tables; every key carries its unit and lengths
are in µm. The keys are declared once, on the dataclass fields (:func:`radiosim.config.edge_field`),
and read and written by :mod:`radiosim.config`. Spectral curves are shipped names, CSV paths
(relative to the file), numbers, or inline tables ``{name, wavelength_um = [...], value = [...]}``.

Presets live in ``radiosim/presets`` (:func:`available_presets`).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from radiosim.config import fields_from_table, from_table, to_table
from radiosim.electronics import Electronics
from radiosim.errors import RadiosimError
from radiosim.fpa import FocalPlaneArray
from radiosim.optics import Optics
from radiosim.psf import as_psf
from radiosim.spectral import (available_spectra, is_spectrum, read_spectrum,
                               spectral_distribution)

__all__ = ["PRESET_DIRECTORY", "available_presets", "camera_fields", "camera_table",
           "SECTIONS"]

#: Folder of the shipped camera presets.
PRESET_DIRECTORY = Path(__file__).resolve().parent / "presets"

#: The camera file's tables and the component each describes.
SECTIONS = {"optics": Optics, "fpa": FocalPlaneArray, "electronics": Electronics}


def available_presets() -> tuple[str, ...]:
    """
    Names of the shipped camera presets.

    Examples
    --------
    >>> "nist-ir" in available_presets()
    True
    """
    return tuple(sorted(p.stem for p in PRESET_DIRECTORY.glob("*.toml")))


def _curve_reader(base: Path | None):
    def read(key, value):
        if isinstance(value, str) and base is not None and (base / value).is_file():
            return base / value
        if isinstance(value, dict):
            try:
                return spectral_distribution(np.asarray(value["wavelength_um"]) * 1e-6,
                                             value["value"], value.get("name", key))
            except KeyError as exc:
                raise RadiosimError(f"inline curve {key} needs wavelength_um and value lists, "
                                    f"missing {exc}") from None
        if isinstance(value, bool) or not isinstance(value, (str, int, float)):
            raise RadiosimError(f"{key} must be a curve name, a CSV path, a number or an inline "
                                f"table, got {value!r}")
        return value
    return read


def _curve_entry(value):
    """A curve as a shipped name (if it is one, unchanged) or an inline table."""
    if not is_spectrum(value):
        return float(value)
    name = value.name
    if name in available_spectra():
        shipped = read_spectrum(name)
        if np.array_equal(shipped.domain, value.domain) and np.array_equal(shipped.values,
                                                                           value.values):
            return name
    return {"name": name, "wavelength_um": (np.asarray(value.domain) * 1e6).tolist(),
            "value": np.asarray(value.values).tolist()}


def camera_fields(camera_class, data: dict, base: Path | None = None) -> dict:
    """
    The keyword arguments of ``camera_class`` from a camera table (a dict as parsed from TOML),
    converted to SI, with its components built.
    """
    data = dict(data)
    converters = {"curve": _curve_reader(base), "psf": lambda key, value: as_psf(value, base)}
    data.pop("description", None)
    components = {}
    for name, component in SECTIONS.items():
        table = data.pop(name, {})
        if not isinstance(table, dict):
            raise RadiosimError(f"[{name}] must be a table, got {table!r}")
        required = ("pixel_pitch_um",) if name == "fpa" else ()
        components[name] = from_table(component, table, f"[{name}]", converters, required)
    return fields_from_table(camera_class, data, "camera",
                             ignore=(*SECTIONS, "description")) | components


def camera_table(camera) -> dict:
    """
    A camera in the preset structure (edge units in the keys), so that :func:`camera_fields`
    rebuilds it exactly. Shipped curves are named; others are inlined.
    """
    converters = {"curve": _curve_entry, "psf": lambda psfs: [p.to_table() for p in psfs]}
    out = to_table(camera, converters)
    for name in SECTIONS:
        out[name] = to_table(getattr(camera, name), converters)
    return out
