"""``stiffness --out`` at one state writes its figure (issue 21 item 3: every command that writes
data writes its figure): the state with its compliance ellipse at the tip, checked against the
closed-form compliance of a straight cantilever, l³/(3 EI) (dimensionless 1/3)."""
import numpy as np
import pytest

from actuator_design.analysis.stiffness import tip_stiffness
from actuator_design.cli.main import main
from actuator_design.model.scene import default_scene
from actuator_design.equilibrium.solver import SolverOptions
from actuator_design.viz.compliance import ELLIPSE_SIZE, compliance_figure


def test_a_straight_cantilever_s_ellipse_is_its_closed_form_compliance():
    st = tip_stiffness(default_scene(h=0.0, phi=0.0, p=0.0), SolverOptions())
    fig = compliance_figure(st)
    ax = fig.axes[0]
    ring = next(ln for ln in ax.get_lines() if ln.get_label().startswith("tip motion"))
    x, y = (np.asarray(v, float) for v in ring.get_data())
    # an inextensible straight rod's tip moves across the rod only: a vertical segment at x = 1
    np.testing.assert_allclose(x, 1.0, atol=1e-9)
    assert max(y) - min(y) == pytest.approx(2 * ELLIPSE_SIZE, rel=1e-9)
    assert "longest axis 0.333 l³/B0" in ax.get_title()


def test_stiffness_out_without_a_sweep_writes_its_figure(tmp_path):
    assert main(["stiffness", "--h", "1", "--phi-deg", "60", "--out", str(tmp_path / "o")]) == 0
    assert (tmp_path / "o" / "stiffness.png").stat().st_size > 10_000
