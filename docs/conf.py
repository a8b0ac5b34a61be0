"""Sphinx configuration of the actuator-design documentation.

Build (from the repository root, after ``pip install '.[docs]'``)::

    python -m sphinx -W --keep-going -b html docs docs/_build/html

Every gallery example in ``examples/`` is executed during the build; an example that raises, or
any Sphinx warning, fails the build. The command pages are generated from the CLI's own ``--help``
text at build time, so they cannot drift from the tool.
"""
from __future__ import annotations

import os
import sys
from pathlib import Path

os.environ.setdefault("MPLBACKEND", "Agg")
HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(ROOT))

import actuator_design  # noqa: E402

project = "actuator-design"
author = "the actuator-design developers"
copyright = "2026, the actuator-design developers"
version = release = actuator_design.__version__

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "sphinx.ext.viewcode",
    "numpydoc",
    "myst_parser",
    "sphinx_gallery.gen_gallery",
]
source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
exclude_patterns = ["_build", "**.ipynb_checkpoints", "auto_examples/*.ipynb", "auto_examples/*.py",
                    "auto_examples/*.zip", "auto_examples/*.json", "auto_examples/*.md5"]
myst_enable_extensions = ["dollarmath", "amsmath"]
myst_heading_anchors = 3
suppress_warnings = ["myst.header"]  # THEORY.md numbers its own sections

autosummary_generate = True
autodoc_default_options = {"members": False}
numpydoc_show_class_members = False
numpydoc_validation_checks: set = set()
numpydoc_xref_param_type = False

smartquotes = False  # "--resume" stays two hyphens, as the CLI spells it
html_theme = "alabaster"
html_title = f"actuator-design {release}"
html_static_path: list = []

sphinx_gallery_conf = {
    "examples_dirs": str(ROOT / "examples"),
    "gallery_dirs": "auto_examples",
    "filename_pattern": r"/plot_",
    "abort_on_example_error": True,
    "only_warn_on_example_error": False,
    "download_all_examples": False,
    "within_subsection_order": "FileNameSortKey",
    "reset_modules": ("matplotlib",),
    "show_memory": False,
}


def _command_pages(app) -> None:
    """Write ``docs/commands/<command>.rst`` from each command's ``--help`` (module docstring and
    arguments), before Sphinx reads the sources."""
    from actuator_design.cli.main import COMMANDS, build_parser

    out = HERE / "commands"
    out.mkdir(exist_ok=True)
    names = []
    for module in COMMANDS:
        command = module.rstrip("_").replace("_", "-")
        parser = build_parser(only=command)
        sub = next(a for a in parser._actions if a.__class__.__name__ == "_SubParsersAction")
        text = sub.choices[command].format_help()
        title = f"``actuator-design {command}``"
        body = "\n".join("    " + ln if ln.strip() else "" for ln in text.splitlines())
        page = (f"{title}\n{'=' * len(title)}\n\n"
                f".. This page is generated from ``actuator-design {command} --help`` by docs/conf.py.\n\n"
                f"What ``actuator-design {command} --help`` prints:\n\n.. code-block:: text\n\n{body}\n")
        path = out / f"{command}.rst"
        if not path.exists() or path.read_text() != page:
            path.write_text(page)
        names.append(command)
    top = build_parser().format_help()
    exits = top[top.index("Exit codes"):].split()  # as the top-level --help states them
    index = ("Commands\n========\n\nOne page per command of the CLI, each its own ``--help``. "
             + " ".join(exits) + "\n\n.. toctree::\n   :maxdepth: 1\n\n"
             + "".join(f"   {n}\n" for n in names))
    if not (out / "index.rst").exists() or (out / "index.rst").read_text() != index:
        (out / "index.rst").write_text(index)


def _escape_bars(app, what, name, obj, options, lines) -> None:
    """The docstrings write absolute values as |x| (THEORY's notation); reST would read them as
    substitution references, so each bar is escaped before numpydoc and docutils see it."""
    for i, line in enumerate(lines):
        if "|" in line:
            lines[i] = line.replace("\\|", "|").replace("|", "\\|")


def setup(app):
    app.connect("builder-inited", _command_pages)
    app.connect("autodoc-process-docstring", _escape_bars, priority=400)
