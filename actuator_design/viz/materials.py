"""Soft against hard magnetic response over the field angle: pure drawing from an
:class:`~actuator_design.analysis.field_angle_response.AngleResponse`."""
from __future__ import annotations

import numpy as np

from actuator_design.viz.style import new_figure

__all__ = ["angle_response_figure"]


def angle_response_figure(response, title: str = "tip angle against field angle"):
    """Tip angle θ(1) (deg) against field angle φ (deg), one curve per scene (unstable points
    hollow); returns the matplotlib Figure."""
    fig = new_figure((6.4, 4.2))
    ax = fig.add_subplot(1, 1, 1)
    phi = np.degrees(response.phi)
    for i, (label, tip) in enumerate(response.tip_angle.items()):
        c = f"C{i % 10}"
        ax.plot(phi, np.degrees(tip), color=c, lw=2, label=label)
        bad = ~response.stable[label]
        if np.any(bad):
            ax.plot(phi[bad], np.degrees(tip[bad]), "o", mfc="none", color=c)
    ax.axhline(0.0, color="k", lw=0.6)
    ax.set_xlabel("field angle φ [deg]")
    ax.set_ylabel("tip angle θ(1) [deg]")
    ax.set_title(title)
    ax.legend()
    return fig
