"""The Morse index counts every negative eigenvalue, not only the three lowest computed.

Reference (THEORY §6–7): the straight rod θ ≡ 0 in a transverse field (φ = 90°, p = 0) has the
second variation −η'' − 2h² η, η(0) = 0, η'(1) = 0, whose eigenvalues are ((2n − 1)π/2)² − 2h²
(n = 1, 2, …): its Morse index is the number of them below zero. Each pitchfork h_crit^(m) adds a
pair of mode-m states, born with the straight rod's index before it (m − 1). Before, the index
was read off the three lowest eigenvalues and stopped at 3 (the straight rod at h = 50 has 23).
"""
import json
import math

import pytest

from actuator_design.analysis.equilibria import find_equilibria
from actuator_design.cli.main import main
from actuator_design.equilibrium.options import SolverOptions
from actuator_design.equilibrium.pipeline import solve
from actuator_design.model.scene import Scene, UniformField


def straight_rod_index(h):
    return sum(1 for n in range(1, 10 * int(h) + 10) if ((2 * n - 1) * math.pi / 2) ** 2 < 2 * h * h)


@pytest.mark.parametrize("h", [2.0, 10.0, 50.0])
def test_the_straight_rod_in_a_transverse_field_has_the_closed_form_index(h):
    scene = Scene(field=UniformField(phi=0.5 * math.pi), h=h)
    r = solve(scene, SolverOptions(start="straight", ensure_stable=False))
    assert r.success and max(abs(r.tip["y"]), abs(r.tip["angle"])) < 1e-12
    assert r.morse_index == straight_rod_index(h)
    assert r.morse_index == {2.0: 1, 10.0: 5, 50.0: 23}[h]


def test_every_equilibrium_at_h_10_has_the_index_of_its_mode():
    """h = 10, φ = 90°: the straight rod (index 5) and a pair per mode m = 1 … 5 (index m − 1)."""
    found = find_equilibria(Scene(field=UniformField(phi=0.5 * math.pi), h=10.0))
    assert found.complete
    assert sorted(e.result.morse_index for e in found.equilibria) == [0, 0, 1, 1, 2, 2, 3, 3, 4, 4, 5]


@pytest.mark.parametrize("argv", [
    ["equilibria", "--h", "14", "--phi-deg", "90", "--method", "deflation"],
    ["critical", "--param", "h", "--window", "40,50", "--phi-deg", "90"],
    ["phase", "--h", "50", "--phi-deg", "90"],
])
def test_a_list_not_certified_complete_exits_3(argv, capsys):
    """A list of equilibria or critical points that may miss some is not a success (each exited 0:
    the deflation search at h = 14 missed both stable states, critical over h ∈ [40, 50] reported
    none of its five pitchforks, the portrait at h = 50 drew nothing)."""
    code = main(argv + ["--json"])
    out, err = capsys.readouterr()
    assert code == 3 and "not complete" in err
    assert json.loads(out)["complete"] is False
