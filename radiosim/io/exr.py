"""
Measurements as multi-channel float32 OpenEXR files, with typed metadata.

Channels (all FLOAT, i.e. float32; masks hold 0 or 1; NaN where a pixel has no reading), from
the table of fields :data:`radiosim.measurement.FIELDS` (:data:`CHANNELS`; the units as the
header writes them: counts in ``DN``, charge in ``e-``, where NetCDF says ``1``):

=========================  ==========================================================
channel                    content [unit]
=========================  ==========================================================
``apparent_temperature``   temperature the camera reports [K]
``counts``                 digital numbers [DN]
``electrons``              charge in the well [e-]
``saturated``              1 where saturated [1]
``under_range``            1 where under range [1]
``over_range``             1 where above the calibration range, not saturated [1]
``peak_error``             tensor max − apparent temperature [K]
``uncertainty``            tensor standard deviation [K]
``tensor_max``             maximum scene temperature over footprint × window [K]
``tensor_mean``            mean scene temperature over footprint × window [K]
``signal_mean``            mean response signal [``radiosim:signal_unit``]
=========================  ==========================================================

Header attributes (typed: doubles as 1-element double arrays, which OpenEXR keeps at 64 bit;
plain floats would be stored as 32-bit): ``radiosim:version``, ``radiosim:integration_time_s``,
``radiosim:t_start_s``, ``radiosim:n_frames``, ``radiosim:pixel_pitch_m``,
``radiosim:response``, ``radiosim:signal_unit``, ``radiosim:camera_name``, ``radiosim:camera``
(the camera as a TOML preset, which rebuilds it exactly), ``radiosim:unit:<channel>`` and
``scene:<key>`` for every item of the scene's description.

A multi-channel (two-colour) measurement (:mod:`radiosim.ratio`) adds each spectral channel's
fields as the layer ``ch<k>`` (``ch1.counts``, …, its band [m] in ``radiosim:band_m:ch<k>``)
and the ``ratio_temperature`` and ``ratio_netd`` channels [K]; :func:`read_exr` reads the
measurement's own fields (the NetCDF file keeps the channels whole). A single-channel
measurement's file is as before.
"""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

import numpy as np

from radiosim.errors import RadiosimError
from radiosim.files import atomic_path, native_output_silenced, why_not_a_file
from radiosim.measurement import FIELDS, Measurement

__all__ = ["CHANNELS", "write_exr", "read_exr", "write_exr_sequence", "read_exr_sequence",
           "write_channels", "UNCERTAINTY_CHANNELS", "write_uncertainty_exr"]

#: Channel name → unit as the header states it (``signal_mean``'s unit is the measurement's
#: ``signal_unit``), from the one table of fields :data:`radiosim.measurement.FIELDS`.
CHANNELS = {f.channel: f.unit for f in FIELDS if f.channel is not None}

#: Channel name → the measurement's field it holds.
_FIELD_OF = {f.channel: f.name for f in FIELDS if f.channel is not None}
_PREFIX = "radiosim:"


