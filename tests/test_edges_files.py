"""
Trust at the edges (issue 20), files and engines: a write is complete or absent, names from a
study stay inside the output folder, a run never writes over its own inputs nor over a user's
files, a running run's folder is marked, studies never silence a warning, one seed gives the
same bits on every engine, and the uncertainty engine's bounds.

Each test asserts its class: file lost (a file destroyed, misplaced or left half-written),
wrong number (a result that differs or carries no flag), hang, misleading message, valid
refused.
"""

from __future__ import annotations

import csv
import errno
import json
import os
import socket
import subprocess
import threading
import time
from pathlib import Path

import numpy as np
import pytest

import radiosim.files as files
from radiosim import Camera
from radiosim.errors import RadiosimError, RadiosimIOError, RadiosimWarning
from radiosim.files import (MANIFEST, RUN_MARKER, OutputFolder, atomic_path, atomic_write,
                            check_not_an_input, safe_name, write_text)
from radiosim.study import Study, format_table
from radiosim.uncertainty import MAX_DRAWS, Normal, Uniform, connect, propagate


# -- helpers ---------------------------------------------------------------------------------


def tree(root: Path) -> dict:
    """Every file under ``root`` → its bytes."""
    return {str(p.relative_to(root)): p.read_bytes() for p in sorted(root.rglob("*"))
            if p.is_file()}


def no_litter(root: Path):
    stray = [p for p in root.rglob("*") if p.name.endswith(".partial") and not p.is_dir()]
    assert not stray, stray
    empty = [p for p in root.rglob("*") if p.is_file() and p.stat().st_size == 0]
    assert not empty, empty


def one_line(message: str, *expected):
    assert "\n" not in message.strip(), message
    for item in expected:
        assert str(item) in message, (item, message)


def frames_study(folder: Path, sweeps=None, name="small", cameras=None, value=600.0,
                 shape=(6, 12, 12)) -> dict:
    """A study dict on ``frames.npy`` in ``folder`` (1 µs frames of 1 µm samples, kelvin)."""
    rng = np.random.default_rng(0)
    np.save(folder / "frames.npy", value + 50.0 * rng.random(shape))
    return {
        "name": name,
        "scene": {"type": "frames", "path": str(folder / "frames.npy"), "dt_us": 1.0,
                  "dx_um": 1.0, "units": "K"},
        "cameras": cameras or {"lin": {"preset": "linear-ideal", "pixel_pitch_um": 3.0}},
        "sweeps": sweeps or [{"name": "t", "cameras": ["lin"], "integration_time_us": [1, 2]}],
    }


def noisy_study(folder: Path) -> Study:
    """Two cameras with noise (nist-ir's electronics, Planck response), three sweeps."""
    cameras = {"real": {"preset": "nist-ir", "pixel_pitch_um": 4.0},
               "other": {"preset": "nist-ir", "pixel_pitch_um": 6.0}}
    sweeps = [{"name": "a", "cameras": ["real"], "integration_time_us": [1, 2, 3]},
              {"name": "b", "cameras": ["other", "real"], "integration_time_us": [2]}]
    return Study.from_dict(frames_study(folder, sweeps, cameras=cameras, value=900.0,
                                        shape=(6, 24, 24)))


def linear_real_study(folder: Path) -> Study:
    """The user guide's trap: a linear response through real electronics (one DN ≈ 100s K)."""
    cameras = {"nist-ir-camera": {"preset": "nist-ir", "pixel_pitch_um": 4.0}}
    sweeps = [{"name": "resp", "cameras": ["nist-ir-camera"], "integration_time_us": [2],
               "response": ["linear", "planck"]}]
    return Study.from_dict(frames_study(folder, sweeps, cameras=cameras, value=1000.0,
                                        shape=(4, 12, 12)))


def columns_equal(a: list[dict], b: list[dict]):
    assert len(a) == len(b) and a
    for key in a[0]:
        left, right = [r[key] for r in a], [r[key] for r in b]
        if all(isinstance(v, float) for v in left):
            assert np.array_equal(np.array(left), np.array(right), equal_nan=True), key
        else:
            assert left == right, key


# =================================================================================================
# 1. A write is complete or absent (file lost)
# =================================================================================================


def enospc(*args, **kwargs):
    raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))


