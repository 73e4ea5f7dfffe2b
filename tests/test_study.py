"""Studies as data."""

import csv
import dataclasses
import json
import os
import tomllib
from pathlib import Path

import numpy as np
import pytest

from radiosim import Camera, Electronics
from radiosim.errors import RadiosimError, RadiosimIOError, RadiosimWarning
from radiosim.files import MANIFEST, RUN_MARKER, OutputFolder
from radiosim.io import read_exr
from radiosim.paper import COLUMN_I_COLUMNS
from conftest import (STUDY_TEMPLATE, VALID_STUDY, api_error, fea_rows, fea_text, frames_study,
                      frames_study_dict, nan_late_study, no_litter, single_line, tree,
                      write_study)
from radiosim.study import STUDY_DIRECTORY, RESULT_COLUMNS, Study, available_studies, format_table
from radiosim.uncertainty import MAX_DRAWS


def test_the_papers_study_plans_table_2():
    study = Study.preset("msec2009")
    plan = list(study.plan())
    time_sweep = [p for p in plan if p[0].name == "integration-time"]
    assert [t for *_, t, _ in time_sweep[:7]] == pytest.approx(
        [1e-6, 10e-6, 25e-6, 45e-6, 60e-6, 75e-6, 90e-6])
    assert {c.response for _, _, c, _, _ in time_sweep} == {"linear", "planck"}
    size = [p for p in plan if p[0].name == "size-of-source"]
    samples = [c.fpa.pixel_pitch / study.scene.dx for _, _, c, _, _ in size[:7]]
    assert samples == pytest.approx([3, 6, 9, 12, 15, 18, 21])
    assert all(t == pytest.approx(0.2e-6) for *_, t, _ in size)
    assert time_sweep[0][2].fpa.pixel_pitch == 6e-6
    assert "msec2009" in available_studies()


def coarse_paper_study():
    data = tomllib.loads((STUDY_DIRECTORY / "msec2009.toml").read_text())
    data["scene"].update(dx_um=2.0, dt_us=1.0)  # a coarse version of the paper's study
    data["sweeps"][0]["integration_time_us"] = [1, 10, 90]
    data["sweeps"][1]["pixel_samples"] = [3, 6]
    data["sweeps"][2]["integration_time_us"] = [1, 90, 180]
    return Study.from_dict(data)


def test_a_coarse_run_of_the_papers_study(tmp_path):
    study = coarse_paper_study()
    result = study.run(tmp_path, write_exr=False)
    assert study.columns() == RESULT_COLUMNS + COLUMN_I_COLUMNS  # the paper's hook adds them
    assert list(result.rows[0]) == study.columns()
    rows = {(r["sweep"], r["camera"], r["integration_time_us"], r["pixel_pitch_um"]): r
            for r in result.rows}
    lin_1, lin_90 = rows[("integration-time", "linear", 1.0, 6.0)], rows[
        ("integration-time", "linear", 90.0, 6.0)]
    planck_90 = rows[("integration-time", "planck", 90.0, 6.0)]
    # Motion blur, and the radiance non-linearity: the Planck camera reads the band hotter.
    assert lin_90["column_I_C"] < lin_1["column_I_C"] - 100
    assert planck_90["column_I_C"] > lin_90["column_I_C"] + 10
    # Long integration settles on the period's mean: 90 and 180 µs agree.
    long = {r["integration_time_us"]: r for r in result.rows if r["sweep"] == "long-integration"}
    assert long[180.0]["peak_C"] == pytest.approx(long[90.0]["peak_C"], abs=0.5)
    assert (tmp_path / "results.csv").is_file() and (tmp_path / "pixel_history.csv").is_file()


def _uniform_frames_study(tmp_path, **sweep):
    """A study of 20 frames of 12 × 12 samples at 400 K, one linear ideal camera of 3 × 3
    samples, one sweep ``s`` with ``sweep``'s keys."""
    stack = tmp_path / "s.npy"
    np.save(stack, np.full((20, 12, 12), 400.0))
    return Study.from_dict({
        "name": "frames",
        "scene": {"type": "frames", "path": str(stack), "dt_us": 1.0, "dx_um": 1.0,
                  "units": "K"},
        "cameras": {"c": {"preset": "linear-ideal", "pixel_pitch_um": 3.0}},
        "sweeps": [{"name": "s", "cameras": ["c"], **sweep}],
    })


def test_window_alignments(tmp_path):
    study = _uniform_frames_study(tmp_path, integration_time_us=[2, 4],
                                  alignment=["starting", "ending"])
    rows = study.run(write_exr=False).rows
    assert [r["t_start_us"] for r in rows] == [0.0, 0.0, 0.0, 0.0]  # no event: from t = 0
    assert all(r["peak_C"] == pytest.approx(400 - 273.15) for r in rows)
    assert all(r["peak_bias_K"] == pytest.approx(0.0) for r in rows)
    assert all(r["alignment"] == "scene start" for r in rows)  # said as it happened


