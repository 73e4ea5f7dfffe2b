"""Measurement, study summaries and the paper's Column I summary, on hand-built measurements.

Every measurement here is constructed directly from small arrays whose answers are known by
construction, so the expected numbers are written in the test, not computed by the package.
"""

import math
import re

import numpy as np
import pytest

from radiosim import Camera
from radiosim.errors import RadiosimError
from radiosim.measurement import Measurement
from radiosim.paper import column_index, column_summary
from radiosim.scenes import SegmentedChip
from radiosim.study import summarise

OFFSET = 273.15  # 0 °C in kelvin, written out: the expected values must not share the code's


@pytest.fixture(scope="module")
def camera():
    return Camera.linear_ideal(6e-6)


def make(camera, apparent, tensor_max, tensor_std=None, saturated=None, under_range=None,
         integration_time=10e-6, t_start=0.0):
    """A measurement from arrays; flagged pixels get NaN as Calibration.read gives them."""
    apparent = np.array(apparent, dtype=float)
    shape = apparent.shape
    saturated = np.zeros(shape, bool) if saturated is None else np.array(saturated, bool)
    under_range = np.zeros(shape, bool) if under_range is None else np.array(under_range, bool)
    apparent = np.where(saturated | under_range, np.nan, apparent)
    tensor_max = np.array(tensor_max, dtype=float)
    tensor_std = np.zeros(shape) if tensor_std is None else np.array(tensor_std, dtype=float)
    return Measurement(
        apparent_temperature=apparent, counts=np.zeros(shape), electrons=np.zeros(shape),
        saturated=saturated, under_range=under_range, tensor_max=tensor_max,
        tensor_mean=tensor_max - 1.0, tensor_std=tensor_std, signal_mean=np.zeros(shape),
        signal_unit="K", camera=camera, integration_time=integration_time, t_start=t_start,
        n_frames=3, scene={"type": "hand-built"},
    )


# -- Measurement ----------------------------------------------------------------------------


def test_peak_error_is_tensor_max_minus_apparent(camera):
    m = make(camera, [[900.0, 1000.0, 1100.0]], [[1000.0, 1000.0, 1000.0]],
             saturated=[[False, False, False]])
    # Reading low (900 for 1000) is a positive error; reading high a negative one.
    np.testing.assert_array_equal(m.peak_error, [[100.0, 0.0, -100.0]])


def test_peak_error_is_nan_where_flagged(camera):
    m = make(camera, [[900.0, 950.0]], [[1000.0, 1000.0]], saturated=[[False, True]])
    assert m.peak_error[0, 0] == 100.0 and math.isnan(m.peak_error[0, 1])


def test_valid_and_saturated_fraction(camera):
    saturated = [[True, False, False, False], [True, True, False, False]]
    under = [[False, False, True, False], [False, False, False, False]]
    m = make(camera, np.full((2, 4), 500.0), np.full((2, 4), 500.0), saturated=saturated,
             under_range=under)
    np.testing.assert_array_equal(m.valid, [[False, True, False, True],
                                            [False, False, True, True]])
    assert m.saturated_fraction == 3 / 8
    assert isinstance(m.saturated_fraction, float)


def test_t_stop_is_start_plus_integration(camera):
    m = make(camera, [[500.0]], [[500.0]], integration_time=0.25, t_start=0.5)
    assert m.t_stop == 0.75  # exact in binary
    m = make(camera, [[500.0]], [[500.0]], integration_time=10e-6, t_start=3e-6)
    assert m.t_stop == pytest.approx(13e-6, rel=1e-15)


def test_repr_is_short_and_names_camera_and_shape(camera):
    # Arrays large enough that printing any of them would blow the budget.
    shape = (30, 40)
    m = make(camera, np.full(shape, 777.0), np.full(shape, 800.0))
    text = repr(m)
    assert len(text) < 300
    assert "linear-ideal" in text
    assert "30 × 40" in text
    assert "777.0" in text  # the reading range is stated


def test_repr_without_valid_pixels(camera):
    m = make(camera, [[1.0, 2.0]], [[3.0, 4.0]], under_range=[[True, True]])
    text = repr(m)
    assert len(text) < 300 and "no valid pixel" in text and "2 under range" in text


# -- the one table of fields and units -----------------------------------------------------

