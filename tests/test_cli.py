"""The radiosim command."""

import argparse
import csv

import numpy as np
import pytest

from radiosim.cli import main, parse_length, parse_temperature, parse_time
from radiosim.io import read_exr

SMALL_STUDY = """
name = "small"
description = "a quick study on a coarse chip"
[scene]
type = "segmented-chip"
dx_um = 2.0
dt_us = 1.0
[cameras.linear]
preset = "linear-ideal"
pixel_pitch_um = 6.0
[cameras.camera]
preset = "nist-ir"
[[sweeps]]
name = "integration-time"
cameras = ["linear", "camera"]
integration_time_us = [1, 10]
[[sweeps]]
name = "size-of-source"
cameras = ["linear"]
pixel_samples = [3, 6]
integration_time_frames = [1]
[hooks]
summary = "radiosim.paper:column_summary"
figures = "radiosim.paper:make_figures"
"""


def test_run_a_study_file_writes_table_exr_and_figures(tmp_path, capsys):
    study = tmp_path / "small.toml"
    study.write_text(SMALL_STUDY)
    out = tmp_path / "out"
    assert main(["run", str(study), "--out", str(out), "--quiet"]) == 0
    printed = capsys.readouterr().out
    assert "study small" in printed and "wrote" in printed
    rows = list(csv.DictReader((out / "results.csv").open()))
    assert len(rows) == 6
    assert {r["camera"] for r in rows} == {"linear", "camera"}
    first = rows[0]
    assert first["integration_time_us"] == "1.0" and first["n_frames"] == "1"
    m = read_exr(out / first["exr"])
    assert m.integration_time == pytest.approx(1e-6)
    # Motion blur: 10 µs reads the shear band colder than 1 µs.
    lin = [r for r in rows if r["camera"] == "linear" and r["sweep"] == "integration-time"]
    assert float(lin[1]["column_I_C"]) < float(lin[0]["column_I_C"])
    assert (out / "figures" / "fig05_peak.png").is_file()
    assert (out / "figures" / "fig09-11_maps.png").is_file()  # the 10 µs case


def test_progress_bar_goes_to_stderr(tmp_path, capsys):
    study = tmp_path / "small.toml"
    study.write_text(SMALL_STUDY)
    assert main(["run", str(study), "--out", str(tmp_path / "o"), "--no-exr"]) == 0
    captured = capsys.readouterr()
    assert "6/6" in captured.err and "6/6" not in captured.out
    figures = sorted(p.name for p in (tmp_path / "o" / "figures").iterdir())
    assert figures == ["fig05_peak.png", "fig07_column_I.png"]  # the others need EXR files


def test_measure_a_numpy_file(tmp_path, capsys):
    frames = np.full((10, 30, 30), 500.0)
    np.save(tmp_path / "s.npy", frames)
    out = tmp_path / "m.exr"
    args = ["measure", str(tmp_path / "s.npy"), "--camera", "linear-ideal", "--pixel-pitch",
            "6um", "--dx", "1um", "--dt", "0.2us", "--units", "C", "--integration-time", "1us",
            "--out", str(out)]
    assert main(args) == 0
    assert "highest reading 500.0 °C" in capsys.readouterr().out
    assert read_exr(out).shape == (5, 5)


def test_measure_errors_are_reported_not_raised(tmp_path, capsys):
    np.save(tmp_path / "s.npy", np.full((4, 30, 30), 500.0))
    args = ["measure", str(tmp_path / "s.npy"), "--camera", "linear-ideal",
            "--integration-time", "1us", "--dx", "1um", "--dt", "1us", "--units", "K"]
    assert main(args) == 2
    assert "needs --pixel-pitch" in capsys.readouterr().err
    assert main(args[:-6] + ["--pixel-pitch", "6um", "--dx", "1um", "--dt", "1us"]) == 2
    assert "give --units" in capsys.readouterr().err  # names the flag that supplies it


def test_presets_lists_cameras_and_studies(capsys):
    assert main(["presets"]) == 0
    out = capsys.readouterr().out
    assert "nist-ir" in out and "msec2009" in out and "linear-ideal" in out


def test_unknown_study(capsys):
    assert main(["run", "nonesuch"]) == 2
    assert "neither a study file nor a shipped study" in capsys.readouterr().err


def test_scene_preview_writes_a_png(tmp_path, capsys):
    out = tmp_path / "scene.png"
    assert main(["scene", "preview", "--time", "45us", "--out", str(out)]) == 0
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize("text, seconds", [("10us", 1e-5), ("0.5ms", 5e-4), ("200ns", 2e-7),
                                           ("2µs", 2e-6), ("1s", 1.0), ("2.5 us", 2.5e-6)])
def test_human_durations(text, seconds):
    assert parse_time(text) == pytest.approx(seconds)


