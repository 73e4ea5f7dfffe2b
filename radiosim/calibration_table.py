"""
Calibrating a camera from a measured table: a CSV of blackbody temperatures against mean counts
(:func:`read_calibration_table`, which refuses a table whose columns contradict each other), and
the fit of the camera's gain and offset to it (:func:`calibrate_from_table`, what ``radiosim
calibrate`` does, through :func:`radiosim.calibration.fit_calibration`).
"""

from __future__ import annotations

import collections
import dataclasses
import os
from dataclasses import dataclass

import numpy as np

from radiosim.calibration import fit_calibration
from radiosim.checks import check_count, check_time
from radiosim.errors import RadiosimError
from radiosim.units import to_celsius, to_kelvin

__all__ = ["CalibrationTable", "read_calibration_table", "calibrate_from_table",
           "check_tables_per_channel", "fitted_camera_toml"]


@dataclass(frozen=True)
class CalibrationTable:
    """
    A measured calibration table, read and checked (:func:`read_calibration_table`).

    Attributes
    ----------
    temperature : numpy.ndarray
        Blackbody temperatures [K].
    counts : numpy.ndarray
        Mean counts [DN].
    instrument_temperature : numpy.ndarray or None
        Instrument temperatures [K] of each row, if the table gives them.
    """

    temperature: np.ndarray
    counts: np.ndarray
    instrument_temperature: np.ndarray | None = None


def _column(path, rows, name, line_of) -> np.ndarray:
    values = []
    for k, row in enumerate(rows):
        text = row.get(name)
        try:
            values.append(float(text))
        except (TypeError, ValueError):
            raise RadiosimError(f"{path}: line {line_of[k]}, column {name} = {text!r}: "
                                "expected a number") from None
    values = np.array(values)
    if not np.all(np.isfinite(values)):
        k = int(np.argmax(~np.isfinite(values)))
        raise RadiosimError(f"{path}: line {line_of[k]}, column {name} = {values[k]}: expected "
                            "a finite number")
    return values


def _temperature(path, rows, columns, stem, line_of, stated):
    """A temperature column [K] given as ``stem_K`` and/or ``stem_C``; both must agree, and
    with the unit a ``# units:`` line states."""
    found = {u: to_kelvin(_column(path, rows, f"{stem}_{u}", line_of), u)
             for u in ("K", "C") if f"{stem}_{u}" in columns}
    if not found:
        return None
    if stated is not None and stated not in found:
        given = next(iter(found))
        raise RadiosimError(f"{path}: column {stem}_{given} is in {given}, but the file's units "
                            f"line says {stem.split('_')[0]}={stated}")
    if len(found) == 2:
        differ = ~np.isclose(found["K"], found["C"], rtol=0, atol=0.01)
        if differ.any():
            k = int(np.argmax(differ))
            raise RadiosimError(
                f"{path}: columns {stem}_K and {stem}_C disagree at line {line_of[k]}: "
                f"{found['K'][k]:g} K against {to_celsius(found['C'][k]):g} °C = "
                f"{found['C'][k]:g} K")
    return found["K"] if "K" in found else found["C"]