#: The EXR channels and the units their header states, as radiosim has always written them.
EXR_CHANNELS = {"apparent_temperature": "K", "counts": "DN", "electrons": "e-",
                "saturated": "1", "under_range": "1", "over_range": "1", "peak_error": "K",
                "uncertainty": "K", "tensor_max": "K", "tensor_mean": "K", "signal_mean": None}


def test_one_table_of_fields_feeds_the_measurement_exr_and_netcdf(camera):
    import radiosim.io.exr as exr
    from radiosim.measurement import FIELDS, field_attributes

    assert list(Measurement.ARRAYS) == [  # the NetCDF variables, in this order
        "apparent_temperature", "counts", "electrons", "saturated", "under_range",
        "over_range", "tensor_max", "tensor_mean", "tensor_std", "signal_mean"]
    assert exr.CHANNELS == EXR_CHANNELS and list(exr.CHANNELS) == list(EXR_CHANNELS)
    assert Measurement.UNITS["counts"] == "DN" and Measurement.UNITS["t_start"] == "s"
    for f in FIELDS:  # every field is something a measurement has
        assert hasattr(make(camera, [[1.0]], [[1.0]]), f.name), f.name
    udunits = {"K", "1", "s"}
    assert {f.udunits for f in FIELDS if f.udunits is not None} <= udunits
    assert field_attributes("electrons") == {
        "units": "1", "long_name": "charge in the well at the end of integration (electrons)"}
    flag = field_attributes("over_range")
    assert flag["standard_name"] == "status_flag" and "units" not in flag
    assert flag["flag_values"].tolist() == [0, 1]
    assert flag["flag_meanings"] == "not_over_range over_range"
    with pytest.raises(RadiosimError, match="'volts' is not a field"):
        field_attributes("volts")
    # The EXR module's table of channels says the same units as the header.
    for name, unit in EXR_CHANNELS.items():
        assert re.search(rf"``{name}``\s+.*\[{re.escape(unit or '``radiosim:signal_unit``')}\]",
                         exr.__doc__), name


def test_to_xarray_carries_the_cf_attributes_of_the_table(camera):
    m = make(camera, [[500.0, 600.0]], [[510.0, 620.0]], saturated=[[False, True]])
    ds = m.to_xarray(history="made by hand")
    assert ds.attrs["Conventions"] == "CF-1.8" and ds.attrs["history"].endswith("made by hand")
    assert ds.attrs["title"] == "radiosim measurement: camera linear-ideal, 1e-05 s from 0 s"
    assert ds.apparent_temperature.attrs["units"] == "K"
    assert ds.counts.attrs["units"] == "1" and ds.signal_mean.attrs["units"] == "K"
    assert ds.saturated.dtype == bool and ds.saturated.values.tolist() == [[False, True]]
    assert "units" not in ds.saturated.attrs
    assert ds.attrs["scene_type"] == "hand-built" and ds.x.attrs["long_name"]


# -- study.summarise -----------------------------------------------------------------------


def test_summarise_picks_the_highest_valid_reading(camera):
    apparent = [[600.0, 950.0, 700.0],
                [980.0, 940.0, 610.0]]
    # The highest *finite* reading would be 990 at (1, 2), but that pixel is saturated.
    apparent[1][2] = 990.0
    tensor_max = [[650.0, 1005.0, 720.0],
                  [1000.0, 1010.0, 1020.0]]
    # The field-wide largest std (40 K) is elsewhere than the pixel of the highest reading.
    tensor_std = [[40.0, 3.0, 1.0],
                  [7.5, 2.0, 30.0]]
    saturated = [[False, False, False], [False, False, True]]
    m = make(camera, apparent, tensor_max, tensor_std, saturated=saturated)
    out = summarise(m)
    # Highest valid reading: 980 K at (1, 0).
    assert out["peak_C"] == pytest.approx(980.0 - OFFSET, abs=1e-12)
    # Bias against the scene's peak over the whole field (1020 K, at the saturated pixel):
    # reading − truth, negative when reading low.
    assert out["peak_bias_K"] == pytest.approx(980.0 - 1020.0, abs=1e-12)
    assert out["peak_bias_K"] < 0
    assert out["peak_scene_C"] == pytest.approx(1020.0 - OFFSET, abs=1e-12)
    # Tensor std at the pixel of the highest reading, not the field maximum (40 K).
    assert out["peak_uncertainty_K"] == 7.5
    assert out["saturated_fraction"] == pytest.approx(1 / 6)
    assert out["under_range_fraction"] == 0.0


