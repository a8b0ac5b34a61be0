"""Figures a paper could use (issue 21 item 3): no offset notation on any axis of the tool's figures."""
import numpy as np

from actuator_design.viz.style import new_axes, png_bytes


def test_a_narrow_range_axis_shows_its_values_not_an_offset():
    """A stiffness that varies by 1e-6 around 5.11194 read as "1e−6 + 5.11194" with matplotlib's
    default; every encoded figure now labels the values themselves."""
    ax = new_axes()
    x = np.linspace(0.0, 1.0, 11)
    ax.plot(x, 5.11194 + 1e-6 * x)
    ax.set_yscale("linear")
    png = png_bytes(ax)
    assert png.startswith(b"\x89PNG")
    for axis in (ax.xaxis, ax.yaxis):
        assert axis.get_offset_text().get_text() == ""
    labels = [t.get_text() for t in ax.yaxis.get_ticklabels() if t.get_text()]
    assert labels and all(lab.replace("\u2212", "-").startswith("5.1119") for lab in labels)


def test_log_axes_are_left_alone():
    ax = new_axes()
    ax.loglog([1, 10, 100], [1, 100, 1e4])
    assert png_bytes(ax).startswith(b"\x89PNG")