def _typed(value):
    """A header value OpenEXR stores with its full precision."""
    if isinstance(value, bool):
        return int(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        return np.array([float(value)], dtype=np.float64)
    if isinstance(value, (list, tuple)):
        return np.array([float(v) for v in value], dtype=np.float64)
    return str(value)


def _untyped(value):
    if isinstance(value, np.ndarray):
        return float(value[0]) if value.size == 1 else [float(v) for v in value]
    return value


def write_exr(path, measurement: Measurement) -> Path:
    """
    Write a measurement to one multi-channel float32 EXR file, atomically.

    The file is written next to its destination under a temporary name and renamed into place,
    so an error never leaves a half-written file (nor destroys an existing one).

    Parameters
    ----------
    path
        Destination ``.exr`` path; its folder must exist.
    measurement
        The :class:`~radiosim.Measurement`.

    Returns
    -------
    pathlib.Path
        The path written.
    """
    from radiosim import __version__

    m = measurement
    channels = {}
    for name in CHANNELS:
        values = getattr(m, _FIELD_OF[name])
        channels[name] = np.ascontiguousarray(values, dtype=np.float32)
    header = {
        _PREFIX + "version": __version__,
        _PREFIX + "integration_time_s": _typed(m.integration_time),
        _PREFIX + "t_start_s": _typed(m.t_start),
        _PREFIX + "n_frames": int(m.n_frames),
        _PREFIX + "pixel_pitch_m": _typed(m.camera.fpa.pixel_pitch),
        _PREFIX + "response": m.camera.response,
        _PREFIX + "signal_unit": m.signal_unit,
        _PREFIX + "camera_name": m.camera.name,
        _PREFIX + "camera": m.camera.to_toml(),
    }
    for name, unit in CHANNELS.items():
        header[f"{_PREFIX}unit:{name}"] = unit or m.signal_unit
    for key, value in m.scene.items():
        header[f"scene:{key}"] = _typed(value)
    if m.channels:
        _add_spectral_channels(m, channels, header)
    return write_channels(path, channels, header)


def _add_spectral_channels(m: Measurement, channels: dict, header: dict):
    """A multi-channel measurement's extra EXR channels: each spectral channel k's fields as
    the layer ``ch<k>`` (``ch1.apparent_temperature``, …; its band in
    ``radiosim:band_m:ch<k>``), and ``ratio_temperature`` and ``ratio_netd`` [K]."""
    for k, own in enumerate(m.channels, 1):
        for name, unit in CHANNELS.items():
            channels[f"ch{k}.{name}"] = np.ascontiguousarray(getattr(own, _FIELD_OF[name]),
                                                             dtype=np.float32)
            header[f"{_PREFIX}unit:ch{k}.{name}"] = unit or m.signal_unit
        header[f"{_PREFIX}band_m:ch{k}"] = _typed(own.camera.optics.band)
    if m.ratio_temperature is not None:
        for name in ("ratio_temperature", "ratio_netd"):
            channels[name] = np.ascontiguousarray(getattr(m, name), dtype=np.float32)
            header[f"{_PREFIX}unit:{name}"] = "K"


def write_channels(path, channels: dict, header: dict) -> Path:
    """
    Write float32 ``channels`` (name → 2-D array) and ``header`` attributes (typed with
    :func:`_typed` by the caller) to one EXR file, atomically (a temporary name, renamed; an
    error or interrupt leaves nothing behind). The written file is read back and compared with
    the channels before the rename: a write the EXR library did not complete (a full disk it
    did not report) fails, and an earlier file at ``path`` stays as it was.
    """
    import OpenEXR

    path = Path(path)
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage, **header}
    channels = {k: np.ascontiguousarray(v, dtype=np.float32) for k, v in channels.items()}
    with atomic_path(path) as temporary:
        with OpenEXR.File(header, dict(channels)) as exr:  # (it converts the dict it gets)
            exr.write(str(temporary))
        _check_written(temporary, channels)
    return path


def _check_written(temporary: Path, channels: dict) -> None:
    """Raise ``OSError`` unless the EXR file ``temporary`` reads back with exactly
    ``channels`` (their names, shapes and bits)."""
    import OpenEXR

    try:
        with OpenEXR.File(str(temporary), separate_channels=True) as back:
            stored = {name: channel.pixels for name, channel in back.channels().items()}
    except Exception as exc:  # noqa: BLE001 - whatever the library says: the file is bad
        raise OSError(f"the file written does not read back ({exc})") from exc
    if set(stored) != set(channels) or any(
            stored[k].shape != v.shape or not np.array_equal(stored[k], v, equal_nan=True)
            for k, v in channels.items()):
        raise OSError("the file written does not read back as written (a full disk?)")


#: Channels of an uncertainty evaluation's EXR file, with their units.
UNCERTAINTY_CHANNELS = {"mean": "K", "std": "K", "low_95": "K", "high_95": "K",
                        "gum_std": "K", "truth": "K", "error": "K", "valid_fraction": "1"}


