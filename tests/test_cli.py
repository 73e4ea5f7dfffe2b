"""The radiosim command."""

import argparse
import csv

import pytest

from radiosim.cli import main, parse_time


def test_run_prints_and_writes_the_demo_table(capsys, tmp_path):
    args = ["run", "--integration-times", "1us", "10us", "--emissivity", "0.3",
            "--out", str(tmp_path)]
    assert main(args) == 0
    out = capsys.readouterr().out
    assert "linear-ideal" in out and "nist-ir" in out
    rows = list(csv.DictReader((tmp_path / "demo.csv").open()))
    assert [r["camera"] for r in rows] == ["linear-ideal"] * 2 + ["nist-ir"] * 2
    # Motion blur: the longer window reads the shear band colder.
    assert float(rows[1]["column_I_apparent_C"]) < float(rows[0]["column_I_apparent_C"])
    assert rows[0]["frames"] == "5"  # 1 µs centred on the event frame: exactly 5 frames
    # The camera set to ε = 1 reads a grey body of ε = 0.3 far colder than the ideal camera.
    assert float(rows[2]["apparent_peak_C"]) < float(rows[0]["apparent_peak_C"]) - 100


def test_scene_preview_writes_a_png(tmp_path, capsys):
    out = tmp_path / "scene.png"
    assert main(["scene", "preview", "--time", "45us", "--out", str(out)]) == 0
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


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
