"""Figures encoded in one draw, and a figure drawn as parts side by side (issue 17: the design
figure's halves are drawn at once, one in a forked process).

References: matplotlib's own ``savefig`` (the pixels of one draw must be the pixels it writes) and
each part encoded alone (the side-by-side image must be those images put together, with white
below the shorter one), in this process and with the parts forked in a fresh interpreter.
"""
import io
import json
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest
from PIL import Image

from actuator_design import forked
from actuator_design.viz.style import new_figure, png_bytes, png_side_by_side, vector_format


def _pixels(data: bytes) -> np.ndarray:
    return np.asarray(Image.open(io.BytesIO(data)).convert("RGBA"))


def _part(height: float, title: str):
    """A constrained-layout figure with a legend and a twin axis (what the design figure has)."""
    fig = new_figure((4.0, height))
    ax = fig.subplots()
    ax.plot([0, 1, 2], [0, 1, 4], label="h")
    ax.twinx().plot([0, 1, 2], [3, 2, 1], color="tab:orange")
    ax.set_title(title)
    ax.legend()
    return fig


def test_one_draw_gives_the_pixels_savefig_writes():
    fig = _part(3.0, "savefig")
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=60)
    np.testing.assert_array_equal(_pixels(png_bytes(_part(3.0, "savefig"), dpi=60)), _pixels(buf.getvalue()))


def test_the_pixels_do_not_follow_the_users_image_settings():
    """imsave reads rcParams["image.origin"]: a user's "lower" must not flip the figure."""
    import matplotlib

    reference = _pixels(png_bytes(_part(2.0, "rc"), dpi=40))
    with matplotlib.rc_context({"image.origin": "lower"}):
        np.testing.assert_array_equal(_pixels(png_bytes(_part(2.0, "rc"), dpi=40)), reference)


def _expected(dpi: int) -> np.ndarray:
    left, right = _pixels(png_bytes(_part(3.0, "left"), dpi)), _pixels(png_bytes(_part(2.0, "right"), dpi))
    pad = np.full((left.shape[0] - right.shape[0], right.shape[1], 4), 255, np.uint8)
    return np.concatenate([left, np.concatenate([right, pad])], axis=1)


def test_parts_side_by_side_are_the_parts_encoded_alone(monkeypatch):
    from functools import partial

    monkeypatch.setenv(forked.WORKERS_ENV, "1")
    got = png_side_by_side([partial(_part, 3.0, "left"), partial(_part, 2.0, "right")], dpi=50)
    np.testing.assert_array_equal(_pixels(got), _expected(50))


@pytest.mark.skipif(not hasattr(os, "fork") or len(os.sched_getaffinity(0)) < 2,
                    reason="forking needs os.fork and two usable CPUs")
def test_a_part_drawn_in_a_forked_process_gives_the_same_image():
    code = textwrap.dedent("""
        import json, sys
        from functools import partial
        sys.path.insert(0, %r)
        from test_figure_parts import _part
        from actuator_design import forked
        from actuator_design.viz.style import png_side_by_side
        pids = []  # the child of each part started beside (None: not forked)
        real = forked.start
        forked.start = lambda task, **kw: (lambda job: pids.append(job._pid) or job)(real(task, **kw))
        png = png_side_by_side([partial(_part, 3.0, "left"), partial(_part, 2.0, "right")], dpi=50)
        sys.stdout.buffer.write(png)
        sys.stderr.write(json.dumps({"forked": [pid is not None for pid in pids]}))
    """) % os.path.dirname(__file__)
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, timeout=300,
                         env={**os.environ, forked.WORKERS_ENV: "2", "MPLBACKEND": "Agg"})
    assert run.returncode == 0, run.stderr.decode()
    assert json.loads(run.stderr.decode().strip().splitlines()[-1]) == {"forked": [True]}
    np.testing.assert_array_equal(_pixels(run.stdout), _expected(50))


def test_a_vector_format_gets_the_whole_figure():
    from functools import partial

    with vector_format("svg"):
        got = png_side_by_side([partial(_part, 3.0, "left")], dpi=40, whole=partial(_part, 3.0, "whole"))
    assert got.vector["svg"].lstrip().startswith((b"<?xml", b"<svg"))
    np.testing.assert_array_equal(_pixels(got), _pixels(png_bytes(_part(3.0, "whole"), dpi=40)))
