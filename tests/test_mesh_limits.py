"""The largest meshes the configuration allows (config.limits) solve within the stated memory and
converge to their tolerance — the README's promise, checked by running them (slow: benchmarks).

Reference: the uniform-field shooting solver's tip at the same field (independent of the NLP), and
the peak resident memory of the child process (``getrusage``), against the ~1 GB budget.
"""
import json
import math
import subprocess
import sys

import numpy as np
import pytest

from actuator_design.config.limits import mesh_problem
from actuator_design.reference.shooting import ShootingParams, solve_shooting


def _largest(transcription, degree):
    e = 1
    while mesh_problem(transcription, 2 * e, degree, tol=1e-10) is None:
        e *= 2
    lo, hi = e, 2 * e
    while hi - lo > 1:
        mid = (lo + hi) // 2
        lo, hi = (mid, hi) if mesh_problem(transcription, mid, degree, tol=1e-10) is None else (lo, mid)
    return lo


@pytest.mark.slow
@pytest.mark.parametrize("transcription,degree", [("midpoint", 1), ("lgl", 10)])
def test_largest_allowed_mesh_converges_within_the_memory_budget(tmp_path, transcription, degree):
    elements = _largest(transcription, degree)
    assert mesh_problem(transcription, elements + 1, degree, tol=1e-10) is not None
    command = [sys.executable, "-m", "actuator_design.cli", "solve", "--h", "1", "--phi-deg", "45",
               "--transcription", transcription, "--elements", str(elements), "--degree", str(degree),
               "--json", "--out", str(tmp_path / "o")]
    # the solve's peak memory alone: measured by a fresh parent whose only children are the solve and
    # its own (this test process's high-water mark over its children includes earlier tests' workers)
    measure = ("import json, resource, subprocess, sys; "
               f"out = subprocess.run({command!r}, capture_output=True, text=True, timeout=600); "
               "print(json.dumps([out.returncode, out.stdout, out.stderr, "
               "resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss]))")
    run = subprocess.run([sys.executable, "-c", measure], capture_output=True, text=True, timeout=700)
    assert run.returncode == 0, run.stderr[-2000:]
    returncode, stdout, stderr, peak_kb = json.loads(run.stdout)
    assert returncode == 0, stderr[-2000:]
    assert 5e4 <= peak_kb <= 1.05e6  # kB: the ~1 GB budget (5 % model error); Python and CasADi alone ≥ 50 MB
    res = json.loads(stdout)
    ref = solve_shooting(ShootingParams(h=1.0, phi=math.pi / 4), 0.5)
    assert ref.converged
    tip = res["tip"] if "tip" in res else res["state"]["tip"]
    # midpoint is second order: error ≈ C / N² ≪ 1e-6 at N ≈ 3e4
    assert tip["angle"] == pytest.approx(ref.tip_angle, abs=1e-6)
    assert np.isfinite(tip["x"])
