"""The named blocks every design NLP lays its unknowns and rows out with (inverse/layout.py)."""
import dataclasses

import casadi as ca
import numpy as np
import pytest

from actuator_design.equilibrium.options import SolverOptions
from actuator_design.equilibrium.pipeline import solve
from actuator_design.equilibrium.solver import get_solver
from actuator_design.inverse.layout import Blocks, state_rows
from actuator_design.model.scene import UniformField, default_scene


def test_blocks_stack_in_order_with_their_default_and_given_bounds():
    rows = Blocks()
    assert rows.add("eq", ca.SX.sym("g", 3), 0.0, 0.0) == slice(0, 3)
    rows.add("none", ca.SX(0, 1))  # an empty block (no obstacles, no profiles) takes no rows
    rows.add("pivots", ca.SX.sym("q", 2), 0.0, np.inf)
    rows.add("box", ca.SX.sym("b", 2), [-1.0, -2.0], [1.0, 2.0])
    assert rows.size == 7 and rows.vector().shape == (7, 1)
    assert rows["pivots"] == slice(3, 5) and rows["none"] == slice(3, 3) and "box" in rows
    lo, hi = rows.bounds()
    assert lo.tolist() == [0, 0, 0, 0, 0, -1, -2] and hi.tolist() == [0, 0, 0, np.inf, np.inf, 1, 2]
    lo, hi = rows.bounds(box=(-5.0, [6.0, 7.0]))
    assert lo[5:].tolist() == [-5, -5] and hi[5:].tolist() == [6, 7]
    assert rows.bounds()[0][5] == -1.0  # a given bound does not change the defaults
    assert "lifted" not in rows


def test_blocks_refuse_a_name_twice_and_an_unknown_block():
    rows = Blocks()
    rows.add("eq", ca.SX.sym("g", 2))
    with pytest.raises(ValueError, match="'eq' is already laid out"):
        rows.add("eq", ca.SX.sym("h", 1))
    with pytest.raises(KeyError, match="tip"):
        rows.bounds(tip=(0.0, 0.0))


def test_a_state_s_rows_are_the_forward_solver_s_at_an_equilibrium():
    """At a forward equilibrium the stationarity rows vanish, the tip is the solver's tip and the
    Hessian's smallest generalised eigenvalue is the solver's stability verdict (a second method)."""
    options = SolverOptions()
    scene = dataclasses.replace(default_scene(h=2.0), field=UniformField(phi=1.2))
    sv = get_solver(scene, options)
    res = solve(scene, options)
    P = sv.parameter_vector(scene)
    z = ca.SX.sym("z", len(res.z) - 1)
    rows = state_rows(sv, z, ca.SX(ca.DM(P)))
    f = ca.Function("rows", [z], [rows.eq, rows.tip, rows.hessian])
    eq, tip, H = (np.asarray(v, float) for v in f(res.z[1:]))
    assert np.max(np.abs(eq)) < 1e-8
    assert tip.ravel() == pytest.approx([res.tip["x"], res.tip["y"], res.tip["angle"]], abs=1e-12)
    m = rows.mass
    lam = np.linalg.eigvalsh(H / np.sqrt(np.outer(m, m)))[0]
    assert lam == pytest.approx(sv.stability(res.z, P).eigenvalues[0], rel=1e-8)
