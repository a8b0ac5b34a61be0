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
