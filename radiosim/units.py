"""
Units at the edges: µm, µs, °C in files and on the command line, SI inside.

This module is the one place that knows units: the Celsius offset, the table of length, time and
temperature units accepted at the edges, and exact conversions. Powers of ten are applied to
the shortest decimal representation of a number, so 3.8 µm becomes exactly the float
``3.8e-6`` (``3.8 / 1e6`` is ``3.7999999999999996e-06``) and converts back to 3.8: preset and
study values survive a round trip unchanged.
"""

from __future__ import annotations

import argparse
import math
import re
from decimal import Decimal

import numpy as np

from radiosim.errors import RadiosimError

__all__ = [
    "CELSIUS_OFFSET",
    "AMBIENT_TEMPERATURE",
    "MICRO",
    "UNITS",
    "TEMPERATURE_OFFSETS",
    "shift",
    "round_significant",
    "readable_time",
    "readable_times",
    "parse_quantity",
    "to_si",
    "to_kelvin",
    "to_celsius",
    "Quantity",
    "looks_negative",
    "parse_time",
    "parse_length",
    "parse_temperature",
    "parse_time_or_zero",
    "whole_number",
    "typed",
    "join_negatives",
]

#: 0 °C in kelvin [K] (exact, by the definition of the Celsius scale).
CELSIUS_OFFSET = 273.15

#: Temperature of a scene's surroundings (and of what an FEA mesh does not cover) when none is
#: stated [K]: a laboratory at 20 °C.
AMBIENT_TEMPERATURE = 293.15

#: The SI prefix micro [1]: the scale of the µm and µs in which files and presets state lengths
#: and times (``pixel_pitch_um``, ``row_time_us``); SI value = edge value × MICRO.
MICRO = 1e-6

#: Units accepted at the edges, per kind: unit → (power of ten, offset) to SI.
UNITS = {
    "time": {"s": (0, 0.0), "ms": (-3, 0.0), "us": (-6, 0.0), "µs": (-6, 0.0), "ns": (-9, 0.0)},
    "length": {"m": (0, 0.0), "mm": (-3, 0.0), "um": (-6, 0.0), "µm": (-6, 0.0),
               "nm": (-9, 0.0)},
    "temperature": {"K": (0, 0.0), "C": (0, CELSIUS_OFFSET), "°C": (0, CELSIUS_OFFSET)},
}

#: Spellings of the micro prefix: the micro sign (U+00B5, ``µ``, what most keyboards type) and
#: the Greek small letter mu (U+03BC, ``μ``, what NFKC normalisation and many fonts produce).
_MICRO = ("\u00b5", "\u03bc")

#: A number with a unit, as typed: sign, digits, exponent, then the unit.
_QUANTITY = re.compile(r"\s*([-+]?[0-9]*\.?[0-9]+(?:[eE][-+]?[0-9]+)?)\s*([^\s0-9].*?)\s*")


class Quantity(float):
    """
    A value in SI units [s, m, K] that remembers how it was typed (``text``), so that a message
    about it can quote the user's own ``5us`` rather than ``5e-06 s``.

    Examples
    --------
    >>> q = Quantity(5e-06, "5us")
    >>> q * 2, q.text
    (1e-05, '5us')
    """

    text: str

    def __new__(cls, value: float, text: str):
        self = super().__new__(cls, value)
        self.text = str(text).strip()
        return self


def looks_negative(text: str) -> bool:
    """
    Whether ``text`` is a negative number with or without a unit (``-5us``, ``-1e-3``), as
    opposed to an option name (``-v``, ``--out``).

    Examples
    --------
    >>> looks_negative("-5us"), looks_negative("-0.5 ms"), looks_negative("-v")
    (True, True, False)
    """
    match = _QUANTITY.fullmatch(str(text))
    return bool(match) and match.group(1).startswith("-") or bool(
        re.fullmatch(r"-[0-9]*\.?[0-9]+(?:[eE][-+]?[0-9]+)?", str(text)))


#: Temperature units of files and their offset to kelvin [K].
TEMPERATURE_OFFSETS = {unit: offset for unit, (_, offset) in UNITS["temperature"].items()
                       if unit != "°C"}


