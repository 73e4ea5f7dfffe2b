"""The radiosim command."""

import argparse
import csv
import json
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from conftest import (STUDY_TEMPLATE, VALID_STUDY, api_error, conflicting_fea, double, fea_rows,
                      fea_text, frames_study, frames_study_dict, gradient_frames, names,
                      nan_late_study, no_litter, single_line, tree, without_paths,
                      write_exr_frames, write_study)
from radiosim import Camera
from radiosim.cli import main, parse_length, parse_temperature, parse_time
from radiosim.errors import RadiosimError
from radiosim.files import OutputFolder
from radiosim.io import read_exr, read_frames
from radiosim.study import Study
from radiosim.uncertainty import MAX_DRAWS

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


# -- units as typed, negative values, the actual quantity named, arguments refused up front --------
# Every refusal: exit 2, one line on stderr naming the option or file, the value and what was
# expected, no traceback, nothing written.


def cli(argv, capsys):
    try:
        code = main([str(a) for a in argv])
    except SystemExit as exc:  # argparse errors exit from parse_args
        code = exc.code
    out, err = capsys.readouterr()
    return code, out, err


def snapshot(root) -> dict:
    root = Path(root)
    return {str(p.relative_to(root)): (None if p.is_dir() else p.read_bytes())
            for p in sorted(root.rglob("*"))}


def refused(argv, capsys, root, *expected, code=2) -> str:
    """Run ``argv`` in ``root``; assert the exit code, one line naming every ``expected``, no
    traceback, nothing written; return the line."""
    before = snapshot(root)
    got, out, err = cli(argv, capsys)
    assert got == code, (got, out, err)
    assert "Traceback" not in err + out, err
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1, err
    line = lines[0]
    assert line.startswith("radiosim: error:"), line
    assert "internal error" not in line, line
    for name in expected:
        assert str(name) in line, f"{name!r} not named in: {line}"
    assert snapshot(root) == before, "files changed"
    return line