def test_full_disk_at_fsync_keeps_the_earlier_file(tmp_path, monkeypatch):
    path = tmp_path / "table.csv"
    path.write_text("the earlier table\n")
    monkeypatch.setattr(files.os, "fsync", enospc)
    with pytest.raises(RadiosimIOError) as info:
        write_text(path, "new table\n" * 100)
    one_line(str(info.value), path, "full")
    assert path.read_text() == "the earlier table\n"
    assert [p.name for p in tmp_path.iterdir()] == ["table.csv"]


def test_full_disk_while_writing_keeps_the_earlier_file(tmp_path):
    path = tmp_path / "a.txt"
    path.write_text("kept")
    with pytest.raises(RadiosimIOError) as info:
        with atomic_write(path) as stream:
            stream.write("half")
            enospc()
    one_line(str(info.value), path)
    assert path.read_text() == "kept"
    assert [p.name for p in tmp_path.iterdir()] == ["a.txt"]


def test_full_disk_in_a_library_writer_is_one_error_naming_the_file(tmp_path):
    path = tmp_path / "m.exr"
    path.write_bytes(b"the user's earlier measurement")
    with pytest.raises(RadiosimIOError) as info:
        with atomic_path(path) as temporary:
            temporary.write_bytes(b"half an EXR")
            enospc()
    one_line(str(info.value), path, "full")
    assert path.read_bytes() == b"the user's earlier measurement"
    assert [p.name for p in tmp_path.iterdir()] == ["m.exr"]


def test_a_new_file_is_absent_after_a_full_disk(tmp_path, monkeypatch):
    monkeypatch.setattr(files.os, "fsync", enospc)
    with pytest.raises(RadiosimIOError):
        write_text(tmp_path / "new.csv", "x\n")
    assert list(tmp_path.iterdir()) == []  # no 0-byte file, no temporary


def test_the_data_is_synced_before_the_rename_and_the_folder_after(tmp_path, monkeypatch):
    events = []
    real_fsync, real_replace = os.fsync, os.replace

    def fsync(fd):
        events.append(("fsync", os.path.isdir(f"/proc/self/fd/{fd}")))
        return real_fsync(fd)

    def replace(a, b):
        events.append(("replace", None))
        return real_replace(a, b)

    monkeypatch.setattr(files.os, "fsync", fsync)
    monkeypatch.setattr(files.os, "replace", replace)
    write_text(tmp_path / "a.txt", "done")
    assert events[0] == ("fsync", False)  # the file's data first
    assert events.index(("replace", None)) > 0
    assert ("fsync", True) in events[events.index(("replace", None)):]  # then the folder
    with atomic_path(tmp_path / "b.bin") as temporary:
        temporary.write_bytes(b"library output")
    assert (tmp_path / "b.bin").read_bytes() == b"library output"


def test_an_interrupt_while_writing_leaves_the_earlier_file(tmp_path):
    path = tmp_path / "a.txt"
    path.write_text("kept")
    with pytest.raises(KeyboardInterrupt):
        with atomic_write(path) as stream:
            stream.write("half")
            raise KeyboardInterrupt
    assert path.read_text() == "kept" and len(list(tmp_path.iterdir())) == 1


@pytest.fixture
def small_disk(tmp_path):
    """A 64 KiB tmpfs (root only; skipped with the reason otherwise)."""
    folder = tmp_path / "disk"
    folder.mkdir()
    try:
        done = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=64k", "tmpfs", str(folder)],
                              capture_output=True, timeout=20)
    except (OSError, subprocess.TimeoutExpired) as exc:
        pytest.skip(f"cannot mount a tmpfs: {exc}")
    if done.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs (needs root): {done.stderr.decode().strip()}")
    try:
        yield folder
    finally:
        subprocess.run(["umount", str(folder)], capture_output=True, timeout=20)


def test_a_real_full_disk_keeps_the_earlier_file(small_disk):
    path = small_disk / "results.csv"
    path.write_text("the earlier results\n")
    with pytest.raises(RadiosimIOError) as info:
        write_text(path, "x" * 200_000)
    one_line(str(info.value), path)
    assert path.read_text() == "the earlier results\n"
    assert [p.name for p in small_disk.iterdir()] == ["results.csv"]


