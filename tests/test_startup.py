"""Importing radiosim is cheap and changes nothing in the process (issue: instant start-up)."""

import json
import subprocess
import sys

PROBE = """
import json, os, sys
import numpy as np
before_env, before_print = dict(os.environ), np.get_printoptions()
import radiosim
after_import = (dict(os.environ) == before_env, np.get_printoptions() == before_print,
                sorted(m for m in ("colour", "matplotlib", "scipy.signal", "pandas", "numba",
                                   "dask", "xarray") if m in sys.modules))
camera = radiosim.Camera.preset("nist-ir")  # builds spectral curves: imports colour-science
after_curves = (np.get_printoptions() == before_print, "colour" in sys.modules)
print(json.dumps({"import": after_import, "curves": after_curves}))
"""


def _probe():
    out = subprocess.run([sys.executable, "-c", PROBE], capture_output=True, text=True,
                         check=True)
    return json.loads(out.stdout)


def test_import_leaves_environment_and_print_options_and_loads_nothing_heavy():
    result = _probe()
    same_env, same_print, heavy = result["import"]
    assert same_env, "import radiosim changed os.environ"
    assert same_print, "import radiosim changed numpy's print options"
    assert heavy == [], f"import radiosim loaded {heavy}"


def test_building_a_curve_imports_colour_and_restores_print_options():
    same_print, colour_loaded = _probe()["curves"]
    assert colour_loaded  # the probe really went through colour-science's import
    assert same_print, "colour-science's import left numpy's print options changed"
