"""Sphinx configuration: tutorial, how-to guides and physics reference (Markdown), the
validation notebooks with their stored outputs (myst-nb, not re-executed), API from numpydoc
docstrings; the pydata theme.

The pages read the same offline: math is MathML written at build time (``_ext/mathml.py``, no
JavaScript from a CDN), the notebooks' Markdown outputs are GitHub-flavoured (their tables are
tables), and the build writes nothing into the source tree (myst-nb's ``jupyter_execute`` goes
under the build's doctree folder). ``pip install -e ".[docs]"`` installs what it needs.
"""

import datetime
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent / "_ext"))

project = "radiosim"
author = "radiosim developers"
copyright = f"2025–{datetime.date.today().year}, radiosim developers"
extensions = [
    "sphinx.ext.autodoc",
    "numpydoc",
    "myst_nb",
    "mathml",  # docs/_ext/mathml.py: LaTeX → MathML at build time
]
html_math_renderer = "mathml"
source_suffix = {".md": "myst-nb", ".rst": "restructuredtext", ".ipynb": "myst-nb"}
exclude_patterns = ["_build", "**.ipynb_checkpoints"]
nb_execution_mode = "off"  # the notebooks are committed with their outputs
nb_merge_streams = True
nb_render_markdown_format = "gfm"  # display(Markdown(...)) tables render as tables
myst_enable_extensions = ["dollarmath"]
myst_heading_anchors = 3
numpydoc_show_class_members = False  # autodoc lists the members
numpydoc_class_members_toctree = False
numpydoc_attributes_as_param_list = True
autodoc_member_order = "bysource"
autodoc_typehints = "none"
autodoc_default_options = {"members": True, "undoc-members": False}
templates_path = ["_templates"]
html_static_path = ["_static"]
html_theme = "pydata_sphinx_theme"
html_title = "radiosim"
html_theme_options = {"github_url": None, "navigation_with_keys": False,
                      "show_toc_level": 2, "show_nav_level": 2}
# The left sidebar holds the whole site's table of contents (the theme's default starts one
# level down, which for a flat site of pages leaves "Section Navigation" empty).
html_sidebars = {"**": ["site-nav"]}
suppress_warnings = ["myst.header"]


def _dataclass_fields() -> set:
    """(class name, field name) of radiosim's dataclasses: their Attributes sections document
    them, so autodoc does not list them a second time with their defaults."""
    import dataclasses
    import importlib
    import pkgutil

    import radiosim

    out = set()
    for info in pkgutil.walk_packages(radiosim.__path__, "radiosim."):
        module = importlib.import_module(info.name)
        for value in vars(module).values():
            if isinstance(value, type) and dataclasses.is_dataclass(value):
                out.update((value.__qualname__, f.name) for f in dataclasses.fields(value))
    return out


def _executed_notebooks_in_build(app):
    """myst-nb writes the notebooks' output files to ``jupyter_execute`` beside the HTML
    folder, which is ``docs/`` itself for ``sphinx-build docs docs/_build``: put them under
    the doctree folder (inside the build) instead."""
    folder = Path(app.doctreedir) / "jupyter_execute"
    app.env.mystnb_config = app.env.mystnb_config.copy(output_folder=str(folder))


def setup(app):
    app.connect("builder-inited", _executed_notebooks_in_build, priority=900)
    fields = _dataclass_fields()
    names = {name for _, name in fields}

    def skip(app, what, name, obj, would_skip, options):
        if name == "Region":  # a type alias (tuple[slice, slice]), described in its module
            return True
        if what == "class" and name in names and not callable(obj) and not isinstance(
                obj, property):
            return True
        return None

    app.connect("autodoc-skip-member", skip)