def test_human_lengths_and_temperatures():
    assert parse_length("6um") == 6e-6
    assert parse_length("0.5 mm") == 5e-4
    assert parse_temperature("739C") == pytest.approx(1012.15)
    assert parse_temperature("300K") == 300.0


@pytest.mark.parametrize("text", ["10", "us", "10xs", "0us", "ten us", "-3us"])
def test_malformed_durations_are_refused(text):
    with pytest.raises(argparse.ArgumentTypeError):
        parse_time(text)


def test_malformed_option_exits_with_a_message(capsys):
    with pytest.raises(SystemExit) as info:
        main(["measure", "x.npy", "--integration-time", "10xs"])
    assert info.value.code == 2
    assert "10xs" in capsys.readouterr().err


def test_measure_fea_names_the_unit_flags(tmp_path, capsys):
    path = tmp_path / "nodes.csv"
    path.write_text("x,y,time,temperature\n0,0,0,300\n10,0,0,300\n0,10,0,300\n10,10,0,300\n"
                    "0,0,1,300\n10,0,1,300\n0,10,1,300\n10,10,1,300\n")
    args = ["measure", str(path), "--camera", "linear-ideal", "--pixel-pitch", "2um",
            "--dx", "1um", "--integration-time", "1us"]
    assert main(args) == 2
    assert "--time-unit" in capsys.readouterr().err
    assert main(args + ["--units", "K", "--time-unit", "us", "--length-unit", "um"]) == 0
    assert "highest reading 26.9 °C" in capsys.readouterr().out


def test_sse_command_writes_its_curve_and_keeps_existing_files(tmp_path, capsys):
    out = tmp_path / "sse.csv"
    assert main(["sse", "nist-ir-psf", "--diameters", "12um", "60um", "300um",
                 "--out", str(out)]) == 0
    lines = out.read_text().splitlines()
    assert lines[0] == "diameter_um,signal,sse,apparent_C" and len(lines) == 4
    sse = [float(line.split(",")[2]) for line in lines[1:]]
    assert sse[0] < sse[1] < sse[2] == 1.0
    capsys.readouterr()
    assert main(["sse", "nist-ir-psf", "--out", str(out)]) == 2
    assert "exists" in capsys.readouterr().err


# -- progress on stderr, and compiling ahead of time ------------------------------------------


def _progress_lines(err: str) -> list[str]:
    return [line for line in err.splitlines() if line.startswith("[")]


def test_sse_prints_one_progress_line_per_disc_and_none_with_quiet(capsys):
    argv = ["sse", "nist-ir-psf", "--diameters", "12um", "60um", "300um"]
    assert main(argv) == 0
    err = capsys.readouterr().err
    assert "\r" not in err  # stderr is not a terminal: plain lines
    # The background and three discs, each counted out of 4 when it is done.
    assert _progress_lines(err) == ["[1/4] background", "[2/4] disc 12 µm", "[3/4] disc 60 µm",
                                    "[4/4] disc 300 µm"]
    assert main(argv + ["-q"]) == 0
    assert capsys.readouterr().err == ""


def test_report_prints_progress_per_step_and_none_with_quiet(tmp_path, capsys):
    assert main(["report", "nist-ir", "--frames", "2", "--out", str(tmp_path / "a")]) == 0
    captured = capsys.readouterr()
    lines = _progress_lines(captured.err)
    # 25 photon-transfer levels, the flat fields, the NETD curve, 13 range times: 40 steps,
    # counted one by one, on stderr only.
    assert [line.split("]")[0] for line in lines] == [f"[{k}/40" for k in range(1, 41)]
    assert "flat-field pair" in lines[0] and "measurable range" in lines[-1]
    assert "\r" not in captured.err and not _progress_lines(captured.out)
    assert main(["report", "nist-ir", "--frames", "2", "-q", "--out", str(tmp_path / "b")]) == 0
    assert capsys.readouterr().err == ""


def test_calibrate_prints_progress_per_step_and_none_with_quiet(tmp_path, capsys):
    from radiosim import Camera

    t = np.linspace(350.0, 550.0, 6)  # [K]; noise-free counts of nist-ir at 100 µs
    counts = Camera.preset("nist-ir").calibration(100e-6).counts(t)
    table = tmp_path / "table.csv"
    table.write_text("temperature_K,counts\n" + "".join(f"{a},{c}\n" for a, c in zip(t, counts)))
    argv = ["calibrate", str(table), "--camera", "nist-ir", "--integration-time", "100us"]
    assert main(argv) == 0
    captured = capsys.readouterr()
    # The table read, the camera's response, the fit: 3 steps, on stderr only, plain lines.
    assert [line.split("]")[0] for line in _progress_lines(captured.err)] == [
        "[1/3", "[2/3", "[3/3"]
    assert "\r" not in captured.err and not _progress_lines(captured.out)
    assert main(argv + ["-q"]) == 0
    assert capsys.readouterr().err == ""


