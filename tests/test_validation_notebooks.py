"""The validation notebooks run top to bottom (reduced settings) and state a conclusion."""

import sys
import tempfile
from pathlib import Path

import nbformat
import pytest

VALIDATION = Path(__file__).resolve().parent.parent / "validation"
sys.path.insert(0, str(VALIDATION))
from run_notebooks import NOTEBOOKS, conclusion_of, execute, stated_conclusion  # noqa: E402


def test_there_are_nine_notebooks():
    assert [p.name for p in NOTEBOOKS] == ["01_paper_reproduction.ipynb",
                                           "02_linear_vs_planck.ipynb",
                                           "03_radiometry_checks.ipynb",
                                           "04_optics_and_background.ipynb",
                                           "05_real_fpa.ipynb",
                                           "06_uncertainty_budget.ipynb",
                                           "07_two_colour.ipynb",
                                           "08_real_recording.ipynb",
                                           "09_correction.ipynb"]


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.stem)
def test_notebook_runs_and_states_its_conclusion(path, tmp_path):
    committed = nbformat.read(path, as_version=4)
    first = committed.cells[0]
    assert first.cell_type == "markdown" and "**Conclusion.**" in first.source
    assert "CONCLUSION_" not in first.source
    # Committed with outputs, so they read without running.
    assert any(cell.get("outputs") for cell in committed.cells if cell.cell_type == "code")
    # The stated conclusion is the one the conclusion cell computed (no number typed by hand).
    assert stated_conclusion(committed) == conclusion_of(committed)
    system_tmp = Path(tempfile.gettempdir())
    before = set(system_tmp.glob("radiosim-*"))
    executed = nbformat.read(execute(path, reduced=True, out=tmp_path), as_version=4)
    # What the notebook wrote in temporary folders is inside the folder named, not left in
    # the system's (two of them write their results there).
    assert not set(system_tmp.glob("radiosim-*")) - before
    errors = [o for cell in executed.cells if cell.cell_type == "code"
              for o in cell.outputs if o.output_type == "error"]
    assert not errors  # the conclusion cell asserts the conclusion's claims on this run too
    assert conclusion_of(executed).startswith("**Conclusion.**")
    images = sum("image/png" in o.get("data", {}) for cell in executed.cells
                 if cell.cell_type == "code" for o in cell.outputs)
    assert images >= 2
