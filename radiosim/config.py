"""
Configuration: TOML files ⇄ radiosim's dataclasses, in one place.

Camera presets, studies and the segmented chip's parameters are data files whose keys carry
their unit (``pixel_pitch_um``, ``period_us``, ``initial_temperature_C``). A dataclass field
declares its TOML key and conversion once, with :func:`edge_field`; :func:`from_table` reads a
table into SI values (checking types and naming unknown keys with the likely typo) and
:func:`to_table` writes them back exactly, so a file survives a round trip unchanged.
TOML is written by tomlkit, which keeps comments.
"""

from __future__ import annotations

import dataclasses
import difflib
import math
import re
import tomllib
from decimal import Decimal
from pathlib import Path

import numpy as np

from radiosim.errors import RadiosimError
from radiosim.units import shift

__all__ = [
    "edge_field",
    "edge_value",
    "si_value",
    "fields_from_table",
    "from_table",
    "read_number",
    "to_table",
    "load_toml",
    "build_from_toml",
    "dumps_toml",
    "reject_unknown",
    "build_checked",
]


def edge_field(default, key: str, scale: float = 1.0, offset: float = 0.0, doc: str = "",
               kind: str = "number", **kwargs):
    """
    A dataclass field with its TOML key (edge units) and conversion SI = value·scale + offset.

    ``kind`` is ``"number"``, ``"int"``, ``"numbers"`` (a list), ``"ints"``, ``"bool"``,
    ``"str"`` or a name the reader resolves through ``converters`` (e.g. ``"curve"``).
    """
    metadata = {"toml": key, "scale": scale, "offset": offset, "doc": doc, "kind": kind}
    if isinstance(default, (list, dict)):
        return dataclasses.field(default_factory=lambda: default, metadata=metadata, **kwargs)
    return dataclasses.field(default=default, metadata=metadata, **kwargs)


def _power_of_ten(scale: float) -> int | None:
    exponent = round(math.log10(scale))
    return exponent if math.isclose(10.0**exponent, scale, rel_tol=1e-15) else None


def si_value(value: float, scale: float = 1.0, offset: float = 0.0) -> float:
    """
    Edge unit → SI: exact on the decimal representation for powers of ten.

    Examples
    --------
    >>> si_value(3.8, 1e-6), si_value(739.0, 1.0, 273.15)
    (3.8e-06, 1012.15)
    """
    exponent = _power_of_ten(scale)
    scaled = shift(value, exponent) if exponent is not None else float(value) * scale
    return _add_exactly(scaled, offset) if offset else scaled


def _add_exactly(value: float, offset: float) -> float:
    """value + offset on their shortest decimal representations (21.3 + 273.15 = 294.45)."""
    if not math.isfinite(value):
        return value + offset
    return float(Decimal(repr(float(value))) + Decimal(repr(float(offset))))


def edge_value(value: float, scale: float = 1.0, offset: float = 0.0) -> float:
    """SI → edge unit (the inverse of :func:`si_value`)."""
    value = _add_exactly(float(value), -offset) if offset else float(value)
    exponent = _power_of_ten(scale)
    if exponent is not None:
        return shift(value, -exponent)
    return float(repr(round(value / scale, 12)))


def _is_number(value) -> bool:
    return isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value,
                                                                                        bool)


