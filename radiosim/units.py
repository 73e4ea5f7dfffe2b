"""
Units at the edges: µm, µs, °C in files and on the command line, SI inside.

Powers of ten are applied to the shortest decimal representation of a number, so 3.8 µm becomes
exactly the float ``3.8e-6`` (``3.8 / 1e6`` is ``3.7999999999999996e-06``) and converts back to
3.8: preset and study values survive a round trip unchanged.
"""

from __future__ import annotations

import math
import re
from decimal import Decimal

from radiosim.errors import RadiosimError

__all__ = ["shift", "parse_quantity", "QUANTITY_UNITS"]

#: Units accepted by :func:`parse_quantity`, per kind: (power of ten, offset to SI).
QUANTITY_UNITS = {
    "time": {"s": (0, 0.0), "ms": (-3, 0.0), "us": (-6, 0.0), "µs": (-6, 0.0), "ns": (-9, 0.0)},
    "length": {"m": (0, 0.0), "mm": (-3, 0.0), "um": (-6, 0.0), "µm": (-6, 0.0),
               "nm": (-9, 0.0)},
    "temperature": {"K": (0, 0.0), "C": (0, 273.15), "°C": (0, 273.15)},
}


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
    units = QUANTITY_UNITS[kind]
    match = re.fullmatch(r"\s*([-+]?[0-9]*\.?[0-9]+(?:[eE][-+]?[0-9]+)?)\s*([^\s0-9].*?)\s*",
                         str(text))
    if not match or match.group(2) not in units:
        raise RadiosimError(f"{text!r} is not a {kind} with a unit; expected a number followed "
                            f"by one of {', '.join(units)} (e.g. "
                            f"{ {'time': '10us', 'length': '6um', 'temperature': '739C'}[kind]})")
    exponent, offset = units[match.group(2)]
    value = shift(float(match.group(1)), exponent)
    return value + offset if offset else value
