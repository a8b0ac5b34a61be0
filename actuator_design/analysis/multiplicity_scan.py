"""Counting the roots of the shooting residual coarse to fine (the engine of the multiplicity maps).

The multiplicity map counts, at every grid point, the sign changes of the free-end residual
r(γ) = b(1)θ'(1) − m on a uniform *fine* grid of γ = θ'(0) over the a-priori window [−W, W]
(THEORY §5, §7; :mod:`.shooting_scan`), and the fine grid is what the resolution claim of the map is
about (:func:`~.shooting_scan.min_gamma_points`). Evaluating r at every fine sample is wasteful:
r is smooth, and the Jacobi field integrated alongside gives its slope r'(γ) = bη'(1) at every
sample for the price of two more equations. So the fine grid is visited coarse to fine:

1. r and r' on every ``k``-th fine sample (``k`` = :data:`COARSE_STEP` fine steps, fewer when the
   window has under :data:`MIN_COARSE_INTERVALS` such steps), for all the scenes of a block at once;
2. an interval between two evaluated samples is *refined* (its middle fine sample evaluated, and the
   two halves examined in turn) while it is longer than one fine step and r may vanish in it:
   r has opposite signs or a zero at its ends; or r is *steep* there, min(|r_a|, |r_b|) <
   β·H·max(|r'_a|, |r'_b|) (a line with the steeper end slope, drawn from the end nearer to zero,
   would reach zero within β = :data:`TANGENT_REACH` interval lengths H); or |r| *dips*: the slope
   at a, the secant and the slope at b say that |r| falls and later rises, so |r| has a minimum
   inside;
3. an interval left unrefined has r of one sign at both ends, |r| large against β·H times the
   steeper slope, and no sign of a minimum of |r| inside: r is assumed not to vanish in it. The sign
   changes of the fine grid are then those between consecutive evaluated samples, and each root's
   bracket is one fine step wide, as in a full scan.

The steep test catches the narrow excursions of r near shots that pass close to a hyperbolic state
of the IVP (THEORY §7; the close root pairs of :func:`~.shooting_scan.min_gamma_points`), whose
slopes are orders of magnitude above |r|/H; the dip test catches a minimum of |r| between two ends
that both look harmless.

The residual at an evaluated sample is the very number a full fine scan computes (same problem,
same arithmetic per element, :func:`residual_at`), so the counts
equal the full scan's wherever assumption 3 holds. They equal it at every point of THEORY §5's
(h², p) map (200 × 200 points, ``problems/bench_multiplicity.py``) and of (h, p) maps at φ = π/4
(h ≤ 11) and φ = π/2 (h ≤ 9), of a hard-magnetic rod and of graded fibres (8 000 points; checked
when these constants were chosen). They still do with β = 1, not with β = 0.5 (one point of the
graded-fibre map): β = 2 keeps a factor 2 to 4. The Morse index of each root is Sturm's count from the end of its
one-step bracket with the smaller |r|, as in the full scan (THEORY §7).
"""
from __future__ import annotations

from typing import Dict, Optional, Tuple

import numpy as np

from actuator_design.analysis.shooting_scan import ShootingProblem

__all__ = ["COARSE_STEP", "MIN_COARSE_INTERVALS", "TANGENT_REACH", "CHUNK", "count_roots",
           "coarse_factor", "residual_at"]

#: Fine γ steps per coarse step (a power of two, so that bisection lands on fine samples).
COARSE_STEP = 16
#: The coarse grid keeps at least this many intervals over the window (else a smaller power of two).
MIN_COARSE_INTERVALS = 10
#: β: r steeper than |r| / (β H) at either end of an interval marks it for refinement (rule 2).
TANGENT_REACH = 2.0
#: Samples integrated together (fewer numpy calls per sample against arrays that fit the caches).
CHUNK = 32768


def coarse_factor(n_fine: int) -> int:
    """Fine steps per coarse step for a window of ``n_fine`` samples: :data:`COARSE_STEP`, halved
    until the window spans at least :data:`MIN_COARSE_INTERVALS` coarse steps (at least 1)."""
    k = COARSE_STEP
    while k > 1 and (n_fine - 1) // k < MIN_COARSE_INTERVALS:
        k //= 2
    return k


