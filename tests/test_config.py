"""TOML configuration (radiosim.config) and units at the edges (radiosim.units).

References are independent of the code under test: Python's own correctly rounded parsing of
decimal literals (``float("3.8e-6")``) for exactness, :mod:`tomllib` for the TOML text, and the
input tables themselves for round trips.
"""

import math
import tokenize
import tomllib
from pathlib import Path

import numpy as np
import pytest

import radiosim
from radiosim import Camera
from radiosim.config import dumps_toml, from_table, to_table
from radiosim.electronics import Electronics
from radiosim.errors import RadiosimError
from radiosim.scenes import ChipParameters
from radiosim.units import (CELSIUS_OFFSET, parse_quantity, to_celsius, to_kelvin, to_si)

PACKAGE = Path(radiosim.__file__).resolve().parent


# -- from_table / to_table -----------------------------------------------------------------


def test_chip_parameters_round_trip_through_a_table():
    params = ChipParameters()
    table = to_table(params)
    assert from_table(ChipParameters, table, "chip parameters") == params
    # A non-default instance too (so defaults cannot hide a dropped key).
    changed = params.replace(period=72e-6, band_width=13.3e-6, cutting_speed=3.0,
                             rake_angle=math.radians(-10.5), clearance_angle=math.radians(10.5),
                             released_bands=4, chip_diffusivity=5.1e-6)
    table = to_table(changed)
    assert from_table(ChipParameters, table, "chip parameters") == changed
    assert table["period_us"] == 72.0 and table["band_width_um"] == 13.3
    assert table["cutting_speed_m_per_min"] == 180.0 and table["released_bands"] == 4
    assert table["rake_angle_deg"] == -10.5


def test_chip_table_in_edge_units_survives_a_round_trip():
    # As a user would write them in a file: decimal numbers in µm, µs, m/min, degrees.
    table = {"period_us": 87.3, "band_width_um": 16.27, "uncut_thickness_um": 0.3e3,
             "cutting_speed_m_per_min": 250.0, "chip_diffusivity_um2_per_us": 4.635,
             "rake_angle_deg": -6.5, "clearance_angle_deg": 6.5, "primary_offset_um": -1.5,
             "initial_temperature_C": 20.0, "released_bands": 5}
    params = from_table(ChipParameters, table, "chip parameters")
    assert params.period == 87.3e-6  # exact: the decimal 87.3 µm is the float 8.73e-05 m
    assert params.band_width == 16.27e-6
    assert params.initial_temperature == 293.15
    out = to_table(params)
    assert {k: out[k] for k in table} == table


def test_celsius_keys_survive_a_round_trip():
    # config's docstring: "to_table writes them back exactly, so a file survives a round trip
    # unchanged."
    for celsius in (0.1, 3.3, 12.34, 21.3, 100.7):
        table = {"initial_temperature_C": celsius, "ambient_temperature_C": celsius}
        out = to_table(from_table(ChipParameters, table, "chip parameters"))
        assert out["initial_temperature_C"] == celsius, celsius


def test_chip_parameters_toml_round_trip(tmp_path):
    params = ChipParameters().replace(period=72e-6)
    text = params.to_toml(tmp_path / "chip.toml")
    assert tomllib.loads(text)["chip"]["period_us"] == 72.0
    assert ChipParameters.from_toml(tmp_path / "chip.toml") == params


def test_camera_round_trip_through_its_dict():
    camera = Camera.preset("nist-ir")
    data = camera.to_dict()
    assert Camera.from_dict(data).to_dict() == data
    # The dict is in edge units, as in the preset file.
    preset = tomllib.loads((PACKAGE / "presets" / "nist-ir.toml").read_text(encoding="utf-8"))
    assert data["fpa"]["pixel_pitch_um"] == preset["fpa"]["pixel_pitch_um"] == 6.0
    assert data["optics"]["band_um"] == preset["optics"]["band_um"] == [3.75, 5.15]
    assert data["electronics"]["gain_dn_per_e"] == preset["electronics"]["gain_dn_per_e"]
    assert data["optics"]["spectral_filter"] == preset["optics"]["spectral_filter"]


