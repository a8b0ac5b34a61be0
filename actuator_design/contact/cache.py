"""The contact NLPs kept for reuse, bounded by their estimated memory.

A contact NLP (:class:`~actuator_design.contact.contact_nlp.ContactNLP`) is kept on its solver, so that the
states of a path and a repeated solve on one mesh reuse it. Its IPOPT solver holds the exact Hessian
of the Lagrangian, dense in the nodes (positions are sums over the rod) and, for an energy that
reads positions (a non-uniform field), costly per entry: on 24 elements of degree 10 in a current's
1/r field, 8.5 M instructions and ~1 GB (the instructions grow about like the nodes squared).
Every split round of a contact solve builds a new mesh, so a fine mesh asked in a non-uniform field
once kept 30 such NLPs (18 GB). Each kept NLP is charged :data:`BYTES_PER_INSTRUCTION` per
instruction of the derivative functions its IPOPT solvers built; beyond :data:`BUDGET` the least
recently used are dropped from their solvers (and rebuilt if needed again). The NLP in use is never
dropped, so one NLP larger than the budget still solves.
"""
from __future__ import annotations

import weakref
from collections import OrderedDict
from typing import Tuple

__all__ = ["BUDGET", "BYTES_PER_INSTRUCTION", "keep", "charge", "kept_bytes"]

#: bytes per instruction of the derivative functions (measured 105–117: the process's peak memory
#: against the instructions of nlp_hess_l, nlp_jac_g and nlp_grad at 8, 16 and 24 elements)
BYTES_PER_INSTRUCTION = 120
#: estimated bytes of contact NLPs kept (a self-contact path on the default mesh keeps ~33 NLPs, ~1.1 GB
#: by this estimate; at 1 GB it rebuilt them, 35 % slower)
BUDGET = 2.0e9

# id(nlp) → [weak reference to its solver, its key in the solver's cache, bytes]; an entry leaves
# with its NLP (weakref.finalize), so an id is never reused while its entry is here
_KEPT: "OrderedDict[int, list]" = OrderedDict()


def keep(solver, key: Tuple, nlp) -> None:
    """Record that ``nlp`` (kept as ``solver._contact_nlps[key]``) is in use: the most recently used."""
    entry = _KEPT.get(id(nlp))
    if entry is None:
        _KEPT[id(nlp)] = [weakref.ref(solver), key, 0]
        weakref.finalize(nlp, _KEPT.pop, id(nlp), None)
    else:
        _KEPT.move_to_end(id(nlp))
    _trim()


def charge(nlp, functions) -> None:
    """Add the instructions of ``functions`` (CasADi functions ``nlp`` built) to its charge, and drop
    the least recently used other NLPs while the kept total exceeds :data:`BUDGET`."""
    entry = _KEPT.get(id(nlp))
    if entry is None:
        return
    entry[2] += BYTES_PER_INSTRUCTION * sum(int(f.n_instructions()) for f in functions)
    _KEPT.move_to_end(id(nlp))
    _trim()


def _trim() -> None:
    """Drop the least recently used NLPs (never the last used) while the kept total exceeds the budget."""
    while kept_bytes() > BUDGET and len(_KEPT) > 1:
        _, (solver_ref, key, _) = _KEPT.popitem(last=False)
        solver = solver_ref()
        if solver is not None:
            solver.__dict__.get("_contact_nlps", {}).pop(key, None)


def kept_bytes() -> float:
    """The estimated bytes of the contact NLPs kept now."""
    return float(sum(entry[2] for entry in _KEPT.values()))
