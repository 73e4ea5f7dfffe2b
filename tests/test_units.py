"""Units and constants at the edges (radiosim.units), and the count check (radiosim.checks)."""

import re

import numpy as np
import pytest

from radiosim.checks import check_count
from radiosim.errors import RadiosimError
from radiosim.units import AMBIENT_TEMPERATURE, CELSIUS_OFFSET, MICRO, shift, to_si


def test_constants_are_stated_once_and_where_they_were():
    from radiosim.optics import Optics
    from radiosim.radiometry import CALIBRATION_RANGE, DEFAULT_BAND, BandRadianceTable
    from radiosim.scenes.base import AMBIENT_TEMPERATURE as from_scenes

    assert AMBIENT_TEMPERATURE == CELSIUS_OFFSET + 20 and from_scenes is AMBIENT_TEMPERATURE
    assert MICRO == to_si(1.0, "um", "length") == to_si(1.0, "us", "time")
    assert DEFAULT_BAND == (shift(3.8, -6), shift(5.1, -6)) == Optics().band
    assert CALIBRATION_RANGE == (150.0, 3000.0)
    table = BandRadianceTable(per_octave=4)
    assert table.band == DEFAULT_BAND
    assert table.temperatures[0] <= 150.0 and table.temperatures[-1] >= 3000.0


@pytest.mark.parametrize("value,minimum,expected", [(3, 1, 3), (3.0, 1, 3), (np.int64(0), 0, 0),
                                                    (np.float32(2), 2, 2)])
def test_check_count_accepts_whole_numbers(value, minimum, expected):
    out = check_count(value, "frames", minimum)
    assert out == expected and type(out) is int


@pytest.mark.parametrize("value", [0, -1, 2.5, True, "3", None, float("nan"), float("inf")])
def test_check_count_refuses_others_naming_them(value):
    with pytest.raises(RadiosimError, match=rf"^frames must be a whole number ≥ 1, got "
                                            rf"{re.escape(repr(value))}$"):
        check_count(value, "frames")


def test_check_count_integers_only():
    assert check_count(np.int32(4), "draws", 2, integers_only=True) == 4
    with pytest.raises(RadiosimError, match="draws must be a whole number ≥ 2, got 4.0"):
        check_count(4.0, "draws", 2, integers_only=True)


def test_library_messages_give_times_in_readable_units():
    """A time in a message is 6 µs or 2.5 ms, not 6e-06 s (whatever the reader typed, the
    number is taken in at a glance), in errors and in a measurement's repr."""
    from radiosim import Camera, UniformBlackbody
    from radiosim.scenes import FrameStack

    with pytest.raises(RadiosimError, match=r"event_time 6 µs is outside the stack "
                                            r"\(0 to 5 µs\)") as info:
        FrameStack(np.full((5, 4, 4), 600.0), 1e-6, 1e-6, event_time=6e-6)
    assert "e-0" not in str(info.value)
    measurement = Camera.linear_ideal(2e-6).measure(UniformBlackbody(600.0, (4, 4), 1e-6, 1e-6),
                                                     2.5e-3)
    assert "2.5 ms from 0 µs" in repr(measurement) and "e-0" not in repr(measurement)
