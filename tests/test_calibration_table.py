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