@pytest.fixture
def here(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("RADIOSIM_SCHEDULER", raising=False)
    np.save(tmp_path / "frames.npy", np.full((20, 24, 24), 500.0))
    return tmp_path


def measure(*extra, pitch="3um", t="2us"):
    return ["measure", "frames.npy", "--camera", "linear-ideal", "--pixel-pitch", pitch,
            "--dx", "1um", "--dt", "1us", "--units", "K", "--integration-time", t, *extra]


FEA = "time,x,y,temperature\n" + "".join(
    f"{t},{2 * x},{2 * y},{500 + x + y + t}\n" for t in range(3) for x in range(5)
    for y in range(5))


@pytest.mark.parametrize("t", ["2\u00b5s", "2\u03bcs", "2us"])
def test_micro_sign_and_greek_mu_are_both_microseconds(here, capsys, t):
    code, out, err = cli(measure(t=t), capsys)
    assert code == 0, err
    assert "2 µs from 0 µs (2 frames)" in out


def test_greek_mu_in_a_length(here, capsys):
    code, out, err = cli(measure(pitch="3\u03bcm"), capsys)
    assert code == 0, err
    assert "8 × 8 pixels" in out  # 24 µm of scene / 3 µm pixels


@pytest.mark.parametrize("argv", [["--integration-time", "-5us"], ["--integration-time=-5us"]])
def test_negative_integration_time_is_a_bad_value_not_an_option(here, capsys, argv):
    line = refused(measure()[:-2] + argv, capsys, here, "--integration-time", "-5us",
                   "must be positive")
    assert "expected one argument" not in line


@pytest.mark.parametrize("option,value", [("--dt", "-1us"), ("--dx", "-0.5um"),
                                          ("--pixel-pitch", "-3um"), ("--dt", "-1e-3s")])
def test_negative_quantities_name_the_option(here, capsys, option, value):
    argv = measure()
    argv[argv.index(option) + 1] = value
    refused(argv, capsys, here, option, value, "must be positive")


def test_temperature_below_absolute_zero(here, capsys):
    refused(["sse", "nist-ir", "--temperature", "-300C"], capsys, here, "--temperature",
            "-300C", "absolute zero")


def test_negative_diameter_in_a_list(here, capsys):
    line = refused(["sse", "nist-ir", "--diameters", "12um", "-60um"], capsys, here,
                   "--diameters", "-60um", "must be positive")
    assert "unrecognized" not in line


def test_negative_celsius_is_a_temperature(here, capsys):
    (here / "fea.csv").write_text("# units: time=us, length=um, temperature=C\n" + FEA)
    code, out, err = cli(["measure", "fea.csv", "--camera", "linear-ideal", "--pixel-pitch",
                          "4um", "--dx", "1um", "--integration-time", "2us", "--fill", "-40C"],
                         capsys)
    assert code == 0, err


def test_window_errors_quote_the_values_as_typed(here, capsys):
    refused(measure(t="50us"), capsys, here, "--integration-time 50us")
    refused(measure("--start", "-5us", t="5us"), capsys, here, "--start -5us")


def test_a_number_without_a_unit(here, capsys):
    refused(measure(t="5"), capsys, here, "--integration-time", "'5'", "10us")


def test_negative_start_is_read_as_a_value(here, capsys):
    # A window start may be negative in a scene's own time; argparse must not take it for an
    # option: the refusal is the window's, not "expected one argument".
    line = refused(measure("--start", "-5us"), capsys, here)
    assert "expected one argument" not in line and "unrecognized" not in line


def test_too_short_integration_names_the_integration_time(here, capsys):
    line = refused(measure(t="0.5ns"), capsys, here, "--integration-time 0.5ns", "--dt 1us")
    assert "Was dt given" not in line


def test_too_small_pixel_names_the_pixel_pitch(here, capsys):
    line = refused(measure(pitch="1nm"), capsys, here, "--pixel-pitch 1nm", "--dx 1um")
    assert "Was dx given" not in line


@pytest.mark.parametrize("argv", [["sse", "linear-ideal"], ["report", "linear-ideal"],
                                  ["calibrate", "table.csv", "--camera", "linear-ideal",
                                   "--integration-time", "10us"]])
def test_linear_ideal_outside_measure_names_what_is_accepted(here, capsys, argv):
    (here / "table.csv").write_text("temperature_K,counts\n300,1000\n")
    line = refused(argv, capsys, here, f"radiosim {argv[0]}", "nist-ir", "camera TOML")
    assert "needs --pixel-pitch" not in line


@pytest.mark.parametrize("address,problem", [("tcp://nonsense:abc", "PROTOCOL://HOST:PORT"),
                                             ("foo:/bar", "PROTOCOL://HOST:PORT"),
                                             ("tcp://127.0.0.1:70000", "port 70000"),
                                             ("http://127.0.0.1:8786", "protocol 'http'")])
def test_malformed_scheduler_address_is_one_clear_line(here, capsys, address, problem):
    (here / "study.toml").write_text(frames_study([2], 3.0))
    refused(["run", "study.toml", "--scheduler", address], capsys, here, "--scheduler",
            address, problem, "tcp://127.0.0.1:8786")


def test_malformed_scheduler_from_the_environment(here, capsys, monkeypatch):
    monkeypatch.setenv("RADIOSIM_SCHEDULER", "tcp:/x")
    refused(["uncertainty", "chip-budget", "--draws", "2"], capsys, here, "tcp:/x",
            "$RADIOSIM_SCHEDULER")


def test_an_empty_scheduler_variable_is_unset(here, capsys, monkeypatch):
    # RADIOSIM_SCHEDULER= (the usual way to unset it in a shell) runs in this process, as
    # without the variable, for the command and for the library's scheduler.
    from radiosim.scheduling import connect

    monkeypatch.setenv("RADIOSIM_SCHEDULER", "")
    np.save(here / "frames.npy", np.full((6, 24, 24), 650.0))
    (here / "study.toml").write_text(frames_study([2], 3.0))
    assert main(["run", "study.toml", "--out", "out", "--no-figures", "-q"]) == 0, \
        capsys.readouterr().err
    assert (here / "out" / "results.csv").exists()
    run, close = connect()  # in this process, in order: no address to reach
    try:
        assert run(abs, [(-1,), (-2,)]) == [1, 2]
    finally:
        close()


@pytest.mark.parametrize("t", ["1s", "2ms"])
def test_sse_integration_past_the_frame_period(here, capsys, t):
    # nist-ir runs at 600 Hz: a frame period of 1666.67 µs, the rule measure enforces.
    refused(["sse", "nist-ir", "--integration-time", t], capsys, here, "--integration-time",
            t, "frame period", "1666.67 µs")


@pytest.mark.parametrize("command, default", [("sse", "10 µs"), ("report", "240 µs")])
def test_a_default_integration_past_the_frame_period_is_said_to_be_the_default(
        here, capsys, command, default):
    # 1000 Hz; 90 rows × 10 µs + 95 µs = 995 µs of readout: 5 µs of integration at most, which
    # both defaults exceed; with 91 rows (1005 µs) no integration fits: the camera is refused.
    def camera(rows):
        (here / "c.toml").write_text(
            'name = "c"\nframe_rate_hz = 1000.0\n[fpa]\npixel_pitch_um = 3.0\n'
            f'row_time_us = 10.0\nreadout_overhead_us = 95.0\nshape = [{rows}, 160]\n')

    camera(90)
    refused([command, "c.toml"], capsys, here, "--integration-time", f"{default} (the default)",
            "1000 µs", "at most 5 µs")
    camera(91)
    refused([command, "c.toml"], capsys, here, "c.toml", "1005 µs", "under 1000 µs")


def test_calibrate_integration_past_the_frame_period(here, capsys):
    (here / "table.csv").write_text("temperature_K,counts\n300,1000\n400,2000\n")
    refused(["calibrate", "table.csv", "--camera", "nist-ir", "--integration-time", "1s"],
            capsys, here, "--integration-time", "1s", "frame period")


@pytest.mark.parametrize("frames", ["0", "-3", "two"])
def test_calibrate_frames_must_be_positive(here, capsys, frames):
    (here / "table.csv").write_text("temperature_K,counts\n300,1000\n400,2000\n")
    refused(["calibrate", "table.csv", "--camera", "nist-ir", "--integration-time", "10us",
             "--frames", frames], capsys, here, "--frames", frames, "≥ 1")


def test_report_frames_needs_two(here, capsys):
    refused(["report", "nist-ir", "--frames", "1"], capsys, here, "--frames", "'1'", "≥ 2")


@pytest.mark.parametrize("option,value", [("--time-unit", "us"), ("--length-unit", "mm")])
def test_csv_unit_options_on_a_npy_are_refused(here, capsys, option, value):
    refused(measure(option, value), capsys, here, option, value, "frames.npy", ".csv")


@pytest.mark.parametrize("draws", ["0", "-5", "2000000"])
def test_draws_out_of_bounds(here, capsys, draws):
    refused(["uncertainty", "chip-budget", "--draws", draws], capsys, here, "--draws", draws,
            "1 to 1,000,000")


@pytest.mark.parametrize("command", [["run"], ["uncertainty", "chip-budget"]])
def test_workers_must_be_positive(here, capsys, command):
    refused(command + ["--workers", "0"], capsys, here, "--workers", "'0'", "≥ 1")


def test_units_contradicting_the_csv_header_are_refused(here, capsys):
    (here / "fea.csv").write_text("# units: time=us, length=um, temperature=C\n" + FEA)
    refused(["measure", "fea.csv", "--camera", "linear-ideal", "--pixel-pitch", "4um", "--dx",
             "1um", "--integration-time", "2us", "--units", "K"], capsys, here, "fea.csv",
            "K", "temperature=C")


def test_csv_time_and_length_units_are_passed_without_units(here, capsys):
    # Before: --time-unit and --length-unit were dropped unless --units was given too.
    (here / "fea.csv").write_text("# units: temperature=C\n" + FEA)
    code, out, err = cli(["measure", "fea.csv", "--camera", "linear-ideal", "--pixel-pitch",
                          "4um", "--dx", "1um", "--integration-time", "2us", "--time-unit",
                          "us", "--length-unit", "um"], capsys)
    assert code == 0, err
    assert "2 µs from 0 µs (2 frames)" in out


def test_camera_file_error_names_the_file_and_key(here, capsys):
    (here / "cam.toml").write_text('name = "x"\n[fpa]\npixel_pitch_um = -3\n')
    refused(["sse", "cam.toml"], capsys, here, "cam.toml", "pixel_pitch", "-3")


def test_camera_file_error_without_the_file_gets_it(here, capsys, monkeypatch):
    from radiosim.camera import Camera
    from radiosim.errors import RadiosimError

    def load(path):
        raise RadiosimError("[fpa] full_well_e = 0: expected a number > 0")

    monkeypatch.setattr(Camera, "from_toml", load)
    (here / "cam.toml").write_text("")
    refused(["sse", "cam.toml"], capsys, here, "cam.toml:", "full_well_e", "> 0")


def test_missing_camera_file_is_named(here, capsys):
    refused(["sse", "nowhere.toml"], capsys, here, "nowhere.toml")


def test_calibration_table_with_a_byte_order_mark(here, capsys):
    # The BOM is not part of the first column's name: the columns are found, and the refusal
    # is the bad value's (without the fix: "needs columns temperature_K ... found
    # ['\\ufefftemperature_K', 'counts']").
    (here / "table.csv").write_text("temperature_K,counts\n300,many\n", encoding="utf-8-sig")
    refused(["calibrate", "table.csv", "--camera", "nist-ir", "--integration-time", "10us"],
            capsys, here, "table.csv", "counts", "many", "expected a number")


def test_a_file_that_is_no_calibration_table_is_said_to_be_one(here, capsys):
    # A study TOML given as the table: its first line is no header of a calibration table,
    # said before any row is read (not "line 2 has 2 values for 1 columns").
    (here / "s.toml").write_text('name = "s"\n[scene]\ntype = "frames", x = 1\n')
    refused(["calibrate", "s.toml", "--camera", "nist-ir", "--integration-time", "10us"],
            capsys, here, "s.toml", "needs columns temperature_K", "counts",
            "first line is 'name = \"s\"'")


def test_study_file_with_a_byte_order_mark(here, capsys):
    (here / "study.toml").write_text(frames_study([2], 3.0), encoding="utf-8-sig")
    code, out, err = cli(["run", "study.toml", "--out", "out", "--no-exr", "--no-figures",
                          "--quiet"], capsys)
    assert code == 0, err
    assert (here / "out" / "results.csv").is_file()


# -- signals at any moment: the real command in a subprocess (bounded by time-outs) ----------------


LONG = frames_study([1 + 0.025 * i for i in range(121)], 1.0, name="long", camera="linear",
                    sweep="integration-time")


def _command(root: Path, *extra):
    # 121 measurements of 480 × 480 samples: about 15 s warm on 2 cores, long enough that
    # every signal below arrives while the command works
    y, x = np.mgrid[0:480, 0:480]
    frame = 600.0 + 200.0 * np.sin(x / 9.0) * np.cos(y / 7.0)
    np.save(root / "frames.npy", np.stack([frame + 10.0 * k for k in range(8)]))
    (root / "long.toml").write_text(LONG)
    return [sys.executable, "-m", "radiosim.cli", "run", "long.toml", "--out", "results",
            "--no-figures", "--quiet", *extra]


def _start(root, argv):
    return subprocess.Popen(argv, cwd=root, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            start_new_session=True, env=dict(os.environ, PYTHONUNBUFFERED="1"))


def _finish(proc, timeout=60):
    try:
        out, err = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        out, err = proc.communicate()
        pytest.fail(f"no exit {timeout} s after the signal:\n{err.decode(errors='replace')}")
    return out.decode("utf-8", "replace"), err.decode("utf-8", "replace")


def _assert_interrupted(proc, out, err, root):
    assert proc.returncode == 130, (proc.returncode, err)
    assert "Traceback" not in out + err, err
    lines = [line for line in err.splitlines() if line.strip()]
    # One line saying so; at most one more naming the kept partial folder, as
    # tests/test_interrupts.py allows.
    assert sum("interrupted" in line for line in lines) == 1, err
    assert len(lines) <= 2 and all("interrupted" in line or "results.partial" in line
                                   for line in lines), err
    assert not (root / "results").exists()
    assert not [p for p in root.rglob("*") if p.name.endswith(".partial") and not p.is_dir()]


ENTRY = Path(sys.executable).with_name("radiosim")  # the console script users run


@pytest.mark.parametrize("entry", ["console script", "python -m radiosim.cli"])
@pytest.mark.parametrize("name", ["SIGINT", "SIGTERM"])
def test_signals_during_start_up_end_in_one_line(tmp_path, name, entry):
    """SIGINT (to the process group, as a terminal's Ctrl-C) and SIGTERM at 0.3 s, 1 s and
    3 s after start: the imports, the first seconds."""
    for delay in (0.3, 1.0, 3.0):  # one at a time: three start-ups at once slow each other
        root = tmp_path / f"{name}-{delay}"
        root.mkdir()
        argv = _command(root)
        if entry == "console script":
            if not ENTRY.is_file():
                pytest.skip(f"no console script {ENTRY} (radiosim not installed)")
            argv = [str(ENTRY)] + argv[3:]
        proc = _start(root, argv)
        time.sleep(delay)
        if proc.poll() is None:
            os.killpg(proc.pid, getattr(signal, name))
        out, err = _finish(proc)
        if proc.returncode == 0:
            pytest.fail(f"the run completed within {delay} s; make the study longer")
        _assert_interrupted(proc, out, err, root)


def _workers_of(pid: int) -> list[int]:
    """The multiprocessing (spawned) children of ``pid``: a local Dask cluster's workers."""
    found = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            ppid = int((entry / "stat").read_text().rsplit(")", 1)[1].split()[1])
            cmdline = (entry / "cmdline").read_bytes()
        except (OSError, IndexError, ValueError):
            continue
        if ppid == pid and b"--multiprocessing-fork" in cmdline:
            found.append(int(entry.name))
    return found


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs /proc (Linux)")
def test_signals_with_local_workers_end_in_one_line(tmp_path):
    """With ``--workers 2`` (a local Dask cluster of worker processes), once both workers are
    up: Ctrl-C in a terminal reaches every process of the group, the workers included (they
    ignore it, and the command ends them quietly; before: 5-6 worker tracebacks); SIGTERM
    reaches the command alone, as a service manager sends it. A Ctrl-C in the tenth of a
    second while a worker's interpreter starts is not covered here (see the report: it needs
    the cluster started with SIGINT blocked, in radiosim.uncertainty.connect)."""
    plan = {"SIGINT": (signal.SIGINT, True), "SIGTERM": (signal.SIGTERM, False)}
    runs = {}
    for name in plan:
        root = tmp_path / name
        root.mkdir()
        runs[name] = (root, _start(root, _command(root, "--workers", "2", "--cluster",
                                                  "always")))
    pending = {name: None for name in plan}  # name -> when to send
    deadline = time.monotonic() + 120
    while pending and time.monotonic() < deadline:
        for name in list(pending):
            root, proc = runs[name]
            signum, group = plan[name]
            if proc.poll() is not None:
                del pending[name]
            elif pending[name] is None and len(_workers_of(proc.pid)) >= 2:
                pending[name] = time.monotonic() + 1.5  # past their interpreters' start
            elif pending[name] is not None and time.monotonic() >= pending[name]:
                (os.killpg if group else os.kill)(proc.pid, signum)
                del pending[name]
        time.sleep(0.02)
    for name, (root, proc) in runs.items():
        out, err = _finish(proc)
        if proc.returncode == 0:
            pytest.fail(f"{name}: the run completed before the signal; make the study longer")
        _assert_interrupted(proc, out, err, root)


# -- the command's bounds are the library's; what a reading of nothing says; interrupts ------------


def test_the_commands_draw_bound_is_the_librarys():
    # The command states the bound without importing the engine (a fast --help); one number.
    from radiosim import cli, uncertainty

    assert cli.MAX_DRAWS == uncertainty.MAX_DRAWS


def test_the_warmup_help_states_no_time_that_could_go_stale(capsys):
    # Measured times live in docs/performance.md: --help says what warmup does, not how long
    # it took on one host.
    import re

    with pytest.raises(SystemExit):
        main(["--help"])
    with pytest.raises(SystemExit):
        main(["warmup", "--help"])
    out = capsys.readouterr().out
    assert "compile" in out and not re.search(r"\d+\s*s\b", out)


def test_a_scene_read_as_kelvin_that_reads_nothing_says_why(here, capsys):
    # 20 read as kelvin (a °C file given --units K): every pixel is under range. The command
    # says so, names the camera's lowest measurable temperature and asks about the unit,
    # instead of printing "nan °C" alone.
    np.save(here / "cold.npy", np.full((5, 24, 24), 20.0))
    code, out, err = cli(["measure", "cold.npy", "--camera", "nist-ir", "--dx", "1um", "--dt",
                          "1us", "--units", "K", "--integration-time", "2us"], capsys)
    assert code == 0, err
    assert "nan" not in out, out
    assert "every pixel is under range" in out and "nist-ir's lowest measurable" in out, out
    assert "--units C" in out, out
    # A scene in range gets no such note.
    code, out, err = cli(["measure", "frames.npy", "--camera", "nist-ir", "--dx", "1um", "--dt",
                          "1us", "--units", "K", "--integration-time", "2us"], capsys)
    assert code == 0 and "under range 0.0 %" in out and "every pixel" not in out, out


def test_an_interrupt_that_surfaces_as_another_error_is_still_an_interrupt(here, capsys,
                                                                          monkeypatch):
    # A signal that cuts an import short surfaces as ImportError ("initialization failed"):
    # once the handler has marked the command interrupted, that is exit 130 and the one
    # interrupt line, not "internal error".
    from radiosim import cli as cli_module
    from radiosim.interrupts import command_state

    def cut_short(args):
        command_state.interrupted = True
        command_state.signal_name = "SIGTERM"
        raise ImportError("initialization failed")

    monkeypatch.setattr(command_state, "interrupted", False)  # restored after the test
    monkeypatch.setattr(command_state, "signal_name", "")

    monkeypatch.setattr(cli_module, "_presets", cut_short)
    code, out, err = cli(["presets"], capsys)
    assert code == 130, (code, err)
    assert err.strip() == "radiosim: interrupted (SIGTERM); temporary files removed", err
    assert "internal error" not in err


def test_a_missing_scene_subcommand_is_named_as_the_user_types_it(here, capsys):
    line = refused(["scene"], capsys, here, "required", "preview", "radiosim scene --help")
    assert "scene_command" not in line


def test_a_pattern_the_shell_expanded_is_said_to_be_one(here, capsys):
    # `radiosim measure run/frame_*.exr` unquoted: the shell passes every file; one short line
    # says so instead of listing them. Words that are not files are listed as argparse does.
    for i in range(4):
        (here / f"frame_{i}.exr").write_bytes(b"")
    line = refused(["measure", *[f"frame_{i}.exr" for i in range(4)], "--camera", "nist-ir",
                    "--integration-time", "10us"], capsys, here, "3 more files",
                   "frame_1.exr …", "quote it")
    assert "frame_3.exr" not in line
    refused(["measure", "frame_0.exr", "extra", "words", "--camera", "nist-ir",
             "--integration-time", "10us"], capsys, here, "unrecognized arguments: extra words")


# -- --out checked before any work; bad samples name the file, in the unit typed -------------------


def measure_file(scene="frames.npy", *extra, units="K"):
    return ["measure", scene, "--camera", "linear-ideal", "--pixel-pitch", "3um", "--dx", "1um",
            "--dt", "1us", "--units", units, "--integration-time", "2us", *extra]


def test_out_below_a_file_is_named_as_a_file_before_any_work(here, capsys):
    line = refused(measure_file("frames.npy", "--out", "frames.npy/m.exr"), capsys, here,
                   "--out frames.npy/m.exr", "frames.npy is a file, not a folder")
    assert "does not exist" not in line
    assert capsys.readouterr().out == ""  # nothing measured (and printed) first


def test_out_in_a_missing_folder_is_refused_before_any_work(here, capsys):
    refused(measure_file("frames.npy", "--out", "nowhere/m.exr"), capsys, here,
            "--out nowhere/m.exr", "folder nowhere does not exist")


def test_out_with_a_name_too_long_is_an_input_error_not_a_failure(here, capsys):
    name = "A" * 300 + ".exr"
    line = refused(measure_file("frames.npy", "--out", name), capsys, here, "--out", "304 bytes",
                   "at most")
    assert name not in line  # one readable line


def test_sse_out_in_a_missing_folder_is_refused_up_front(here, capsys):
    refused(["sse", "nist-ir", "--out", "nowhere/sse.csv"], capsys, here,
            "--out nowhere/sse.csv", "does not exist")


def test_out_with_spaces_and_unicode_is_written(here, capsys):
    code, out, err = cli(measure_file("frames.npy", "--out", "a b é.exr"), capsys)
    assert code == 0, err
    assert (here / "a b é.exr").is_file()


def test_a_negative_kelvin_sample_names_the_file_not_the_window(here, capsys):
    stack = np.full((20, 24, 24), 500.0)
    stack[1, 4, 5] = -1.0
    np.save(here / "bad.npy", stack)
    line = refused(measure_file("bad.npy"), capsys, here, "bad.npy", "frame 1", "row 4",
                   "column 5", "-1 K")
    assert "--integration-time" not in line  # the window is not at fault


def test_a_sample_below_absolute_zero_in_celsius_is_reported_in_celsius(here, capsys):
    stack = np.full((20, 24, 24), 20.0)
    stack[1, 4, 5] = -300.0
    np.save(here / "bad.npy", stack)
    line = refused(measure_file("bad.npy", units="C"), capsys, here, "bad.npy", "-300 °C",
                   "absolute zero")
    assert "°C passed as kelvin" not in line  # the user said C


def test_a_nan_sample_names_the_file(here, capsys):
    stack = np.full((20, 24, 24), 500.0)
    stack[0, 2, 3] = np.nan
    np.save(here / "bad.npy", stack)
    refused(measure_file("bad.npy"), capsys, here, "bad.npy", "frame 0", "row 2", "NaN")


def test_fill_on_a_numpy_stack_is_refused(here, capsys):
    refused(measure_file("frames.npy", "--fill", "20C"), capsys, here, "--fill 20C", "frames.npy",
            ".csv")


# -- study files: the file, the sweep, the key and the value as typed ------------------------------


def study(here, sweep="integration_time_us = [2]", scene_extra="", extra=""):
    (here / "s.toml").write_text(STUDY_TEMPLATE.format(sweep=sweep, scene_extra=scene_extra)
                                 + extra)
    return ["run", "s.toml", "--no-figures", "-q", "--out", "out"]


@pytest.mark.parametrize("sweep,named", [
    ("pixel_samples = [1.5]\nintegration_time_us = [2]", "pixel_samples"),
    ("integration_time_frames = [2.5]", "integration_time_frames"),
])
def test_a_fraction_where_a_count_is_expected_is_refused_not_rounded(here, capsys, sweep,
                                                                     named):
    refused(study(here, sweep), capsys, here, "s.toml", "sweep 'a'", named, "2.5"
            if "frames" in named else "1.5", "whole numbers")


@pytest.mark.parametrize("key", ["response", "alignment"])
def test_an_empty_list_that_would_measure_nothing_is_refused(here, capsys, key):
    refused(study(here, f"{key} = []\nintegration_time_us = [2]"), capsys, here, "s.toml",
            f"{key} = []", "measures nothing")


@pytest.mark.parametrize("sweep,named", [
    ("integration_time_us = [2, 2]", "integration_time_us lists 2 twice"),
    ("integration_time_us = [2]\nalignment = [\"centred\", \"centred\"]",
     "alignment lists 'centred' twice"),
])
def test_a_value_listed_twice_is_refused_its_files_would_clash(here, capsys, sweep, named):
    refused(study(here, sweep), capsys, here, "s.toml", named)


def test_a_camera_listed_twice_is_refused(here, capsys):
    argv = study(here)
    (here / "s.toml").write_text((here / "s.toml").read_text().replace(
        'cameras = ["lin"]', 'cameras = ["lin", "lin"]'))
    refused(argv, capsys, here, "s.toml", "cameras lists 'lin' twice")


def test_two_sweeps_of_one_name_are_refused(here, capsys):
    argv = study(here, extra='\n[[sweeps]]\nname = "a"\ncameras = ["lin"]\n'
                              'integration_time_us = [3]\n')
    refused(argv, capsys, here, "s.toml", "two sweeps are named 'a'")


def test_values_that_round_to_one_file_name_are_refused_before_any_work(here, capsys):
    argv = study(here, "integration_time_us = [2.000001, 2.000002]")
    refused(argv, capsys, here, "s.toml", "exr/a_lin_linear_2us_3um_centred.exr",
            "2.000001", "2.000002")


def test_a_sweep_longer_than_the_scene_names_the_sweep_and_its_time(here, capsys):
    refused(study(here, "integration_time_us = [200]"), capsys, here, "s.toml", "sweep 'a'",
            "camera 'lin'", "200 µs", "runs past the scene's last frame")


def test_a_sweep_pixel_larger_than_the_scene_names_the_sweep(here, capsys):
    refused(study(here, "pixel_pitch_um = [100]\nintegration_time_us = [2]"), capsys, here,
            "s.toml", "sweep 'a'", "100 µm", "no whole pixel fits")


@pytest.mark.parametrize("key,value", [("dt_us", "-1.0"), ("dx_um", "0")])
def test_a_scene_grid_value_is_named_in_the_unit_of_its_key(here, capsys, key, value):
    text = STUDY_TEMPLATE.replace(f"{key} = 1.0", f"{key} = {value}")
    (here / "s.toml").write_text(text.format(sweep="integration_time_us = [2]",
                                             scene_extra=""))
    line = refused(["run", "s.toml", "--no-figures", "-q", "--out", "out"], capsys, here,
                   "s.toml", f"[scene] {key} = {value}", "µs" if key == "dt_us" else "µm")
    assert "e-06" not in line  # not in seconds or metres


@pytest.mark.parametrize("scene_extra,named", [
    ("emissivity = 1.5", "1.5"),
    ("reflected_temperature_K = -5", "-5 K"),
    ("event_time_us = 500", "event_time_us = 500"),
])
def test_scene_errors_name_the_study_file_and_the_scene_table(here, capsys, scene_extra,
                                                              named):
    line = refused(study(here, scene_extra=scene_extra), capsys, here, "s.toml", "[scene]",
                   named)
    assert "np.float64" not in line


def test_a_scene_file_missing_names_the_study_file(here, capsys):
    (here / "frames.npy").unlink()
    refused(study(here), capsys, here, "s.toml", "[scene]", "frames.npy does not exist")


@pytest.mark.parametrize("sweep,named", [
    ('integration_time_us = [2]\nresponse = ["plank"]', "response must be"),
    ('integration_time_us = [2]\nalignment = ["center"]', "alignment must be"),
    ('integration_time_us = [2]\nkind = "pixels"', "kind must be"),
])
def test_a_bad_choice_names_the_value_given(here, capsys, sweep, named):
    bad = sweep.split('"')[1]
    refused(study(here, sweep), capsys, here, "s.toml", named, f"got '{bad}'")


# -- run: the output folder, another run, the scheduler, the draws (exit code and one line) --------


def write_toml_study(folder: Path, extra: str = "") -> Path:
    rng = np.random.default_rng(0)
    np.save(folder / "frames.npy", 600.0 + 50.0 * rng.random((6, 12, 12)))
    path = folder / "s.toml"
    path.write_text('name = "small"\n[scene]\ntype = "frames"\npath = "frames.npy"\n'
                    'dt_us = 1.0\ndx_um = 1.0\nunits = "K"\n[cameras.lin]\n'
                    'preset = "linear-ideal"\npixel_pitch_um = 3.0\n[[sweeps]]\nname = "t"\n'
                    'cameras = ["lin"]\nintegration_time_us = [1, 2]\n' + extra)
    return path


def test_the_command_refuses_a_dangling_out_in_one_line(tmp_path, capsys):
    study = write_toml_study(tmp_path)
    (tmp_path / "out").symlink_to(tmp_path / "gone")
    code, _, err = cli(["run", study, "--out", tmp_path / "out", "--quiet", "--no-figures"],
                       capsys)
    assert code == 2
    single_line(err, "symbolic link")
    assert not (tmp_path / "gone").exists() and not (tmp_path / "out.partial").exists()


def test_the_command_names_another_running_run(tmp_path, capsys):
    study = write_toml_study(tmp_path)
    holder = OutputFolder(tmp_path / "out")
    try:
        code, _, err = cli(["run", study, "--out", tmp_path / "out", "--quiet",
                            "--no-figures"], capsys)
    finally:
        holder.abandon(keep=False)
    assert code == 2
    single_line(err, f"another run (pid {os.getpid()})")
    assert "delete" not in err


def test_the_command_names_a_malformed_scheduler(tmp_path, capsys):
    study = write_toml_study(tmp_path)
    code, _, err = cli(["run", study, "--out", tmp_path / "out", "--quiet", "--no-figures",
                        "--scheduler", "tcp://localhost:notaport"], capsys)
    assert code == 2
    single_line(err, "tcp://localhost:notaport")
    assert "internal error" not in err
    assert not (tmp_path / "out").exists() and not (tmp_path / "out.partial").exists()


def test_the_command_refuses_a_huge_draw_count(tmp_path, capsys):
    study = write_toml_study(tmp_path, '[uncertainty]\ncamera = "lin"\nintegration_time_us = 2\n'
                                       '[uncertainty.inputs]\nemissivity = {distribution = '
                                       '"uniform", low = 0.8, high = 0.9}\n')
    code, _, err = cli(["uncertainty", study, "--draws", "100000000", "--out",
                        tmp_path / "u", "--quiet"], capsys)
    assert code == 2
    single_line(err, "100000000")
    assert str(MAX_DRAWS) in err.replace(",", "")
    assert not (tmp_path / "u").exists() and not (tmp_path / "u.partial").exists()


def test_a_refused_folder_is_named_in_the_callers_words(tmp_path, capsys):
    # The command names its option and suggests --overwrite; Python's Study.run suggests
    # overwrite=True; example-data (no --out option) names its folder argument.
    out = tmp_path / "out"
    out.mkdir()
    (out / "data.csv").write_text("the user's data")
    study = tmp_path / "s.toml"
    import tomlkit

    study.write_text(tomlkit.dumps(frames_study_dict(tmp_path)))
    code, _, err = cli(["run", str(study), "--out", str(out), "-q"], capsys)
    assert code == 2 and f"--out {out} is not empty" in err and "pass --overwrite " in err
    assert "overwrite=True" not in err
    for overwrite in (False, True):  # not empty; with overwrite: not radiosim's folder
        with pytest.raises(RadiosimError) as info:
            Study.from_dict(frames_study_dict(tmp_path)).run(out, overwrite=overwrite)
        assert "overwrite=True" in str(info.value) and "--" not in str(info.value)
    code, _, err = cli(["run", str(study), "--out", str(out), "--overwrite", "-q"], capsys)
    assert code == 2 and "--overwrite replaces only radiosim's own files" in err
    code, _, err = cli(["example-data", str(out / "data.csv")], capsys)
    assert code == 2 and "--out" not in err and "example data's folder" in err
    assert tree(out) == {"data.csv": b"the user's data"}


# -- bad inputs: one clean line (exit 2 input, 1 runtime), nothing written or overwritten ----------


def one_line(err: str, *expected) -> str:
    """The single ``radiosim: error:`` line of ``err``, which names every one of ``expected``;
    returned without its temporary paths."""
    assert "Traceback" not in err, err
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1, f"expected exactly one line on stderr, got {len(lines)}:\n{err}"
    line = lines[0]
    assert line.startswith("radiosim: error:"), line
    assert "internal error" not in line, line
    for name in expected:
        assert names(line, name), f"{name!r} is not named in: {line}"
    return without_paths(line)


def assert_unchanged(before: dict, root):
    after = snapshot(root)
    added = sorted(set(after) - set(before))
    removed = sorted(set(before) - set(after))
    changed = sorted(k for k in set(before) & set(after) if before[k] != after[k])
    assert not (added or removed or changed), (
        f"files changed: added {added}, removed {removed}, modified {changed}")


def write_frames_npy(path, shape=(20, 24, 24), value=500.0):
    np.save(path, np.full(shape, value))
    return Path(path)


def measure_args(scene, *extra):
    return ["measure", scene, "--camera", "linear-ideal", "--pixel-pitch", "3um", "--dx", "1um",
            "--dt", "1us", "--units", "K", "--integration-time", "2us", *extra]


def is_root_proof_readonly(folder: Path) -> bool:
    """True if ``folder`` really cannot be written (root ignores permission bits)."""
    if os.access(folder, os.W_OK):
        return False
    try:
        (folder / ".probe").write_text("x")
    except OSError:
        return True
    (folder / ".probe").unlink()
    return False


@pytest.fixture
def readonly(tmp_path):
    folder = tmp_path / "ro"
    folder.mkdir()
    folder.chmod(0o500)
    try:
        if not is_root_proof_readonly(folder):
            pytest.skip("permissions are not enforced for this user (root): a chmod 0o500 "
                        "folder is writable")
        yield folder
    finally:
        folder.chmod(0o700)


SUBPROCESS_CASES = {
    # name: the arguments after "radiosim" ({study}, {root}, {afile}, {npz}: the case's files);
    # "dev-full" runs with its stdout on /dev/full (every write fails: ENOSPC)
    "out-is-file": ["run", "{study}", "--out", "{afile}", "--quiet", "--no-figures"],
    "progress": ["run", "{study}", "--out", "{root}/progress-out", "--no-figures"],
    "npz": ["measure", "{npz}", "--camera", "linear-ideal", "--pixel-pitch", "3um", "--dx", "1um",
            "--dt", "1us", "--units", "K", "--integration-time", "2us"],
    "dev-full": ["run", "{study}", "--out", "{root}/full-out", "--quiet", "--no-figures"],
    "bad-seed": ["run", "{study}", "--out", "{root}/seed-out", "--seed", "-1", "--quiet"],
}


@pytest.fixture(scope="module")
def processes(tmp_path_factory):
    """Each case of SUBPROCESS_CASES run by ``python -m radiosim.cli`` in its own folder, all at
    once; returns name → (exit code, stdout bytes, stderr bytes, folder, snapshot before)."""
    running = {}
    for name, argv in SUBPROCESS_CASES.items():
        root = tmp_path_factory.mktemp(name)
        study = write_study(root)
        (root / "afile").write_text("a user's file\n")
        np.savez_compressed(root / "c.npz", a=np.full((6, 12, 12), 500.0))
        args = [a.format(study=study, root=root, afile=root / "afile", npz=root / "c.npz")
                for a in argv]
        before = snapshot(root)
        stdout = subprocess.PIPE
        if name == "dev-full":
            if not os.path.exists("/dev/full"):
                running[name] = None
                continue
            stdout = open("/dev/full", "w")
        proc = subprocess.Popen([sys.executable, "-m", "radiosim.cli", *args], cwd=root,
                                stdout=stdout, stderr=subprocess.PIPE)
        running[name] = (proc, root, before, stdout)
    results = {}
    try:
        for name, item in running.items():
            if item is None:
                results[name] = None
                continue
            proc, root, before, stdout = item
            out, err = proc.communicate(timeout=120)
            results[name] = (proc.returncode, out or b"", err, root, before)
    finally:
        for item in running.values():
            if item is not None:
                proc, stdout = item[0], item[3]
                if proc.poll() is None:
                    proc.kill()
                    proc.communicate()
                if stdout is not subprocess.PIPE:
                    stdout.close()
    return results


@pytest.fixture
def unwritable():
    """A folder that even root cannot write in: /proc (nothing can be created there)."""
    folder = Path("/proc")
    if not (folder / "self").is_dir():
        pytest.skip("no /proc file system here")
    try:
        with open(folder / "radiosim-probe", "x"):
            pass
    except OSError:
        return folder
    (folder / "radiosim-probe").unlink()
    pytest.skip("/proc is writable here")


@pytest.fixture(params=["readonly", "unwritable"])
def blocked(request):
    """A folder nothing can be written in: a chmod 0o500 one (skipped as root, which writes
    anyway) or /proc (even root cannot)."""
    return request.getfixturevalue(request.param)


# A write the system refuses is a failure while running (exit 1), not an input mistake.


@pytest.mark.usefixtures("in_tmp")
def test_cli_run_into_a_blocked_folder(tmp_path, blocked, capsys):
    study = write_study(tmp_path)
    before = snapshot(tmp_path)
    out = blocked / "radiosim-test-out"
    code, _, err = cli(["run", study, "--out", out, "--quiet", "--no-figures"], capsys)
    assert code == 1
    one_line(err, blocked)
    assert_unchanged(before, tmp_path)
    assert not out.exists()


@pytest.mark.usefixtures("in_tmp")
def test_cli_readonly_folder_itself_as_out(tmp_path, readonly, capsys):
    study = write_study(tmp_path)
    before = snapshot(tmp_path)
    code, _, err = cli(["run", study, "--out", readonly, "--quiet", "--no-figures"], capsys)
    assert code in (1, 2)
    one_line(err, readonly)
    assert_unchanged(before, tmp_path)


@pytest.mark.usefixtures("in_tmp")
@pytest.mark.parametrize("command, name", [
    (lambda npy, out: ["scene", "preview", "--out", out], "x.png"),
    (lambda npy, out: measure_args(npy, "--out", out), "m.exr"),
], ids=["preview", "measure"])
def test_cli_write_into_a_blocked_folder(tmp_path, blocked, capsys, command, name):
    npy = write_frames_npy(tmp_path / "s.npy")
    before = snapshot(tmp_path)
    code, _, err = cli(command(npy, blocked / name), capsys)
    assert code == 1
    one_line(err, blocked / name)
    assert_unchanged(before, tmp_path)


@pytest.mark.usefixtures("in_tmp")
def test_cli_out_is_an_existing_file(tmp_path, capsys):
    study = write_study(tmp_path)
    afile = tmp_path / "afile"
    afile.write_text("a user's file\n")
    before = snapshot(tmp_path)
    code, _, err = cli(["run", study, "--out", afile, "--quiet", "--no-figures"], capsys)
    assert code == 2
    one_line(err, afile)
    assert_unchanged(before, tmp_path)


@pytest.mark.usefixtures("in_tmp")
def test_cli_out_is_an_existing_file_real_process(processes):
    code, out, err, root, before = processes["out-is-file"]
    assert code == 2
    one_line(err.decode(), root / "afile")
    assert_unchanged(before, root)


@pytest.mark.usefixtures("in_tmp")
@pytest.mark.parametrize("seed", ["-1", "-3", "1.5", "abc", "1e3"])
@pytest.mark.parametrize("command", ["run", "measure"])
def test_cli_bad_seed(tmp_path, capsys, command, seed):
    study = write_study(tmp_path)
    npy = write_frames_npy(tmp_path / "s.npy")
    before = snapshot(tmp_path)
    argv = (["run", study, "--out", tmp_path / "out", "--quiet"] if command == "run"
            else measure_args(npy, "--out", tmp_path / "m.exr"))
    code, _, err = cli([*argv, f"--seed={seed}"], capsys)
    assert code == 2
    one_line(err, seed, "--seed")
    assert_unchanged(before, tmp_path)


@pytest.mark.usefixtures("in_tmp")
def test_cli_negative_seed_real_process(processes):
    code, out, err, root, before = processes["bad-seed"]
    assert code == 2
    one_line(err.decode(), "-1", "--seed")
    assert_unchanged(before, root)


@pytest.mark.usefixtures("in_tmp")
@pytest.mark.parametrize("option, value, named", [
    ("--integration-time", "10", "10"),       # no unit
    ("--integration-time", "-1us", "-1us"),
    ("--integration-time", "0us", "0us"),
    ("--integration-time", "nanus", "nanus"),
    ("--dx", "0um", "0um"),
    ("--dt", "1 parsec", "1 parsec"),
    ("--pixel-pitch", "6", "6"),
    ("--fill", "-5K", "-5K"),
    ("--units", "F", "F"),
    ("--start", "-3us", "-3 µs"),              # named in the unit typed, not 3e-06 s
])
def test_cli_bad_option_value(tmp_path, capsys, option, value, named):
    npy = write_frames_npy(tmp_path / "s.npy")
    before = snapshot(tmp_path)
    code, _, err = cli([*measure_args(npy, "--out", tmp_path / "m.exr"), f"{option}={value}"],
                       capsys)
    assert code == 2
    one_line(err, named)
    assert_unchanged(before, tmp_path)


@pytest.mark.usefixtures("in_tmp")
@pytest.mark.parametrize("content", [
    pytest.param(np.array([]), id="empty-1d"),
    pytest.param(np.zeros((0, 12, 12)), id="empty-3d"),
    pytest.param(None, id="zero-bytes"),
])
def test_cli_empty_npy(tmp_path, capsys, content):
    path = tmp_path / "empty.npy"
    if content is None:
        path.write_bytes(b"")
    else:
        np.save(path, content)
    before = snapshot(tmp_path)
    code, _, err = cli(measure_args(path, "--out", tmp_path / "m.exr"), capsys)
    assert code == 2
    one_line(err, path)
    assert_unchanged(before, tmp_path)


@pytest.mark.usefixtures("in_tmp")
@pytest.mark.parametrize("key, text", [
    ("pixel_pitch_um", '"6"'),
    ("f_number", '"2.5"'),
    ("fill_factor", '"1"'),
    ("read_noise_e", '"0"'),
    ("assumed_emissivity", '"1"'),
    ("calibration_range_K", '["150", "3000"]'),
])
def test_cli_camera_toml_number_as_string(tmp_path, capsys, key, text):
    toml = Camera.linear_ideal(3e-6).to_toml()
    toml, n = re.subn(rf"(?m)^{key} = .*$", f"{key} = {text}", toml)
    assert n == 1
    camera = tmp_path / "camera.toml"
    camera.write_text(toml)
    npy = write_frames_npy(tmp_path / "s.npy")
    before = snapshot(tmp_path)
    argv = ["measure", npy, "--camera", camera, "--dx", "1um", "--dt", "1us", "--units", "K",
            "--integration-time", "2us", "--out", tmp_path / "m.exr"]
    code, _, err = cli(argv, capsys)
    assert code == 2
    one_line(err, key, camera)
    assert_unchanged(before, tmp_path)


@pytest.mark.usefixtures("in_tmp")
@pytest.mark.parametrize("step", [0, 1])
def test_cli_fea_collinear_step_is_one_clean_line(tmp_path, capfd, step):
    rows = [r for r in fea_rows() if r[0] != step]
    rows += [[step, 2.0 * i, 2.0 * i, 500.0] for i in range(5)]  # on the diagonal: collinear
    rows.sort(key=lambda r: r[0])
    path = tmp_path / "nodes.csv"
    path.write_text(fea_text(rows))
    before = snapshot(tmp_path)
    argv = ["measure", path, "--camera", "linear-ideal", "--pixel-pitch", "3um", "--dx", "1um",
            "--integration-time", "3us", "--start", "0us", "--out", tmp_path / "m.exr"]
    code, out, err = cli(argv, capfd)  # capfd: qhull writes at the C level
    assert code == 2
    line = one_line(err, path.name, "collinear")
    assert "QH" not in line and "qhull" not in line.lower()
    assert "QH" not in out and "qhull" not in out.lower()
    assert_unchanged(before, tmp_path)


@pytest.mark.usefixtures("in_tmp")
@pytest.mark.parametrize("cut", [
    pytest.param(16, id="cut-16"),
    pytest.param(24, id="cut-24"),
    pytest.param(100, id="cut-100"),
])
def test_cli_truncated_exr_frame_is_one_clean_line(tmp_path, capfd, cut):
    folder = write_exr_frames(tmp_path / "frames", n=2, dt_s=1e-6, dx_m=1e-6,
                              temperature_unit="K")
    data = (folder / "frame_1.exr").read_bytes()
    (folder / "frame_1.exr").write_bytes(data[:-cut])  # cut inside the chunks
    before = snapshot(tmp_path)
    argv = ["measure", folder, "--camera", "linear-ideal", "--pixel-pitch", "3um",
            "--dx", "1um", "--dt", "1us", "--integration-time", "2us"]
    code, out, err = cli(argv, capfd)  # capfd: the OpenEXR library writes at the C level
    assert code == 2
    one_line(err, "frame_1.exr")
    assert out == "", f"the library wrote on stdout: {out!r}"
    assert_unchanged(before, tmp_path)


@pytest.mark.usefixtures("in_tmp")
@pytest.mark.parametrize("old, new, name", [
    pytest.param('path = "frames.npy"\n', "", "path", id="scene-without-path"),
    pytest.param('path = "frames.npy"', "path = 5", "path", id="scene-path-number"),
    pytest.param("dt_us = 1.0", "dt_us = [1.0]", "dt_us", id="dt-list"),
    pytest.param('[cameras.lin]\npreset = "linear-ideal"\npixel_pitch_um = 3.0',
                 '[cameras]\nlin = "linear-ideal"', "lin", id="camera-not-a-table"),
    pytest.param('[[sweeps]]\nname = "t"\ncameras = ["lin"]\nintegration_time_us = [2, 4]',
                 '[sweeps]\nname = "t"', "sweeps", id="sweeps-not-a-list"),
])
def test_cli_malformed_study_is_one_clean_line(tmp_path, capsys, old, new, name):
    assert old in VALID_STUDY
    study = write_study(tmp_path, VALID_STUDY.replace(old, new))
    before = snapshot(tmp_path)
    code, _, err = cli(["run", study, "--out", tmp_path / "out", "--quiet", "--no-figures"],
                       capsys)
    assert code == 2
    one_line(err, name)
    assert_unchanged(before, tmp_path)


# -- bad inputs: silent garbage refused ------------------------------------------------------------


@pytest.mark.usefixtures("in_tmp")
def test_cli_infinite_temperature(tmp_path, capsys):
    stack = np.full((6, 12, 12), 500.0)
    stack[1, 4, 5] = np.inf
    np.save(tmp_path / "hot.npy", stack)
    before = snapshot(tmp_path)
    code, _, err = cli(measure_args(tmp_path / "hot.npy", "--out", tmp_path / "m.exr"), capsys)
    assert code == 2
    one_line(err, "frame 1", "row 4", "column 5", "inf")
    assert_unchanged(before, tmp_path)


@pytest.mark.usefixtures("in_tmp")
def test_cli_fea_conflicting_temperatures(tmp_path, capsys):
    path = conflicting_fea(tmp_path)
    before = snapshot(tmp_path)
    argv = ["measure", path, "--camera", "linear-ideal", "--pixel-pitch", "3um", "--dx", "1um",
            "--integration-time", "2us", "--out", tmp_path / "m.exr"]
    code, _, err = cli(argv, capsys)
    assert code == 2
    one_line(err, path.name, "two temperatures")
    assert_unchanged(before, tmp_path)


@pytest.mark.usefixtures("in_tmp")
def test_cli_study_dt_as_string(tmp_path, capsys):
    study = write_study(tmp_path, VALID_STUDY.replace("dt_us = 1.0", 'dt_us = "0.2"'))
    before = snapshot(tmp_path)
    code, _, err = cli(["run", study, "--out", tmp_path / "out", "--quiet", "--no-figures"],
                       capsys)
    assert code == 2
    one_line(err, "dt_us")
    assert_unchanged(before, tmp_path)


@pytest.mark.usefixtures("in_tmp")
def test_cli_unit_slip_is_named(tmp_path, capsys):
    npy = write_frames_npy(tmp_path / "s.npy", shape=(3, 30, 30))
    before = snapshot(tmp_path)
    argv = ["measure", npy, "--camera", "linear-ideal", "--pixel-pitch", "6um", "--dx", "0.667m",
            "--dt", "0.2us", "--units", "K", "--integration-time", "0.2us"]
    code, _, err = cli(argv, capsys)
    assert code == 2
    one_line(err, "0.667", "dx")
    assert_unchanged(before, tmp_path)


@pytest.mark.usefixtures("in_tmp")
def test_cli_near_zero_integration_time_does_not_saturate(tmp_path, capsys):
    np.save(tmp_path / "grad.npy", gradient_frames())
    argv = ["measure", tmp_path / "grad.npy", "--camera", "nist-ir", "--dx", "1um", "--dt",
            "0.1us", "--units", "K", "--integration-time", "1ns"]
    code, out, err = cli(argv, capsys)
    assert code == 0, err
    assert "Traceback" not in err
    assert "saturated 0.0 %" in out, out


# -- bad inputs: no data lost, no litter -----------------------------------------------------------


def _first_run(tmp_path, capsys, out):
    study = write_study(tmp_path)
    code, _, err = cli(["run", study, "--out", out, "--quiet", "--no-figures"], capsys)
    assert code == 0, err
    return study


@pytest.mark.usefixtures("in_tmp")
@pytest.mark.parametrize("previous", ["user-files", "radiosim-run"])
def test_run_into_non_empty_folder_refuses_without_overwrite(tmp_path, capsys, previous):
    out = tmp_path / "out"
    if previous == "radiosim-run":
        study = _first_run(tmp_path, capsys, out)
    else:
        study = write_study(tmp_path)
        out.mkdir()
        (out / "thesis.tex").write_text("\\chapter{Results}\n")
        (out / "results.csv").write_text("my own table\n")
    before = snapshot(tmp_path)
    code, _, err = cli(["run", study, "--out", out, "--quiet", "--no-figures"], capsys)
    assert code == 2
    one_line(err, out, "--overwrite")
    assert_unchanged(before, tmp_path)
    assert not (tmp_path / "out.partial").exists()


@pytest.mark.usefixtures("in_tmp")
def test_overwrite_replaces_radiosims_files_and_keeps_the_users(tmp_path, capsys):
    out = tmp_path / "out"
    study = _first_run(tmp_path, capsys, out)
    notes = out / "notes.txt"
    notes.write_text("the user's notes\n")
    os.utime(notes, ns=(1_000_000_000, 1_000_000_000))
    manifest = json.loads((out / "radiosim-manifest.json").read_text())
    ours = {name: (out / name).stat().st_ino for name in manifest["files"]}
    assert "results.csv" in ours and any(name.endswith(".exr") for name in ours)
    code, _, err = cli(["run", study, "--out", out, "--quiet", "--no-figures", "--overwrite"],
                       capsys)
    assert code == 0, err
    assert notes.read_text() == "the user's notes\n"
    assert notes.stat().st_mtime_ns == 1_000_000_000
    for name, inode in ours.items():
        assert (out / name).is_file()
        assert (out / name).stat().st_ino != inode, f"{name} was not replaced"
    assert not (tmp_path / "out.partial").exists()
    no_litter(tmp_path)


@pytest.mark.usefixtures("in_tmp")
def test_overwrite_never_deletes_outside_the_folder(tmp_path, capsys):
    out = tmp_path / "runs" / "out"
    out.parent.mkdir()
    study = _first_run(tmp_path, capsys, out)
    victim = tmp_path / "victim.txt"
    victim.write_text("precious\n")
    manifest = out / "radiosim-manifest.json"
    data = json.loads(manifest.read_text())
    data["files"] += ["../../victim.txt"]
    manifest.write_text(json.dumps(data))
    code, _, err = cli(["run", study, "--out", out, "--quiet", "--no-figures", "--overwrite"],
                       capsys)
    assert victim.is_file() and victim.read_text() == "precious\n"


@pytest.mark.usefixtures("in_tmp")
def test_run_failing_mid_way_leaves_only_a_named_partial_result(tmp_path, capsys):
    study = nan_late_study(tmp_path)
    out = tmp_path / "out"
    code, _, err = cli(["run", study, "--out", out, "--quiet", "--no-figures"], capsys)
    assert code == 2
    assert "Traceback" not in err
    lines = [line for line in err.splitlines() if line.strip()]
    errors = [line for line in lines if line.startswith("radiosim: error:")]
    assert len(errors) == 1 and "frame 18" in errors[0] and "NaN" in errors[0], err
    partial = tmp_path / "out.partial"
    assert len(lines) <= 2
    for line in lines:
        assert line in errors or str(partial) in line, err
    assert not out.exists()
    no_litter(tmp_path)
    if partial.exists():
        rows = list(csv.DictReader((partial / "results.csv").open(encoding="utf-8")))
        assert [r["integration_time_us"] for r in rows] == ["2.0", "4.0"]
        for row in rows:
            read_exr(partial / row["exr"])


@pytest.mark.usefixtures("in_tmp")
def test_run_failing_at_once_leaves_no_empty_folder(tmp_path, capsys):
    study = nan_late_study(tmp_path, frame=0)
    out = tmp_path / "new" / "sub" / "out"
    code, _, err = cli(["run", study, "--out", out, "--quiet", "--no-figures"], capsys)
    assert code == 2
    one_line(err, "frame 0", "NaN")
    assert not (tmp_path / "new").exists()
    no_litter(tmp_path)


@pytest.mark.usefixtures("in_tmp")
def test_run_whose_output_fails_leaves_no_empty_partial_folder(processes):
    result = processes["dev-full"]
    if result is None:
        pytest.skip("no /dev/full on this system")
    code, out, err, root, before = result
    assert code == 1, err.decode()
    one_line(err.decode())
    assert not (root / "full-out").exists()
    no_litter(root)


@pytest.mark.usefixtures("in_tmp")
def test_run_refuses_when_an_earlier_partial_result_exists(tmp_path, capsys):
    study = write_study(tmp_path)
    partial = tmp_path / "out.partial"
    partial.mkdir()
    (partial / "results.csv").write_text("an earlier run's rows\n")
    before = snapshot(tmp_path)
    code, _, err = cli(["run", study, "--out", tmp_path / "out", "--quiet", "--no-figures"],
                       capsys)
    assert code == 2
    one_line(err, partial)
    assert_unchanged(before, tmp_path)


@pytest.mark.usefixtures("in_tmp")
def test_preview_refuses_to_overwrite_without_flag(tmp_path, capsys):
    png = tmp_path / "x.png"
    png.write_bytes(b"\x89PNG the user's picture")
    before = snapshot(tmp_path)
    code, _, err = cli(["scene", "preview", "--out", png], capsys)
    assert code == 2
    one_line(err, png, "--overwrite")
    assert_unchanged(before, tmp_path)


@pytest.mark.usefixtures("in_tmp")
@pytest.mark.parametrize("name", ["m.png", "m.txt", "m"])
def test_measure_refuses_an_out_that_is_not_exr(tmp_path, capsys, name):
    npy = write_frames_npy(tmp_path / "s.npy")
    before = snapshot(tmp_path)
    code, _, err = cli(measure_args(npy, "--out", tmp_path / name), capsys)
    assert code == 2
    one_line(err, tmp_path / name, ".exr")
    assert_unchanged(before, tmp_path)


@pytest.mark.usefixtures("in_tmp")
def test_measure_refuses_to_overwrite_an_exr_without_flag(tmp_path, capsys):
    npy = write_frames_npy(tmp_path / "s.npy")
    existing = tmp_path / "m.exr"
    existing.write_bytes(b"the user's measurement")
    before = snapshot(tmp_path)
    code, _, err = cli(measure_args(npy, "--out", existing), capsys)
    assert code == 2
    one_line(err, existing, "--overwrite")
    assert_unchanged(before, tmp_path)


@pytest.mark.usefixtures("in_tmp")
def test_overwrite_refuses_a_folder_radiosim_did_not_write(tmp_path, capsys):
    study = tmp_path / "s.toml"
    write_frames_npy(tmp_path / "frames.npy")
    study.write_text(VALID_STUDY)
    out = tmp_path / "theirs"
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    before = snapshot(tmp_path)
    code, _, err = cli(["run", study, "--out", out, "--overwrite", "--quiet", "--no-figures"],
                       capsys)
    assert code == 2 and "did not write it" in err
    assert_unchanged(before, tmp_path)


@pytest.mark.usefixtures("in_tmp")
def test_overwrite_refuses_a_manifest_that_lists_a_folder(tmp_path, capsys):
    study = tmp_path / "s.toml"
    write_frames_npy(tmp_path / "frames.npy")
    study.write_text(VALID_STUDY)
    out = tmp_path / "out"
    assert cli(["run", study, "--out", out, "--quiet", "--no-figures"], capsys)[0] == 0
    (out / "sub").mkdir()
    (out / "radiosim-manifest.json").write_text(json.dumps({"files": ["sub", "results.csv"]}))
    before = snapshot(tmp_path)
    code, _, err = cli(["run", study, "--out", out, "--overwrite", "--quiet", "--no-figures"],
                       capsys)
    assert code == 2 and "which is a folder" in err
    assert_unchanged(before, tmp_path)


# -- bad inputs: valid input read, text that does not mislead --------------------------------------


@pytest.mark.usefixtures("in_tmp")
def test_cli_exr_frames_with_double_attributes_are_measured(tmp_path, capsys):
    folder = write_exr_frames(tmp_path / "folder", n=3, dt_s=double(1e-6), dx_m=double(1e-6),
                              temperature_unit="K")
    code, out, err = cli(["measure", folder, "--camera", "linear-ideal", "--pixel-pitch",
                          "3um", "--integration-time", "2us"], capsys)
    assert code == 0, err
    assert "4 × 4 pixels" in out


@pytest.mark.usefixtures("in_tmp")
def test_cli_exr_missing_dx_names_attribute_file_and_flag(tmp_path, capsys):
    folder = write_exr_frames(tmp_path / "folder", n=2, dt_s=double(1e-6), temperature_unit="K")
    before = snapshot(tmp_path)
    code, _, err = cli(["measure", folder, "--camera", "linear-ideal", "--pixel-pitch", "3um",
                        "--integration-time", "2us", "--out", tmp_path / "m.exr"], capsys)
    assert code == 2
    one_line(err, "dx_m", "frame_0.exr", "--dx")
    assert_unchanged(before, tmp_path)


@pytest.mark.usefixtures("in_tmp")
def test_cli_exr_missing_unit_names_attribute_file_and_flag(tmp_path, capsys):
    folder = write_exr_frames(tmp_path / "folder", n=2, dt_s=1e-6, dx_m=1e-6)
    before = snapshot(tmp_path)
    code, _, err = cli(["measure", folder, "--camera", "linear-ideal", "--pixel-pitch", "3um",
                        "--integration-time", "2us"], capsys)
    assert code == 2
    one_line(err, "temperature_unit", "frame_0.exr", "--units")
    assert_unchanged(before, tmp_path)


@pytest.mark.usefixtures("in_tmp")
def test_cli_micro_sign_units_are_read(tmp_path, capsys):
    npy = write_frames_npy(tmp_path / "s.npy")
    code, out, err = cli(["measure", npy, "--camera", "linear-ideal", "--pixel-pitch", "3µm",
                          "--dx", "1µm", "--dt", "1µs", "--units", "K",
                          "--integration-time", "2µs"], capsys)
    assert code == 0, err
    assert "8 × 8 pixels" in out


@pytest.mark.usefixtures("in_tmp")
def test_text_file_named_npy_is_not_called_pickled(tmp_path, capsys):
    path = tmp_path / "notes.npy"
    path.write_text("time,temperature\n0,500\n")
    with pytest.raises(RadiosimError) as info:
        read_frames(path, dt=1e-6, dx=1e-6, units="K")
    message = api_error(info, path.name)
    assert "pickle" not in message.lower()
    assert "not a NumPy" in message or "not a numpy" in message.lower()
    before = snapshot(tmp_path)
    code, _, err = cli(measure_args(path), capsys)
    assert code == 2
    line = one_line(err, path.name)
    assert "pickle" not in line.lower()
    assert_unchanged(before, tmp_path)


@pytest.mark.usefixtures("in_tmp")
def test_cli_study_typo_names_the_likely_key(tmp_path, capsys):
    study = write_study(tmp_path, VALID_STUDY.replace("integration_time_us =",
                                                      "integration_time_uss ="))
    before = snapshot(tmp_path)
    code, _, err = cli(["run", study, "--out", tmp_path / "out", "--quiet"], capsys)
    assert code == 2
    one_line(err, "integration_time_uss", "did you mean")
    assert_unchanged(before, tmp_path)


@pytest.mark.usefixtures("in_tmp")
def test_cli_fea_without_dx_names_the_flag(tmp_path, capsys):
    path = tmp_path / "nodes.csv"
    path.write_text(fea_text(fea_rows()))
    before = snapshot(tmp_path)
    code, _, err = cli(["measure", path, "--camera", "linear-ideal", "--pixel-pitch", "3um",
                        "--integration-time", "2us"], capsys)
    assert code == 2
    one_line(err, "--dx")
    assert_unchanged(before, tmp_path)


@pytest.mark.usefixtures("in_tmp")
def test_progress_to_a_pipe_has_no_carriage_return(processes):
    code, out, err, root, before = processes["progress"]
    assert code == 0, err.decode()
    assert b"\r" not in err
    assert b"[2/2]" in err
    assert b"Traceback" not in err


@pytest.mark.usefixtures("in_tmp")
def test_cli_compressed_npz_warning_is_one_line_without_source(processes):
    code, out, err, root, before = processes["npz"]
    text = err.decode()
    assert code == 0, text
    assert "Traceback" not in text
    lines = [line for line in text.splitlines() if line.strip()]
    warned = [line for line in lines if "compressed" in line]
    assert len(warned) == 1 and warned[0].startswith("radiosim: warning:"), text
    assert "c.npz" in warned[0]
    assert len(lines) == 1, text  # no source line ("warnings.warn(...)") after it
    assert "warnings.warn" not in text


def _own_process(args, cwd, **popen):
    """The radiosim command itself, in a process of its own (``python -m radiosim.cli``)."""
    import subprocess
    import sys

    return subprocess.run([sys.executable, "-m", "radiosim.cli", *args], cwd=cwd,
                          capture_output="stdout" not in popen, text=True, timeout=300, **popen)


_MEASURE = ["measure", "frames.npy", "--camera", "linear-ideal", "--pixel-pitch", "3um",
            "--integration-time", "2us", "--dt", "1us", "--dx", "1um", "--units", "K"]


def test_the_command_ends_well_with_a_closed_stdout_or_an_ascii_terminal(here):
    # Closed stdout (>&-): the file is written and the exit is 0, no traceback at the end.
    # PYTHONIOENCODING=ascii: µ and ° escaped, the file written, exit 0.
    import os
    import subprocess

    closed = _own_process([*_MEASURE, "--out", "a.exr"], here, stdout=subprocess.DEVNULL,
                      stderr=subprocess.PIPE, preexec_fn=lambda: os.close(1))
    assert closed.returncode == 0 and closed.stderr == "", closed.stderr
    assert (here / "a.exr").stat().st_size > 0
    ascii_ = _own_process([*_MEASURE, "--out", "b.exr"], here,
                      env={**os.environ, "PYTHONIOENCODING": "ascii"})
    assert ascii_.returncode == 0, ascii_.stderr
    assert "\\xb5s" in ascii_.stdout and (here / "b.exr").stat().st_size > 0


def test_a_bad_mplbackend_is_named_in_one_line(here):
    import os

    done = _own_process(["scene", "preview", "--out", "s.png"], here,
                    env={**os.environ, "MPLBACKEND": "nonsense"})
    assert done.returncode == 2
    assert done.stderr.count("\n") == 1 and "MPLBACKEND='nonsense'" in done.stderr, done.stderr
    assert not (here / "s.png").exists()


def test_the_command_runs_with_numbas_jit_disabled(here):
    # NUMBA_DISABLE_JIT=1 (a debugging setting): the numpy engine measures (the compiled one's
    # intrinsics have no Python form), warmup says there is nothing to compile; exit 0 both.
    import os

    env = {**os.environ, "NUMBA_DISABLE_JIT": "1"}
    done = _own_process([*_MEASURE, "--out", "j.exr"], here, env=env)
    assert done.returncode == 0 and done.stderr == "", done.stderr
    assert (here / "j.exr").stat().st_size > 0
    warm = _own_process(["warmup", "-q"], here, env=env)
    assert warm.returncode == 0 and warm.stdout.startswith("nothing to compile"), warm


def test_too_small_an_address_space_is_named_in_one_line(here):
    # ulimit -v far below what numpy, scipy and numba need: one line naming the limit, exit 1,
    # not "internal error" nor a library's own words alone.
    import resource

    def limited():
        resource.setrlimit(resource.RLIMIT_AS, (350 * 2**20, 350 * 2**20))

    done = _own_process([*_MEASURE], here, preexec_fn=limited)
    assert done.returncode == 1, done.stderr
    assert done.stderr.count("\n") == 1 and "ulimit -v 358400" in done.stderr, done.stderr


def test_a_damaged_kernel_cache_is_named_in_one_line(here, tmp_path):
    # numba's cache of the kernels with a damaged file: one line naming the folder to delete,
    # exit 1 (an "internal error" with UnpicklingError before); once deleted, the next run
    # compiles again and measures.
    import os
    import shutil

    cache = tmp_path / "numba-cache"
    env = {**os.environ, "NUMBA_CACHE_DIR": str(cache)}
    assert _own_process([*_MEASURE], here, env=env).returncode == 0  # compiles, fills it
    for index in cache.rglob("*.nbi"):
        index.write_bytes(b"\x00damaged")
    done = _own_process([*_MEASURE], here, env=env)
    assert done.returncode == 1 and done.stderr.count("\n") == 1, done.stderr
    named = done.stderr.split("delete the folder ")[1].split(" (the kernels")[0]
    assert Path(named).is_dir() and Path(named).is_relative_to(cache), done.stderr
    shutil.rmtree(named)
    assert _own_process([*_MEASURE], here, env=env).returncode == 0
