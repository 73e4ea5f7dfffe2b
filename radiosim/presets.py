"""
Camera presets: the TOML schema of a camera, and the shipped preset files.

A camera file has top-level keys (``name``, ``response``, ``frame_rate_hz``,
``assumed_emissivity``, ``linear_responsivity_e_per_s_per_K``, ``calibration_range_K``) and
``[optics]``, ``[fpa]`` and ``[electronics]`` tables; every key carries its unit and lengths
are in µm. A multi-channel (two-colour) camera adds ``assumed_emissivity_ratio`` and one
``[[channels]]`` table per spectral channel (:class:`~radiosim.ratio.Channel`: ``band_um``, and
optionally ``spectral_filter``, ``integration_time_us``, ``time_offset_us``,
``registration_offset_um``, ``[[channels.psf]]`` and ``[channels.electronics]``). The keys
are declared once, on the dataclass fields (:func:`radiosim.config.edge_field`), and read
and written by :mod:`radiosim.config`. Spectral curves are shipped names, CSV paths (relative
to the file), numbers, or inline tables ``{name, wavelength_um = [...], value = [...]}``.

Presets live in ``radiosim/presets`` (:func:`available_presets`).
"""

from __future__ import annotations

import dataclasses
import difflib
from pathlib import Path

import numpy as np

from radiosim.config import fields_from_table, from_table, to_table
from radiosim.electronics import Electronics
from radiosim.errors import RadiosimError
from radiosim.fpa import FocalPlaneArray
from radiosim.optics import Optics
from radiosim.psf import as_psf
from radiosim.ratio import Channel
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
    channels = data.pop("channels", None)
    if channels is not None:
        components["channels"] = _channels_from(channels, converters)
    return fields_from_table(camera_class, data, "camera",
                             ignore=(*SECTIONS, "description")) | components


def _channels_from(tables, converters) -> tuple:
    """The :class:`~radiosim.ratio.Channel` of each ``[[channels]]`` table."""
    if not isinstance(tables, list) or not all(isinstance(t, dict) for t in tables):
        raise RadiosimError(f"channels must be [[channels]] tables, got {tables!r:.80}")
    if not tables:
        raise RadiosimError("channels = []: a camera with channels needs at least one "
                            "[[channels]] table")
    known = {f.metadata["toml"] for f in dataclasses.fields(Channel) if "toml" in f.metadata}
    out = []
    for k, table in enumerate(tables, 1):
        what = f"[[channels]] {k}"
        table = dict(table)
        for key, value in table.items():
            if key not in known and key != "electronics":
                close = difflib.get_close_matches(key, sorted(known), n=1)
                hint = f" (did you mean {close[0]}?)" if close else ""
                raise RadiosimError(f"{what}: unknown key {key} = {value!r}{hint}; known: "
                                    f"{', '.join(sorted(known | {'electronics'}))}")
        extra = {}
        if "electronics" in table:
            extra["electronics"] = from_table(Electronics, table.pop("electronics"),
                                              f"{what} electronics")
        out.append(from_table(Channel, table, what, converters, ("band_um",), extra))
    return tuple(out)


def camera_table(camera) -> dict:
    """
    A camera in the preset structure (edge units in the keys), so that :func:`camera_fields`
    rebuilds it exactly. Shipped curves are named; others are inlined.
    """
    converters = {"curve": _curve_entry, "psf": lambda psfs: [p.to_table() for p in psfs]}
    out = to_table(camera, converters)
    if out.get("assumed_emissivity_ratio") == 1.0:  # the default: files stay as before
        del out["assumed_emissivity_ratio"]
    for name in SECTIONS:
        out[name] = to_table(getattr(camera, name), converters)
    if camera.channels is not None:
        out["channels"] = []
        for channel in camera.channels:
            table = to_table(channel, converters)
            if table.get("time_offset_us") == 0.0:
                del table["time_offset_us"]
            if table.get("registration_offset_um") == [0.0, 0.0]:
                del table["registration_offset_um"]
            if channel.electronics is not None:
                table["electronics"] = to_table(channel.electronics, converters)
            out["channels"].append(table)
    return out