def test_a_study_result_labels_its_dataset_with_the_study_that_ran(tmp_path):
    # A result run from Python names its study in the dataset, as the rows do (the CLI's
    # results.nc passes the name; a caller of to_xarray() need not).
    result = _uniform_frames_study(tmp_path, integration_time_us=[2]).run(write_exr=False)
    assert {r["study"] for r in result.rows} == {"frames"}
    ds = result.to_xarray()
    assert ds.attrs["study"] == "frames" and "frames" in ds.attrs["title"]
    assert result.to_xarray("renamed").attrs["study"] == "renamed"


def test_window_alignments_around_an_event(tmp_path):
    # Frame k holds 300 + k kelvin; the event is frame 10 (its mid-time 10.5 µs).
    stack = tmp_path / "s.npy"
    np.save(stack, 300.0 + np.arange(20)[:, None, None] * np.ones((20, 6, 6)))
    study = Study.from_dict({
        "name": "frames",
        "scene": {"type": "frames", "path": str(stack), "dt_us": 1.0, "dx_um": 1.0,
                  "units": "K", "event_time_us": 10.5},
        "cameras": {"c": {"preset": "linear-ideal", "pixel_pitch_um": 3.0}},
        "sweeps": [{"name": "s", "cameras": ["c"], "integration_time_us": [3],
                    "alignment": ["centred", "starting", "ending"]}],
    })
    rows = {r["alignment"]: r for r in study.run(write_exr=False).rows}
    # centred: frames 9, 10, 11; starting: 10, 11, 12; ending: 8, 9, 10 (the event's end).
    assert rows["centred"]["t_start_us"] == pytest.approx(9.0)
    assert rows["starting"]["t_start_us"] == pytest.approx(10.0)
    assert rows["ending"]["t_start_us"] == pytest.approx(8.0)
    for name, frames in (("centred", (9, 10, 11)), ("starting", (10, 11, 12)),
                         ("ending", (8, 9, 10))):
        assert rows[name]["peak_C"] == pytest.approx(300 + np.mean(frames) - 273.15, abs=1e-9)


@pytest.mark.parametrize("change, message", [
    (lambda d: d.pop("scene"), "needs a \\[scene\\]"),
    (lambda d: d.update(colour="red"), r"study: unknown key\(s\) colour"),
    (lambda d: d["sweeps"][0].update(cameras=["nope"]), "cameras must name"),
    (lambda d: d["sweeps"][0].update(integration_time_frames=[1]), "one of them"),
    (lambda d: d["sweeps"][0].update(alignment=["sideways"]), "alignment must be"),
    (lambda d: d["sweeps"][0].update(integration_time_us=[-1]), "positive numbers"),
    (lambda d: d["cameras"]["linear"].update(preset="hubble"), "unknown camera preset"),
    (lambda d: d["scene"].update(type="movie"), "scene type 'movie'"),
])
def test_bad_studies_are_named(change, message):
    data = tomllib.loads((STUDY_DIRECTORY / "msec2009.toml").read_text())
    change(data)
    with pytest.raises(RadiosimError, match=message):
        Study.from_dict(data).scene


def test_a_study_states_the_scene_environment_and_the_camera_setting(tmp_path):
    """A reflecting scene read by a camera whose setting matches reads the truth; one set to a
    black room reads the reflection as a bias (ε = 0.5: as much reflected as emitted)."""
    np.save(tmp_path / "frames.npy", np.full((4, 24, 24), 700.0))
    scene = ('units = "K"\nemissivity = 0.5\nreflected_temperature_K = 500.0\n'
             'surroundings_temperature_K = 700.0')
    cameras = ('file = "cam.toml"\nassumed_emissivity = 0.5\n'
               'assumed_reflected_temperature_K = 500.0\n'
               '[cameras.dark]\nfile = "cam.toml"\nassumed_emissivity = 0.5')
    text = frames_study([2], 4.0, name="room", camera="set").replace(
        'units = "K"', scene).replace('preset = "linear-ideal"\npixel_pitch_um = 4.0', cameras)
    text = text.replace('cameras = ["set"]', 'cameras = ["set", "dark"]')
    camera = Camera.preset("nist-ir").replace(electronics=Electronics.ideal())
    camera = camera.replace(fpa=dataclasses.replace(camera.fpa, pixel_pitch=4e-6, shape=None,
                                                    detector_pitch=None))
    (tmp_path / "cam.toml").write_text(camera.to_toml())
    (tmp_path / "room.toml").write_text(text)
    study = Study.from_toml(tmp_path / "room.toml")
    assert study.scene.reflected_temperature == 500.0
    rows = study.run(tmp_path / "out", write_exr=False).rows
    by_camera = {r["camera"]: r for r in rows}
    assert by_camera["set"]["peak_C"] == pytest.approx(700.0 - 273.15, abs=1e-6)
    assert by_camera["dark"]["peak_C"] > by_camera["set"]["peak_C"] + 10


