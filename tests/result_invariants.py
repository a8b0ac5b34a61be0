"""The invariant every design and schedule result must keep: ``verified`` and ``success`` never
contradict each other or the message (issue 9, item 5). Used by the tests that produce results."""


def design_contradictions(d: dict) -> list:
    """Contradictions in a ``design --json`` object (empty when consistent)."""
    out = []
    ok, verified, msg = d["success"], d["verified"], d["message"]
    if ok and not (verified and d["reachable"] and d["stable"] and d["snap_free"]):
        out.append("success without verified, reachable, stable and snap-free")
    if verified and not (d["stable"] and d["snap_free"]):
        out.append("verified but not stable and snap-free")
    if ("verified by" in msg) != verified:
        out.append(f"verified is {verified} but the message {'does not say' if verified else 'says'} 'verified by'")
    if ok and any(w in msg for w in ("not verified", "no snap-free path", "not a success", "not reachable")):
        out.append("success, but the message says otherwise")
    if not ok and not msg.strip():
        out.append("not a success, and no reason given")
    if not ok and verified and d["reachable"] and "not a success" not in msg:
        out.append("verified and reachable but not a success, and the message does not say why")
    return out


def schedule_contradictions(d: dict) -> list:
    """Contradictions in a ``schedule --json`` object (empty when consistent)."""
    out = []
    if d["success"] != d["verified"]:
        out.append("a schedule is verified exactly when every claim holds (success)")
    if d["success"] and not (d["snap_free"] and d["all_stable"]):
        out.append("success without snap-free and all stable")
    if ("verification failed" in d["message"]) == bool(d["verified"]) and d["rows"]:
        out.append("verified disagrees with the message")
    if not d["success"] and not d["message"].strip():
        out.append("not a success, and no reason given")
    return out
