"""The fit's model curve is not joined across a jump between branches (issue 21 item 3: the
curve spiked just before the buckling threshold and was drawn as one line through the jump)."""
from pathlib import Path

import numpy as np

from actuator_design.calibration.curves import branch_switches
from actuator_design.calibration.solve import fit_config
from actuator_design.viz.calibration import fit_figures

ROOT = Path(__file__).resolve().parents[1]


def test_a_smooth_branch_has_no_switch_and_a_jump_back_is_one():
    t = np.linspace(0.0, 1.0, 101)
    smooth = [np.array([np.sin(3 * v), v ** 2, np.tanh(20 * (v - 0.5))]) for v in t]
    assert not branch_switches(smooth).any()
    noisy_flat = [np.full(3, 1e-9 * (-1) ** k) for k in range(50)]  # round-off on a flat branch
    assert not branch_switches(noisy_flat).any()
    # a pitchfork's natural branch climbing, then the data's branch on the other side
    angle = np.r_[0.01 * np.exp(np.linspace(0, 2, 30)), -0.3 - 0.01 * np.arange(30)]
    jump = [np.array([a, 2 * a]) for a in angle]
    assert np.flatnonzero(branch_switches(jump)).tolist() == [30]


def test_the_buckling_fit_draws_the_jump_dotted():
    r = fit_config(str(ROOT / "configs/fit_transverse_buckling.yaml"),
                   str(ROOT / "problems/data/synthetic_transverse_buckling.csv"))
    g = r.curves["groups"][0]
    marks = np.flatnonzero(g["branch_switch"])
    assert len(marks) == 1
    m = int(marks[0])
    y = g["y"]["tip_angle"]
    # the natural branch of the fitted imperfection and the data's branch lie on either side of
    # the straight rod; the data beyond the jump are on the second
    assert y[m - 1] * y[m] < 0 and np.sign(y[m]) == np.sign(r.data.columns["tip_angle"][-1])
    ax = fit_figures(r)["fit_data_vs_model"].axes[0]
    dotted = [ln for ln in ax.get_lines() if ln.get_linestyle() == ":"]
    assert len(dotted) == 1 and len(dotted[0].get_xdata()) == 2  # the two ends of the jump only


def test_the_fits_stability_verdict_is_the_one_rule_at_a_marginal_state():
    """Issue 18 (one stability rule): the fit's verdict is the package's rule (THEORY §7), not a
    Cholesky factor of H_r alone, which calls a state stable as soon as λ0 > 0. The straight rod in a
    transverse field (φ = π/2) is an equilibrium at every h; its lowest eigenvalue λ0(h) crosses 0 at
    the buckling field. Found by secant steps on λ0 (the rule's own eigenvalues): a state with
    0 < λ0 < τ is marginal, neither stable nor unstable, to both."""
    import math

    from actuator_design.calibration.branches import BranchSelector
    from actuator_design.equilibrium.options import SolverOptions
    from actuator_design.equilibrium.solver import get_solver
    from actuator_design.model.scene import default_scene

    sc = default_scene(h=1.0, phi=math.pi / 2)
    sv = get_solver(sc, SolverOptions())
    z = np.zeros(sv.transcription.nodes.size)
    lam0 = lambda h: sv.stability(z, sv.parameter_vector(sc.with_values(h=h))).eigenvalues[0]
    a, b = 1.0, 2.0  # λ0(1) > 0 > λ0(2): the buckling field h_c ≈ π/(2√2) ≈ 1.11 lies between
    la, lb = lam0(a), lam0(b)
    assert la > 0 > lb
    for _ in range(60):  # secant/bisection until 0 < λ0 < τ/10
        c = b - lb * (b - a) / (lb - la)
        if not a < c < b:
            c = 0.5 * (a + b)
        lc = lam0(c)
        if 0 < lc < 1e-10:
            break
        a, la, b, lb = (c, lc, b, lb) if lc > 0 else (a, la, c, lc)
    assert 0 < lc < 1e-10
    P = sv.parameter_vector(sc.with_values(h=c))
    ref = sv.stability(z, P)
    assert ref.marginal and not ref.stable and ref.morse_index == 0
    selector = BranchSelector(sv, np.zeros(0, int), [1], np.ones(1))
    verdict, _ = selector.verdict(z, P)
    assert (verdict.stable, verdict.marginal, verdict.morse_index) == (False, True, 0)
    # and well inside the stable range it is certified stable
    verdict, _ = selector.verdict(z, sv.parameter_vector(sc.with_values(h=0.5)))
    assert verdict.stable and not verdict.marginal