def test_camera_round_trip_through_toml_text():
    camera = Camera.linear_ideal(3.8e-6)
    text = camera.to_toml()
    data = tomllib.loads(text)
    assert data["fpa"]["pixel_pitch_um"] == 3.8
    rebuilt = Camera.from_dict(data)
    assert rebuilt.fpa.pixel_pitch == 3.8e-6
    assert rebuilt.to_dict() == camera.to_dict()


def test_a_number_written_as_a_string_is_refused_with_a_hint():
    with pytest.raises(RadiosimError) as info:
        from_table(ChipParameters, {"period_us": "90"}, "chip parameters")
    message = str(info.value)
    assert "period_us" in message and "drop the quotes" in message
    with pytest.raises(RadiosimError) as info:
        from_table(Electronics, {"gain_dn_per_e": "0.0014"}, "[electronics]")
    message = str(info.value)
    assert "gain_dn_per_e" in message and "drop the quotes" in message


def test_a_string_in_a_camera_file_is_refused():
    data = Camera.preset("nist-ir").to_dict()
    data["fpa"]["pixel_pitch_um"] = "6.0"
    with pytest.raises(RadiosimError, match="pixel_pitch_um.*drop the quotes"):
        Camera.from_dict(data)


def test_an_unknown_key_names_the_likely_typo():
    with pytest.raises(RadiosimError) as info:
        from_table(ChipParameters, {"perod_us": 90.0}, "chip parameters")
    assert "perod_us (did you mean period_us?)" in str(info.value)
    data = Camera.preset("nist-ir").to_dict()
    data["electronics"]["read_nosie_e"] = data["electronics"].pop("read_noise_e")
    with pytest.raises(RadiosimError, match=r"did you mean read_noise_e\?"):
        Camera.from_dict(data)
    data = Camera.preset("nist-ir").to_dict()
    data["frame_rate_h"] = data.pop("frame_rate_hz")
    with pytest.raises(RadiosimError, match=r"did you mean frame_rate_hz\?"):
        Camera.from_dict(data)


def test_a_boolean_is_not_a_number():
    with pytest.raises(RadiosimError, match="period_us"):
        from_table(ChipParameters, {"period_us": True}, "chip parameters")


# -- dumps_toml --------------------------------------------------------------------------------


def test_dumps_toml_keeps_comments_and_parses_back():
    data = {"name": "test", "rate_hz": 600.0, "limits_K": (150.0, 3000.0),
            "fpa": {"pitch_um": 6.0, "shape": [120, 160], "qe": np.float64(0.8),
                    "bits": np.int64(14)}}
    text = dumps_toml(data, tables=("fpa",),
                      comments={"rate_hz": "frames per second", "pitch_um": "object space"},
                      header="first header line\nsecond header line")
    lines = text.splitlines()
    assert lines[0] == "# first header line" and lines[1] == "# second header line"
    assert any(line.startswith("rate_hz") and line.endswith("# frames per second")
               for line in lines)
    assert any(line.startswith("pitch_um") and line.endswith("# object space") for line in lines)
    assert "[fpa]" in lines
    parsed = tomllib.loads(text)
    assert parsed == {"name": "test", "rate_hz": 600.0, "limits_K": [150.0, 3000.0],
                      "fpa": {"pitch_um": 6.0, "shape": [120, 160], "qe": 0.8, "bits": 14}}
    assert type(parsed["fpa"]["bits"]) is int


def test_chip_toml_carries_its_comments():
    text = ChipParameters().to_toml()
    line = next(l for l in text.splitlines() if l.startswith("period_us"))
    assert "# segmentation period P" in line


# -- units -------------------------------------------------------------------------------------


DECIMALS = ["3.8", "3.75", "5.15", "0.1", "0.3", "6.0", "12.49", "16.27", "21.07", "4.635",
            "87.3", "0.07", "1234.5678"]


@pytest.mark.parametrize("text", DECIMALS)
def test_to_si_is_exact_on_the_decimal(text):
    value = float(text)
    # Python parses "3.8e-6" to the nearest double of the decimal 3.8 × 10⁻⁶: the reference.
    assert to_si(value, "um", "length") == float(text + "e-6")
    assert to_si(value, "µm", "length") == float(text + "e-6")
    assert to_si(value, "mm", "length") == float(text + "e-3")
    assert to_si(value, "nm", "length") == float(text + "e-9")
    assert to_si(value, "us", "time") == float(text + "e-6")
    assert to_si(value, "ms", "time") == float(text + "e-3")
    assert to_si(value, "s", "time") == value


