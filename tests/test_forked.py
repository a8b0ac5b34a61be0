"""Work computed beside the process (:mod:`actuator_design.forked`, issue 17): a forked task gives
exactly what the task gives here, whatever it returns or raises, and a design is the same with one
worker or two.

A process that runs threads does not fork (a test session that has run a Dask cluster has), so
the forking cases run in a fresh interpreter each."""
import json
import os
import subprocess
import sys
import textwrap

import pytest

from actuator_design import forked

pytestmark = pytest.mark.skipif(not hasattr(os, "fork") or len(os.sched_getaffinity(0)) < 2,
                                reason="forking needs os.fork and two usable CPUs")


def _fresh(code: str, env=None) -> dict:
    """Run ``code`` in a fresh interpreter; it prints one JSON object, returned."""
    run = subprocess.run([sys.executable, "-c", textwrap.dedent(code)], capture_output=True, text=True,
                         timeout=600, env={**os.environ, **(env or {})})
    assert run.returncode == 0, run.stderr
    return json.loads(run.stdout.strip().splitlines()[-1])


def test_a_forked_task_runs_in_another_process_and_returns_its_value():
    out = _fresh("""
        import json, os
        import numpy as np
        from actuator_design import forked
        job = forked.start(lambda: (os.getpid(), np.arange(5.0) ** 2))
        forked_pid = job._pid
        pid, value = job.result()
        print(json.dumps({"forked": forked_pid is not None, "elsewhere": pid != os.getpid(),
                          "value": value.tolist()}))
    """)
    assert out == {"forked": True, "elsewhere": True, "value": [0.0, 1.0, 4.0, 9.0, 16.0]}


def test_one_worker_runs_the_task_here_only_when_its_result_is_asked(monkeypatch):
    monkeypatch.setenv(forked.WORKERS_ENV, "1")
    calls = []
    job = forked.start(lambda: calls.append(os.getpid()) or 7)
    assert calls == []  # not run before it is asked for
    assert job.result() == 7 and calls == [os.getpid()]
    assert job.result() == 7 and len(calls) == 1  # once
    cancelled = forked.start(lambda: calls.append("never"))
    cancelled.cancel()
    assert "never" not in calls
    with pytest.raises(RuntimeError, match="cancelled"):
        cancelled.result()


def test_a_task_that_raises_or_does_not_pickle_is_run_here_and_warnings_come_back():
    out = _fresh("""
        import json, os, traceback, warnings
        import numpy as np
        from actuator_design import forked

        def fails():
            raise np.linalg.LinAlgError("Singular matrix")

        def warns():
            warnings.warn("the mesh is coarse", RuntimeWarning)
            return os.getpid()

        raised = None
        try:
            forked.start(fails).result()
        except np.linalg.LinAlgError as exc:  # its own type and message, raised with its frames here
            raised = [str(exc), any(f.name == "fails" for f in traceback.extract_tb(exc.__traceback__))]
        job = forked.start(lambda: (lambda: 3))  # a lambda does not pickle: computed here
        value = job.result()()
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            pid = forked.start(warns).result()
        print(json.dumps({"raised": raised, "value": value, "warned": [str(w.message) for w in caught],
                          "elsewhere": pid != os.getpid()}))
    """)
    assert out == {"raised": ["Singular matrix", True], "value": 3, "warned": ["the mesh is coarse"],
                   "elsewhere": True}


def test_cancel_ends_the_child_and_the_family_never_outgrows_its_workers():
    out = _fresh("""
        import json, os, time
        from actuator_design import forked
        first = forked.start(lambda: time.sleep(60))
        second = forked.start(lambda: os.getpid())  # ACTUATOR_DESIGN_WORKERS=2: no slot left
        pid = first._pid
        t0 = time.perf_counter()
        first.cancel()
        took = time.perf_counter() - t0
        try:
            os.kill(pid, 0)
            gone = False
        except ProcessLookupError:
            gone = True
        third = forked.start(lambda: os.getpid())  # the slot is back
        print(json.dumps({"gone": gone, "quick": took < 5, "second_here": second.result() == os.getpid(),
                          "third_forked": third._pid is not None and third.result() != os.getpid()}))
    """, env={forked.WORKERS_ENV: "2"})
    assert out == {"gone": True, "quick": True, "second_here": True, "third_forked": True}


@pytest.mark.parametrize("targets", [[(0.3, 0.5)], [(0.3, 0.5), (0.6, 0.2)]])
def test_the_main_job_is_the_same_with_one_worker_or_two(targets):
    """The search of the next variable set, half of each multi-start, the robust design (while
    this process reports the nominal one and builds the fold search's solvers ahead), the
    verification and the poses' checks run beside the design; with ACTUATOR_DESIGN_WORKERS=1
    everything runs in one process. The designs, robustness reports and verified schedules agree
    to the last bit: the same computations on the same state."""
    code = f"""
        import json
        from actuator_design.inverse.design import design
        from actuator_design.inverse.poses import design_poses
        targets = {targets!r}
        res = design(targets[0]) if len(targets) == 1 else design_poses(targets)
        d = res.to_dict()
        keys = ("design", "achieved", "schedule", "robustness", "message", "status", "poses")
        print(json.dumps({{"success": bool(res.success), **{{k: d[k] for k in keys if k in d}}}}))
    """
    two = _fresh(code, env={forked.WORKERS_ENV: "2"})
    one = _fresh(code, env={forked.WORKERS_ENV: "1"})
    assert two["success"] and one["success"]
    assert two == one


def test_an_equilibrium_result_travels_whole():
    """A result pickles (as a forked task sends it back): the copy's dense shape, clamp curvature
    and force balance are the original's, the balance's solver built again for its scene."""
    import pickle

    import numpy as np

    from actuator_design.equilibrium.pipeline import solve
    from actuator_design.model.scene import default_scene

    r = solve(default_scene(h=3.0, phi=1.0))
    copy = pickle.loads(pickle.dumps(r))
    s = np.linspace(0.0, 1.0, 301)
    for a, b in zip(r._dense(s), copy._dense(s)):
        np.testing.assert_array_equal(a, b)
    assert copy._clamp_curvature() == r._clamp_curvature()
    for a, b in zip(r._balance(), copy._balance()):
        np.testing.assert_allclose(b, a, rtol=0, atol=1e-14)


def test_a_contact_result_travels_whole():
    """A contact result pickles too (a study's worker sends it back): its balance, with the contact
    forces as point loads, is the original's; a self-contact result likewise."""
    import copy as cp
    import math
    import pickle

    import numpy as np

    from actuator_design.contact.obstacles import Wall
    from actuator_design.equilibrium.pipeline import solve
    from actuator_design.model.profiles import expression_profile
    from actuator_design.model.scene import Scene

    wall = Scene(field=None, tip_force=(0.0, -1.0), obstacles=(Wall((0.0, -0.1), 0.5 * math.pi),))
    coil = Scene(field=None, tip_moment=8.5, stiffness=expression_profile("exp(-s)"), contact_gap=0.01)
    for scene in (wall, coil):
        r = solve(scene)
        assert r.success and r.contact["points"], r.message
        copy = pickle.loads(pickle.dumps(r))
        assert copy.contact == r.contact and copy.tip == r.tip
        np.testing.assert_array_equal(copy.clamp_force, r.clamp_force)
        assert copy.el_residual == r.el_residual
        # the warm start of a path's next state lives in this process: a pickle drops it, a copy keeps it
        assert copy._contact_multipliers is None
        assert cp.copy(r)._contact_multipliers is r._contact_multipliers
        assert cp.deepcopy(r)._contact_multipliers is r._contact_multipliers