def round_significant(value, digits: int = 10):
    """
    A float rounded to ``digits`` significant digits, as ``results.csv`` writes it
    (:func:`radiosim.study.format_value`: no float noise such as 5.999999999999999); other
    values unchanged.

    Examples
    --------
    >>> round_significant(5.999999999999999), round_significant(1172.55 - 273.15)
    (6.0, 899.4)
    >>> round_significant(7), round_significant("centred")
    (7, 'centred')
    """
    if isinstance(value, (float, np.floating)):
        return float(f"{float(value):.{digits}g}")
    return value


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
    >>> parse_quantity("10\u00b5s", "time") == parse_quantity("10\u03bcs", "time") == 1e-05
    True
    """
    units = UNITS[kind]
    match = _QUANTITY.fullmatch(str(text))
    unit = match.group(2) if match else None
    if unit is not None and unit[:1] in _MICRO:  # 10μs (Greek mu) is 10µs (micro sign)
        unit = "u" + unit[1:]
    if not match or unit not in units:
        raise RadiosimError(f"{text!r} is not a {kind} with a unit; expected a number followed "
                            f"by one of {', '.join(units)} (e.g. "
                            f"{ {'time': '10us', 'length': '6um', 'temperature': '739C'}[kind]})")
    return to_si(float(match.group(1)), unit, kind)


# -- the command line's quantities (argparse types of radiosim.cli) ---------------------------

#: Examples of each kind of quantity, for messages.
_EXAMPLES = {"time": "10us, 0.5ms, 200ns", "length": "6um, 0.5mm",
             "temperature": "739C, 1012K"}

def _parser_of(kind: str, positive: bool = True):
    """An argparse type: a ``kind`` with a unit, as a :class:`~radiosim.units.Quantity` in SI
    that remembers the text typed (messages quote it)."""
    def parse(text: str) -> float:
        try:
            value = parse_quantity(text, kind)
        except RadiosimError:
            raise argparse.ArgumentTypeError(
                f"{text.strip()!r} is not a {kind} with a unit; expected e.g. "
                f"{_EXAMPLES[kind]}") from None
        if positive and not value > 0:
            raise argparse.ArgumentTypeError(
                f"{text.strip()} must be " + ("above absolute zero (0 K, -273.15C)"
                                              if kind == "temperature" else "positive")
                + f" (a {kind} with a unit, e.g. {_EXAMPLES[kind]})")
        return Quantity(value, text)

    parse.__name__ = f"parse_{kind}"
    return parse


#: A duration with a unit (``10us``, ``0.5ms``, ``200ns``, ``10µs``, ``10μs``) in seconds, > 0.
parse_time = _parser_of("time")
parse_length = _parser_of("length")
parse_temperature = _parser_of("temperature")
parse_time_or_zero = _parser_of("time", positive=False)


def whole_number(least: int, most: int | None = None, what: str = "a whole number"):
    """An argparse type: a whole number in [least, most]."""
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            value = None
        if value is None or value < least or (most is not None and value > most):
            bound = f"≥ {least}" if most is None else f"from {least} to {most:,}"
            raise argparse.ArgumentTypeError(f"{text.strip()!r} is not {what} {bound}")
        return value

    return parse


def readable_times(*seconds: float) -> tuple[list[str], str]:
    """
    Times [s] in one unit a reader takes in at a glance: µs below a millisecond, ms below a
    second, else s (the unit of the largest); each to 6 significant digits.

    Examples
    --------
    >>> readable_times(3e-6, 8e-6)
    (['3', '8'], 'µs')
    >>> readable_times(0.0, 0.0025)
    (['0', '2.5'], 'ms')
    """
    largest = max((abs(float(t)) for t in seconds), default=0.0)
    scale, unit = (1e-6, "µs") if largest < 1e-3 else (1e-3, "ms") if largest < 1 else (1, "s")
    return [f"{round_significant(float(t) / scale, 6):g}" for t in seconds], unit


def readable_time(seconds: float) -> str:
    """
    One time [s] as a reader takes it in (:func:`readable_times`), with its unit.

    Examples
    --------
    >>> readable_time(5e-06), readable_time(0.0125), readable_time(2.0)
    ('5 µs', '12.5 ms', '2 s')
    """
    (text,), unit = readable_times(seconds)
    return f"{text} {unit}"


def typed(value, unit: str = "s") -> str:
    """A value as the user typed it (``5us``) when the command knows, else in SI."""
    return value.text if isinstance(value, Quantity) else f"{value:g} {unit}"


def join_negatives(parser: argparse.ArgumentParser, argv: list[str]) -> list[str]:
    """
    ``--opt -5us`` as ``--opt=-5us``: argparse takes a token that starts with ``-`` and is
    not a plain number for an option, and would report "expected one argument" instead of
    checking the value. Only after an option that takes one value.
    """
    takes_one, takes_many = set(), set()
    stack = [parser]
    while stack:
        p = stack.pop()
        for action in p._actions:  # argparse exposes no public list of options
            if isinstance(action, argparse._SubParsersAction):
                stack.extend(action.choices.values())
            elif action.option_strings and action.nargs is None:
                takes_one.update(action.option_strings)
            elif action.option_strings and action.nargs in ("+", "*"):
                takes_many.update(action.option_strings)
    out, many = [], None  # many: the option of a list being read (--diameters 12um 60um)
    for token in argv:
        if out and looks_negative(token) and out[-1] in takes_one:
            out[-1] = f"{out[-1]}={token}"
        elif many is not None and looks_negative(token):
            parser.error(f"argument {many}: {token} must be positive (a list of values with "
                         "units, e.g. 12um 60um)")
        else:
            out.append(token)
        if token.startswith("-") and not looks_negative(token):
            many = token if token in takes_many else None
    return out