@pytest.mark.parametrize("line, message", [
    ('reflected_temperature_K = "tool"', "segmented-chip"),
    ("reflection_view_um = 3.0", "tool"),
    ("path_transmission = 0.5", "path_temperature"),
    ("reflected_temperature_K = -3.0", "reflected_temperature"),
])
def test_bad_scene_environments_are_named(tmp_path, line, message):
    np.save(tmp_path / "frames.npy", np.full((2, 8, 8), 700.0))
    text = frames_study([1], 2.0).replace('units = "K"', f'units = "K"\n{line}')
    (tmp_path / "s.toml").write_text(text)
    with pytest.raises(RadiosimError, match=message):
        Study.from_toml(tmp_path / "s.toml").scene


def test_the_plan_is_named_records():
    from radiosim.study import Planned

    study = Study.preset("msec2009")
    first = next(study.plan())
    assert isinstance(first, Planned)
    assert first._fields == ("sweep", "camera_name", "camera", "integration_time", "alignment")
    assert (first.sweep.name, first.camera_name, first.integration_time,
            first.alignment) == ("integration-time", "linear", 1e-6, "centred")
    assert first.camera is study.cameras["linear"]  # no override: the study's own camera


def test_a_local_cluster_only_where_it_pays(caplog):
    # The paper's study: 44 measurements of about 0.075 s each (3.3 s) against a cluster's
    # 3.2 s start plus 12× the work shared by 2 processes (23 s): it runs in this process,
    # saying why; a plan a hundred times the work would too on 2 cores, and would take a
    # cluster of 32 workers on 32 cores.
    from radiosim.scheduling import SECONDS_PER_SAMPLE, worth_a_cluster

    study = Study.preset("msec2009")
    plan = list(study.plan())
    each = study._seconds_per_measurement(plan)
    # Independent count: 28 field measurements over the whole 1113 × 1440 chip, windows of
    # 1, 10, … µs at 0.2 µs (t/dt + 1 frames), and 16 pixel measurements of 9 × 9 samples.
    field = 1113 * 1440 * (2 * sum(t / 0.2 + 1 for t in (1, 10, 25, 45, 60, 75, 90)) + 14 * 2)
    pixel = 81 * sum(t / 0.2 + 1 for t in (1, 5, 10, 25, 45, 60, 75, 90, 135, 180, 270, 360,
                                           450, 540, 630, 725))
    assert each == pytest.approx(SECONDS_PER_SAMPLE * (field + pixel) / 44, rel=1e-9)
    assert not worth_a_cluster(44, each, 2, cores=2)[0]
    assert not worth_a_cluster(44, 100 * each, 2, cores=2)[0]
    assert worth_a_cluster(44, 100 * each, 32, cores=32)[0]


def test_a_pixel_crop_keeps_the_frames_it_made_for_the_history():
    # The pixel sweep's crop keeps the frames measured over its whole extent: the history reads
    # them back (the scene does not make them again) with the same values.
    from radiosim import MovingGaussianBand
    from radiosim.study import _KeptPixel

    scene = MovingGaussianBand(shape=(20, 30), dx=1e-6, dt=1e-6)
    crop = scene.crop((4, 13), (9, 18))
    kept = _KeptPixel(crop)
    assert (kept.shape, kept.offset, kept.dt, kept.describe()) == (
        crop.shape, crop.offset, crop.dt, crop.describe())
    whole = (slice(0, 9), slice(0, 9))
    samples = [kept.sample_unchecked(k, whole) for k in range(5)]
    kept.sample_unchecked(6, (slice(0, 3), slice(0, 9)))  # part of the crop: not kept
    assert sorted(kept._kept) == list(range(5))
    made = []
    original = type(scene)._read
    scene._read = lambda k, region: made.append(k) or original(scene, k, region)
    for k, sample in enumerate(samples):
        np.testing.assert_array_equal(kept.frame(k), crop.frame(k))
        np.testing.assert_array_equal(kept.frame(k), sample.temperature)
    assert made == list(range(5))  # only crop.frame made them again
    assert kept.frame(6).shape == (9, 9) and made[-1] == 6


def test_an_exr_file_that_cannot_be_written_fails_the_run_and_drops_its_row(tmp_path,
                                                                             monkeypatch):
    # The EXR files are written on a thread of their own: a file that fails (a full disk)
    # still ends the run with its one-line error, and the completed rows kept beside the
    # output list only measurements whose file exists.
    import radiosim.io.exr as exr
    from radiosim.errors import RadiosimIOError

    study = _uniform_frames_study(tmp_path, integration_time_us=[2, 4, 6])
    write = exr.write_exr

    def full_at_4us(path, measurement):
        if "_4us_" in path.name:
            raise RadiosimIOError(f"cannot write {path}: No space left on device")
        return write(path, measurement)

    monkeypatch.setattr(exr, "write_exr", full_at_4us)
    out = tmp_path / "out"
    with pytest.raises(RadiosimIOError, match="_4us_.*No space left"):
        study.run(out)
    kept = [p for p in tmp_path.iterdir() if p.name.startswith("out")]
    assert len(kept) == 1  # the completed measurements, kept beside the named folder
    table = (kept[0] / "results.csv").read_text().splitlines()
    files = sorted(p.name for p in (kept[0] / "exr").iterdir())
    # 2 µs's row and file; 6 µs's too if it was measured before the failure was known; never
    # a row without its file, nor 4 µs's row.
    listed = sorted(line.split("exr/")[1].split(",")[0] for line in table[1:])
    assert listed == files and "_2us_" in files[0] and not any("_4us_" in f for f in files)


