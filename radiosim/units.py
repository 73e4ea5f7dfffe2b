"""
Units at the edges: µm, µs, °C in files and on the command line, SI inside.

This module is the one place that knows units: the Celsius offset, the table of length, time and
temperature units accepted at the edges, and exact conversions. Powers of ten are applied to
the shortest decimal representation of a number, so 3.8 µm becomes exactly the float
``3.8e-6`` (``3.8 / 1e6`` is ``3.7999999999999996e-06``) and converts back to 3.8: preset and
study values survive a round trip unchanged.
"""

from __future__ import annotations

import math
import re
from decimal import Decimal

import numpy as np

from radiosim.errors import RadiosimError

__all__ = [
    "CELSIUS_OFFSET",
    "UNITS",
    "TEMPERATURE_OFFSETS",
    "shift",
    "parse_quantity",
    "to_si",
    "to_kelvin",
    "to_celsius",
]

#: 0 °C in kelvin [K] (exact, by the definition of the Celsius scale).
CELSIUS_OFFSET = 273.15

#: Units accepted at the edges, per kind: unit → (power of ten, offset) to SI.
UNITS = {
    "time": {"s": (0, 0.0), "ms": (-3, 0.0), "us": (-6, 0.0), "µs": (-6, 0.0), "ns": (-9, 0.0)},
    "length": {"m": (0, 0.0), "mm": (-3, 0.0), "um": (-6, 0.0), "µm": (-6, 0.0),
               "nm": (-9, 0.0)},
    "temperature": {"K": (0, 0.0), "C": (0, CELSIUS_OFFSET), "°C": (0, CELSIUS_OFFSET)},
}

#: Temperature units of files and their offset to kelvin [K].
TEMPERATURE_OFFSETS = {unit: offset for unit, (_, offset) in UNITS["temperature"].items()
                       if unit != "°C"}


def shift(value: float, exponent: int) -> float:
    """
    ``value`` × 10^``exponent``, exact on the decimal representation.

    Examples
    --------
    >>> shift(3.8, -6), shift(3.8e-6, 6)
    (3.8e-06, 3.8)
    """
    value = float(value)
    if not math.isfinite(value) or exponent == 0:
        return value
    return float(Decimal(repr(value)).scaleb(exponent))


def to_si(value: float, unit: str, kind: str) -> float:
    """
    ``value`` in ``unit`` (of ``kind``: time, length or temperature) in SI [s, m, K].

    Examples
    --------
    >>> to_si(6.0, "um", "length"), to_si(739.0, "C", "temperature")
    (6e-06, 1012.15)
    """
    units = UNITS[kind]
    if unit not in units:
        raise RadiosimError(f"unknown {kind} unit {unit!r}; expected one of {', '.join(units)}")
    exponent, offset = units[unit]
    value = shift(value, exponent)
    return value + offset if offset else value


def to_kelvin(values, unit: str):
    """Temperatures in ``unit`` (``"K"`` or ``"C"``) as kelvin [K] (arrays or numbers)."""
    if unit not in TEMPERATURE_OFFSETS:
        raise RadiosimError(f"temperature unit must be one of {', '.join(TEMPERATURE_OFFSETS)}, "
                            f"got {unit!r}")
    offset = TEMPERATURE_OFFSETS[unit]
    return values + offset if offset else values


def to_celsius(kelvin):
    """Temperatures [K] in degrees Celsius [°C] (arrays or numbers).

    Examples
    --------
    >>> round(to_celsius(1012.15), 10)
    739.0
    """
    if isinstance(kelvin, (float, int, np.floating, np.integer)):
        return float(kelvin) - CELSIUS_OFFSET
    return np.asarray(kelvin) - CELSIUS_OFFSET


def parse_quantity(text: str, kind: str) -> float:
    """
    A number with a unit (``10us``, ``6 um``, ``739C``) in SI units.

    Parameters
    ----------
    text
        The number and its unit.
    kind
        ``"time"`` [s], ``"length"`` [m] or ``"temperature"`` [K].

    Examples
    --------
    >>> parse_quantity("10us", "time"), parse_quantity("739C", "temperature")
    (1e-05, 1012.15)
    """
    units = UNITS[kind]
    match = re.fullmatch(r"\s*([-+]?[0-9]*\.?[0-9]+(?:[eE][-+]?[0-9]+)?)\s*([^\s0-9].*?)\s*",
                         str(text))
    if not match or match.group(2) not in units:
        raise RadiosimError(f"{text!r} is not a {kind} with a unit; expected a number followed "
                            f"by one of {', '.join(units)} (e.g. "
                            f"{ {'time': '10us', 'length': '6um', 'temperature': '739C'}[kind]})")
    return to_si(float(match.group(1)), match.group(2), kind)
