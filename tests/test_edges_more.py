"""A second, separate set of edge cases (issue 20): a hostile new user of the ``radiosim``
command and of the Python API.

Each case asserts its class: through the command, the exit code (2 for a mistake in the
input), exactly one line on stderr naming the file, the key and the value as typed, no
traceback and nothing written; through the API, a RadiosimError naming the values.
"""

from __future__ import annotations

import numpy as np
import pytest

from radiosim.camera import Camera
from radiosim.errors import RadiosimError
from radiosim.io import read_exr, read_frames
from radiosim.scenes import FrameStack
from radiosim.study import Study
from test_edges_cli import cli, refused


@pytest.fixture
def here(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("RADIOSIM_SCHEDULER", raising=False)
    np.save(tmp_path / "frames.npy", np.full((20, 24, 24), 500.0))
    return tmp_path


def measure(scene="frames.npy", *extra, units="K"):
    return ["measure", scene, "--camera", "linear-ideal", "--pixel-pitch", "3um", "--dx", "1um",
            "--dt", "1us", "--units", units, "--integration-time", "2us", *extra]


# -- the command: --out checked before any work -------------------------------------------


def test_out_below_a_file_is_named_as_a_file_before_any_work(here, capsys):
    line = refused(measure("frames.npy", "--out", "frames.npy/m.exr"), capsys, here,
                   "--out frames.npy/m.exr", "frames.npy is a file, not a folder")
    assert "does not exist" not in line
    assert capsys.readouterr().out == ""  # nothing measured (and printed) first


def test_out_in_a_missing_folder_is_refused_before_any_work(here, capsys):
    refused(measure("frames.npy", "--out", "nowhere/m.exr"), capsys, here,
            "--out nowhere/m.exr", "folder nowhere does not exist")


def test_out_with_a_name_too_long_is_an_input_error_not_a_failure(here, capsys):
    name = "A" * 300 + ".exr"
    line = refused(measure("frames.npy", "--out", name), capsys, here, "--out", "304 bytes",
                   "at most")
    assert name not in line  # one readable line


def test_sse_out_in_a_missing_folder_is_refused_up_front(here, capsys):
    refused(["sse", "nist-ir", "--out", "nowhere/sse.csv"], capsys, here,
            "--out nowhere/sse.csv", "does not exist")


def test_out_with_spaces_and_unicode_is_written(here, capsys):
    code, out, err = cli(measure("frames.npy", "--out", "a b é.exr"), capsys)
    assert code == 0, err
    assert (here / "a b é.exr").is_file()


# -- the command: bad samples name the file, in the unit typed ----------------------------


def test_a_negative_kelvin_sample_names_the_file_not_the_window(here, capsys):
    stack = np.full((20, 24, 24), 500.0)
    stack[1, 4, 5] = -1.0
    np.save(here / "bad.npy", stack)
    line = refused(measure("bad.npy"), capsys, here, "bad.npy", "frame 1", "row 4",
                   "column 5", "-1 K")
    assert "--integration-time" not in line  # the window is not at fault


def test_a_sample_below_absolute_zero_in_celsius_is_reported_in_celsius(here, capsys):
    stack = np.full((20, 24, 24), 20.0)
    stack[1, 4, 5] = -300.0
    np.save(here / "bad.npy", stack)
    line = refused(measure("bad.npy", units="C"), capsys, here, "bad.npy", "-300 °C",
                   "absolute zero")
    assert "°C passed as kelvin" not in line  # the user said C


def test_a_nan_sample_names_the_file(here, capsys):
    stack = np.full((20, 24, 24), 500.0)
    stack[0, 2, 3] = np.nan
    np.save(here / "bad.npy", stack)
    refused(measure("bad.npy"), capsys, here, "bad.npy", "frame 0", "row 2", "NaN")


def test_fill_on_a_numpy_stack_is_refused(here, capsys):
    refused(measure("frames.npy", "--fill", "20C"), capsys, here, "--fill 20C", "frames.npy",
            ".csv")


# -- the command: study files ------------------------------------------------------------

STUDY = """name = "s"
[scene]
type = "frames"
path = "frames.npy"
dt_us = 1.0
dx_um = 1.0
units = "K"
{scene_extra}
[cameras.lin]
preset = "linear-ideal"
pixel_pitch_um = 3.0

[[sweeps]]
name = "a"
cameras = ["lin"]
{sweep}
"""


def study(here, sweep="integration_time_us = [2]", scene_extra="", extra=""):
    (here / "s.toml").write_text(STUDY.format(sweep=sweep, scene_extra=scene_extra) + extra)
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
    text = STUDY.replace(f"{key} = 1.0", f"{key} = {value}")
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


# -- the API ---------------------------------------------------------------------------------


def test_camera_replace_with_an_unknown_field_names_the_likely_one():
    camera = Camera.linear_ideal(3e-6)
    with pytest.raises(RadiosimError, match=r"nmae.*did you mean name"):
        camera.replace(nmae="x")


def test_camera_replace_with_a_known_field_still_works():
    camera = Camera.linear_ideal(3e-6).replace(name="mine")
    assert camera.name == "mine"


def test_read_exr_on_a_folder_says_it_is_a_folder(tmp_path):
    with pytest.raises(RadiosimError, match="is a folder, not an EXR file"):
        read_exr(tmp_path)


def test_read_frames_on_a_folder_named_npy_says_it_is_a_folder(tmp_path):
    (tmp_path / "x.npy").mkdir()
    with pytest.raises(RadiosimError, match=r"x\.npy is a folder, not a \.npy file"):
        read_frames(tmp_path / "x.npy", dt=1e-6, dx=1e-6, units="K")


def test_an_emissivity_map_outside_0_1_names_the_value_and_where():
    emissivity = np.full((4, 4), 0.5)
    emissivity[2, 3] = 1.5
    with pytest.raises(RadiosimError, match=r"got 1\.5 at row 2, column 3 \(1 value"):
        FrameStack(np.full((2, 4, 4), 500.0), dt=1e-6, dx=1e-6, emissivity=emissivity)


@pytest.mark.parametrize("rng", ["abc", 1.5, -1, [1, 2], True,
                                 np.random.RandomState(0)])
def test_measure_with_an_rng_of_the_wrong_type_is_one_error(rng):
    scene = FrameStack(np.full((4, 6, 6), 500.0), dt=1e-6, dx=1e-6)
    with pytest.raises(RadiosimError, match="rng must be a seed"):
        Camera.linear_ideal(3e-6).measure(scene, 2e-6, rng=rng)


def test_study_from_python_names_the_file_in_a_scene_error(tmp_path):
    (tmp_path / "s.toml").write_text(STUDY.format(sweep="integration_time_us = [2]",
                                                  scene_extra=""))
    study = Study.from_toml(tmp_path / "s.toml")
    with pytest.raises(RadiosimError, match=r"s\.toml: \[scene\]: .*frames\.npy does not "
                                            "exist"):
        study.scene