def test_summarise_bias_is_positive_when_reading_high(camera):
    m = make(camera, [[1050.0, 900.0]], [[1000.0, 1000.0]], [[2.0, 9.0]])
    out = summarise(m)
    assert out["peak_bias_K"] == pytest.approx(50.0, abs=1e-12)
    assert out["peak_uncertainty_K"] == 2.0


def test_summarise_without_valid_pixels_is_nan(camera):
    m = make(camera, [[900.0, 950.0]], [[1000.0, 1100.0]], [[1.0, 2.0]],
             saturated=[[True, False]], under_range=[[False, True]])
    out = summarise(m)
    assert math.isnan(out["peak_C"])
    assert math.isnan(out["peak_bias_K"])
    assert math.isnan(out["peak_uncertainty_K"])
    # The scene truth is still known.
    assert out["peak_scene_C"] == pytest.approx(1100.0 - OFFSET, abs=1e-12)
    assert out["saturated_fraction"] == 0.5 and out["under_range_fraction"] == 0.5


# -- paper.column_summary ------------------------------------------------------------------


@pytest.fixture(scope="module")
def chip():
    return SegmentedChip(dx=4e-6, dt=1e-6)


def test_column_summary_reads_column_I(camera, chip):
    column = column_index(chip, 6e-6)
    # Written out: Column I crosses the shear plane L0 440 µm from the rake face; the shear
    # angle is φ = atan(r cos α / (1 − r sin α)) (r = 0.55, α = −7°), the tool a right-angle
    # wedge (γ = 7°), so x = x_tip − 440 µm · cos φ / cos(φ + γ) ≈ 227 µm: pixel column 37.
    p = chip.params
    phi = math.atan(p.chip_ratio * math.cos(p.rake_angle)
                    / (1 - p.chip_ratio * math.sin(p.rake_angle)))
    x = p.tool_tip_x - 440e-6 * math.cos(phi) / math.cos(phi + p.clearance_angle)
    assert column == math.floor(x / 6e-6) == 37
    rows, cols = 4, column + 3
    apparent = np.full((rows, cols), 700.0)
    tensor_max = np.full((rows, cols), 750.0)
    tensor_std = np.full((rows, cols), 1.0)
    # Decoys: hotter readings, a hotter scene and a larger std in the neighbouring columns.
    apparent[:, column - 1] = apparent[:, column + 1] = 1200.0
    tensor_max[:, column + 1] = 1300.0
    tensor_std[:, column - 1] = 99.0
    # Column I itself: the highest valid reading is 905 K in row 1 (row 3 reads higher but
    # is saturated); its scene peak is 960 K (row 3); the std at row 1 is 6.5 K, at row 0 20 K.
    apparent[:, column] = [880.0, 905.0, 890.0, 999.0]
    tensor_max[:, column] = [900.0, 930.0, 920.0, 960.0]
    tensor_std[:, column] = [20.0, 6.5, 3.0, 4.0]
    saturated = np.zeros((rows, cols), bool)
    saturated[3, column] = True
    m = make(camera, apparent, tensor_max, tensor_std, saturated=saturated)
    out = column_summary(m, chip)
    assert out["column_I_C"] == pytest.approx(905.0 - OFFSET, abs=1e-12)
    assert out["column_I_scene_C"] == pytest.approx(960.0 - OFFSET, abs=1e-12)
    assert out["column_I_bias_K"] == pytest.approx(905.0 - 960.0, abs=1e-12)
    assert out["column_I_uncertainty_K"] == 6.5


def test_column_summary_without_valid_pixels_in_the_column(camera, chip):
    column = column_index(chip, 6e-6)
    apparent = np.full((2, column + 1), 800.0)
    under = np.zeros(apparent.shape, bool)
    under[:, column] = True
    tensor_max = np.full(apparent.shape, 820.0)
    tensor_max[0, column] = 850.0
    out = column_summary(make(camera, apparent, tensor_max, under_range=under), chip)
    assert out == {"column_I_scene_C": pytest.approx(850.0 - OFFSET, abs=1e-12)}


def test_column_summary_is_empty_when_the_column_is_not_measured(camera, chip):
    column = column_index(chip, 6e-6)
    m = make(camera, np.full((2, column), 800.0), np.full((2, column), 820.0))
    assert column_summary(m, chip) == {}
    assert column_summary(m, None) == {}
