"""The design's verification ramps the applied field from zero (issue 18: the schedule rows name h
and the remanent groups; every other group the field drives follows h by the lens's rule).

In a non-uniform field the positional group h_pos (−h_pos² |h|², THEORY §5) is ∝ H like h. The
verification used to ramp h from a scene with h = 0 but h_pos at its design value, so its "path
from zero field" started from a rod already bent by the χ̂ term. References: zero field leaves the
unloaded rod straight (θ ≡ 0); along the ramp h_pos/h stays the design's ratio (both ∝ H); the
path ends on the forward solve of the design scene."""
from dataclasses import replace
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from actuator_design.equilibrium.options import SolverOptions
from actuator_design.equilibrium.pipeline import solve
from actuator_design.inverse.design import DesignSettings, design
from actuator_design.inverse.verify import ramped_groups, verify
from actuator_design.model.profiles import constant_profile
from actuator_design.model.scene import DipoleField, Scene, default_scene
from actuator_design.physics import parameters as lens
from actuator_design.robust.tolerances import parse_tolerances


def test_a_dipole_design_is_verified_by_a_ramp_that_starts_at_zero_field():
    design_scene = Scene(field=DipoleField(x0=1.2, y0=-0.5, moment_angle=0.0), h=0.02, h_pos=0.012,
                         tip_force=None, fibres=constant_profile(0.0))
    options = SolverOptions()
    forward = solve(design_scene, options)
    assert forward.success
    tip = np.array([forward.tip["x"], forward.tip["y"], forward.tip["angle"]])
    problem = SimpleNamespace(options=options, settings=SimpleNamespace(ramp_steps=12))
    choice = SimpleNamespace(point=SimpleNamespace(h=design_scene.h, phi=0.0, p=0.0, tip=tip),
                             candidate=SimpleNamespace(vary=("h",)), scene=design_scene)
    v = verify(problem, choice)
    assert v.path is not None, v.label
    first = v.path.states[0]
    assert first.scene.h == 0.0 and abs(first.scene.h_pos) < 1e-300  # zero field (h_pos kept as a tiny float)
    assert np.max(np.abs(first.evaluate(np.linspace(0, 1, 11))["theta"])) < 1e-12  # the straight rod
    ratio = design_scene.h_pos / design_scene.h
    for st in v.path.states[1:]:
        assert st.scene.h_pos == pytest.approx(ratio * st.scene.h, rel=1e-12)
    final = v.path.final
    assert max(abs(final.tip[k] - forward.tip[k]) for k in ("x", "y", "angle")) < 1e-8
    assert all(set(row) <= {"h", "phi"} for row in v.schedule)  # h_pos follows h (phi: unused here)


def test_ramped_groups_name_the_magnitude_and_the_remanent_groups():
    soft = default_scene(h=1.0)
    assert ramped_groups(soft) == {"h": (1.0, 1)}
    from dataclasses import replace
    hard = replace(soft, h_r=2.0, magnetization=constant_profile(0.0))
    assert ramped_groups(hard) == {"h": (1.0, 1), "h_r": (2.0, 1)}


def test_the_certificate_of_a_big_dense_hessian_is_refused_before_it_exhausts_memory():
    """The shipped dipole example (80 unknowns, dense positional Hessian) asked for more than 24 GB
    when its certified design NLP was built (the process was killed); the bound refuses it in one
    line, while banded Hessians and the foundation's smaller dense one keep their certificate."""
    from actuator_design.config import load_config
    from actuator_design.inverse.design_map import prepare_scene
    from actuator_design.inverse.ldl import CertificateTooLarge, check_certificate_size
    from actuator_design.inverse.nlp import get_design_nlp

    cfg = load_config(Path(__file__).resolve().parents[1] / "configs" / "permanent_magnet_dipole.yaml")
    dipole = get_design_nlp(prepare_scene(cfg.to_scene(), ("h",)), ("h",), cfg.solver_options(), 4)
    with pytest.raises(CertificateTooLarge, match="certificate was not built: the reduced Hessian is dense"):
        dipole.nlpsol(certified=True)
    point = dipole._solve_once(prepare_scene(cfg.to_scene(), ("h",)), np.zeros(dipole.n + 1), np.array([0.01]),
        SimpleNamespace(target=(0.9, -0.2), stage="A", margin=1e-6, bounds={"h_max": 1.0}, d_prev=None,
                        w_rate=0.0, stiffness=None), certified=True, w_eff=1.0)
    assert not point.converged and point.status.startswith("the stability certificate was not built")
    for scene in (default_scene(h=1.0), default_scene(h=1.0).with_term("foundation", k_foundation=10.0)):
        nlp = get_design_nlp(prepare_scene(scene, ("h", "phi")), ("h", "phi"), SolverOptions(), 4)
        check_certificate_size(nlp.solver, nlp.n)  # passes


def test_a_dipole_design_reports_every_group_it_moved_so_a_forward_solve_reproduces_it():
    """Designing h in a non-uniform field moves h_pos with it (both ∝ H). The report names h_pos
    at the design field, so the scene with the reported groups set one by one (as ``--set`` does)
    is the designed state. Reference: the target is the tip of an independent forward solve at
    1.3 × the base field (h and h_pos both × 1.3)."""
    base = Scene(field=DipoleField(x0=1.2, y0=-0.5, moment_angle=0.0), h=0.02, h_pos=0.012,
                 tip_force=None, fibres=constant_profile(0.0))
    made = solve(replace(base, h=0.026, h_pos=0.0156))
    assert made.success
    res = design((made.tip["x"], made.tip["y"]), base, vary=("h",),
                 settings=DesignSettings(ramp_steps=6, tolerances=parse_tolerances("none")))
    assert res.success, res.message
    assert res.design["h"] == pytest.approx(0.026, rel=1e-7)
    assert res.design["h_pos"] == pytest.approx(0.0156, rel=1e-7)
    scene = base
    for name in ("h", "h_pos"):
        scene = lens.set_value(scene, name, res.design[name])
    again = solve(scene)
    assert max(abs(again.tip[k] - res.achieved[k]) for k in ("x", "y", "angle")) < 1e-9