def test_background_writes_stop_at_the_first_failure_and_skip_the_rest_on_an_error(
        tmp_path, monkeypatch):
    # A failed write is raised by the next write asked for; after the body's error every
    # write asked for is done, after an interrupt those not yet started are not (and are
    # counted as not written). Every step waits on a handshake (an Event the other side sets,
    # with a generous time-out), not on a delay.
    import concurrent.futures
    import threading

    from radiosim.files import BackgroundWrites

    timeout = 30.0  # [s] for a loaded machine; a handshake that never comes fails the test
    gate = threading.Event()
    gate.set()
    started = threading.Event()  # a write of the text "1" has begun
    may_fail = threading.Event()
    failure_known = threading.Event()

    def write(path, text):
        if path.name == "bad":
            assert may_fail.wait(timeout)
            raise OSError(28, "No space left on device", str(path))
        if path.name == "probe":
            failure_known.set()
            return
        if text == "1":
            started.set()
        assert gate.wait(timeout)
        path.write_text(text)

    writes = BackgroundWrites(write)
    with pytest.raises(OSError, match="No space"):
        with writes:
            writes(tmp_path / "bad", "x")
            writes(tmp_path / "probe", "")  # asked for while "bad" still runs: not raised
            may_fail.set()
            # The writes run one at a time, in order: the probe starts once "bad" has failed.
            assert failure_known.wait(timeout)
            writes(tmp_path / "b", "y")  # raises it
    assert writes.failed == [tmp_path / "bad"] and not (tmp_path / "b").exists()
    # The gate opens while __exit__ waits for the writes: when it calls
    # concurrent.futures.wait (after an interrupt has cancelled the writes not started).
    real_wait = concurrent.futures.wait

    def wait_then_open(futures, *args, **kwargs):
        if threading.current_thread() is threading.main_thread():
            gate.set()
        return real_wait(futures, *args, **kwargs)

    monkeypatch.setattr(concurrent.futures, "wait", wait_then_open)
    for error, first, second in ((KeyError, tmp_path / "c", tmp_path / "d"),
                                 (KeyboardInterrupt, tmp_path / "e", tmp_path / "f")):
        gate.clear()
        started.clear()
        writes = BackgroundWrites(write)
        with pytest.raises(error):
            with writes:
                writes(first, "1")
                assert started.wait(timeout)  # started: waits for the gate, then completes
                writes(second, "2")  # not started when the body fails
                raise error("the body's error")
        assert first.read_text() == "1"
        if error is KeyError:  # a failed body's writes are of completed work: done
            assert second.read_text() == "2" and writes.failed == []
        else:  # interrupted: those not started are not done
            assert not second.exists() and writes.failed == [second]


# -- study files: errors that name the file, the key and the value ---------------------------------


def test_study_from_python_names_the_file_in_a_scene_error(tmp_path):
    (tmp_path / "s.toml").write_text(STUDY_TEMPLATE.format(sweep="integration_time_us = [2]",
                                                  scene_extra=""))
    study = Study.from_toml(tmp_path / "s.toml")
    with pytest.raises(RadiosimError, match=r"s\.toml: \[scene\]: .*frames\.npy does not "
                                            "exist"):
        study.scene


STRING_NUMBERS = [
    pytest.param("dt_us = 1.0", 'dt_us = "0.2"', "dt_us", id="scene-dt_us"),
    pytest.param("dx_um = 1.0", 'dx_um = "1"', "dx_um", id="scene-dx_um"),
    pytest.param("dt_us = 1.0", "dt_us = true", "dt_us", id="scene-dt_us-bool"),
    pytest.param('units = "K"', 'units = "K"\nevent_time_us = "3"', "event_time_us",
                 id="scene-event_time_us"),
    pytest.param("pixel_pitch_um = 3.0", 'pixel_pitch_um = "3"', "pixel_pitch_um",
                 id="camera-pixel_pitch_um"),
    pytest.param("pixel_pitch_um = 3.0", 'pixel_pitch_um = 3.0\nassumed_emissivity = "0.9"',
                 "assumed_emissivity", id="camera-assumed_emissivity"),
    pytest.param("integration_time_us = [2, 4]", 'integration_time_us = ["2", "4"]',
                 "integration_time_us", id="sweep-integration_time_us"),
]


@pytest.mark.usefixtures("in_tmp")
@pytest.mark.parametrize("old, new, key", STRING_NUMBERS)
def test_study_number_written_as_string_is_refused(tmp_path, old, new, key):
    study = write_study(tmp_path, VALID_STUDY.replace(old, new, 1))
    with pytest.raises(RadiosimError) as info:
        Study.from_toml(study).scene  # noqa: B018 (building the scene is the check)
    api_error(info, key)


