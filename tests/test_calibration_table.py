"""The calibration table read by ``radiosim calibrate`` (radiosim.calibration_table): its columns,
units and values checked against each other, and the points the fit cannot use named. Expected
counts are written out from the EMVA 1288 linear model (see conftest.py)."""

import numpy as np
import pytest

from conftest import counts_table, one_line_message, true_camera, write_file
from radiosim import Camera
from radiosim.calibration_table import calibrate_from_table, read_calibration_table
from radiosim.errors import RadiosimError, RadiosimWarning


@pytest.fixture(scope="module")
def nist():
    return Camera.preset("nist-ir")


def test_a_table_in_both_units_that_disagree_is_refused(tmp_path):
    path = write_file(tmp_path, "temperature_K,temperature_C,counts\n400,126.85,1100\n"
                  "500,300,1200\n600,326.85,1300\n")
    with pytest.raises(RadiosimError) as info:
        read_calibration_table(path)
    message = one_line_message(info)
    assert str(path) in message and "temperature_K" in message and "temperature_C" in message
    assert "line 3" in message


def test_a_table_in_both_units_that_agree_is_read(tmp_path):
    path = write_file(tmp_path, "temperature_K,temperature_C,counts\n400,126.85,1100\n"
                  "500,226.85,1200\n")
    table = read_calibration_table(path)
    np.testing.assert_allclose(table.temperature, [400.0, 500.0])


def test_a_duplicate_column_is_refused(tmp_path):
    path = write_file(tmp_path, "temperature_K,counts,counts\n400,1100,1\n500,1200,2\n")
    with pytest.raises(RadiosimError, match="column counts appears 2 times"):
        read_calibration_table(path)


def test_a_units_line_contradicting_the_column_is_refused(tmp_path):
    path = write_file(tmp_path, "# units: temperature=C\ntemperature_K,counts\n400,1100\n")
    with pytest.raises(RadiosimError, match="temperature_K") as info:
        read_calibration_table(path)
    assert "temperature=C" in one_line_message(info)


def test_counts_not_monotonic_in_temperature_are_refused(tmp_path):
    path = write_file(tmp_path, "temperature_K,counts\n400,1100\n500,1050\n600,1300\n")
    with pytest.raises(RadiosimError, match="column counts is not monotonic") as info:
        read_calibration_table(path)
    assert "line 3" in one_line_message(info)


def test_a_value_that_is_not_a_number_names_line_and_column(tmp_path):
    path = write_file(tmp_path, "temperature_K,counts\n400,1100\n500,n/a\n")
    with pytest.raises(RadiosimError, match="line 3, column counts = 'n/a'"):
        read_calibration_table(path)


def test_a_table_with_a_byte_order_mark_is_read(tmp_path):
    path = write_file(tmp_path, "temperature_C,counts\n100,1100\n200,1200\n", encoding="utf-8-sig")
    table = read_calibration_table(path)
    np.testing.assert_allclose(table.temperature, [373.15, 473.15])


@pytest.mark.parametrize("frames", [0, -1, 2.5])
def test_calibrate_frames_are_checked_before_the_table_is_read(nist, tmp_path, frames):
    with pytest.raises(RadiosimError, match="frames") as info:
        calibrate_from_table(nist, tmp_path / "missing.csv", 1e-5, frames=frames)
    one_line_message(info)


def test_calibrate_from_table_names_the_file_and_the_points(nist, tmp_path):
    true = true_camera(nist)
    temperatures = [350.0, 450.0, 550.0, 650.0]
    counts = list(counts_table(true, temperatures, 1e-5)) + [16383.0]
    rows = "".join(f"{t},{float(c)!r}\n" for t, c in zip(temperatures + [3000.0], counts))
    path = write_file(tmp_path, "temperature_K,counts\n" + rows)
    with pytest.raises(RadiosimError) as info:
        calibrate_from_table(true, path, 1e-5)
    message = one_line_message(info)
    assert str(path) in message and "3000 K (16383 DN)" in message
    with pytest.warns(RadiosimWarning, match="3000 K"):
        fitted, residuals, table = calibrate_from_table(true, path, 1e-5, exclude_unusable=True)
    assert fitted.electronics.gain == pytest.approx(true.electronics.gain, rel=1e-6)


