"""Contact benchmark (issue 20): a contact solve at the default mesh against the contact-free solve
of the same rod, both whole ``solve()`` calls in one process.

    python problems/bench_contact.py [--repeat N]

Cases: the free cantilever (the peer), a tip pressed onto a floor, a box edge under the tip (a
polygon), a peg under the rod's middle (one interior contact: element boundaries moved to it),
a rod through a 70 deg bend of a lumen (an interior and a tip contact), and a strip coiled by a tip
moment until its turns press on each other (self-contact: a load ramp from rest, then element
boundaries at both points of each contact), with its own peer, the same strip solved without
self-contact (``coil peer``; its ratio is to that).

``first`` is the first call (it builds the transcription and the NLPs; the contact cases after the
free one share its transcription), ``again`` the median of the repeated calls (cached NLPs, taken
round-robin over the cases); the ratios are to the free solve's times. Each contact case's answer
is checked as the tests check it (success, stable); the numbers are printed, not judged.
"""
from __future__ import annotations

import argparse
import math
import statistics
import time

from actuator_design.equilibrium.pipeline import solve
from actuator_design.contact.obstacles import Lumen, Peg, Polygon, Wall
from actuator_design.equilibrium.options import SolverOptions
from actuator_design.model.profiles import expression_profile
from actuator_design.model.scene import Scene

COIL = Scene(field=None, tip_moment=8.5, stiffness=expression_profile("exp(-s)"), contact_gap=0.01)

CASES = {
    "free": Scene(field=None, tip_force=(0.0, -1.0)),
    "floor (tip)": Scene(field=None, tip_force=(0.0, -1.0), obstacles=(Wall((0.0, -0.1), 0.5 * math.pi),)),
    "box edge (tip)": Scene(field=None, tip_force=(0.0, -1.0),
                            obstacles=(Polygon(((0.5, -0.5), (1.5, -0.5), (1.5, -0.1), (0.5, -0.1))),)),
    "peg (interior)": Scene(field=None, tip_force=(0.0, -1.6), obstacles=(Peg((0.6, -0.2), 0.1),), contact_gap=0.025),
    "lumen bend (interior + tip)": Scene(field=None, contact_gap=0.01, obstacles=(
        Lumen((-0.1, 0.0), 0.0, 0.06, (("straight", 0.3), ("arc", 0.5, math.radians(70)), ("straight", 0.6))),)),
    "coil peer (no self-contact)": COIL,
    "coil (self-contact)": COIL,
}
#: options of the cases that need their own (default: SolverOptions())
OPTIONS = {"coil peer (no self-contact)": SolverOptions(self_contact=False)}
#: the peer each ratio is to (default: "free")
PEER = {"coil (self-contact)": "coil peer (no self-contact)"}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args(argv)
    first, again, results = {}, {name: [] for name in CASES}, {}
    for name, scene in CASES.items():
        t = time.perf_counter()
        results[name] = solve(scene, OPTIONS.get(name, SolverOptions()))
        first[name] = time.perf_counter() - t
    # the repeated calls round-robin over the cases, so that every case meets the machine's
    # changing speed (other processes, clock) alike
    for _ in range(args.repeat):
        for name, scene in CASES.items():
            t = time.perf_counter()
            solve(scene, OPTIONS.get(name, SolverOptions()))
            again[name].append(time.perf_counter() - t)
    rows = {name: (first[name], statistics.median(again[name]), results[name]) for name in CASES}
    print(f"{'case':30s} {'first s':>9s} {'again s':>9s} {'first/free':>11s} {'again/free':>11s}  result")
    for name, (first, again, r) in rows.items():
        f0, a0, _ = rows[PEER.get(name, "free")]
        n = len([p for p in (r.contact or {}).get("points", []) if not p["weak"]])
        note = f"{'ok' if r.success and r.stable else 'FAILED: ' + r.status}, {n} contact point(s)"
        print(f"{name:30s} {first:9.3f} {again:9.4f} {first / f0:11.1f} {again / a0:11.1f}  {note}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