@pytest.mark.usefixtures("in_tmp")
@pytest.mark.parametrize("fill, names", [
    pytest.param('"300"', ["fill_K", "'300'"], id="string"),
    pytest.param("0", ["fill", "0"], id="zero"),
    pytest.param("0.0", ["fill", "0"], id="zero-float"),
    pytest.param("-20", ["fill", "-20"], id="negative"),
])
def test_study_fea_bad_fill_is_refused(tmp_path, fill, names):
    (tmp_path / "nodes.csv").write_text(fea_text(fea_rows()))
    text = VALID_STUDY.replace(
        'type = "frames"\npath = "frames.npy"\ndt_us = 1.0\ndx_um = 1.0\nunits = "K"',
        f'type = "fea"\npath = "nodes.csv"\ndx_um = 1.0\nfill_K = {fill}')
    study = write_study(tmp_path, text)
    with pytest.raises(RadiosimError) as info:
        Study.from_toml(study).scene  # noqa: B018
    api_error(info, *names)


TYPOS = [
    pytest.param("integration_time_us =", "integration_time_uss =", "integration_time_uss",
                 id="sweep-integration_time_uss"),
    pytest.param("integration_time_us =", "integraton_time_us =", "integraton_time_us",
                 id="sweep-integraton_time_us"),
    pytest.param('cameras = ["lin"]', 'cameras = ["lin"]\npixel_pitch_umm = [3.0]',
                 "pixel_pitch_umm", id="sweep-pixel_pitch_umm"),
    pytest.param("dx_um =", "dx_umm =", "dx_umm", id="scene-dx_umm"),
    pytest.param('units = "K"', 'units = "K"\nevent_time_uss = 3.0', "event_time_uss",
                 id="scene-event_time_uss"),
    pytest.param('preset = "linear-ideal"', 'presett = "linear-ideal"', "presett",
                 id="camera-presett"),
    pytest.param("pixel_pitch_um = 3.0", "pixel_pich_um = 3.0", "pixel_pich_um",
                 id="camera-pixel_pich_um"),
    pytest.param("[cameras.lin]", "[camera.lin]", "camera", id="top-camera"),
    pytest.param("[[sweeps]]", "[[sweep]]", "sweep", id="top-sweep"),
    pytest.param('name = "small"', 'name = "small"\ndescriptoin = "x"', "descriptoin",
                 id="top-descriptoin"),
]


@pytest.mark.usefixtures("in_tmp")
@pytest.mark.parametrize("old, new, typo", TYPOS)
def test_study_typo_names_the_likely_key(tmp_path, old, new, typo):
    study = write_study(tmp_path, VALID_STUDY.replace(old, new, 1))
    with pytest.raises(RadiosimError) as info:
        Study.from_toml(study).scene  # noqa: B018
    message = api_error(info, typo)
    assert "did you mean" in message, message


@pytest.mark.usefixtures("in_tmp")
@pytest.mark.parametrize("old, new, key", [
    pytest.param('units = "K"\n', "", "units", id="scene-units"),
    pytest.param("dt_us = 1.0\n", "", "dt_us", id="scene-dt_us"),
    pytest.param('type = "frames"\n', "", "type", id="scene-type"),
    pytest.param('cameras = ["lin"]\n', "", "cameras", id="sweep-cameras"),
])
def test_study_missing_required_key_is_named(tmp_path, old, new, key):
    study = write_study(tmp_path, VALID_STUDY.replace(old, new, 1))
    with pytest.raises(RadiosimError) as info:
        Study.from_toml(study).scene  # noqa: B018
    api_error(info, key)


@pytest.mark.usefixtures("in_tmp")
@pytest.mark.parametrize("old, new, key", [
    pytest.param('cameras = ["lin"]', 'cameras = "lin"', "cameras", id="cameras-string"),
    pytest.param('cameras = ["lin"]', 'cameras = ["lin"]\nalignment = "centred"', "alignment",
                 id="alignment-string"),
    pytest.param('cameras = ["lin"]', 'cameras = ["lin"]\nresponse = "linear"', "response",
                 id="response-string"),
])
def test_study_scalar_where_a_list_is_expected_says_list(tmp_path, old, new, key):
    study = write_study(tmp_path, VALID_STUDY.replace(old, new, 1))
    with pytest.raises(RadiosimError) as info:
        Study.from_toml(study)
    message = api_error(info, key)
    assert "list" in message, message
    assert "['l', 'i', 'n']" not in message


def test_a_huge_draw_count_in_a_study_file_is_refused(tmp_path):
    data = frames_study_dict(tmp_path)
    data["uncertainty"] = {"camera": "lin", "integration_time_us": 2, "draws": 10**8,
                           "inputs": {"emissivity": {"distribution": "uniform", "low": 0.8,
                                                     "high": 0.9}}}
    with pytest.raises(RadiosimError) as info:
        Study.from_dict(data)
    single_line(str(info.value), "[uncertainty] draws", "100000000", str(MAX_DRAWS))


def test_a_study_lists_its_inputs(tmp_path):
    data = frames_study_dict(tmp_path)
    camera = Camera.linear_ideal(3e-6)
    (tmp_path / "cam.toml").write_text(camera.to_toml())
    data["cameras"] = {"lin": {"file": "cam.toml"}}
    study = Study.from_dict(data, base=tmp_path)
    study.scene
    inputs = {p.resolve() for p in study.inputs()}
    assert (tmp_path / "frames.npy").resolve() in inputs
    assert (tmp_path / "cam.toml").resolve() in inputs