def test_a_real_full_disk_during_an_exr_write_leaves_no_file(small_disk):
    from radiosim.io import write_exr

    scene_camera = Camera.linear_ideal(2e-6)
    from radiosim.scenes import FrameStack

    values = 600.0 + 100.0 * np.random.default_rng(0).random((3, 200, 200))
    scene = FrameStack(values, dt=1e-6, dx=1e-6)
    m = scene_camera.measure(scene, 2e-6, rng=0)
    (small_disk / "filler").write_bytes(b"\0" * 50_000)
    with pytest.raises(RadiosimIOError) as info:
        write_exr(small_disk / "m.exr", m)
    one_line(str(info.value), small_disk / "m.exr")
    assert sorted(p.name for p in small_disk.iterdir()) == ["filler"]


def test_a_study_on_a_real_full_disk_fails_naming_a_file_and_commits_nothing(small_disk):
    (small_disk / "filler").write_bytes(b"\0" * 40_000)
    study = Study.from_dict(frames_study(small_disk.parent, shape=(4, 60, 60)))
    with pytest.raises(RadiosimIOError) as info:
        study.run(small_disk / "out")
    one_line(str(info.value), small_disk)
    assert not (small_disk / "out").exists()
    no_litter(small_disk)


# =================================================================================================
# 2. Names from a study stay inside the output folder (file misplaced)
# =================================================================================================


@pytest.mark.parametrize("name", ["../../x", "/tmp/abs", "a/b", "", "..", "a\\b", " "])
def test_a_sweep_name_that_would_leave_out_is_refused(tmp_path, name):
    data = frames_study(tmp_path)
    data["sweeps"][0]["name"] = name
    with pytest.raises(RadiosimError) as info:
        Study.from_dict(data)
    one_line(str(info.value), repr(name), "sweeps")


@pytest.mark.parametrize("name", ["../../evil", "/tmp/evil", "", "."])
def test_a_study_name_that_would_leave_out_is_refused(tmp_path, name):
    data = frames_study(tmp_path, name=name)
    with pytest.raises(RadiosimError) as info:
        Study.from_dict(data)
    one_line(str(info.value), repr(name), "study name")


def test_a_camera_name_with_a_separator_is_refused(tmp_path):
    data = frames_study(tmp_path, cameras={"../c": {"preset": "linear-ideal",
                                                    "pixel_pitch_um": 3.0}},
                        sweeps=[{"name": "t", "cameras": ["../c"], "integration_time_us": [1]}])
    with pytest.raises(RadiosimError) as info:
        Study.from_dict(data)
    one_line(str(info.value), "'../c'")