def residual_at(prob: ShootingProblem, rows: np.ndarray, gammas: np.ndarray,
                steps: Optional[np.ndarray] = None):
    """r, Sturm data and r'(γ) for a flat list of (scene, γ) samples of ``prob``, integrated at once.

    The same arithmetic as :meth:`~.shooting_scan.ShootingProblem.residual` element by element (so
    the same numbers, bit for bit), for samples spread unevenly over the batch (e.g. a coarse scan
    and its refinements). With ``steps`` (autonomous batches only) each scene has its own number of
    RK4 steps, and its numbers are those of a problem built with that number.

    Parameters
    ----------
    prob : ShootingProblem
        B scenes.
    rows : ndarray of int, shape (K,)
        Batch index of the scene of each sample.
    gammas : ndarray, shape (K,)
        γ = θ'(0) of each sample (rad per rod length).
    steps : ndarray of int, shape (B,), optional
        RK4 steps of each scene of the batch (default: ``prob.N`` for all).

    Returns
    -------
    r, zeros, eta1, slope : ndarrays, shape (K,)
        Residual, sign changes of η over the step points in (0, 1], η(1), and
        r'(γ) = bη'(1) (THEORY §7).
    """
    rows = np.asarray(rows, int)
    g = np.asarray(gammas, float)
    order = None
    if steps is not None:
        if not prob.autonomous:
            raise ValueError("per-scene step counts need an autonomous batch")
        n = np.asarray(steps, int)[rows]
        order = np.argsort(n, kind="stable")  # fewest steps first: the active samples are a suffix
        rows, g, n = rows[order], g[order], n[order]
    coef = {name: getattr(prob, name)[:, rows, 0] for name in ("A", "Bs", "D", "nx", "ny", "invb")}
    out = prob.integrate(g, coef, prob.theta0[rows, 0], prob.m[rows, 0], prob.b0[rows, 0], True,
                          None if order is None else n)
    if order is None:
        return out
    back = np.empty_like(order)
    back[order] = np.arange(order.size)
    return tuple(o[back] for o in out)


class _Samples:
    """r, Sturm data and r' at requested (scene, fine index) pairs of one block of scenes."""

    def __init__(self, prob: ShootingProblem, window: np.ndarray, n_fine: np.ndarray, steps):
        self.prob, self.window, self.steps = prob, window, steps
        # linspace(−1, 1, G) of every distinct G, end to end, and where each scene's starts
        sizes, which = np.unique(n_fine, return_inverse=True)
        self.unit = np.concatenate([np.linspace(-1.0, 1.0, int(G)) for G in sizes])
        self.start = (np.cumsum(sizes) - sizes)[which]

    def gammas(self, scene: np.ndarray, index: np.ndarray) -> np.ndarray:
        """γ of fine sample ``index`` of each ``scene``: W·linspace(−1, 1, G)[index], the numbers of
        a full scan bit for bit."""
        return self.window[scene] * self.unit[self.start[scene] + index]

    def __call__(self, scene: np.ndarray, index: np.ndarray):
        g = self.gammas(scene, index)
        parts = [residual_at(self.prob, scene[i:i + CHUNK], g[i:i + CHUNK], self.steps)
                 for i in range(0, scene.size, CHUNK)]
        if not parts:
            return tuple(np.empty(0, dtype) for dtype in (float, int, float, float))
        return tuple(np.concatenate([p[v] for p in parts]) for v in range(4))


def _may_vanish(ra, rb, da, db, length):
    """bool per interval: r may vanish inside (rule 2 of the module docstring).

    ``ra``, ``rb``: r at the ends; ``da``, ``db``: r' there; ``length``: the interval's γ length.
    """
    sign = np.sign(ra)
    steep = np.minimum(np.abs(ra), np.abs(rb)) < TANGENT_REACH * length * np.maximum(np.abs(da), np.abs(db))
    # |r| falls before it rises (the slope at a, the secant, the slope at b, in this order)
    down_a, secant, up_b = sign * da < 0, sign * (rb - ra), sign * db > 0
    dip = (down_a & ((secant > 0) | up_b)) | ((secant < 0) & up_b)
    return (ra * rb <= 0) | steep | dip