# -- names from a study stay inside the output folder ----------------------------------------------


@pytest.mark.parametrize("name", ["../../x", "/tmp/abs", "a/b", "", "..", "a\\b", " "])
def test_a_sweep_name_that_would_leave_out_is_refused(tmp_path, name):
    data = frames_study_dict(tmp_path)
    data["sweeps"][0]["name"] = name
    with pytest.raises(RadiosimError) as info:
        Study.from_dict(data)
    single_line(str(info.value), repr(name), "sweeps")


@pytest.mark.parametrize("name", ["../../evil", "/tmp/evil", "", "."])
def test_a_study_name_that_would_leave_out_is_refused(tmp_path, name):
    data = frames_study_dict(tmp_path, name=name)
    with pytest.raises(RadiosimError) as info:
        Study.from_dict(data)
    single_line(str(info.value), repr(name), "study name")


def test_a_camera_name_with_a_separator_is_refused(tmp_path):
    data = frames_study_dict(tmp_path, cameras={"../c": {"preset": "linear-ideal",
                                                    "pixel_pitch_um": 3.0}},
                        sweeps=[{"name": "t", "cameras": ["../c"], "integration_time_us": [1]}])
    with pytest.raises(RadiosimError) as info:
        Study.from_dict(data)
    single_line(str(info.value), "'../c'")


def test_names_with_spaces_stay_valid_and_inside_out(tmp_path):
    data = frames_study_dict(tmp_path, name="my study",
                        cameras={"cam one": {"preset": "linear-ideal", "pixel_pitch_um": 3.0}},
                        sweeps=[{"name": "long run", "cameras": ["cam one"],
                                 "integration_time_us": [1]}])
    before = {p for p in tmp_path.parent.rglob("*") if tmp_path not in p.parents}
    result = Study.from_dict(data).run(tmp_path / "out")
    row = result.rows[0]
    assert row["sweep"] == "long run" and row["camera"] == "cam one"
    exr = (tmp_path / "out" / row["exr"]).resolve()
    assert (tmp_path / "out").resolve() in exr.parents and exr.is_file()
    after = {p for p in tmp_path.parent.rglob("*") if tmp_path not in p.parents}
    assert after == before  # nothing outside


# -- Study.run: the command's rules for its folder; a full disk; a failure keeps completed rows ----


def no_litter_files(root: Path):
    stray = [p for p in root.rglob("*") if p.name.endswith(".partial") and not p.is_dir()]
    assert not stray, stray
    empty = [p for p in root.rglob("*") if p.is_file() and p.stat().st_size == 0]
    assert not empty, empty