def _read_value(key: str, value, meta: dict, what: str, converters: dict):
    kind, scale, offset = meta["kind"], meta["scale"], meta["offset"]
    if value is None:
        return None
    if kind in ("number", "int"):
        if not _is_number(value):
            hint = " (a number written as a string? drop the quotes)" if isinstance(
                value, str) else ""
            raise RadiosimError(f"{what}: {key} must be a number, got {value!r}{hint}")
        if not math.isfinite(value):
            raise RadiosimError(f"{what}: {key} must be finite, got {value!r}")
        if kind == "int":
            if int(value) != value:
                raise RadiosimError(f"{what}: {key} must be a whole number, got {value!r}")
            return int(value)
        return si_value(value, scale, offset)
    if kind in ("numbers", "ints"):
        if not isinstance(value, (list, tuple)) or not all(_is_number(v) for v in value):
            raise RadiosimError(f"{what}: {key} must be a list of numbers, got {value!r}")
        if kind == "ints":
            if any(int(v) != v for v in value):
                raise RadiosimError(f"{what}: {key} must be a list of whole numbers, got "
                                    f"{value!r}")
            return tuple(int(v) for v in value)
        return tuple(si_value(v, scale, offset) for v in value)
    if kind == "bool":
        if not isinstance(value, bool):
            raise RadiosimError(f"{what}: {key} must be true or false, got {value!r}")
        return value
    if kind == "str":
        if not isinstance(value, str):
            raise RadiosimError(f"{what}: {key} must be a string, got {value!r}")
        return value
    try:
        return converters[kind](key, value)
    except RadiosimError as exc:
        message = str(exc)
        raise RadiosimError(message if key in message else
                            f"{_where(what)}{key} = {_shown(value)}: {message}") from None


def _where(what: str) -> str:
    """The table's name as a prefix: "[optics] ", or nothing for the top level."""
    return f"{what} " if what and what.startswith("[") else ""


