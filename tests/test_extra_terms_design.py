"""Design, robust design and calibration with a term of actuator_design/physics/extra_terms (the
elastic foundation), against references written out here:

* a design's field, solved forward by scipy's solve_bvp on the rod's equation with the field and
  the foundation, puts the tip on the target;
* a robust design over a Young's modulus tolerance reports corner tips equal to forward solves of
  corner scenes scaled by hand (h ∝ E^-½, k ∝ 1/E, THEORY §5);
* a fit of E to tip deflections made by solve_bvp at a known E, with the foundation given in Pa,
  recovers that E (the foundation's k ℓ⁴/B follows the fitted B).
"""
import math

import numpy as np
import pytest

from actuator_design.equilibrium.pipeline import solve
from actuator_design.equilibrium.options import SolverOptions
from actuator_design.model.scene import Scene, UniformField
from rod_bvp import S, rod_bvp


def field_foundation_bvp(h, phi, k, fy=0.0, guess_theta=None):
    """The field's torque h² sin 2(θ − φ), a dead tip force fy and the bed k."""
    return rod_bvp(lambda s, th: h ** 2 * np.sin(2 * (th - phi)) - fy * np.cos(th), k, guess_theta)[:2]


def fitted_youngs_modulus(tmp_path, rows, term):
    """E (Pa) fitted to ``load [mN], tip_deflection [mm]`` rows on the 20 × 5 × 0.5 mm strip with
    ``term`` (a ``terms:`` mapping entry with units), starting from E = 2 MPa."""
    from actuator_design.calibration import fit_config

    (tmp_path / "d.csv").write_text("load [mN], tip_deflection [mm]\n" + "\n".join(rows) + "\n")
    (tmp_path / "f.yaml").write_text(
        "scene:\n  type: physical\n  rod: {length: 20 mm, width: 5 mm, thickness: 0.5 mm, youngs_modulus: 2 MPa}\n"
        f"  loads:\n    tip_force: {{x: 0 N, y: 0.1 mN}}\n  terms:\n    {term}\n"
        "study:\n  type: fit\n  parameters:\n    youngs_modulus: {bounds: [0.1 MPa, 20 MPa]}\n"
        "  uncertainty: {tip_deflection: 0.01 mm}\n")
    res = fit_config(tmp_path / "f.yaml", tmp_path / "d.csv")
    assert res.success, res.message
    return res.parameters["youngs_modulus"]["value"]


def bed_scene(k=15.0):
    return Scene(field=UniformField(phi=0.0), h=0.0, tip_force=(0.0, 0.0)).with_term(
        "foundation", k_foundation=k)


@pytest.mark.slow  # 7 s; the tapered load's design test covers the same path in the default run
def test_design_of_the_field_with_a_foundation_is_the_bvp_forward():
    from actuator_design.inverse.design import design

    k = 15.0
    target = field_foundation_bvp(1.6, 1.2, k)  # a reachable target: a known field's tip
    d = design(target, scene=bed_scene(k), vary=("h", "phi"), options=SolverOptions(), verify=False)
    assert d.reachable and d.error < 1e-6
    assert d.design_scene.term_values("foundation") == {"k_foundation": k}
    h, phi = float(d.design["h"]), float(d.design["phi"])
    r = solve(d.design_scene)
    x, y = field_foundation_bvp(h, phi, k, guess_theta=lambda s: np.interp(s, S, r.evaluate(S)["theta"]))
    assert (x, y) == pytest.approx(target, abs=1e-6)


def test_robust_design_over_youngs_modulus_scales_the_foundation():
    from actuator_design.inverse.design import design
    from actuator_design.inverse.settings import DesignSettings
    from actuator_design.robust.tolerances import Tolerances

    k, tol = 15.0, 0.1
    target = field_foundation_bvp(1.6, 1.2, k)
    settings = DesignSettings(tolerances=Tolerances(field_rel=0.0, angle=0.0, youngs_rel=tol))
    d = design(target, scene=bed_scene(k), vary=("h", "phi"), settings=settings)
    assert d.reachable and d.verified
    corners = d.to_dict()["robustness"]["corners"]
    assert len(corners) == 2
    nominal = solve(d.design_scene)
    for c in corners:
        e = 1.0 + c["offset"]["youngs_rel"] * tol  # E → e E: h ∝ E^-½, k ∝ 1/E (THEORY §5)
        sc = d.design_scene.with_values(h=d.design_scene.h / math.sqrt(e)).with_term(
            "foundation", k_foundation=k / e)
        r = solve(sc, initial=nominal)
        assert r.success and r.stable
        assert (r.tip["x"], r.tip["y"]) == pytest.approx((c["tip"]["x"], c["tip"]["y"]), abs=1e-6)
        assert math.hypot(r.tip["x"] - target[0], r.tip["y"] - target[1]) == pytest.approx(c["error"], abs=1e-6)


def test_fit_of_youngs_modulus_with_a_foundation_in_pascal(tmp_path):
    L, W, T, E, K_PA = 20e-3, 5e-3, 0.5e-3, 1.2e6, 20.0
    B = E * W * T ** 3 / 12
    rows = []
    for load_mN in (0.05, 0.1, 0.2, 0.3):
        fy = load_mN * 1e-3 * L ** 2 / B
        _, y = field_foundation_bvp(0.0, 0.0, K_PA * L ** 4 / B, fy=fy)
        rows.append(f"{load_mN!r}, {float(y * L * 1e3)!r}")
    assert fitted_youngs_modulus(tmp_path, rows, "foundation: {k_foundation: 20 Pa}") == pytest.approx(E, rel=1e-6)