def test_progress_on_a_terminal_is_one_bar_created_before_the_work(capsys):
    import io

    from radiosim.cli import _Progress

    class Terminal(io.StringIO):
        def isatty(self):
            return True

    stream = Terminal()
    progress = _Progress("disc", stream=stream)
    assert progress.bar is not None and progress.bar.n == 0  # before the first step
    for k in range(1, 4):
        progress(k, 3, f"disc {k}")
    assert progress.bar.n == 3 and "3/3" in stream.getvalue()
    quiet = Terminal()
    _Progress("disc", quiet=True, stream=quiet)(1, 3, "disc 1")
    assert quiet.getvalue() == ""


def test_warmup_compiles_every_path_and_says_so_in_one_line(capsys, monkeypatch):
    # Last in this file: the tests above have compiled the integrator's kernel (one for every
    # frame dtype and map), so this loads it from numba's cache and compiles only what is
    # left (the sub-band kernel, if no test above launched it).
    from radiosim.kernels import compile_pending, compiling
    from radiosim.kernels.bands import band_kernel
    from radiosim.scenes.segmented_chip.kernel import moving_terms_kernel

    pending = (compile_pending(("float32", "float64"), ("uint8", "intp"))
               or not compiling._fresh_signatures(band_kernel)
               or not compiling._fresh_signatures(moving_terms_kernel))
    assert main(["warmup", "-q"]) == 0
    out = capsys.readouterr().out.splitlines()
    said = "compiled radiosim's kernels in " if pending else "radiosim's kernels were compiled"
    assert len(out) == 1 and out[0].startswith(said), out
    assert "cached in" in out[0]
    # Nothing is left to compile, for any frame or index-map type, nor the sub-band kernel.
    assert not compile_pending(("float32", "float64"), ("uint8", "intp"))
    assert compiling._fresh_signatures(band_kernel)
    # A second warmup compiles nothing and says so, rather than "compiled in 1 s".
    assert main(["warmup", "-q"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert len(out) == 1 and out[0].startswith("radiosim's kernels were compiled already"), out


def test_workers_on_a_study_too_small_to_gain_run_in_this_process(tmp_path, capsys):
    # Three measurements of 4 frames of 24 × 24 samples: a cluster's start (about 3 s) could
    # never pay; the command says why in one line and measures here (no cluster started).
    import logging

    from conftest import frames_study

    np.save(tmp_path / "frames.npy", np.full((6, 24, 24), 650.0))
    (tmp_path / "s.toml").write_text(frames_study([1, 2, 3], 4.0))
    logging.getLogger("radiosim.scheduling").addHandler(handler := logging.StreamHandler())
    try:
        assert main(["run", str(tmp_path / "s.toml"), "--out", str(tmp_path / "out"),
                     "--workers", "2", "--no-figures", "-q"]) == 0
    finally:
        logging.getLogger("radiosim.scheduling").removeHandler(handler)
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "measuring in this process" in err[0], err
    assert (tmp_path / "out" / "results.csv").exists()


def test_calibrate_writes_over_the_camera_file_keeping_its_comments(tmp_path, capsys):
    # The fitted camera keeps the preset's comments and layout, changes only the fitted values
    # and records the table it was fitted to: its path and SHA-256 (computed here).
    import hashlib
    import tomllib

    from radiosim import Camera
    from radiosim.presets import PRESET_DIRECTORY

    t = np.linspace(350.0, 550.0, 6)  # [K]; nist-ir's counts at 100 µs, 3 % more gain
    counts = Camera.preset("nist-ir").calibration(100e-6).counts(t) * 1.03 + 20.0
    table = tmp_path / "table.csv"
    table.write_text("temperature_K,counts\n" + "".join(f"{a},{c}\n" for a, c in zip(t, counts)))
    out = tmp_path / "fitted.toml"
    assert main(["calibrate", str(table), "--camera", "nist-ir", "--integration-time", "100us",
                 "--out", str(out), "-q"]) == 0
    text = out.read_text(encoding="utf-8")
    preset = (PRESET_DIRECTORY / "nist-ir.toml").read_text(encoding="utf-8")
    comments = [line for line in preset.splitlines() if line.startswith("#")]
    assert all(line in text for line in comments)
    assert hashlib.sha256(table.read_bytes()).hexdigest() in text and str(table) in text
    written, original = tomllib.loads(text), tomllib.loads(preset)
    assert written["name"] == "nist-ir-fitted"
    assert written["electronics"]["gain_dn_per_e"] != original["electronics"]["gain_dn_per_e"]
    assert written["optics"] == original["optics"] and written["fpa"] == original["fpa"]
    assert Camera.from_toml(out).name == "nist-ir-fitted"  # a camera file radiosim reads
