"""The radiosim command."""

import argparse
import csv

import pytest

from radiosim.cli import main, parse_time


def test_run_prints_and_writes_the_demo_table(capsys, tmp_path):
    assert main(["run", "--integration-times", "1us", "10us", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "linear-ideal" in out and "nist-ir" in out
    rows = list(csv.DictReader((tmp_path / "demo.csv").open()))
    assert [r["camera"] for r in rows] == ["linear-ideal"] * 2 + ["nist-ir"] * 2
    # Motion blur: the longer window reads the band colder.
    assert float(rows[1]["mean_at_band_C"]) < float(rows[0]["mean_at_band_C"])
    assert rows[0]["frames"] == "6"  # a 1 µs window centred mid-frame touches 6 frames


def test_presets_lists_nist(capsys):
    assert main(["presets"]) == 0
    assert "nist-ir" in capsys.readouterr().out


@pytest.mark.parametrize("text, seconds", [("10us", 1e-5), ("0.5ms", 5e-4), ("200ns", 2e-7),
                                           ("2µs", 2e-6), ("1s", 1.0)])
def test_human_durations(text, seconds):
    assert parse_time(text) == pytest.approx(seconds)


@pytest.mark.parametrize("text", ["10", "us", "10xs", "0us", "ten us"])
def test_malformed_durations_are_refused(text, capsys):
    with pytest.raises(SystemExit) as info:
        main(["run", "--integration-times", text])
    assert info.value.code == 2
    assert "not a positive duration with a unit" in capsys.readouterr().err


def test_negative_duration_is_refused():
    with pytest.raises(argparse.ArgumentTypeError, match="positive duration"):
        parse_time("-3us")
