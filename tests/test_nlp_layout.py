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


def test_one_design_vector_map_lays_out_one_pose_and_several_poses():
    from actuator_design.inverse.design_map import DesignVector
    single = DesignVector.single(("h", "phi", "alpha", "p", "magnetization"), 3)
    joint = DesignVector.poses(("alpha", "magnetization"), ("h", "phi", "p"), 2, 3)
    # each map's slices tile its vector exactly, in storage order
    for dmap, size in ((single, 9), (joint, 12)):
        cover = sorted((sl.start, sl.stop) for sl in dmap._slices.values())
        assert cover[0][0] == 0 and cover[-1][1] == dmap.size == size
        assert all(a[1] == b[0] for a, b in zip(cover, cover[1:]))
    assert single["alpha"] == slice(2, 5) and joint.slice("p", 1) == slice(11, 12)
    assert joint.slice("alpha", 1) == joint["alpha"] == slice(0, 3)  # shared by every pose
    assert list(single.values(np.arange(9.0))) == ["h", "phi", "alpha", "p", "magnetization"]
    # two poses joined from single-pose vectors and read back: each pose's scalars, pose 1's profiles
    d1, d2 = np.arange(9.0), 100 + np.arange(9.0)
    d = np.zeros(joint.size)
    for k, dv in reversed(list(enumerate((d1, d2)))):
        single.move(dv, 0, joint, d, into_pose=k)
    back = [joint.move(d, k, single, np.zeros(single.size)) for k in (0, 1)]
    assert back[0].tolist() == d1.tolist()
    assert back[1].tolist() == [100, 101, 2, 3, 4, 105, 6, 7, 8]
    lo, hi = joint.bounds({"h_max": 7.0, "p_max": 3.0})
    assert np.isinf(lo[:6]).all() and hi[joint.slice("h", 1)][0] == 7.0 and lo[joint.slice("p", 0)][0] == -3.0
    # the fibre gauge: α's mean moved into every pose's φ
    g = joint.fix_gauge(d)
    assert g[0] == 0.0 and g[joint.slice("phi", 1)][0] == d[joint.slice("phi", 1)][0] - d[0]
    assert g[1:6].tolist() == d[1:6].tolist()


def test_the_states_of_two_poses_are_the_forward_solver_s_equilibria_of_their_scenes():
    """DesignStates (poses × scenarios): at each pose's forward equilibrium (a fresh solve of the
    scene its design values stand for) that pose's stationarity rows vanish and its tip is the
    solver's; a corner scenario is the forward solve at the corner's parameters."""
    from actuator_design.inverse.design_map import DesignVector
    from actuator_design.inverse.layout import DesignStates
    from actuator_design.inverse.nlp import get_design_nlp
    options = SolverOptions()
    base = default_scene()
    nlp = get_design_nlp(base, ("h", "phi", "alpha"), options, 3)
    joint = DesignVector.poses(("alpha",), ("h", "phi"), 2, 3)
    singles = [nlp.design_vector(h=2.5, phi=1.2, coefficients=[0.1, -0.2, 0.05]),
               nlp.design_vector(h=4.0, phi=0.7, coefficients=[0.1, -0.2, 0.05])]
    dv = np.zeros(joint.size)
    for k in (1, 0):
        nlp.dmap.move(singles[k], 0, joint, dv, into_pose=k)
    sv = nlp.solver
    d, P0 = ca.SX.sym("d", joint.size), ca.SX.sym("P0", sv.layout.size)
    theta0 = sv.layout.slices["theta0"]

    def tilt(P, c):  # a corner: the clamp turned by 0.1 rad
        Pc = ca.SX(P)
        Pc[theta0] = P[theta0] + 0.1
        return Pc

    states = DesignStates(sv, joint, d, P0, nlp.vandermonde, 1, tilt)
    assert len(states.rows) == 4 and len(states.params) == 2
    for k in (0, 1):
        scene = nlp.scene_for(base, singles[k])
        for c, sc in enumerate((scene, dataclasses.replace(scene, theta0=scene.theta0 + 0.1))):
            res = solve(sc, options)
            assert res.success
            rows = states.rows[2 * k + c]
            f = ca.Function("rows", [states.z[2 * k + c], d, P0], [rows.eq, rows.tip])
            eq, tip = (np.asarray(v, float).ravel() for v in f(res.z[1:], dv, sv.parameter_vector(base)))
            assert np.max(np.abs(eq)) < 1e-8
            assert tip == pytest.approx([res.tip["x"], res.tip["y"], res.tip["angle"]], abs=1e-10)


def test_a_map_of_shared_profiles_alone_keeps_its_poses():
    from actuator_design.inverse.design_map import DesignVector
    joint = DesignVector.poses(("alpha",), (), 3, 4)
    assert joint.n_poses == 3 and joint.size == 4
    assert all(list(joint.values(np.arange(4.0), k)) == ["alpha"] for k in range(3))
