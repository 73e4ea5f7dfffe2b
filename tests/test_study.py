"""Studies as data."""

import dataclasses
import time
import tomllib

import numpy as np
import pytest

from radiosim import Camera, Electronics
from radiosim.errors import RadiosimError
from radiosim.paper import COLUMN_I_COLUMNS
from conftest import frames_study
from radiosim.study import STUDY_DIRECTORY, RESULT_COLUMNS, Study, available_studies


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


def test_background_writes_stop_at_the_first_failure_and_skip_the_rest_on_an_error(tmp_path):
    # A failed write is raised by the next write asked for; after the body's error every
    # write asked for is done, after an interrupt those not yet started are not (and are
    # counted as not written).
    import threading

    from radiosim.files import BackgroundWrites

    gate = threading.Event()
    gate.set()

    def write(path, text):
        if path.name == "bad":
            raise OSError(28, "No space left on device", str(path))
        gate.wait(5)
        path.write_text(text)

    writes = BackgroundWrites(write)
    with pytest.raises(OSError, match="No space"):
        with writes:
            writes(tmp_path / "bad", "x")
            time.sleep(0.2)  # the failure is known by now
            writes(tmp_path / "b", "y")  # raises it
    assert writes.failed == [tmp_path / "bad"] and not (tmp_path / "b").exists()
    for error, first, second in ((KeyError, tmp_path / "c", tmp_path / "d"),
                                 (KeyboardInterrupt, tmp_path / "e", tmp_path / "f")):
        gate.clear()
        writes = BackgroundWrites(write)
        with pytest.raises(error):
            with writes:
                writes(first, "1")  # started: waits for the gate, then completes
                writes(second, "2")  # not started when the body fails
                threading.Timer(0.3, gate.set).start()  # the gate opens while __exit__ waits
                raise error("the body's error")
        assert first.read_text() == "1"
        if error is KeyError:  # a failed body's writes are of completed work: done
            assert second.read_text() == "2" and writes.failed == []
        else:  # interrupted: those not started are not done
            assert not second.exists() and writes.failed == [second]