def test_names_with_spaces_stay_valid_and_inside_out(tmp_path):
    data = frames_study(tmp_path, name="my study",
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


@pytest.mark.parametrize("name, expected", [("../../x", "_.__._x"), ("a/b", "a_b"),
                                            ("long run", "long_run"), (".hidden", "hidden")])
def test_safe_name_is_one_component(name, expected):
    assert safe_name(name, "name") == expected
    assert "/" not in expected and not expected.startswith(".")


# =================================================================================================
# 3. Study.run follows the command's rules; no run writes over its inputs; a run is marked
# =================================================================================================


def test_study_run_refuses_to_overwrite_a_users_results(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (out / "results.csv").write_text("the user's own results\n")
    study = Study.from_dict(frames_study(tmp_path))
    with pytest.raises(RadiosimError) as info:
        study.run(out)
    one_line(str(info.value), out, "overwrite")
    assert tree(out) == {"results.csv": b"the user's own results\n"}
    assert not (tmp_path / "out.partial").exists()


def test_study_run_overwrite_replaces_only_its_own_files(tmp_path):
    out = tmp_path / "out"
    study = Study.from_dict(frames_study(tmp_path))
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
        Study.from_dict(frames_study(tmp_path)).run(out, overwrite=True)
    one_line(str(info.value), out, MANIFEST)
    assert tree(out) == {"data.csv": b"the user's data"}


def test_a_dangling_symlink_as_out_is_refused_before_any_work(tmp_path):
    out = tmp_path / "out"
    out.symlink_to(tmp_path / "nowhere")
    calls = []
    with pytest.raises(RadiosimError) as info:
        Study.from_dict(frames_study(tmp_path)).run(out, progress=lambda *a: calls.append(a))
    one_line(str(info.value), out, "symbolic link")
    assert calls == [] and out.is_symlink() and not (tmp_path / "nowhere").exists()


def test_a_file_as_out_is_refused_before_any_work(tmp_path):
    out = tmp_path / "out"
    out.write_text("a user's file")
    calls = []
    with pytest.raises(RadiosimError) as info:
        Study.from_dict(frames_study(tmp_path)).run(out, progress=lambda *a: calls.append(a))
    one_line(str(info.value), out, "not a folder")
    assert calls == [] and out.read_text() == "a user's file"


def test_an_out_below_a_file_is_refused(tmp_path):
    (tmp_path / "afile").write_text("x")
    with pytest.raises(RadiosimError) as info:
        Study.from_dict(frames_study(tmp_path)).run(tmp_path / "afile" / "out")
    one_line(str(info.value), tmp_path / "afile", "not a folder")


def test_a_run_never_replaces_one_of_its_own_inputs(tmp_path):
    out = tmp_path / "out"
    study = Study.from_dict(frames_study(tmp_path))
    study.run(out, write_exr=False)
    # The scene now lives in the output folder, as a file of radiosim's previous run.
    (out / "frames.npy").write_bytes((tmp_path / "frames.npy").read_bytes())
    manifest = json.loads((out / MANIFEST).read_text())
    manifest["files"].append("frames.npy")
    (out / MANIFEST).write_text(json.dumps(manifest))
    data = frames_study(tmp_path)
    data["scene"]["path"] = str(out / "frames.npy")
    before = tree(out)
    with pytest.raises(RadiosimError) as info:
        Study.from_dict(data).run(out, write_exr=False, overwrite=True)
    one_line(str(info.value), out / "frames.npy", "overwrite")
    assert tree(out) == before


def test_an_output_that_is_an_input_is_refused(tmp_path):
    frame = tmp_path / "run" / "frame_0.exr"
    frame.parent.mkdir()
    frame.write_bytes(b"an input frame")
    with pytest.raises(RadiosimError) as info:
        check_not_an_input(tmp_path / "run" / ".." / "run" / "frame_0.exr", [frame])
    one_line(str(info.value), "frame_0.exr", "inputs")
    check_not_an_input(tmp_path / "other.exr", [frame])  # another name: fine


def test_a_running_run_marks_its_folder_and_a_second_run_names_it(tmp_path):
    first = OutputFolder(tmp_path / "out")
    marker = first.staging / RUN_MARKER
    assert marker.read_text().split()[0] == str(os.getpid())
    with pytest.raises(RadiosimError) as info:
        OutputFolder(tmp_path / "out")
    message = str(info.value)
    one_line(message, f"another run (pid {os.getpid()})", tmp_path / "out")
    assert "delete" not in message
    write_text(first.staging / "results.csv", "a,b\n")
    first.commit()
    assert not (tmp_path / "out" / RUN_MARKER).exists()
    assert RUN_MARKER not in json.loads((tmp_path / "out" / MANIFEST).read_text())["files"]


def test_a_stale_marker_is_recognised(tmp_path):
    child = subprocess.Popen(["true"])
    child.wait()  # a pid that has ended
    staging = tmp_path / "out.partial"
    staging.mkdir()
    (staging / RUN_MARKER).write_text(f"{child.pid} {socket.gethostname()}\n")
    with pytest.raises(RadiosimError) as info:
        OutputFolder(tmp_path / "out")
    one_line(str(info.value), staging, f"pid {child.pid}", "no longer running")


def test_a_study_run_from_python_is_marked_while_it_runs(tmp_path):
    seen = []

    def progress(done, total, label):
        marker = tmp_path / "out.partial" / RUN_MARKER
        seen.append(marker.is_file() and marker.read_text().split()[0] == str(os.getpid()))

    Study.from_dict(frames_study(tmp_path)).run(tmp_path / "out", progress=progress)
    assert seen and all(seen)
    assert not (tmp_path / "out.partial").exists()
    assert not (tmp_path / "out" / RUN_MARKER).exists()


def test_a_failed_run_keeps_its_rows_in_a_partial_folder_without_marker(tmp_path):
    study = Study.from_dict(frames_study(tmp_path))

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
    no_litter(tmp_path)


def test_a_run_into_an_output_folders_staging_is_committed_by_its_owner(tmp_path):
    folder = OutputFolder(tmp_path / "out")
    result = Study.from_dict(frames_study(tmp_path)).run(folder.staging, write_exr=False)
    assert result.table == folder.staging / "results.csv"
    written = folder.commit()
    assert tmp_path / "out" / "results.csv" in written


# =================================================================================================
# 4. Studies never silence a warning (wrong number, unflagged)
# =================================================================================================


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


# =================================================================================================
# 5. One seed, the same bits on every engine (wrong number)
# =================================================================================================


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


# =================================================================================================
# 6. The uncertainty engine's bounds (hang, misleading message)
# =================================================================================================


def small_budget_case(tmp_path):
    from radiosim.scenes import FrameStack

    scene = FrameStack(np.full((4, 12, 12), 700.0), dt=1e-6, dx=1e-6)
    return Camera.linear_ideal(3e-6), scene


def test_a_huge_draw_count_is_refused_naming_the_bound(tmp_path):
    camera, scene = small_budget_case(tmp_path)
    with pytest.raises(RadiosimError) as info:
        propagate(camera, scene, 2e-6, {"emissivity": Uniform(0.8, 0.9)}, draws=100_000_000)
    one_line(str(info.value), "draws", "100000000", str(MAX_DRAWS))


def test_a_huge_draw_count_in_a_study_file_is_refused(tmp_path):
    data = frames_study(tmp_path)
    data["uncertainty"] = {"camera": "lin", "integration_time_us": 2, "draws": 10**8,
                           "inputs": {"emissivity": {"distribution": "uniform", "low": 0.8,
                                                     "high": 0.9}}}
    with pytest.raises(RadiosimError) as info:
        Study.from_dict(data)
    one_line(str(info.value), "[uncertainty] draws", "100000000", str(MAX_DRAWS))


def test_progress_gives_a_time_estimate(tmp_path):
    camera, scene = small_budget_case(tmp_path)
    calls = []
    propagate(camera, scene, 2e-6, {"emissivity": Uniform(0.8, 0.9)}, draws=6, batch=2,
              rng=0, budget_draws=2, progress=lambda done, total, left: calls.append(
                  (done, total, left)))
    assert [c[:2] for c in calls] == [(2, 6), (4, 6), (6, 6)]
    assert all(left is not None and left >= 0 for _, _, left in calls)
    assert calls[-1][2] == 0


def test_a_scheduler_that_never_answers_times_out_in_one_line():
    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen(4)
    accepted = []

    def accept():
        while True:
            try:
                accepted.append(server.accept()[0])
            except OSError:
                return

    threading.Thread(target=accept, daemon=True).start()
    address = f"tcp://127.0.0.1:{server.getsockname()[1]}"
    start = time.monotonic()
    try:
        with pytest.raises(RadiosimError) as info:
            connect(address, timeout=2)
    finally:
        server.close()
        for conn in accepted:
            conn.close()
    assert time.monotonic() - start < 8
    one_line(str(info.value), address, "did not answer")


@pytest.mark.parametrize("address", ["tcp://localhost:notaport", "tcp://:::1", "tcp://",
                                     "tcp://host:99999", "foo://host:1"])
def test_a_malformed_scheduler_address_is_named(address):
    with pytest.raises(RadiosimError) as info:
        connect(address)
    one_line(str(info.value), repr(address), "tcp://HOST:PORT")
    assert "internal error" not in str(info.value)


@pytest.mark.parametrize("name, dist, domain", [
    ("psf_sigma", Uniform(-5e-6, 1e-6), "[0, inf]"),
    ("emissivity", Uniform(0.5, 1.2), "[0, 1]"),
    ("halo_fraction", Normal(0.01, 0.02), "(0, 1]"),
])
def test_an_input_range_outside_its_domain_is_refused_naming_it(tmp_path, name, dist, domain):
    camera, scene = small_budget_case(tmp_path)
    with pytest.raises(RadiosimError) as info:
        propagate(camera, scene, 2e-6, {name: dist}, draws=2)
    one_line(str(info.value), repr(name), "domain", domain)


def test_a_negative_psf_sigma_is_named_in_micrometres(tmp_path):
    camera, scene = small_budget_case(tmp_path)
    with pytest.raises(RadiosimError) as info:
        propagate(camera, scene, 2e-6, {"psf_sigma": Uniform(-5e-6, 1e-6)}, draws=2)
    one_line(str(info.value), "-5", "µm")


def test_a_budgets_warnings_reach_the_caller(tmp_path):
    camera = Camera.preset("nist-ir").replace(response="linear").with_pixel_pitch(4e-6)
    from radiosim.scenes import FrameStack

    scene = FrameStack(np.full((4, 12, 12), 1000.0), dt=1e-6, dx=1e-6)
    with pytest.warns(RadiosimWarning, match="one DN"):
        result = propagate(camera, scene, 2e-6, {"emissivity": Uniform(0.8, 0.9)}, draws=4,
                           batch=2, rng=0, budget_draws=2)
    assert any("one DN" in text for text in result.warnings)


# =================================================================================================
# 7. Through the command (exit code and one line)
# =================================================================================================


def cli(argv, capsys):
    from radiosim.cli import main

    try:
        code = main([str(a) for a in argv])
    except SystemExit as exc:  # argparse's own refusal
        code = exc.code
    out, err = capsys.readouterr()
    return code, out, err


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
    one_line(err, "symbolic link")
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
    one_line(err, f"another run (pid {os.getpid()})")
    assert "delete" not in err


def test_the_command_names_a_malformed_scheduler(tmp_path, capsys):
    study = write_toml_study(tmp_path)
    code, _, err = cli(["run", study, "--out", tmp_path / "out", "--quiet", "--no-figures",
                        "--scheduler", "tcp://localhost:notaport"], capsys)
    assert code == 2
    one_line(err, "tcp://localhost:notaport")
    assert "internal error" not in err
    assert not (tmp_path / "out").exists() and not (tmp_path / "out.partial").exists()


def test_the_command_refuses_a_huge_draw_count(tmp_path, capsys):
    study = write_toml_study(tmp_path, '[uncertainty]\ncamera = "lin"\nintegration_time_us = 2\n'
                                       '[uncertainty.inputs]\nemissivity = {distribution = '
                                       '"uniform", low = 0.8, high = 0.9}\n')
    code, _, err = cli(["uncertainty", study, "--draws", "100000000", "--out",
                        tmp_path / "u", "--quiet"], capsys)
    assert code == 2
    one_line(err, "100000000")
    assert str(MAX_DRAWS) in err.replace(",", "")
    assert not (tmp_path / "u").exists() and not (tmp_path / "u.partial").exists()


def test_a_study_lists_its_inputs(tmp_path):
    data = frames_study(tmp_path)
    camera = Camera.linear_ideal(3e-6)
    (tmp_path / "cam.toml").write_text(camera.to_toml())
    data["cameras"] = {"lin": {"file": "cam.toml"}}
    study = Study.from_dict(data, base=tmp_path)
    study.scene
    inputs = {p.resolve() for p in study.inputs()}
    assert (tmp_path / "frames.npy").resolve() in inputs
    assert (tmp_path / "cam.toml").resolve() in inputs


def test_a_refused_folder_is_named_in_the_callers_words(tmp_path, capsys):
    # The command names its option and suggests --overwrite; Python's Study.run suggests
    # overwrite=True; example-data (no --out option) names its folder argument.
    out = tmp_path / "out"
    out.mkdir()
    (out / "data.csv").write_text("the user's data")
    study = tmp_path / "s.toml"
    import tomlkit

    study.write_text(tomlkit.dumps(frames_study(tmp_path)))
    code, _, err = cli(["run", str(study), "--out", str(out), "-q"], capsys)
    assert code == 2 and f"--out {out} is not empty" in err and "pass --overwrite " in err
    assert "overwrite=True" not in err
    for overwrite in (False, True):  # not empty; with overwrite: not radiosim's folder
        with pytest.raises(RadiosimError) as info:
            Study.from_dict(frames_study(tmp_path)).run(out, overwrite=overwrite)
        assert "overwrite=True" in str(info.value) and "--" not in str(info.value)
    code, _, err = cli(["run", str(study), "--out", str(out), "--overwrite", "-q"], capsys)
    assert code == 2 and "--overwrite replaces only radiosim's own files" in err
    code, _, err = cli(["example-data", str(out / "data.csv")], capsys)
    assert code == 2 and "--out" not in err and "example data's folder" in err
    assert tree(out) == {"data.csv": b"the user's data"}