def count_roots(prob: ShootingProblem, window: np.ndarray, n_fine: np.ndarray,
                stability: bool = True, steps: Optional[np.ndarray] = None
                ) -> Tuple[np.ndarray, np.ndarray, Dict[str, int]]:
    """Sign changes of r on each scene's fine γ grid, and the stable roots among them.

    Parameters
    ----------
    prob : ShootingProblem
        The B scenes of the block, with their common number of RK4 steps (or with ``steps``).
    window : ndarray, shape (B,)
        Half-width W of each scene's γ window (rad per rod length).
    n_fine : ndarray of int, shape (B,)
        Fine samples G of each scene over [−W, W] (odd).
    stability : bool
        Also count the stable roots (Sturm's Morse index = 0, THEORY §7); else ``stable`` is −1.
    steps : ndarray of int, shape (B,), optional
        RK4 steps of each scene (autonomous blocks only, :func:`residual_at`).

    Returns
    -------
    counts, stable : ndarray of int, shape (B,)
    stats : dict
        ``samples`` evaluated and ``fine_samples`` of the full scan (their ratio is the saving).
    """
    window = np.asarray(window, float)
    n_fine = np.asarray(n_fine, int)
    B = window.size
    sample = _Samples(prob, window, n_fine, steps)
    step = 2.0 * window / (n_fine - 1)  # fine γ step of each scene
    # 1. the coarse grid: every k-th fine sample and the last one
    scene, index = [], []
    for i in range(B):
        G = int(n_fine[i])
        idx = np.arange(0, G, coarse_factor(G))
        if idx[-1] != G - 1:
            idx = np.append(idx, G - 1)
        scene.append(np.full(idx.size, i))
        index.append(idx)
    scene, index = np.concatenate(scene), np.concatenate(index)
    r, Z, eta, dr = sample(scene, index)
    n_samples = scene.size
    zeros = [(scene[r == 0.0], index[r == 0.0], Z[r == 0.0], eta[r == 0.0])]
    store = [(scene, index, r)]
    same = scene[1:] == scene[:-1]  # consecutive coarse samples of one scene bound an interval
    lo, hi = np.flatnonzero(same), np.flatnonzero(same) + 1
    iv = {"s": scene[lo], "a": index[lo], "b": index[hi]}
    for name, v in (("r", r), ("Z", Z), ("e", eta), ("d", dr)):
        iv[name + "a"], iv[name + "b"] = v[lo], v[hi]
    brackets = []
    # 2. refine the intervals in which r may vanish, down to one fine step
    while iv["s"].size:
        long = iv["b"] - iv["a"] > 1
        split = long & _may_vanish(iv["ra"], iv["rb"], iv["da"], iv["db"],
                                   (iv["b"] - iv["a"]) * step[iv["s"]])
        done = ~long & (iv["ra"] * iv["rb"] < 0.0)
        brackets.append({k: v[done] for k, v in iv.items()})
        iv = {k: v[split] for k, v in iv.items()}
        if not iv["s"].size:
            break
        mid = (iv["a"] + iv["b"]) // 2
        rm, Zm, em, dm = sample(iv["s"], mid)
        n_samples += mid.size
        hit = rm == 0.0
        zeros.append((iv["s"][hit], mid[hit], Zm[hit], em[hit]))
        store.append((iv["s"], mid, rm))
        left = {k: v for k, v in iv.items()}
        left.update(b=mid, rb=rm, Zb=Zm, eb=em, db=dm)
        right = {k: v for k, v in iv.items()}
        right.update(a=mid, ra=rm, Za=Zm, ea=em, da=dm)
        iv = {k: np.concatenate([left[k], right[k]]) for k in iv}
    # 3. count: one root per one-step bracket, one per exact zero (as a full scan counts them)
    br = {k: np.concatenate([b[k] for b in brackets]) for k in brackets[0]}
    zs, zi, zZ, ze = (np.concatenate([z[v] for z in zeros]) for v in range(4))
    counts = np.bincount(br["s"], minlength=B) + np.bincount(zs, minlength=B)
    stats = {"samples": int(n_samples), "fine_samples": int(n_fine.sum())}
    if not stability:
        return counts, np.full(B, -1), stats
    # Morse index from the bracket end with the smaller |r| (Sturm, THEORY §7)
    left = np.abs(br["ra"]) <= np.abs(br["rb"])
    Zb, eb = np.where(left, br["Za"], br["Zb"]), np.where(left, br["ea"], br["eb"])
    stable_b = (Zb == 0) & (eb * (br["rb"] - br["ra"]) > 0)
    stable = np.bincount(br["s"][stable_b], minlength=B)
    if zs.size:  # exact zeros: slope from the fine neighbours (evaluated: their intervals split)
        known = {}
        for s_, i_, r_ in store:
            known.update(zip(zip(s_.tolist(), i_.tolist()), r_.tolist()))
        for s_, i_, Z_, e_ in zip(zs.tolist(), zi.tolist(), zZ.tolist(), ze.tolist()):
            G = int(n_fine[s_])
            dz = known[(s_, i_ + 1)] - known[(s_, i_ - 1)] if 0 < i_ < G - 1 else 0.0
            stable[s_] += int(Z_ == 0 and e_ * dz > 0)
    return counts, stable, stats
