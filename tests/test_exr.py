"""Measurements to EXR and back."""

import dataclasses
import warnings

import numpy as np
import OpenEXR
import pytest

from conftest import one_line_naming, single_line
from radiosim import Camera, FrameStack, RadiosimWarning
from radiosim.acquisition import record
from radiosim.errors import RadiosimError, RadiosimIOError
from radiosim.io import read_exr, read_exr_sequence, write_exr, write_exr_sequence
from radiosim.io.exr import CHANNELS
from radiosim.scenes import SegmentedChip

ARRAYS = ["apparent_temperature", "counts", "electrons", "tensor_max", "tensor_mean",
          "tensor_std", "signal_mean"]


@pytest.fixture(scope="module")
def measurement():
    scene = SegmentedChip(dx=2e-6, dt=1e-6).crop((90, 210), (150, 330))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RadiosimWarning)
        return Camera.preset("nist-ir").measure(scene, 150e-6, rng=4)


def test_round_trip_gives_an_equal_measurement(tmp_path, measurement):
    m = measurement
    assert m.saturated.any() and m.valid.any()  # both kinds of pixel are exercised
    path = write_exr(tmp_path / "m.exr", m)
    back = read_exr(path)
    for name in ARRAYS:  # float32 channels: equal to the float32 values written
        np.testing.assert_array_equal(getattr(back, name),
                                      getattr(m, name).astype(np.float32).astype(np.float64))
    np.testing.assert_array_equal(back.saturated, m.saturated)
    np.testing.assert_array_equal(back.under_range, m.under_range)
    assert back.integration_time == m.integration_time  # doubles, exactly
    assert back.t_start == m.t_start and back.n_frames == m.n_frames
    assert back.signal_unit == m.signal_unit
    assert back.camera.to_dict() == m.camera.to_dict()
    assert back.scene == m.scene


def test_channels_units_and_typed_attributes(tmp_path, measurement):
    path = write_exr(tmp_path / "m.exr", measurement)
    with OpenEXR.File(str(path)) as exr:
        header = dict(exr.header())  # the bindings clear it when the file closes
        channels = exr.channels()
        assert set(channels) == set(CHANNELS)
        assert all(ch.pixels.dtype == np.float32 for ch in channels.values())
    assert header["radiosim:unit:apparent_temperature"] == "K"
    assert header["radiosim:unit:signal_mean"] == "photons s-1 m-2 sr-1"
    assert header["radiosim:integration_time_s"].dtype == np.float64
    assert header["radiosim:camera_name"] == "nist-ir"
    assert header["radiosim:version"]
    assert "scene:chip_band_width_um" in header


def test_writing_is_atomic(tmp_path, measurement):
    path = write_exr(tmp_path / "m.exr", measurement)
    before = path.read_bytes()
    broken = dataclasses.replace(measurement, counts=np.zeros((3, 3)))  # wrong shape
    with pytest.raises(RadiosimError, match="cannot write"):
        write_exr(path, broken)
    assert path.read_bytes() == before  # the existing file is untouched
    assert [p.name for p in tmp_path.iterdir()] == ["m.exr"]  # no partial file left
    with pytest.raises(RadiosimError, match="does not exist"):
        write_exr(tmp_path / "missing" / "m.exr", measurement)


def test_reading_rejects_other_files(tmp_path):
    with OpenEXR.File({"type": OpenEXR.scanlineimage},
                      {"Y": np.ones((2, 2), np.float32)}) as exr:
        exr.write(str(tmp_path / "plain.exr"))
    with pytest.raises(RadiosimError, match="not a radiosim measurement"):
        read_exr(tmp_path / "plain.exr")
    (tmp_path / "junk.exr").write_bytes(b"junk")
    with pytest.raises(RadiosimError, match="cannot read EXR file"):
        read_exr(tmp_path / "junk.exr")


def test_a_recording_becomes_numbered_files(tmp_path):
    scene = SegmentedChip(dx=4e-6, dt=1e-6)
    camera = Camera.preset("nist-ir").replace(frame_rate=1e5)  # 10 µs apart
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RadiosimWarning)
        frames = record(camera, scene.crop((60, 120), (60, 150)), 2e-6, 3, rng=1)
    paths = write_exr_sequence(tmp_path / "rec", frames)
    assert [p.name for p in paths] == ["frame_0000.exr", "frame_0001.exr", "frame_0002.exr"]
    back = read_exr_sequence(tmp_path / "rec")
    assert [b.t_start for b in back] == pytest.approx([f.t_start for f in frames])
    assert back[2].t_start - back[0].t_start == pytest.approx(2e-5)
    # The band moves between frames: the recordings differ.
    assert not np.array_equal(back[0].tensor_mean, back[2].tensor_mean)


# -- edges: a full disk, a folder, a recording with a file removed ---------------------------------


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
    single_line(str(info.value), small_disk / "m.exr")
    assert sorted(p.name for p in small_disk.iterdir()) == ["filler"]


def test_read_exr_on_a_folder_says_it_is_a_folder(tmp_path):
    with pytest.raises(RadiosimError, match="is a folder, not an EXR file"):
        read_exr(tmp_path)


def test_a_written_exr_recording_with_a_file_removed_is_refused(tmp_path):
    from radiosim.io import read_exr_sequence, write_exr_sequence

    scene = FrameStack(np.full((4, 6, 6), 500.0), dt=1e-6, dx=1e-6)
    m = Camera.linear_ideal(3e-6).measure(scene, 1e-6, t_start=0.0)
    files = write_exr_sequence(tmp_path / "rec", [m, m, m, m])
    assert len(read_exr_sequence(tmp_path / "rec")) == 4
    files[2].unlink()
    with pytest.raises(RadiosimError) as info:
        read_exr_sequence(tmp_path / "rec")
    one_line_naming(info, "frame_0003.exr", "frame number 2 is missing", "frame_0001.exr")


def test_an_exr_write_the_library_left_incomplete_fails_and_keeps_the_earlier_file(
        tmp_path, monkeypatch):
    # A write the EXR library reports as done but left short (a full disk it did not report)
    # is caught by reading the file back before the rename: one line naming the file, and
    # the earlier file at that path byte for byte as it was.
    import OpenEXR

    from radiosim.io import write_exr
    from radiosim.scenes import FrameStack

    scene = FrameStack(np.full((2, 12, 12), 700.0), dt=1e-6, dx=1e-6)
    m = Camera.linear_ideal(2e-6).measure(scene, 2e-6, rng=0)
    path = write_exr(tmp_path / "m.exr", m)
    earlier = path.read_bytes()
    original = OpenEXR.File.write

    def short_write(self, filename):
        original(self, filename)
        with open(filename, "r+b") as handle:
            handle.truncate(len(earlier) // 2)

    monkeypatch.setattr(OpenEXR.File, "write", short_write)
    with pytest.raises(RadiosimIOError) as info:
        write_exr(path, m)
    single_line(str(info.value), path)
    assert path.read_bytes() == earlier
    assert sorted(p.name for p in tmp_path.iterdir()) == ["m.exr"]
