"""Legends show what is drawn (issue 21 item 3): a path ramped up and back labels each direction
on the line that is drawn in that direction, the way back visible where it retraces the way out;
a map's bistable region is hatched in the legend as in the panel."""
from types import SimpleNamespace

import numpy as np

from actuator_design.continuation.loading import follow_path, ramp
from actuator_design.model.scene import default_scene
from actuator_design.viz.landscape import plot_landscape_map
from actuator_design.viz.loading import path_figure


def _lines(ax):
    return {ln.get_label(): ln for ln in ax.get_lines() if not ln.get_label().startswith("_")}


def test_a_path_up_and_back_labels_each_direction_on_its_own_line():
    path = follow_path(default_scene(h=0.0, phi=0.0), schedule=ramp("h", 0.0, 1.0, back=True))
    ax = path_figure(path).axes[0]
    lines = _lines(ax)
    up, down = lines["h increasing"], lines["h decreasing"]
    x_up, x_down = np.asarray(up.get_xdata(), float), np.asarray(down.get_xdata(), float)
    # each line runs in the direction its label says, over the whole ramp
    assert np.all(np.diff(x_up) >= 0) and np.all(np.diff(x_down) <= 0)
    assert (x_up[0], x_up[-1]) == (0.0, 1.0) and (x_down[0], x_down[-1]) == (1.0, 0.0)
    # the way back retraces the way out here (no hysteresis below the buckling field): it is
    # dashed, so the solid line under it stays visible
    assert up.get_linestyle() == "-" and down.get_linestyle() not in ("-", "solid")
    assert [t.get_text() for t in ax.get_legend().get_texts()] == ["h increasing", "h decreasing"]


def test_the_bistable_legend_entry_is_hatched_like_the_region():
    x, y = np.meshgrid(np.linspace(0, 1, 5), np.linspace(0, 1, 4))
    stable = np.where(x > 0.5, 2, 1)
    mmap = SimpleNamespace(x=x, y=y, counts=stable + 1, stable=stable, x_param="h", y_param="p")
    axes = plot_landscape_map(mmap)
    legend = axes[1].get_legend()
    entry = [h for h, t in zip(legend.legend_handles, legend.get_texts()) if t.get_text().startswith("bistable")]
    assert len(entry) == 1 and entry[0].get_hatch() == "//"


def test_the_shape_draws_the_field_at_the_angle_the_text_reports():
    """A design's text reports the angle the schedule leaves the field at (153.8°) while its state
    holds the same axis the other way (-26.2°; the soft-magnetic energy is even in ĥ, THEORY §5):
    the figure draws and labels the reported angle and names the other, and the arrows point along it."""
    import math

    import pytest

    from actuator_design.equilibrium.pipeline import solve
    from actuator_design.viz.shape import plot_shape

    phi = math.radians(-26.2419)
    res = solve(default_scene(h=2.0, phi=phi))
    ax = plot_shape(res, field_angle=phi + math.pi)
    (label,) = [t.get_text() for t in ax.texts if t.get_text().startswith("field:")]
    assert "φ = 153.8°" in label and "the same axis as −26.24°" in label.replace("-", "−")
    arrows = [a for a in ax.texts if getattr(a, "arrow_patch", None) is not None and a.get_text() == ""]
    d = np.subtract(arrows[0].xy, arrows[0].xyann)
    assert math.atan2(d[1], d[0]) == pytest.approx(phi + math.pi, abs=1e-9)
    # without the override (or with the scene's own angle) the scene's angle is drawn, no note
    ax = plot_shape(res, field_angle=phi)
    (label,) = [t.get_text() for t in ax.texts if t.get_text().startswith("field:")]
    assert "φ = -26.24°" in label and "same axis" not in label


def test_a_branch_legend_names_only_what_is_drawn():
    """A stable branch without folds or branch points: its legend has 'stable' and nothing it does
    not draw; the straight rod continued through the first pitchfork adds 'unstable' and
    'branch point' (h_crit = π/(2√2), THEORY §6)."""
    import math

    from actuator_design.continuation.follow import continue_branch
    from actuator_design.viz.landscape import plot_branches

    plain = continue_branch(default_scene(h=0.0, phi=0.0), "h", 0.0, 1.0)
    labels = [t.get_text() for t in plot_branches([plain.branch]).get_legend().get_texts()]
    assert labels == ["stable"]
    through = continue_branch(default_scene(h=0.0, phi=math.pi / 2), "h", 0.0, 1.5, initial=None)
    assert through.branch.branch_points
    labels = [t.get_text() for t in plot_branches([through.branch]).get_legend().get_texts()]
    assert labels == ["stable", "unstable", "branch point"]