def read_calibration_table(path, monotonic: bool = True) -> CalibrationTable:
    """
    Read a calibration table: a CSV with ``temperature_K`` (or ``temperature_C``) and
    ``counts`` columns, optionally ``instrument_temperature_K`` (or ``_C``); ``#`` lines are
    comments, and a ``# units: temperature=C`` line states units the columns must agree with.
    A table whose columns contradict each other is refused naming the file and the column:
    a column given twice, a temperature in both units that disagree, a units line that
    disagrees with a column's suffix, a value that is not a number, or (with ``monotonic``)
    counts that fall as the temperature rises at all. (:func:`calibrate_from_table` leaves
    that to the fit, which knows the counts' noise: a dip within it is no contradiction.)
    """
    import csv
    import re
    from pathlib import Path

    from radiosim.errors import RadiosimIOError

    from radiosim.files import why_not_a_file

    path = Path(path)
    why = why_not_a_file(path)
    if why is not None:
        raise RadiosimError(f"{path} {why} (expected a CSV of temperature_K or "
                            "temperature_C, and counts)")
    try:
        text = path.read_text(encoding="utf-8-sig")
    except UnicodeDecodeError as exc:
        raise RadiosimError(f"cannot read {path}: not UTF-8 text ({exc.reason})") from None
    except OSError as exc:
        raise RadiosimIOError(f"cannot read {path}: {exc.strerror or exc}") from None
    lines = text.splitlines()
    stated = {}
    data_lines = []
    for number, line in enumerate(lines, start=1):
        if line.lstrip().startswith("#"):
            match = re.match(r"#\s*units?\s*:\s*(.*)$", line.strip(), re.IGNORECASE)
            for item in re.split(r"[,;\s]+", match.group(1)) if match else ():
                if "=" in item:
                    key, _, unit = item.partition("=")
                    unit = unit.strip().upper().replace("°", "")
                    stated[key.strip().lower()] = unit
        elif line.strip():
            data_lines.append((number, line))
    if not data_lines:
        raise RadiosimError(f"{path}: no header and no rows (expected columns temperature_K or "
                            "temperature_C, and counts)")
    try:
        parsed = list(csv.reader([line for _, line in data_lines]))
    except csv.Error as exc:
        raise RadiosimError(f"{path}: not a valid CSV: {exc}") from None
    header = [h.strip() for h in parsed[0]]
    times = collections.Counter(header)  # one pass: a long header line is no hang
    duplicate = sorted(h for h, n in times.items() if n > 1)
    if duplicate:
        raise RadiosimError(f"{path}: column {duplicate[0]} appears {times[duplicate[0]]} "
                            "times in the header; give each column once")
    if "counts" not in header and not any(h.startswith("temperature") for h in header):
        found = ", ".join(header)  # not a calibration table at all (a TOML file, say)
        found = found if len(found) <= 60 else found[:60] + "…"
        raise RadiosimError(f"{path}: needs columns temperature_K (or temperature_C) and "
                            f"counts; its first line is {found!r}")
    rows, line_of = [], []
    for (number, _), values in zip(data_lines[1:], parsed[1:]):
        if len(values) != len(header):
            raise RadiosimError(f"{path}: line {number} has {len(values)} values for "
                                f"{len(header)} columns ({', '.join(header)})")
        rows.append(dict(zip(header, values)))
        line_of.append(number)
    columns = set(header)
    for stem in ("temperature", "instrument_temperature"):
        unit = stated.get(stem)
        if unit is not None and unit not in ("K", "C"):
            raise RadiosimError(f"{path}: units line gives {stem}={unit}; expected K or C")
    temperature = _temperature(path, rows, columns, "temperature", line_of,
                               stated.get("temperature"))
    if temperature is None or "counts" not in columns:
        other = next((name for sep, name in ((";", "semicolons"), ("\t", "tabs"))
                      if len(header) == 1 and sep in header[0]), None)
        hint = f" (its columns are separated by {other}; radiosim reads commas)" if other else ""
        raise RadiosimError(f"{path}: needs columns temperature_K (or temperature_C) and "
                            f"counts, found {', '.join(header)}{hint}")
    if not rows:
        raise RadiosimError(f"{path}: the table has a header but no rows")
    counts = _column(path, rows, "counts", line_of)
    instrument = _temperature(path, rows, columns, "instrument_temperature", line_of,
                              stated.get("instrument_temperature"))
    if np.any(temperature <= 0):
        k = int(np.argmax(temperature <= 0))
        if "temperature_K" in columns:
            raise RadiosimError(f"{path}: line {line_of[k]}: temperature {temperature[k]:g} K "
                                "is not above 0 K (°C in a temperature_K column?)")
        raise RadiosimError(f"{path}: line {line_of[k]}: temperature_C "
                            f"{to_celsius(temperature[k]):g} °C is below absolute zero "
                            "(-273.15 °C)")
    if instrument is None and monotonic:
        order = np.argsort(temperature, kind="stable")
        ts, ys = temperature[order], counts[order]
        fall = (np.diff(ts) > 0) & (np.diff(ys) < 0)
        if fall.any():
            j = int(np.argmax(fall))
            a, b = line_of[order[j]], line_of[order[j + 1]]
            raise RadiosimError(
                f"{path}: column counts is not monotonic in temperature: {ys[j]:g} DN at "
                f"{ts[j]:g} K (line {a}) but {ys[j + 1]:g} DN at {ts[j + 1]:g} K (line {b})")
    return CalibrationTable(temperature, counts, instrument)


def check_tables_per_channel(camera, path) -> list:
    """The calibration tables ``path`` (one, or a list) as a list, one per channel of
    ``camera`` in order; a count that does not match is refused in one line naming the
    channels without a table."""
    paths = [path] if isinstance(path, (str, os.PathLike)) else list(path)
    cameras = camera.channel_cameras
    if len(paths) == len(cameras):
        return paths
    if camera.channels is None:
        raise RadiosimError(f"{camera.name} has one band: give one calibration table, got "
                            f"{len(paths)} ({', '.join(str(p) for p in paths)})")
    missing = ", ".join(f"channel {k + 1} ({lo * 1e6:g}–{hi * 1e6:g} µm)"
                        for k, (lo, hi) in enumerate(c.band for c in camera.channels)
                        if k >= len(paths))
    raise RadiosimError(
        f"{camera.name} has {len(cameras)} channels: give one calibration table per channel, "
        f"in order; got {len(paths)}"
        + (f", none for {missing}" if missing else f": {len(paths) - len(cameras)} too many"))