def write_uncertainty_exr(path, result, camera, integration_time: float) -> Path:
    """The per-pixel maps of an :class:`~radiosim.uncertainty.UncertaintyResult` as one EXR
    file (channels :data:`UNCERTAINTY_CHANNELS`; the camera as TOML in the header)."""
    from radiosim import __version__

    low, high = result.interval(0.95)
    channels = {"mean": result.mean, "std": result.std, "low_95": low, "high_95": high,
                "gum_std": result.gum_std, "truth": result.truth, "error": result.error,
                "valid_fraction": result.valid_fraction}
    header = {_PREFIX + "version": __version__, _PREFIX + "draws": int(result.draws),
              _PREFIX + "integration_time_s": _typed(integration_time),
              _PREFIX + "camera_name": camera.name, _PREFIX + "camera": camera.to_toml()}
    for name, unit in UNCERTAINTY_CHANNELS.items():
        header[f"{_PREFIX}unit:{name}"] = unit
    return write_channels(path, channels, header)


def read_exr(path) -> Measurement:
    """
    Read a measurement written by :func:`write_exr`.

    Arrays come back as float64 holding the file's float32 values, masks as booleans, the
    camera rebuilt from its TOML, the scene description from the ``scene:`` attributes.
    """
    import OpenEXR

    from radiosim.camera import Camera

    path = Path(path)
    why = why_not_a_file(path)
    if why is not None:
        raise RadiosimError(f"{path} is a folder, not an EXR file" if path.is_dir()
                            else f"{path} {why}")
    try:
        with native_output_silenced(), OpenEXR.File(str(path)) as exr:
            header = dict(exr.header())
            pixels = {name: np.array(ch.pixels) for name, ch in exr.channels().items()}
    except Exception as exc:
        raise RadiosimError(f"cannot read EXR file {path}: {exc}") from None
    missing = [c for c in CHANNELS if c not in pixels and c != "over_range"]  # older files
    if missing or _PREFIX + "camera" not in header:
        raise RadiosimError(f"{path} is not a radiosim measurement (missing "
                            f"{', '.join(missing) or 'the radiosim:camera attribute'})")
    camera = Camera.from_dict(tomllib.loads(header[_PREFIX + "camera"]))
    scene = {k[len("scene:"):]: _untyped(v) for k, v in header.items() if k.startswith("scene:")}

    def arr(name):
        return pixels[name].astype(np.float64)

    return Measurement(
        apparent_temperature=arr("apparent_temperature"),
        counts=arr("counts"),
        electrons=arr("electrons"),
        saturated=pixels["saturated"] > 0.5,
        under_range=pixels["under_range"] > 0.5,
        over_range=pixels["over_range"] > 0.5 if "over_range" in pixels else None,
        tensor_max=arr("tensor_max"),
        tensor_mean=arr("tensor_mean"),
        tensor_std=arr("uncertainty"),
        signal_mean=arr("signal_mean"),
        signal_unit=header[_PREFIX + "signal_unit"],
        camera=camera,
        integration_time=_untyped(header[_PREFIX + "integration_time_s"]),
        t_start=_untyped(header[_PREFIX + "t_start_s"]),
        n_frames=int(header[_PREFIX + "n_frames"]),
        scene=scene,
    )


def write_exr_sequence(folder, measurements, stem: str = "frame") -> list[Path]:
    """
    Write a recording (measurements in time order) as numbered files ``stem_0000.exr`` … .
    """
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    width = max(4, len(str(len(measurements) - 1)))
    return [write_exr(folder / f"{stem}_{i:0{width}d}.exr", m)
            for i, m in enumerate(measurements)]


def read_exr_sequence(folder, stem: str = "frame") -> list[Measurement]:
    """Read the numbered files written by :func:`write_exr_sequence`, in the order of their
    numbers; a duplicate or missing number raises, naming the files."""
    from radiosim.scenes.exr_sequence import check_numbering

    files = sorted(Path(folder).glob(f"{stem}_*.exr"),
                   key=lambda f: [int(t) if t.isdigit() else t for t in re.split(r"(\d+)", f.name)])
    if not files:
        raise RadiosimError(f"no {stem}_*.exr files in {folder}")
    check_numbering(files)
    return [read_exr(f) for f in files]
