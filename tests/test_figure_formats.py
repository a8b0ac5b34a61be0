"""``--format svg|pdf``: every figure of an ``--out`` set also in a vector format (issue 21 item 3).

Checked on the files themselves: the SVG parses as XML with an ``<svg>`` root, the PDF starts
with its magic number, each vector file sits beside the PNG of the same name, the same figure gives
the same bytes twice (no creation date), and without ``--format`` no vector file is written.
"""
import xml.etree.ElementTree as ET

import pytest
import yaml

from actuator_design.cli.main import main
from actuator_design.viz.style import FigureBytes, new_axes, png_bytes, vector_format

STUDY = {
    "name": "format sweep",
    "scene": {"type": "dimensionless", "h": 1.0, "phi": "90 deg", "p": 0},
    "solver": {"elements": 4, "degree": 10},
    "study": {"type": "sweep", "grid": "cartesian", "sweep": {"h": [0.5, 1.5]},
              "analyses": ["solve"]},
}


def _svg_root(path):
    return ET.parse(path).getroot().tag.rsplit("}", 1)[-1]


def test_solve_writes_svg_beside_png_deterministically(tmp_path):
    for run in ("a", "b"):
        assert main(["solve", "--out", str(tmp_path / run), "--format", "svg"]) == 0
    names = sorted(p.name for p in (tmp_path / "a").iterdir())
    assert "shape.png" in names and "shape.svg" in names
    assert _svg_root(tmp_path / "a" / "shape.svg") == "svg"
    assert (tmp_path / "a" / "shape.svg").read_bytes() == (tmp_path / "b" / "shape.svg").read_bytes()


def test_pdf_and_default_png_only(tmp_path):
    assert main(["solve", "--out", str(tmp_path / "pdf"), "--format", "pdf"]) == 0
    assert (tmp_path / "pdf" / "shape.pdf").read_bytes()[:5] == b"%PDF-"
    assert main(["solve", "--out", str(tmp_path / "png")]) == 0
    assert not [p for p in (tmp_path / "png").iterdir() if p.suffix in (".svg", ".pdf")]


def test_unknown_format_is_one_line_exit_2(tmp_path, capsys):
    assert main(["solve", "--out", str(tmp_path / "x"), "--format", "eps"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--format" in err[0] and "svg" in err[0]
    assert not (tmp_path / "x").exists()


def test_study_figures_in_vector_format(tmp_path):
    cfg = tmp_path / "study.yaml"
    cfg.write_text(yaml.safe_dump(STUDY))
    out = tmp_path / "out"
    assert main(["study", str(cfg), "--out", str(out), "--workers", "1", "--format", "svg"]) == 0
    pngs = sorted((out / "figures").glob("*.png"))
    assert pngs
    for png in pngs:
        assert _svg_root(png.with_suffix(".svg")) == "svg"


def test_vector_format_scope_and_validation():
    ax = new_axes()
    ax.plot([0, 1], [0, 1])
    plain = png_bytes(ax)
    assert isinstance(plain, FigureBytes) and plain.vector == {} and plain[:4] == b"\x89PNG"
    with vector_format("svg"):
        with_svg = png_bytes(ax)
    assert set(with_svg.vector) == {"svg"} and bytes(with_svg) == bytes(plain)
    assert png_bytes(ax).vector == {}  # the context ended
    with pytest.raises(ValueError, match="svg"):
        with vector_format("eps"):
            pass
