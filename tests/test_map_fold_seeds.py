"""``map``'s fold curves are complete when a curve lies only inside the x range: a transverse
field's p-fold exists only above h_crit = π/(2√2) (THEORY §6), so over h ∈ [0.166, 1.989] it is
between the evenly spaced starts (0.166, 1.08, 1.99: none has a fold of p in [0, 1.08]) and was
missed. The map's own counts now seed the search. Reference: the shooting scan's counts on either
side of every point of the curve (three equilibria below the fold, one above)."""
import json
import math

from actuator_design.continuation.critical import count_equilibria
from actuator_design.cli.main import main
from actuator_design.model.scene import default_scene


def test_a_fold_curve_inside_the_range_is_found_and_is_where_the_count_changes(capsys):
    code = main(["map", "--phi-deg", "90", "--x-param", "h", "--x-range", "0.166,1.989", "--y-param", "p",
                 "--y-range", "0,1.08", "--n", "12", "--quiet", "--workers", "1", "--json"])
    assert code == 0
    curves = json.loads(capsys.readouterr().out)["critical_curves"]
    assert len(curves) == 1
    points = curves[0]["points"]
    assert len(points) >= 4
    h_crit = math.pi / (2 * math.sqrt(2))
    for pt in points:
        h, p = pt["h"], pt["p"]
        assert h > h_crit
        below = count_equilibria(default_scene(h=h, phi=math.pi / 2, p=p * 0.97 - 1e-4))[0]
        above = count_equilibria(default_scene(h=h, phi=math.pi / 2, p=p * 1.03 + 1e-4))[0]
        assert (below, above) == (3, 1), (h, p)