def _shown(value) -> str:
    """A TOML value as the file writes it (short)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return f'"{value}"'
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def build_checked(cls, kwargs: dict, table: dict, what: str):
    """
    ``cls(**kwargs)`` (kwargs read from the TOML ``table``); a :class:`RadiosimError` of its
    checks is re-raised naming the TOML key and the value as the file gives it, e.g.
    ``[electronics] full_well_e = -5: full_well must be None or > 0 [e⁻]``.
    """
    try:
        return cls(**kwargs)
    except RadiosimError as exc:
        raise RadiosimError(_name_key(cls, str(exc), table, what)) from None


def _name_key(cls, message: str, table: dict, what: str) -> str:
    fields = [f for f in dataclasses.fields(cls) if "toml" in f.metadata
              and f.metadata["toml"] in table]
    named = None
    # The field the message names (the longest name first: full_well before well), else the
    # key whose text value it quotes (an unknown curve name).
    for f in sorted(fields, key=lambda f: -len(f.name)):
        key = f.metadata["toml"]
        if re.search(rf"(?<![\w-]){re.escape(f.name)}(?![\w-])", message) or re.search(
                rf"(?<![\w-]){re.escape(key)}(?![\w-])", message):
            named = key
            break
    if named is None:
        quoted = [f.metadata["toml"] for f in fields if isinstance(table[f.metadata["toml"]], str)
                  and repr(table[f.metadata["toml"]]) in message]
        named = quoted[0] if quoted else None
    if named is None:
        return f"{what}: {message}" if what and not message.startswith(what) else message
    expected = re.sub(r",? got .*$", "", message)
    return f"{_where(what)}{named} = {_shown(table[named])}: {expected}"


def reject_unknown(keys, known, what: str):
    """Raise a :class:`RadiosimError` naming unknown ``keys`` and the likely typo of each."""
    keys = list(keys)
    if not keys:
        return
    parts = []
    for key in keys:
        close = difflib.get_close_matches(str(key), list(known), n=1)
        parts.append(f"{key} (did you mean {close[0]}?)" if close else str(key))
    listing = f"; known: {', '.join(sorted(known))}" if len(known) <= 12 else ""
    raise RadiosimError(f"{what}: unknown key(s) {', '.join(parts)}{listing}")


def fields_from_table(cls, table: dict, what: str, converters: dict | None = None,
                      required=(), ignore=()) -> dict:
    """
    The keyword arguments (field name → SI value) of dataclass ``cls`` that a TOML table in
    edge units gives; ``required`` keys must be present; keys neither declared nor in
    ``ignore`` raise naming the likely typo.
    """
    converters = converters or {}
    by_key = {f.metadata["toml"]: f for f in dataclasses.fields(cls) if "toml" in f.metadata}
    for key in required:
        if key not in table:
            raise RadiosimError(f"{what}: needs {key} ({by_key[key].metadata['doc']})")
    reject_unknown([k for k in table if k not in by_key and k not in ignore],
                   [*by_key, *ignore], what)
    return {by_key[key].name: _read_value(key, value, by_key[key].metadata, what, converters)
            for key, value in table.items() if key in by_key}


def from_table(cls, table: dict, what: str, converters: dict | None = None,
               required=(), extra: dict | None = None):
    """
    An instance of dataclass ``cls`` from a TOML table in edge units (see
    :func:`fields_from_table`); fields without a TOML key are taken from ``extra``, missing keys
    take the defaults.
    """
    kwargs = dict(extra or {}) | fields_from_table(cls, table, what, converters, required)
    return build_checked(cls, kwargs, table, what)


def read_number(table: dict, key: str, what: str, scale: float = 1.0):
    """
    ``table[key]`` (removed from it) as a finite number converted by ``scale`` (edge unit →
    SI), ``None`` if absent; strings and booleans are refused naming the key.
    """
    if key not in table:
        return None
    meta = {"kind": "number", "scale": scale, "offset": 0.0}
    return _read_value(key, table.pop(key), meta, what, {})


def to_table(obj, converters: dict | None = None, skip_defaults_none: bool = True) -> dict:
    """The fields of dataclass ``obj`` that have TOML keys, in edge units (see
    :func:`from_table`); ``None`` values are left out."""
    converters = converters or {}
    out = {}
    for f in dataclasses.fields(obj):
        meta = f.metadata
        if "toml" not in meta:
            continue
        value = getattr(obj, f.name)
        if value is None and skip_defaults_none:
            continue
        kind = meta["kind"]
        if kind == "number":
            value = edge_value(value, meta["scale"], meta["offset"])
        elif kind == "int":
            value = int(value)
        elif kind == "numbers":
            value = [edge_value(v, meta["scale"], meta["offset"]) for v in value]
        elif kind == "ints":
            value = [int(v) for v in value]
        elif kind in converters:
            value = converters[kind](value)
        out[meta["toml"]] = value
    return out


def load_toml(path, what: str) -> dict:
    """
    Parse a TOML file (UTF-8, with or without a byte-order mark); unreadable or invalid files
    raise a :class:`RadiosimError` naming the file, what it should hold (``what``) and the
    problem.
    """
    path = Path(path)
    try:
        return tomllib.loads(path.read_text(encoding="utf-8-sig"))
    except (OSError, UnicodeDecodeError) as exc:
        raise RadiosimError(f"cannot read {what} {path}: {exc}") from exc
    except tomllib.TOMLDecodeError as exc:
        raise RadiosimError(f"{path} is not valid TOML: {exc}") from exc


def build_from_toml(path, what: str, build):
    """``build(data, folder)`` on a parsed TOML file; its errors are prefixed with the path."""
    path = Path(path)
    data = load_toml(path, what)
    try:
        return build(data, path.parent)
    except RadiosimError as exc:
        raise RadiosimError(f"{path}: {exc}") from None


def _plain(value):
    if isinstance(value, (np.integer,)):
        return int(value)
    if isinstance(value, (np.floating,)):
        return float(value)
    if isinstance(value, tuple):
        return [_plain(v) for v in value]
    if isinstance(value, list):
        return [_plain(v) for v in value]
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    return value


def dumps_toml(data: dict, tables=(), comments: dict | None = None, header: str = "") -> str:
    """
    TOML text (written by tomlkit): top-level keys, then the sections named in ``tables`` as
    ``[name]`` tables; ``comments`` maps keys to end-of-line comments, ``header`` is a comment
    block at the top.
    """
    import tomlkit

    comments = comments or {}
    document = tomlkit.document()
    for line in header.splitlines():
        document.add(tomlkit.comment(line))

    def add(container, key, value):
        value = _plain(value)
        if isinstance(value, dict):
            inline = tomlkit.inline_table()
            inline.update(value)
            item = tomlkit.item(inline)
        else:
            item = tomlkit.item(value)
        if comments.get(key):
            item.comment(comments[key])
        container.add(key, item)

    for key, value in data.items():
        if key not in tables:
            add(document, key, value)
    for name in tables:
        if name in data:
            table = tomlkit.table()
            for key, value in data[name].items():
                add(table, key, value)
            document.add(name, table)
    return tomlkit.dumps(document)