@pytest.mark.slow
def test_scenario_nlp_scales_the_foundation_with_youngs_modulus(monkeypatch):
    """The robust stage's own corner scenarios (the scenario NLP) against forward solves of corner
    scenes scaled by hand: its worst corner error is theirs."""
    from actuator_design.robust import design_robust
    from actuator_design.inverse.design import design
    from actuator_design.inverse.settings import DesignSettings
    from actuator_design.robust.tolerances import Tolerances
    from actuator_design.model.scene import default_scene

    calls = []
    real = design_robust.ScenarioDesignNLP.solve

    def spy(self, base_scene, tol, scale, targets, *a, **k):
        pt = real(self, base_scene, tol, scale, targets, *a, **k)
        calls.append((self, base_scene, tol, scale, pt))
        return pt

    monkeypatch.setattr(design_robust.ScenarioDesignNLP, "solve", spy)
    monkeypatch.setenv("ACTUATOR_DESIGN_WORKERS", "1")  # the robust stage in this process (the spy sees it)
    k, target = 10.0, (0.3, 0.5)
    settings = DesignSettings(tolerances=Tolerances(youngs_rel=0.1))  # with the default field box
    design(target, scene=default_scene(h=0.0).with_term("foundation", k_foundation=k), settings=settings,
           verify=False)
    converged = [c for c in calls if c[4].converged and c[0].C == 8]
    assert converged, "the robust stage did not run its scenario NLP"
    snlp, base, tol, scale, pt = converged[-1]
    sc = design_robust.pose_designs(snlp, base, pt.d)[0]
    errors = []
    for c, corner_offset in enumerate(tol.corners(), start=1):
        o = {a: corner_offset.get(a, 0.0) * getattr(tol, a) * scale for a in ("field_rel", "angle", "youngs_rel")}
        e = 1.0 + o["youngs_rel"]  # E → e E: h ∝ H E^-½, k ∝ 1/E (THEORY §5)
        corner = sc.with_values(h=sc.h * (1.0 + o["field_rel"]) / math.sqrt(e), phi=sc.phi + o["angle"])
        r = solve(corner.with_term("foundation", k_foundation=k / e), initial=pt.z[0][c])
        assert r.success
        errors.append(math.hypot(r.tip["x"] - target[0], r.tip["y"] - target[1]))
    assert pt.worst_error[0] == pytest.approx(max(errors), abs=1e-6)


def field_tapered_bvp(h, phi, root, tip, guess_theta=None):
    """The field's torque and the tapered load's, Qx sin θ − Qy cos θ with Q(s) = ∫ₛ¹ q written out."""
    (ax, ay), (bx, by) = root, tip

    def torque(s, th):
        qx = ax * (1 - s) ** 2 / 2 + bx * (1 - s ** 2) / 2
        qy = ay * (1 - s) ** 2 / 2 + by * (1 - s ** 2) / 2
        return h ** 2 * np.sin(2 * (th - phi)) + qx * np.sin(th) - qy * np.cos(th)

    return rod_bvp(torque, 0.0, guess_theta)[:2]


def test_design_with_a_tapered_load_is_the_bvp_forward():
    from actuator_design.inverse.design import design

    root, tip = (0.0, -1.0), (0.0, -0.3)
    base = Scene(field=UniformField(phi=0.0), h=0.0, tip_force=(0.0, 0.0)).with_term(
        "tapered_load", q_root_x=root[0], q_root_y=root[1], q_tip_x=tip[0], q_tip_y=tip[1])
    target = field_tapered_bvp(1.2, 1.0, root, tip)
    d = design(target, scene=base, vary=("h", "phi"), options=SolverOptions(), verify=False)
    assert d.reachable and d.error < 1e-6
    r = solve(d.design_scene)
    x, y = field_tapered_bvp(float(d.design["h"]), float(d.design["phi"]), root, tip,
                             guess_theta=lambda s: np.interp(s, S, r.evaluate(S)["theta"]))
    assert (x, y) == pytest.approx(target, abs=1e-6)


def test_fit_of_youngs_modulus_with_a_tapered_load_in_newton_per_metre(tmp_path):
    L, W, T, E, Q = 20e-3, 5e-3, 0.5e-3, 0.8e6, -0.05  # q_tip in N/m
    B = E * W * T ** 3 / 12
    rows = []
    for load_mN in (0.0, 0.05, 0.1, 0.2):
        fy, q_tip = load_mN * 1e-3 * L ** 2 / B, Q * L ** 3 / B  # dimensionless (THEORY §5)
        _, y, _ = rod_bvp(lambda s, th: -(q_tip * (1 - s ** 2) / 2 + fy) * np.cos(th))  # Q(s) + the tip force
        rows.append(f"{load_mN!r}, {float(y * L * 1e3)!r}")
    assert fitted_youngs_modulus(tmp_path, rows, "tapered_load: {q_tip_y: -0.05 N/m}") == pytest.approx(E, rel=1e-6)
