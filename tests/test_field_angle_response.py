"""Soft against hard response over the field angle (THEORY §5, §9), checked by symmetry: the soft
rod's response is π-periodic in φ, the hard rod's is 2π-periodic and, to first order in h_r, odd
under φ → φ + π (turning the field over reverses the torque; linear: θ = h_r sin φ (s − s²/2))."""
import math

import numpy as np
import pytest

from actuator_design.analysis.field_angle_response import field_angle_response
from actuator_design.model.profiles import constant_profile
from actuator_design.model.scene import Scene, UniformField


def test_soft_is_pi_periodic_and_weak_hard_is_antiperiodic(tmp_path):
    soft = Scene(field=UniformField(), h=0.6, tip_force=None)
    hard = Scene(field=UniformField(), h=0.0, tip_force=None, h_r=1e-3,
                 magnetization=constant_profile(0.0))
    phi = np.array([0.3, 1.0, 0.3 + math.pi, 1.0 + math.pi])
    res = field_angle_response({"soft": soft, "hard": hard}, phi)
    s, h = res.tip_angle["soft"], res.tip_angle["hard"]
    assert s[2] == pytest.approx(s[0], abs=1e-10) and s[3] == pytest.approx(s[1], abs=1e-10)
    h_r = 1e-3  # the odd part is linear in h_r, the even part O(h_r²)
    assert abs(h[2] + h[0]) < h_r**2 and abs(h[3] + h[1]) < h_r**2
    assert abs(h[0]) > 100 * h_r**2
    # linear theory: θ(1) = h_r sin φ / 2 + O(h_r²)
    assert h[1] == pytest.approx(h_r * math.sin(1.0) / 2, abs=h_r**2)
    from actuator_design.viz.materials import angle_response_figure
    fig = angle_response_figure(res)
    fig.savefig(tmp_path / "r.png")
    assert (tmp_path / "r.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
