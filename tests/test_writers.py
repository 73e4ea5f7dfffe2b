"""Output formats by name (radiosim.io.writers): each writes what its reader reads back."""

import numpy as np
import pytest

import radiosim as rs
from radiosim.cli import main
from radiosim.errors import RadiosimError
from radiosim.io import read_exr, read_netcdf
from radiosim.io.writers import (MEASUREMENT_WRITERS, RESULTS_FORMATS, measurement_writer,
                                 write_measurement)


def _measurement():
    scene = rs.FrameStack(np.linspace(400.0, 900.0, 3 * 12 * 12).reshape(3, 12, 12),
                          dt=1e-6, dx=1e-6)
    return rs.Camera.preset("nist-ir").with_pixel_pitch(3e-6).measure(scene, 2e-6, 0.0, rng=1)


@pytest.mark.parametrize("suffix, read", [(".exr", read_exr), (".nc", read_netcdf)])
def test_each_measurement_writer_round_trips_through_its_reader(tmp_path, suffix, read):
    m = _measurement()
    path = write_measurement(tmp_path / f"m{suffix.upper()}", m)  # the suffix in any case
    back = read(path)
    np.testing.assert_array_equal(back.counts, m.counts)
    np.testing.assert_allclose(back.apparent_temperature, m.apparent_temperature, rtol=1e-6)
    assert measurement_writer(path) is MEASUREMENT_WRITERS[suffix]


def test_an_unknown_suffix_is_refused_naming_the_ones_there_are(tmp_path):
    with pytest.raises(RadiosimError, match=r"m\.tif: no measurement format .*\.exr, \.nc"):
        write_measurement(tmp_path / "m.tif", _measurement())
    assert not (tmp_path / "m.tif").exists()


def test_the_command_offers_the_registered_formats(tmp_path, monkeypatch, capsys):
    # radiosim measure writes any registered suffix (here NetCDF), and refuses others naming
    # them; radiosim run's --format choices are the registry's.
    monkeypatch.chdir(tmp_path)
    np.save(tmp_path / "frames.npy", np.full((20, 24, 24), 500.0))
    args = ["measure", "frames.npy", "--camera", "linear-ideal", "--pixel-pitch", "3um",
            "--integration-time", "2us", "--dt", "1us", "--dx", "1um", "--units", "K"]
    assert main([*args, "--out", "m.nc"]) == 0
    assert read_netcdf(tmp_path / "m.nc").counts.shape == (8, 8)
    assert main([*args, "--out", "m.png"]) == 2
    assert "give a path ending in .exr or .nc" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["run", "--help"])
    out = capsys.readouterr().out
    assert all(name in out for name in RESULTS_FORMATS)