def calibrate_from_table(camera, path, integration_time: float, frames: int = 1,
                         exclude_unusable: bool = False, fit_full_well: bool = False,
                         progress=None):
    """
    What ``radiosim calibrate`` does: read and check the table at ``path``
    (:func:`read_calibration_table`), check ``integration_time`` [s] and ``frames`` (a whole
    number ≥ 1 of read-outs averaged in each counts value), and fit the camera
    (:func:`~radiosim.calibration.fit_calibration`); errors name the file. ``progress``, if
    given, is called as ``progress(done, total, label)`` after each of the three steps (the
    table read, the camera's response built, the fit) of each table.

    A camera of several channels is calibrated channel by channel: ``path`` is then a list of
    tables, one per channel in order (each blackbody measured through that channel), each
    fitting its channel's electronics (gain and offset; the channels share the optics, so a
    channel's table cannot fit their emissivity); a missing table is refused naming its
    channel.

    Returns
    -------
    camera, residuals, table
        The fitted camera, measured minus fitted counts [DN], the :class:`CalibrationTable`
        (for several channels: lists of the residuals and tables, one per channel).
    """
    frames = check_count(frames, "frames (read-outs averaged per counts value)")
    t_int = check_time(integration_time, "integration_time")
    paths = check_tables_per_channel(camera, path)
    cameras = camera.channel_cameras
    total = 3 * len(paths)

    def step(done, label):
        if progress is not None:
            progress(done, total, label)

    fits = []
    for k, (own, table_path) in enumerate(zip(cameras, paths)):
        table = read_calibration_table(table_path, monotonic=False)  # the fit judges dips
        which = f" ({own.name})" if camera.channels is not None else ""
        if camera.channels is not None and table.instrument_temperature is not None:
            raise RadiosimError(f"{table_path}: a channel's table cannot fit the optics' "
                                "emissivity (the channels share the optics): drop its "
                                "instrument-temperature column, or fit one band")
        step(3 * k + 1, f"read {len(table.temperature)} points{which}")
        own.response_model  # the response (for Planck, its radiance table), built once
        step(3 * k + 2, f"the response{which}")
        try:
            fitted, residuals = fit_calibration(
                own, table.temperature, table.counts, t_int, frames,
                instrument_temperatures=table.instrument_temperature,
                exclude_unusable=exclude_unusable, fit_full_well=fit_full_well)
        except RadiosimError as exc:
            raise RadiosimError(f"{table_path}: {exc}") from None
        step(3 * k + 3, f"fitted gain and offset{which}")
        fits.append((fitted, residuals, table))
    if camera.channels is None:
        return fits[0]
    channels = tuple(dataclasses.replace(channel, electronics=fitted.electronics)
                     for channel, (fitted, _, _) in zip(camera.channels, fits))
    return (camera.replace(channels=channels), [r for _, r, _ in fits],
            [t for _, _, t in fits])


def fitted_camera_toml(original, fitted, source, table, integration_time: float) -> str:
    """
    The camera file of a calibration: ``fitted`` (named ``<name>-fitted``) as TOML, written
    over the text of the camera file it came from (``source``: a TOML path, a preset's name, or
    ``None`` for a camera without a file) so that the file's comments and layout stay and only
    the values the fit changed are replaced; headed by a record of the fit — radiosim's
    version, the date (UTC), the table's path and SHA-256 (each table's, one per channel),
    the integration time [s].
    """
    import datetime
    import hashlib
    from pathlib import Path

    import tomlkit

    from radiosim._version import __version__

    tables = ([Path(table)] if isinstance(table, (str, os.PathLike))
              else [Path(t) for t in table])
    stamp = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")
    header = (f"# Calibrated by radiosim {__version__} on {stamp} at "
              f"{integration_time * 1e6:g} µs:\n")
    for k, path in enumerate(tables):
        digest = hashlib.sha256(path.read_bytes()).hexdigest()
        which = f"channel {k + 1}: " if len(tables) > 1 else ""
        header += f"# {which}fitted to {path} (sha256 {digest});\n"
    header += "# the values the fit changed replace the original's, its comments kept.\n"
    fitted = fitted.replace(name=f"{original.name}-fitted")
    if source is not None and not str(source).endswith(".toml"):
        from radiosim.presets import PRESET_DIRECTORY

        source = PRESET_DIRECTORY / f"{source}.toml"
        source = source if source.is_file() else None
    if source is None:
        return header + fitted.to_toml()
    document = tomlkit.parse(Path(source).read_text(encoding="utf-8"))
    _replace_changed(document, original.to_dict(), fitted.to_dict())
    return header + tomlkit.dumps(document)


def _replace_changed(document, before: dict, after: dict) -> None:
    """Set in ``document`` (a tomlkit table) each value of ``after`` that differs from
    ``before``'s, recursing into tables; untouched keys keep their text and comments."""
    for key, value in after.items():
        if isinstance(value, dict):
            if key in document:
                _replace_changed(document[key], before.get(key, {}), value)
            elif value != before.get(key):
                document[key] = value
        elif value != before.get(key):
            document[key] = value