def test_3_8_um_is_exactly_3_8e_6():
    assert to_si(3.8, "um", "length") == 3.8e-6
    assert 3.8 / 1e6 != 3.8e-6  # the naive division would not be
    assert parse_quantity("3.8 µm", "length") == 3.8e-6
    assert parse_quantity("3.8um", "length") == 3.8e-6


def test_temperature_conversions():
    assert to_si(739.0, "C", "temperature") == 739.0 + 273.15
    assert to_si(739.0, "°C", "temperature") == 739.0 + 273.15
    assert to_si(739.0, "K", "temperature") == 739.0
    np.testing.assert_array_equal(to_kelvin(np.array([0.0, 100.0, -273.15]), "C"),
                                  [273.15, 100.0 + 273.15, 0.0])
    kelvin = np.array([300.0, 900.0])
    assert to_kelvin(kelvin, "K") is kelvin  # no conversion, no copy
    assert to_celsius(273.15) == 0.0
    assert isinstance(to_celsius(np.float64(300.0)), float)
    np.testing.assert_array_equal(to_celsius([273.15, 373.15]), [0.0, 373.15 - 273.15])
    assert to_celsius(to_kelvin(25.0, "C")) == pytest.approx(25.0, abs=1e-12)
    with pytest.raises(RadiosimError, match="temperature unit"):
        to_kelvin(1.0, "F")
    with pytest.raises(RadiosimError, match="unknown length unit"):
        to_si(1.0, "in", "length")


def test_celsius_offset_is_exact():
    assert CELSIUS_OFFSET == 273.15


@pytest.mark.parametrize("text, kind, expected", [
    ("10us", "time", 1e-5), ("10 us", "time", 1e-5), ("1.6 ms", "time", 1.6e-3),
    ("90µs", "time", 90e-6), ("250 ns", "time", 250e-9), ("0.5s", "time", 0.5),
    ("6 um", "length", 6e-6), ("3.75um", "length", 3.75e-6), ("1e3 nm", "length", 1e-6),
    ("739C", "temperature", 739.0 + 273.15), ("739 °C", "temperature", 739.0 + 273.15),
    ("300 K", "temperature", 300.0), ("-20C", "temperature", -20.0 + 273.15),
])
def test_parse_quantity(text, kind, expected):
    assert parse_quantity(text, kind) == expected


@pytest.mark.parametrize("text, kind", [("10", "time"), ("us", "time"), ("10 um", "time"),
                                        ("ten us", "time"), ("6 inch", "length")])
def test_parse_quantity_refuses_what_is_not_a_quantity(text, kind):
    with pytest.raises(RadiosimError, match="with a unit"):
        parse_quantity(text, kind)


# -- one place for 273.15 ------------------------------------------------------------------------


def _number_literals(path: Path):
    """Numeric literals of a Python file's code (not strings, docstrings or comments)."""
    with path.open("rb") as handle:
        tokens = tokenize.tokenize(handle.readline)
        return [(tok.string, tok.start[0]) for tok in tokens if tok.type == tokenize.NUMBER]


def _is_celsius_offset(literal: str) -> bool:
    try:
        return float(literal.replace("_", "")) == 273.15  # also 273.150, 2.7315e2
    except ValueError:
        return False


def test_the_tokeniser_finds_the_offset_in_units():
    # The search below must be able to see a literal: units.py holds the one definition.
    found = [line for literal, line in _number_literals(PACKAGE / "units.py")
             if _is_celsius_offset(literal)]
    assert len(found) == 1


def test_celsius_offset_is_the_only_273_15_in_the_package():
    files = sorted(PACKAGE.rglob("*.py"))
    assert len(files) > 20
    hits = []
    for path in files:
        if path == PACKAGE / "units.py":
            continue
        hits += [f"{path.relative_to(PACKAGE)}:{line}: {literal}"
                 for literal, line in _number_literals(path) if _is_celsius_offset(literal)]
    assert hits == []
