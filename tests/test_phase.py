"""Phase portraits against the first integral (a conservation law) and the paper's closed relations:
for h = 0, γ²/2 = p sin θ(1) (paper eq. 301); for the transverse field, the modes' θ'(0) of the
elliptic-function solution (THEORY §6) and the paper's rule that mode m meets the θ axis m times."""
import math
from dataclasses import replace

import numpy as np
import pytest

from actuator_design.analysis.phase import check_autonomous, first_integral, phase_portrait
from actuator_design.equilibrium.pipeline import solve
from actuator_design.equilibrium.options import SolverOptions
from actuator_design.model.profiles import table_profile
from actuator_design.reference.closed_forms import transverse_mode
from actuator_design.model.scene import DipoleField, default_scene

FINE = SolverOptions(elements=6, degree=14)


def test_first_integral_is_constant_along_equilibria_with_loads_and_fibres():
    """H = ½θ'² + h²cos²(θ+α−φ) + fy sin θ + fx cos θ is conserved (differentiate and use the EL
    equation): a check of the formula and of the solutions, independent of the solver."""
    sc = replace(default_scene(h=1.3, phi=0.9, p=0.7, alpha=0.3), tip_force=(-0.5, 0.7))
    r = solve(sc, FINE)
    pp = phase_portrait(sc, [r])
    t = pp.trajectories[0]
    assert t.spread < 1e-9 * max(1.0, abs(t.level))
    # and H differs between the ends if a term is dropped (the check can fail)
    H = first_integral(replace(sc, tip_force=(0.0, 0.7)))
    vals = H(t.theta, t.dtheta)
    assert np.ptp(vals) > 1e-3


def test_elastica_relation_gamma_squared_is_two_p_sin_beta():
    """Field-free cantilever, p above p_crit^(1): every equilibrium satisfies γ²/2 = p sin β."""
    p = 15.0
    pp = phase_portrait(default_scene(h=0.0, phi=0.0, p=p), None, FINE)
    assert len(pp.trajectories) == 3
    for t in pp.trajectories:
        assert 0.5 * t.gamma ** 2 == pytest.approx(p * math.sin(t.tip_angle), abs=1e-8)
        assert t.level == pytest.approx(p * math.sin(t.tip_angle), abs=1e-8)
        assert t.dtheta[-1] == pytest.approx(0.0, abs=1e-8)  # ends on the θ axis
        assert t.theta[0] == 0.0  # starts on the θ' axis


def test_transverse_modes_gamma_and_axis_crossings():
    """φ = π/2, p = 0, h_crit^(2) < h < h_crit^(3): the straight rod and modes 1, 2 (± each);
    |θ'(0)| of mode m is w sin β_m (THEORY §6) and its curve meets the θ axis m times."""
    h = 3.5
    pp = phase_portrait(default_scene(h=h, phi=0.5 * math.pi, p=0.0), None, FINE)
    assert len(pp.trajectories) == 5
    for m in (1, 2):
        mode = transverse_mode(h, m)
        hits = [t for t in pp.trajectories if abs(abs(t.gamma) - mode.gamma) < 1e-6]
        assert len(hits) == 2, (m, [t.gamma for t in pp.trajectories])
        for t in hits:
            assert t.crossings + 1 == m
            assert abs(t.tip_angle) == pytest.approx(mode.beta, abs=1e-8)
            assert t.stable == (m == 1)
    straight = [t for t in pp.trajectories if abs(t.gamma) < 1e-9]
    assert len(straight) == 1 and straight[0].morse_index == 2


@pytest.mark.parametrize("change, field", [
    (dict(fibres=table_profile([0, 1], [0, 0.5])), "fibres"),
    (dict(stiffness=table_profile([0, 1], [1, 0.5])), "stiffness"),
    (dict(distributed_load=(0.0, -1.0)), "distributed_load"),
    (dict(field=DipoleField()), "field"),
])
def test_non_autonomous_scenes_are_refused_naming_the_field(change, field):
    with pytest.raises(ValueError, match=f"^{field}: "):
        check_autonomous(replace(default_scene(), **change))


def test_phase_figure_is_drawn():
    from actuator_design.viz.phase import phase_figure
    from actuator_design.viz.style import png_bytes

    sc = default_scene(h=2.0, phi=0.5 * math.pi)
    pp = phase_portrait(sc, [solve(sc)])
    assert png_bytes(phase_figure([pp, pp]))[:4] == b"\x89PNG"