def test_study_run_refuses_to_overwrite_a_users_results(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (out / "results.csv").write_text("the user's own results\n")
    study = Study.from_dict(frames_study_dict(tmp_path))
    with pytest.raises(RadiosimError) as info:
        study.run(out)
    single_line(str(info.value), out, "overwrite")
    assert tree(out) == {"results.csv": b"the user's own results\n"}
    assert not (tmp_path / "out.partial").exists()


def test_study_run_overwrite_replaces_only_its_own_files(tmp_path):
    out = tmp_path / "out"
    study = Study.from_dict(frames_study_dict(tmp_path))
    study.run(out, write_exr=False)
    (out / "notes.txt").write_text("the user's notes")
    with pytest.raises(RadiosimError):
        study.run(out, write_exr=False)  # not without overwrite=True
    result = study.run(out, write_exr=False, overwrite=True)
    assert result.table == out / "results.csv" and result.table.is_file()
    assert (out / "notes.txt").read_text() == "the user's notes"
    assert "results.csv" in json.loads((out / MANIFEST).read_text())["files"]


def test_study_run_overwrite_refuses_a_folder_radiosim_did_not_write(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (out / "data.csv").write_text("the user's data")
    with pytest.raises(RadiosimError) as info:
        Study.from_dict(frames_study_dict(tmp_path)).run(out, overwrite=True)
    single_line(str(info.value), out, MANIFEST)
    assert tree(out) == {"data.csv": b"the user's data"}


def test_a_dangling_symlink_as_out_is_refused_before_any_work(tmp_path):
    out = tmp_path / "out"
    out.symlink_to(tmp_path / "nowhere")
    calls = []
    with pytest.raises(RadiosimError) as info:
        Study.from_dict(frames_study_dict(tmp_path)).run(out, progress=lambda *a: calls.append(a))
    single_line(str(info.value), out, "symbolic link")
    assert calls == [] and out.is_symlink() and not (tmp_path / "nowhere").exists()


def test_a_file_as_out_is_refused_before_any_work(tmp_path):
    out = tmp_path / "out"
    out.write_text("a user's file")
    calls = []
    with pytest.raises(RadiosimError) as info:
        Study.from_dict(frames_study_dict(tmp_path)).run(out, progress=lambda *a: calls.append(a))
    single_line(str(info.value), out, "not a folder")
    assert calls == [] and out.read_text() == "a user's file"


def test_an_out_below_a_file_is_refused(tmp_path):
    (tmp_path / "afile").write_text("x")
    with pytest.raises(RadiosimError) as info:
        Study.from_dict(frames_study_dict(tmp_path)).run(tmp_path / "afile" / "out")
    single_line(str(info.value), tmp_path / "afile", "not a folder")


def test_a_run_never_replaces_one_of_its_own_inputs(tmp_path):
    out = tmp_path / "out"
    study = Study.from_dict(frames_study_dict(tmp_path))
    study.run(out, write_exr=False)
    # The scene now lives in the output folder, as a file of radiosim's previous run.
    (out / "frames.npy").write_bytes((tmp_path / "frames.npy").read_bytes())
    manifest = json.loads((out / MANIFEST).read_text())
    manifest["files"].append("frames.npy")
    (out / MANIFEST).write_text(json.dumps(manifest))
    data = frames_study_dict(tmp_path)
    data["scene"]["path"] = str(out / "frames.npy")
    before = tree(out)
    with pytest.raises(RadiosimError) as info:
        Study.from_dict(data).run(out, write_exr=False, overwrite=True)
    single_line(str(info.value), out / "frames.npy", "overwrite")
    assert tree(out) == before


def test_a_study_run_from_python_is_marked_while_it_runs(tmp_path):
    seen = []

    def progress(done, total, label):
        marker = tmp_path / "out.partial" / RUN_MARKER
        seen.append(marker.is_file() and marker.read_text().split()[0] == str(os.getpid()))

    Study.from_dict(frames_study_dict(tmp_path)).run(tmp_path / "out", progress=progress)
    assert seen and all(seen)
    assert not (tmp_path / "out.partial").exists()
    assert not (tmp_path / "out" / RUN_MARKER).exists()


def test_a_failed_run_keeps_its_rows_in_a_partial_folder_without_marker(tmp_path):
    study = Study.from_dict(frames_study_dict(tmp_path))

    def fail(done, total, label):
        if done == 2:
            raise RuntimeError("stopped")

    with pytest.raises(RuntimeError):
        study.run(tmp_path / "out", progress=fail)
    partial = tmp_path / "out.partial"
    assert not (tmp_path / "out").exists()
    rows = list(csv.DictReader((partial / "results.csv").open(encoding="utf-8")))
    assert len(rows) == 2 and all((partial / r["exr"]).is_file() for r in rows)
    assert not (partial / RUN_MARKER).exists()
    no_litter_files(tmp_path)


def test_a_run_into_an_output_folders_staging_is_committed_by_its_owner(tmp_path):
    folder = OutputFolder(tmp_path / "out")
    result = Study.from_dict(frames_study_dict(tmp_path)).run(folder.staging, write_exr=False)
    assert result.table == folder.staging / "results.csv"
    written = folder.commit()
    assert tmp_path / "out" / "results.csv" in written


def test_a_study_on_a_real_full_disk_fails_naming_a_file_and_commits_nothing(small_disk):
    (small_disk / "filler").write_bytes(b"\0" * 40_000)
    study = Study.from_dict(frames_study_dict(small_disk.parent, shape=(4, 60, 60)))
    with pytest.raises(RadiosimIOError) as info:
        study.run(small_disk / "out")
    single_line(str(info.value), small_disk)
    assert not (small_disk / "out").exists()
    no_litter_files(small_disk)


@pytest.mark.usefixtures("in_tmp")
@pytest.mark.parametrize("frame", [
    pytest.param(0, id="fails-at-once"),
    pytest.param(18, id="fails-late"),
])
def test_study_run_api_failure_keeps_only_completed_rows(tmp_path, frame):
    study = Study.from_toml(nan_late_study(tmp_path, frame))
    with pytest.raises(RadiosimError) as info:
        study.run(tmp_path / "res")
    api_error(info, f"frame {frame}", "NaN")
    table = tmp_path / "res" / "results.csv"
    if table.exists():  # the rows that completed, each with its EXR file
        rows = list(csv.DictReader(table.open(encoding="utf-8")))
        assert rows and all(r["integration_time_us"] in ("2.0", "4.0") for r in rows)
        for row in rows:
            read_exr(tmp_path / "res" / row["exr"])
    no_litter(tmp_path)


# -- studies never silence a warning ---------------------------------------------------------------


def linear_real_study(folder: Path) -> Study:
    """The user guide's trap: a linear response through real electronics (one DN ≈ 100s K)."""
    cameras = {"nist-ir-camera": {"preset": "nist-ir", "pixel_pitch_um": 4.0}}
    sweeps = [{"name": "resp", "cameras": ["nist-ir-camera"], "integration_time_us": [2],
               "response": ["linear", "planck"]}]
    return Study.from_dict(frames_study_dict(folder, sweeps, cameras=cameras, value=1000.0,
                                        shape=(4, 12, 12)))


def test_a_coarse_reading_is_flagged_in_its_row_and_raised(tmp_path):
    study = linear_real_study(tmp_path)
    with pytest.warns(RadiosimWarning, match="one DN is about"):
        result = study.run(tmp_path / "out", write_exr=False)
    rows = {r["response"]: r for r in result.rows}
    assert "one DN is about" in rows["linear"]["warnings"]
    assert rows["planck"]["warnings"] == ""
    table = list(csv.DictReader((tmp_path / "out" / "results.csv").open(encoding="utf-8")))
    assert "one DN is about" in {r["response"]: r for r in table}["linear"]["warnings"]


def test_warnings_travel_back_from_dask_tasks(tmp_path):
    study = linear_real_study(tmp_path)
    with pytest.warns(RadiosimWarning, match="one DN"):
        local = study.run(None, rng=3, scheduler="threads").rows
    assert "one DN is about" in local[0]["warnings"] and local[1]["warnings"] == ""


def test_the_console_table_shows_response_alignment_full_names_and_flags(tmp_path):
    study = linear_real_study(tmp_path)
    with pytest.warns(RadiosimWarning):
        rows = study.run(None).rows
    lines = format_table(rows)
    body = [line for line in lines if line.startswith("resp")]
    assert len(body) == 2
    assert all("nist-ir-camera" in line for line in body)  # not cut to 8 characters
    assert "linear" in body[0] and "planck" in body[1]
    assert all(rows[0]["alignment"] in line for line in body)
    assert body[0].rstrip().endswith("[1]") and not body[1].rstrip().endswith("]")
    assert any(line.strip().startswith("[1]") and "one DN" in line for line in lines)


# -- one seed, the same bits on every engine -------------------------------------------------------


def noisy_study(folder: Path) -> Study:
    """Two cameras with noise (nist-ir's electronics, Planck response), three sweeps."""
    cameras = {"real": {"preset": "nist-ir", "pixel_pitch_um": 4.0},
               "other": {"preset": "nist-ir", "pixel_pitch_um": 6.0}}
    sweeps = [{"name": "a", "cameras": ["real"], "integration_time_us": [1, 2, 3]},
              {"name": "b", "cameras": ["other", "real"], "integration_time_us": [2]}]
    return Study.from_dict(frames_study_dict(folder, sweeps, cameras=cameras, value=900.0,
                                        shape=(6, 24, 24)))


def columns_equal(a: list[dict], b: list[dict]):
    assert len(a) == len(b) and a
    for key in a[0]:
        left, right = [r[key] for r in a], [r[key] for r in b]
        if all(isinstance(v, float) for v in left):
            assert np.array_equal(np.array(left), np.array(right), equal_nan=True), key
        else:
            assert left == right, key


def test_in_process_and_threads_and_synchronous_give_the_same_bits(tmp_path):
    study = noisy_study(tmp_path)
    local = study.run(None, rng=11, write_exr=False).rows
    columns_equal(local, study.run(None, rng=11, scheduler="synchronous").rows)
    columns_equal(local, study.run(None, rng=11, scheduler="threads").rows)
    other = study.run(None, rng=12).rows
    assert not np.array_equal([r["peak_C"] for r in local], [r["peak_C"] for r in other])


def test_in_process_and_a_two_worker_cluster_give_the_same_bits(tmp_path):
    from distributed import Client, LocalCluster

    study = noisy_study(tmp_path)
    local = study.run(None, rng=5).rows
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                      dashboard_address=None) as cluster, Client(cluster) as client:
        remote = study.run(None, rng=5, scheduler=client).rows
    columns_equal(local, remote)


def test_a_measurement_keeps_its_noise_whatever_follows_it(tmp_path):
    study = noisy_study(tmp_path)
    full = study.run(None, rng=2).rows
    study.sweeps = study.sweeps[:1]
    first = study.run(None, rng=2).rows
    columns_equal(full[:len(first)], first)


def test_a_seed_sequence_and_its_integer_agree(tmp_path):
    study = noisy_study(tmp_path)
    columns_equal(study.run(None, rng=9).rows,
                  study.run(None, rng=np.random.SeedSequence(9)).rows)


def test_a_studys_cluster_tasks_are_parts_of_a_scenes_frames(tmp_path, monkeypatch):
    """On an engine a study submits, per scene, one task per part of the frames its cases'
    windows span (its cases sharing each part's pass), not one per measurement; the rows are
    the in-process run's bits."""
    import radiosim.study as study_module
    from radiosim.scheduling import connect

    submitted = []

    def spying_connect(scheduler=None, workers=None, timeout=None):
        run, close = connect("synchronous")

        def spy(function, argument_lists, shared=()):
            submitted.append((function.__name__, len(argument_lists)))
            return run(function, argument_lists, shared=shared)
        return spy, close

    monkeypatch.setattr(study_module, "connect", spying_connect)
    study = noisy_study(tmp_path)
    local = study.run(None, rng=5).rows
    remote = study.run(None, rng=5, scheduler="synchronous").rows
    columns_equal(local, remote)
    assert {name for name, _ in submitted} == {"_recorded_part"}
    assert sum(n for _, n in submitted) == study._tasks(list(study.plan()))
