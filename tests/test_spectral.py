"""Shipped spectral curves and the CSV reader."""

import numpy as np
import pytest

from radiosim.errors import RadiosimError
from radiosim.spectral import as_spectrum, available_spectra, read_spectrum, spectra_directory


def test_every_shipped_curve_states_its_provenance():
    names = available_spectra()
    assert {"filter_mwir_3.8-5.1um", "qe_insb_77K", "optics_mwir_lens",
            "emissivity_steel_clean", "emissivity_steel_oxidised"} <= set(names)
    for name in names:
        sd = read_spectrum(name)
        for key in ("quantity", "wavelength_unit", "source", "idealised"):
            assert sd.metadata[key], (name, key)
        assert sd.metadata["idealised"].startswith("yes")
        assert np.all((sd.values >= 0) & (sd.values <= 1))
        assert 1e-7 < sd.domain[0] < sd.domain[-1] < 1e-4  # metres


def test_curves_are_zero_outside_their_range():
    sd = read_spectrum("optics_mwir_lens")
    lo, hi = sd.domain[0], sd.domain[-1]
    assert sd[np.array([0.5 * lo, 2 * hi])].tolist() == [0.0, 0.0]
    assert sd[lo] > 0
    assert np.all(sd[np.linspace(3.8e-6, 5.1e-6, 27)] > 0.93)  # AR-coated in its band


def test_filter_half_power_points_and_insb_cutoff():
    flt = read_spectrum("filter_mwir_3.8-5.1um")
    peak = flt.values.max()
    assert flt[3.8e-6] == pytest.approx(peak / 2, rel=1e-6)
    assert flt[5.1e-6] == pytest.approx(peak / 2, rel=1e-6)
    qe = read_spectrum("qe_insb_77K")
    inband = qe[np.linspace(1.0e-6, 5.0e-6, 50)]
    assert np.all((inband > 0.8) & (inband <= 0.9))
    assert qe[5.30e-6] == 0.0 and qe[5.2e-6] > 0.5  # cut-off hc/Eg = 5.30 µm


def test_user_csv_in_nanometres(tmp_path):
    path = tmp_path / "mine.csv"
    path.write_text("# quantity: transmission\n# wavelength_unit: nm\n# source: lab\n"
                    "# idealised: no\nwl_nm,t\n4000,0.5\n4500,0.7\n")
    sd = read_spectrum(path)
    assert sd[4.25e-6] == pytest.approx(0.6)
    assert sd.name == "mine"


@pytest.mark.parametrize("body, message", [
    ("# quantity: t\n# wavelength_unit: um\n# source: x\n# idealised: no\nw,v\n4,0.5\n4.5,abc\n",
     "line 7"),
    ("# quantity: t\n# source: x\n# idealised: no\nw,v\n4,0.5\n4.5,0.6\n", "wavelength_unit"),
    ("# quantity: t\n# wavelength_unit: furlong\n# source: x\n# idealised: no\nw,v\n4,0.5\n5,1\n",
     "furlong"),
    ("# quantity: t\n# wavelength_unit: um\n# source: x\n# idealised: no\nw,v\n4,0.5\n5,1.5\n",
     r"\[0, 1\]"),
    ("# quantity: t\n# wavelength_unit: um\n# source: x\n# idealised: no\nw,v\n5,0.5\n4,1\n",
     "increasing"),
    ("# quantity: t\n# wavelength_unit: um\n# source: x\n# idealised: no\nw,v\n4,0.5\n", "two"),
])
def test_broken_csv_is_named(tmp_path, body, message):
    path = tmp_path / "broken.csv"
    path.write_text(body)
    with pytest.raises(RadiosimError, match=message) as info:
        read_spectrum(path)
    assert "broken.csv" in str(info.value)


def test_unknown_name_and_bad_scalars():
    with pytest.raises(RadiosimError, match="unknown spectrum"):
        read_spectrum("unobtainium")
    with pytest.raises(RadiosimError, match=r"\[0, 1\]"):
        as_spectrum(1.2, "emissivity")
    with pytest.raises(RadiosimError, match="emissivity"):
        as_spectrum([0.1, 0.2], "emissivity")
    assert spectra_directory().is_dir()
