"""
Input checks every stage may use: one line naming the value and what was expected.

They raise :class:`~radiosim.errors.RadiosimError`, never a raw numpy or Python error, so that
nothing a user passes ends in a traceback from deep inside the chain.
"""

from __future__ import annotations

import math

import numpy as np

from radiosim.errors import RadiosimError

__all__ = ["check_positive", "check_non_negative", "check_fraction", "check_frame", "check_rng",
           "check_time", "check_count", "check_whole", "bad_sample_message"]


def check_rng(rng) -> np.random.Generator:
    """
    A :class:`numpy.random.Generator` from ``rng``: ``None`` (fresh entropy), a seed (a whole
    number ≥ 0), a :class:`numpy.random.SeedSequence` or a Generator (used as it is).
    """
    if isinstance(rng, np.random.Generator):
        return rng
    if rng is None or isinstance(rng, np.random.SeedSequence) or (
            isinstance(rng, (int, np.integer)) and not isinstance(rng, bool) and rng >= 0):
        return np.random.default_rng(rng)
    raise RadiosimError(f"rng must be a seed (a whole number ≥ 0), a numpy Generator or None, "
                        f"got {rng!r}")


def check_time(value, name: str, positive: bool = True) -> float:
    """
    A time [s] as a finite float (> 0; any finite value with ``positive=False``: the scene's
    own time decides what it may be); strings and booleans are refused with a hint (times
    are numbers in seconds: 1e-6 for 1 µs).

    Examples
    --------
    >>> check_time(2e-6, "integration_time")
    2e-06
    """
    if isinstance(value, (str, bytes, bool, np.bool_)):
        hint = (f" (times are numbers in seconds: e.g. 1e-6 for 1 µs; "
                f"radiosim.units.parse_quantity({value!r}, 'time') converts text)"
                if isinstance(value, str) else "")
        raise RadiosimError(f"{name} must be a number [s], got {value!r}{hint}")
    if positive:
        return check_positive(value, name, "s")
    number = _number(value, name, "s")
    if not math.isfinite(number):
        raise RadiosimError(f"{name} must be a finite time [s], got {value!r}")
    return number


def check_count(value, name: str, minimum: int = 1, *, integers_only: bool = False) -> int:
    """
    A count (frames, draws, bands, a seed) as an int ≥ ``minimum``, or a
    :class:`RadiosimError` naming it: ``{name} must be a whole number ≥ {minimum}, got …``.

    Booleans, strings, non-finite and fractional values are refused; a whole float (``3.0``)
    is accepted unless ``integers_only`` (then only ``int`` and numpy integers are: a count
    that the API documents as an int).

    Examples
    --------
    >>> check_count(3.0, "frames"), check_count(0, "seed", 0)
    (3, 0)
    >>> check_count(3.0, "draws", 2, integers_only=True)
    Traceback (most recent call last):
    ...
    radiosim.errors.RadiosimError: draws must be a whole number ≥ 2, got 3.0
    """
    kinds = (int, np.integer) if integers_only else (int, float, np.integer, np.floating)
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, kinds) or \
            not math.isfinite(value) or int(value) != value or value < minimum:
        raise RadiosimError(f"{name} must be a whole number ≥ {minimum}, got {value!r}")
    return int(value)


#: The former name of :func:`check_count` (same behaviour).
check_whole = check_count


def _number(value, name: str, unit: str) -> float:
    if isinstance(value, (str, bytes)):
        raise RadiosimError(f"{name} must be a number [{unit}], got the string {value!r}")
    try:
        return float(value)
    except (TypeError, ValueError):
        raise RadiosimError(f"{name} must be a number [{unit}], got {value!r}") from None


def check_positive(value, name: str, unit: str) -> float:
    """
    ``value`` as a finite float > 0, or a :class:`RadiosimError` naming it.

    Examples
    --------
    >>> check_positive(2.5, "f_number", "1")
    2.5
    """
    number = _number(value, name, unit)
    if not math.isfinite(number) or number <= 0:
        raise RadiosimError(f"{name} must be finite and > 0 [{unit}], got {value!r}")
    return number


def check_non_negative(value, name: str, unit: str) -> float:
    """``value`` as a finite float ≥ 0, or a :class:`RadiosimError` naming it."""
    number = _number(value, name, unit)
    if not math.isfinite(number) or number < 0:
        raise RadiosimError(f"{name} must be finite and ≥ 0 [{unit}], got {value!r}")
    return number


def check_fraction(value, name: str, low_open: bool = True) -> float:
    """``value`` as a float in (0, 1] (or [0, 1] with ``low_open=False``)."""
    number = _number(value, name, "1")
    ok = (0 < number <= 1) if low_open else (0 <= number <= 1)
    if not ok:
        raise RadiosimError(f"{name} must be in {'(' if low_open else '['}0, 1], got {value!r}")
    return number


def check_frame(frame: np.ndarray, k: int, origin: tuple[int, int] = (0, 0)) -> np.ndarray:
    """
    Check that a temperature frame is usable: finite and > 0 K everywhere.

    Parameters
    ----------
    frame
        Temperature [K], 2-D.
    k
        Frame index, for the error message.
    origin
        (row, column) of ``frame[0, 0]`` in the full frame, for the error message.
    """
    if frame.size and frame.min() > 0 and frame.max() < np.inf:  # NaN compares false
        return frame
    bad = ~((frame > 0) & (frame < np.inf))
    i, j = (int(v) for v in np.argwhere(bad)[0])
    raise RadiosimError(bad_sample_message(float(frame[i, j]), k, i + origin[0], j + origin[1],
                                           int(bad.sum())))


def bad_sample_message(value: float, k: int, row: int, column: int, count: int) -> str:
    """The one line that names a bad temperature sample: frame, row, column, value, count."""
    if np.isnan(value):
        what, expected = "NaN", "finite"
    elif np.isinf(value):
        what, expected = f"{value:g}", "finite"
    else:
        what, expected = f"{value:g} K", "> 0 K (°C passed as kelvin?)"
    return (f"frame {k}: temperature at row {row}, column {column} is {what}; temperatures "
            f"must be {expected} ({count} bad sample(s) in this frame)")
