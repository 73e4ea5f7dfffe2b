"""Output files (radiosim.files): a write is complete or absent (a full disk, an interrupt), a
name from a study stays one path component, no output is one of the run's inputs, and a running
run marks its folder."""

import errno
import json
import os
import socket
import subprocess

import pytest

import radiosim.files as files
from conftest import single_line
from radiosim.errors import RadiosimError, RadiosimIOError
from radiosim.files import (MANIFEST, RUN_MARKER, OutputFolder, atomic_path, atomic_write,
                            check_not_an_input, safe_name, write_text)


# -- a write is complete or absent: a full disk, an interrupt --------------------------------------


def enospc(*args, **kwargs):
    raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))


def test_full_disk_at_fsync_keeps_the_earlier_file(tmp_path, monkeypatch):
    path = tmp_path / "table.csv"
    path.write_text("the earlier table\n")
    monkeypatch.setattr(files.os, "fsync", enospc)
    with pytest.raises(RadiosimIOError) as info:
        write_text(path, "new table\n" * 100)
    single_line(str(info.value), path, "full")
    assert path.read_text() == "the earlier table\n"
    assert [p.name for p in tmp_path.iterdir()] == ["table.csv"]


def test_full_disk_while_writing_keeps_the_earlier_file(tmp_path):
    path = tmp_path / "a.txt"
    path.write_text("kept")
    with pytest.raises(RadiosimIOError) as info:
        with atomic_write(path) as stream:
            stream.write("half")
            enospc()
    single_line(str(info.value), path)
    assert path.read_text() == "kept"
    assert [p.name for p in tmp_path.iterdir()] == ["a.txt"]


def test_full_disk_in_a_library_writer_is_one_error_naming_the_file(tmp_path):
    path = tmp_path / "m.exr"
    path.write_bytes(b"the user's earlier measurement")
    with pytest.raises(RadiosimIOError) as info:
        with atomic_path(path) as temporary:
            temporary.write_bytes(b"half an EXR")
            enospc()
    single_line(str(info.value), path, "full")
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


def test_a_real_full_disk_keeps_the_earlier_file(small_disk):
    path = small_disk / "results.csv"
    path.write_text("the earlier results\n")
    with pytest.raises(RadiosimIOError) as info:
        write_text(path, "x" * 200_000)
    single_line(str(info.value), path)
    assert path.read_text() == "the earlier results\n"
    assert [p.name for p in small_disk.iterdir()] == ["results.csv"]


# -- names stay one path component; an output is never an input; a running run is marked -----------


@pytest.mark.parametrize("name, expected", [("../../x", "_.__._x"), ("a/b", "a_b"),
                                            ("long run", "long_run"), (".hidden", "hidden")])
def test_safe_name_is_one_component(name, expected):
    assert safe_name(name, "name") == expected
    assert "/" not in expected and not expected.startswith(".")


def test_an_output_that_is_an_input_is_refused(tmp_path):
    frame = tmp_path / "run" / "frame_0.exr"
    frame.parent.mkdir()
    frame.write_bytes(b"an input frame")
    with pytest.raises(RadiosimError) as info:
        check_not_an_input(tmp_path / "run" / ".." / "run" / "frame_0.exr", [frame])
    single_line(str(info.value), "frame_0.exr", "inputs")
    check_not_an_input(tmp_path / "other.exr", [frame])  # another name: fine


def test_a_running_run_marks_its_folder_and_a_second_run_names_it(tmp_path):
    first = OutputFolder(tmp_path / "out")
    marker = first.staging / RUN_MARKER
    assert marker.read_text().split()[0] == str(os.getpid())
    with pytest.raises(RadiosimError) as info:
        OutputFolder(tmp_path / "out")
    message = str(info.value)
    single_line(message, f"another run (pid {os.getpid()})", tmp_path / "out")
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
    single_line(str(info.value), staging, f"pid {child.pid}", "no longer running")


def test_why_a_path_is_no_file_names_the_real_cause(tmp_path):
    # A FIFO, a device, a folder, a symbolic link that loops or points nowhere: each said for
    # what it is, not "does not exist"; a regular file (or a link to one) is fine.
    import os

    from radiosim.files import why_not_a_file

    (tmp_path / "f.npy").write_bytes(b"x")
    os.mkfifo(tmp_path / "fifo.npy")
    os.symlink(tmp_path / "loop_a", tmp_path / "loop_b")
    os.symlink(tmp_path / "loop_b", tmp_path / "loop_a")
    os.symlink(tmp_path / "nowhere", tmp_path / "broken")
    os.symlink(tmp_path / "f.npy", tmp_path / "link.npy")
    assert why_not_a_file(tmp_path / "f.npy") is None
    assert why_not_a_file(tmp_path / "link.npy") is None
    assert why_not_a_file(tmp_path / "missing") == "does not exist"
    assert why_not_a_file(tmp_path) == "is a folder, not a file"
    assert why_not_a_file(tmp_path / "fifo.npy") == "is a FIFO (named pipe), not a file"
    assert why_not_a_file("/dev/null") == "is a device, not a file"
    assert why_not_a_file(tmp_path / "loop_a") == "is a symbolic link that loops back on itself"
    assert why_not_a_file(tmp_path / "broken") == "is a broken link (its target does not exist)"


def test_a_run_starting_meanwhile_is_named_not_taken_for_an_old_partial_result(tmp_path):
    # Another run has just made its staging folder and not yet written its marker: this one
    # waits a moment for the marker and says a run is writing there (it said "an earlier
    # run's partial result" before, while the other run was still starting).
    import threading

    out = tmp_path / "results"
    staging = tmp_path / "results.partial"
    staging.mkdir()
    writer = threading.Timer(0.3, lambda: (staging / RUN_MARKER).write_text(
        f"{os.getpid()} {socket.gethostname()}\n"))
    writer.start()
    try:
        with pytest.raises(RadiosimError, match=r"another run \(pid \d+\) is writing"):
            OutputFolder(out)
    finally:
        writer.join()
    assert staging.exists() and not out.exists()
