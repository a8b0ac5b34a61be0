"""The documentation site (issue 21 item 1): its sources are sound without Sphinx, and, marked
slow (the CI builds the docs itself, .ci/run), the whole site builds from scratch with every
gallery example executed and no warning."""
import ast
import filecmp
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS, EXAMPLES = ROOT / "docs", ROOT / "examples"


def test_the_theory_page_is_the_projects_theory():
    shared = ROOT.parent / "shared" / "theory" / "THEORY.md"
    if not shared.exists():
        pytest.skip("../shared/theory/THEORY.md not beside the checkout")
    assert filecmp.cmp(DOCS / "theory" / "THEORY.md", shared, shallow=False), \
        "docs/theory/THEORY.md differs from ../shared/theory/THEORY.md: copy it again"


def test_the_gallery_has_at_least_twelve_examples_each_with_a_title():
    examples = sorted(EXAMPLES.glob("plot_*.py"))
    assert len(examples) >= 12
    for path in examples:
        tree = ast.parse(path.read_text(), filename=str(path))  # compiles
        doc = ast.get_docstring(tree)
        assert doc, f"{path.name}: no docstring (the gallery's title and text)"
        lines = doc.strip().splitlines()
        assert len(lines) >= 3 and set(lines[1]) == {"="} and len(lines[1]) >= len(lines[0]), \
            f"{path.name}: the docstring must start with a reST title"


def test_the_readme_links_to_the_docs_and_keeps_its_two_commands():
    readme = (ROOT / "README.md").read_text()
    assert "actuator-design design --target-tip 0.3,0.5" in readme
    assert ".venv/bin/python -m pytest -q" in readme
    assert "-m sphinx -W --keep-going -b html docs docs/_build/html" in readme


@pytest.mark.slow
def test_the_docs_build_without_warnings(tmp_path):
    pytest.importorskip("sphinx")
    pytest.importorskip("sphinx_gallery")
    src = tmp_path / "repo"
    shutil.copytree(ROOT, src, ignore=shutil.ignore_patterns(".venv", ".git", "_build", "auto_examples",
                                                              "generated", "commands", "__pycache__"))
    env = dict(os.environ, MPLBACKEND="Agg", PYTHONPATH=str(src))
    run = subprocess.run([sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-b", "html",
                          "docs", "docs/_build/html"], cwd=src, env=env, capture_output=True,
                         text=True, timeout=900)
    assert run.returncode == 0, run.stderr[-4000:]
    html = src / "docs" / "_build" / "html"
    assert (html / "index.html").exists() and (html / "api.html").exists()
    ran = sorted((html / "auto_examples").glob("plot_*.html"))
    assert len(ran) >= 12