def test_a_header_of_many_columns_is_read_in_one_pass(tmp_path):
    # 400 000 distinct column names on one line (4 MB): the duplicate-column check counts them
    # in one pass (it compared every name with every other before: 1.6e11 comparisons, a hang),
    # and the table is refused for what it lacks, naming the file. Run in a process of its own
    # with a time limit far above a linear scan's, so a quadratic one fails instead of hanging.
    import subprocess
    import sys

    path = tmp_path / "wide.csv"
    path.write_text(",".join(f"c{k}" for k in range(400_000)) + "\n1\n")
    code = ("import sys; from radiosim.calibration_table import read_calibration_table\n"
            "try:\n    read_calibration_table(sys.argv[1])\n"
            "except Exception as exc:\n    print(type(exc).__name__, exc)\n")
    done = subprocess.run([sys.executable, "-c", code, str(path)], capture_output=True,
                          text=True, timeout=120)
    assert done.stdout.startswith("RadiosimError") and "wide.csv" in done.stdout, done.stdout


def test_a_dip_within_the_counts_noise_is_fitted_and_one_beyond_it_refused(tmp_path):
    # The command and fit_calibration agree: counts dipping 0.3 DN as the temperature rises
    # (inside one frame's temporal noise) are no contradiction and fit; a 50 DN drop is
    # refused naming the file, by the fit's noise-aware check.
    camera = Camera.preset("nist-ir")  # its noise: about 1 DN per frame at 450 K
    temperatures = np.array([450.0, 450.02, 500.0, 550.0, 600.0])
    counts = counts_table(camera, temperatures, 100e-6)
    counts[1] = counts[0] - 0.3  # the dip
    rows = "".join(f"{t:g},{c:.4f}\n" for t, c in zip(temperatures, counts))
    fitted, _, _ = calibrate_from_table(camera, write_file(tmp_path, "temperature_K,counts\n"
                                                           + rows), 100e-6)
    assert fitted.electronics.gain > 0
    counts[1] = counts[0] - 50.0
    rows = "".join(f"{t:g},{c:.4f}\n" for t, c in zip(temperatures, counts))
    path = write_file(tmp_path, "temperature_K,counts\n" + rows, name="drop.csv")
    with pytest.raises(RadiosimError, match="counts fall as the temperature rises") as info:
        calibrate_from_table(camera, path, 100e-6)
    assert str(path) in one_line_message(info)


# -- a camera of several channels: a table per channel (issue 40) ----------------------------------


def _channel_tables(folder, scales):
    """Tables of two-colour's channels at 100 µs, channel k's counts × a + b (its gain × a,
    its offset × a + b): the fit must find those, channel by channel."""
    from radiosim import Camera

    camera = Camera.preset("two-colour")
    t = np.linspace(500.0, 900.0, 6)  # [K]
    paths = []
    for k, (own, (a, b)) in enumerate(zip(camera.channel_cameras, scales)):
        counts = own.calibration(100e-6).counts(t) * a + b
        path = folder / f"channel{k + 1}.csv"
        path.write_text("temperature_K,counts\n"
                        + "".join(f"{x},{c}\n" for x, c in zip(t, counts)))
        paths.append(path)
    return camera, paths


def test_a_two_colour_camera_is_calibrated_with_a_table_per_channel(tmp_path, capsys):
    import tomllib

    from radiosim import Camera
    from radiosim.cli import main

    scales = [(1.03, 20.0), (0.97, -10.0)]
    camera, paths = _channel_tables(tmp_path, scales)
    out = tmp_path / "fitted.toml"
    assert main(["calibrate", *map(str, paths), "--camera", "two-colour", "--integration-time",
                 "100us", "--out", str(out), "-q"]) == 0
    printed = capsys.readouterr().out
    assert "two-colour channel 1 fitted to channel1.csv" in printed
    assert "two-colour channel 2 fitted to channel2.csv" in printed
    fitted = Camera.from_toml(out)
    for own, (a, b) in zip(fitted.channel_cameras, scales):
        el = camera.electronics
        assert own.electronics.gain == pytest.approx(a * el.gain, rel=1e-6)
        assert own.electronics.offset == pytest.approx(a * el.offset + b, abs=1e-3)
    text = out.read_text(encoding="utf-8")
    assert "channel 1: fitted to" in text and "channel 2: fitted to" in text
    assert tomllib.loads(text)["channels"][0]["band_um"] == [3.8, 4.2]


def test_a_two_colour_camera_given_one_table_is_refused_naming_the_missing_channel(tmp_path,
                                                                                   capsys):
    from radiosim.cli import main

    _, paths = _channel_tables(tmp_path, [(1.0, 0.0), (1.0, 0.0)])
    code = main(["calibrate", str(paths[0]), "--camera", "two-colour", "--integration-time",
                 "100us"])
    captured = capsys.readouterr()
    assert code == 2 and captured.out == "", captured
    (line,) = captured.err.strip().splitlines()
    assert "one calibration table per channel" in line and "channel 2 (4.6–5.1 µm)" in line
    code = main(["calibrate", *map(str, paths), "--camera", "nist-ir", "--integration-time",
                 "100us"])
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and "nist-ir has one band" in line and "got 2" in line
