"""
TOML in and out for radiosim's data files (camera presets, studies, scene parameters).
"""

from __future__ import annotations

import tomllib
from pathlib import Path

import numpy as np

from radiosim.errors import RadiosimError

__all__ = ["load_toml", "build_from_toml", "dumps_toml"]


def load_toml(path, what: str) -> dict:
    """
    Parse a TOML file; unreadable or invalid files raise a :class:`RadiosimError` naming the
    file, what it should hold (``what``) and the problem.
    """
    path = Path(path)
    try:
        return tomllib.loads(path.read_text(encoding="utf-8"))
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


def _value(value) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, np.integer)):
        return str(int(value))
    if isinstance(value, (float, np.floating)):
        return repr(float(value))
    if isinstance(value, str):
        return '"' + value.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_value(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{ " + ", ".join(f"{k} = {_value(v)}" for k, v in value.items()) + " }"
    raise TypeError(f"cannot write {type(value).__name__} to TOML")


def dumps_toml(data: dict, tables=(), comments: dict | None = None) -> str:
    """
    TOML text for radiosim's structures: top-level keys, then the sections named in
    ``tables`` as ``[name]`` tables; values are numbers, strings, booleans, lists and inline
    tables. ``comments`` maps keys to end-of-line comments.
    """
    comments = comments or {}

    def line(key, value):
        note = f"  # {comments[key]}" if comments.get(key) else ""
        return f"{key} = {_value(value)}{note}"

    lines = [line(k, v) for k, v in data.items() if k not in tables]
    for key in tables:
        if key in data:
            lines += ["", f"[{key}]"] + [line(k, v) for k, v in data[key].items()]
    return "\n".join(lines) + "\n"
