"""Sphinx configuration: tutorial, how-to guides and physics reference (Markdown), the
validation notebooks with their stored outputs (myst-nb, not re-executed), API from numpydoc
docstrings; the pydata theme."""

import datetime

project = "radiosim"
author = "radiosim developers"
copyright = f"2025–{datetime.date.today().year}, radiosim developers"
extensions = [
    "sphinx.ext.autodoc",
    "numpydoc",
    "sphinx.ext.mathjax",
    "myst_nb",
]
source_suffix = {".md": "myst-nb", ".rst": "restructuredtext", ".ipynb": "myst-nb"}
exclude_patterns = ["_build", "**.ipynb_checkpoints"]
nb_execution_mode = "off"  # the notebooks are committed with their outputs
nb_merge_streams = True
myst_enable_extensions = ["dollarmath"]
myst_heading_anchors = 3
numpydoc_show_class_members = False  # autodoc lists the members
numpydoc_class_members_toctree = False
numpydoc_attributes_as_param_list = True
autodoc_member_order = "bysource"
autodoc_typehints = "none"
autodoc_default_options = {"members": True, "undoc-members": False}
html_theme = "pydata_sphinx_theme"
html_title = "radiosim"
html_theme_options = {"github_url": None, "navigation_with_keys": False,
                      "show_toc_level": 2}
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


def setup(app):
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
