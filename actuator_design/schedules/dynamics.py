"""Small vibrations about an equilibrium, and when a schedule stops being quasi-static (issue 19 item 4).

About an equilibrium θ*, small motions θ = θ* + δθ(t) of a rod of uniform mass per length ρA obey
M δθ̈ + H δθ = 0 (THEORY §7's reduced Hessian H, energy unit B0/ℓ), with the kinetic energy's mass
matrix in the nodal angles

    M = ∫₀¹ J(s)ᵀ J(s) ds,    J(s) = ∂r(s)/∂θ   (the centre line's motion, r in units of ℓ),

evaluated with the transcription's quadrature (the clamp's angle fixed). The eigenvalues ω² of
H v = ω² M v are the squared natural frequencies in units of B0/(ρA ℓ⁴); the lowest, ω₁, is the slowest
mode (a straight cantilever: ω₁ = 1.87510² = 3.5160, ω₂ = 4.69409² = 22.035, the Euler–Bernoulli
values). With a modal damping ratio ζ (the rod's material damping, user-given: elastomers ~0.02–0.2)
a disturbance of that mode decays as exp(−ζ ω₁ t): the **relaxation time** τ = 1/(ζ ω₁) (for
ζ < 1; an overdamped mode, ζ ≥ 1, relaxes in τ = (ζ + √(ζ² − 1))/ω₁). A schedule step that
changes the field faster than τ does not leave the rod at equilibrium before the next one: the
quasi-static assumption of paths and designs fails there (:func:`quasi_static`). That verdict
depends on how finely the schedule is cut; the size of the failure much less so: the **tip lag**
is how far the tip x(t) gets from its quasi-static position p*(t) during each step, with the
slowest mode's dynamics applied to the tip, ẍ + 2ζω₁ẋ + ω₁²(x − p*) = 0, p* linear in time over
each step (ω₁ that of the state the step arrives at) and the rod at rest at the start. The lag
e = x − p* then obeys ë + 2ζω₁ė + ω₁²e = −2ζω₁v within a step of tip speed v, and ė drops by the
change of v at each step's start; each step is solved exactly (a matrix exponential) and |e|
sampled 32 times a period (at most :data:`MAX_LAG_SAMPLES` times a step). A steady
speed v gives the lag 2ζv/ω₁; a sudden start rings with amplitude ~v/ω₁.
The frequencies assume a uniform ρA and ignore the fluid around the rod and the rotary inertia of
its section.
"""
from __future__ import annotations

import math
import weakref
from typing import Optional

import casadi as ca
import numpy as np
import scipy.linalg as sla

from actuator_design.continuation.loading import follow_path
from actuator_design.equilibrium.solver import get_solver

__all__ = ["natural_frequencies", "relaxation_time", "quasi_static", "schedule_states", "DEFAULT_DAMPING_RATIO",
           "QUASI_STATIC_FACTOR"]

#: the modal damping ratio assumed when the user gives none (a soft silicone elastomer)
DEFAULT_DAMPING_RATIO = 0.05
#: a step is quasi-static when it lasts at least this many relaxation times (one: a step faster than
#: the rod relaxes leaves it ringing, or lagging, when the next begins)
QUASI_STATIC_FACTOR = 1.0
#: the tip lag is sampled at most this many times within one step (32 times a period below that)
MAX_LAG_SAMPLES = 4096


def natural_frequencies(result, count: int = 3) -> np.ndarray:
    """The ``count`` lowest natural frequencies ω of small vibrations about the equilibrium
    ``result`` (units of √(B0/(ρA ℓ⁴)), rad per unit time; NaN for an unstable mode: ω² < 0).

    Returns
    -------
    ndarray, shape (count,)
    """
    H, M = _matrices(result)
    k = min(count, H.shape[0])
    try:  # M v = (1/ω²) H v: M is nearly singular (fine wiggles of θ barely move the rod), H is not
        mu = sla.eigh(M, H, eigvals_only=True)[::-1][:k]
        return np.sqrt(1.0 / mu)
    except sla.LinAlgError:  # H not positive definite: an unstable state, ω² < 0 for some mode
        w2 = sla.eigh(H, M + 1e-12 * np.trace(M) / M.shape[0] * np.eye(M.shape[0]), eigvals_only=True)[:k]
        return np.where(w2 > 0, np.sqrt(np.abs(w2)), np.nan)


def relaxation_time(result, mass_per_length: Optional[float], damping_ratio: float = DEFAULT_DAMPING_RATIO,
                    scales=None) -> float:
    """The slowest mode's relaxation time about ``result``: 1/(ζ ω₁) (module doc), in s when
    ``scales`` (the scene's :class:`~actuator_design.model.scene.Scales`) and ``mass_per_length`` (ρA,
    kg/m) are given, else in units of √(ρA ℓ⁴/B0). NaN for an unstable state."""
    if not (math.isfinite(damping_ratio) and damping_ratio > 0):
        raise ValueError(f"damping ratio: must be a finite number > 0, got {damping_ratio!r}")
    w1 = float(natural_frequencies(result, 1)[0])
    if not w1 > 0:
        return math.nan
    z = damping_ratio
    tau = 1.0 / (z * w1) if z < 1.0 else (z + math.sqrt(z * z - 1.0)) / w1
    if scales is not None and mass_per_length is not None:
        tau *= math.sqrt(mass_per_length * scales.length**4 / scales.bending_stiffness)
    return tau


def quasi_static(states, table, scales) -> Optional[dict]:
    """Whether each step of a timed schedule lasts at least :data:`QUASI_STATIC_FACTOR` relaxation
    times of the state it arrives at, and how far the tip trails its quasi-static path (in place:
    every row of ``table`` gets ``relaxation_time_s``, ``quasi_static`` and ``tip_lag``, rod lengths:
    the module docstring's largest lag during the step; NaN at an unstable state, after which the
    rod is taken to start again from rest).

    Parameters
    ----------
    states : sequence of EquilibriumResult
        The state at each schedule step (the verification's loading path), as many as ``table``.
    table : list of dict
        Rows of :func:`~actuator_design.schedules.schedule.schedule_table` with ``time_s``.
    scales : Scales
        With ``mass_per_length`` > 0 (the rod's density given).

    Returns
    -------
    dict or None
        ``slowest_relaxation_time_s`` and its ``step``, ``damping_ratio`` (``damping_assumed``: the
        default), ``factor``, ``too_fast`` (the steps shorter than factor × τ, with their durations),
        ``largest_tip_lag`` (rod lengths; ``largest_tip_lag_m`` in m) and its ``tip_lag_step``;
        None when the schedule is not timed, the states do not match it or the density is unknown.
    """
    if (scales is None or not scales.mass_per_length > 0 or not table or "time_s" not in table[0]
            or len(states) != len(table)):
        return None
    zeta = scales.damping_ratio or DEFAULT_DAMPING_RATIO
    taus, fast, lags = [], [], []
    lag, rate, speed = np.zeros(2), np.zeros(2), np.zeros(2)  # e, ė (rod lengths, per s), v of p*
    for k, (row, state) in enumerate(zip(table, states)):
        tau = relaxation_time(state, scales.mass_per_length, zeta, scales)
        row["relaxation_time_s"] = tau
        dt = row["time_s"] - table[k - 1]["time_s"] if k else math.inf
        row["quasi_static"] = bool(k == 0 or (math.isfinite(tau) and dt >= QUASI_STATIC_FACTOR * tau))
        largest = 0.0
        if k and math.isfinite(tau):
            lag, rate, speed, largest = _lag_after(lag, rate, speed, _tip(state) - _tip(states[k - 1]), dt, tau, zeta)
        elif k:  # an unstable state: no lag to give; the rod taken to start again from rest
            lag, rate, speed, largest = np.zeros(2), np.zeros(2), np.zeros(2), math.nan
        row["tip_lag"] = largest
        taus.append(tau)
        lags.append(row["tip_lag"])
        if not row["quasi_static"]:
            fast.append({"step": k, "duration_s": dt, "relaxation_time_s": tau})
    finite = [(t, k) for k, t in enumerate(taus) if math.isfinite(t)]
    slowest, step = max(finite) if finite else (math.nan, None)
    known = [(v, k) for k, v in enumerate(lags) if not math.isnan(v)]
    lag, lag_step = max(known) if known else (math.nan, None)
    return {"slowest_relaxation_time_s": slowest, "step": step, "damping_ratio": zeta,
            "damping_assumed": not scales.damping_ratio, "factor": QUASI_STATIC_FACTOR, "too_fast": fast,
            "largest_tip_lag": lag, "largest_tip_lag_m": lag * scales.length, "tip_lag_step": lag_step}


def _tip(state) -> np.ndarray:
    return np.array([float(state.tip["x"]), float(state.tip["y"])])


def _lag_after(lag, rate, speed, move, dt: float, tau: float, zeta: float):
    """(e, ė, v, the largest |e| during the step) after a step of ``dt`` s in which the
    quasi-static tip moves by ``move`` (rod lengths, (2,)) at a steady speed v, from (e, ė) at its
    start and the previous step's speed (module docstring; ω₁ from ``tau`` and ``zeta``). A step of
    no duration moves p* at once: e drops by the whole move."""
    if not dt > 0:
        return lag - move, rate, speed, float(np.hypot(*(lag - move)))
    w = 1.0 / (zeta * tau) if zeta < 1.0 else (zeta + math.sqrt(zeta * zeta - 1.0)) / tau
    v = move / dt
    rate = rate - (v - speed)  # ẋ is continuous, ṗ* jumps
    A = np.array([[0.0, 1.0, 0.0], [-w * w, -2.0 * zeta * w, -2.0 * zeta * w], [0.0, 0.0, 0.0]])
    # the largest |e| during the step: sampled every 1/32 of a period (every transient is gone,
    # e^−60, after 60 τ: the steady lag holds from there on)
    span = min(dt, 60.0 * tau)
    period = 2.0 * math.pi / (w * math.sqrt(1.0 - zeta * zeta)) if zeta < 1.0 else tau
    n = int(min(max(math.ceil(32.0 * span / period), 1), MAX_LAG_SAMPLES))
    E = sla.expm(A * (span / n))
    S = np.vstack([lag, rate, v])  # a column per coordinate: (e, ė, v)
    largest = float(np.hypot(*lag))  # from the step's start (e is continuous)
    for _ in range(n):
        S = E @ S
        largest = max(largest, float(np.hypot(S[0, 0], S[0, 1])))
    if dt > span:
        S[:2] = np.vstack([-2.0 * zeta * v / w, np.zeros(2)])
        largest = max(largest, float(np.hypot(*S[0])))
    return S[0].copy(), S[1].copy(), v, largest


def schedule_states(scene, schedule, options=None) -> list:
    """The state at every step of a field schedule ([{"h", "phi"}, ...], from rest), by one loading
    path through it (:func:`~actuator_design.continuation.loading.follow_path`); fewer states than
    steps when the path stops (then :func:`quasi_static` makes no check)."""
    steps = [{"h": float(q["h"]), "phi": float(q["phi"])} for q in schedule]
    if len(steps) < 2:
        return []
    return list(follow_path(scene, options, steps).states)


def _matrices(result):
    """(H, M): the reduced Hessian and the kinetic mass matrix at ``result``'s state, free nodes."""
    sv = get_solver(result.scene, result.options)
    z = np.asarray(result.z, float)
    ker = sv.kernel  # the solver's compiled Hessian (the CasADi one takes ~0.1 s in a fitted field)
    ker.set_params(sv.parameter_vector(result.scene))
    ker.evaluate(z[1:])
    H = ker.hessian_dense()
    M = _mass_function(sv)(z)
    return 0.5 * (H + H.T), M


_MASS = weakref.WeakKeyDictionary()  # per solver (an id could be reused by a new one)


def _mass_function(sv):
    """z ↦ M (free nodes × free nodes), built once per solver."""
    key = sv
    if key not in _MASS:
        tr = sv.transcription
        z = ca.SX.sym("z", tr.nodes.size)
        thq, _ = tr.point_values(z)
        xq, yq = tr.point_positions(thq)
        w = ca.DM(np.asarray(tr.quadrature_weights, float))
        Jx, Jy = ca.jacobian(xq, z)[:, 1:], ca.jacobian(yq, z)[:, 1:]
        M = ca.mtimes(Jx.T, ca.diag(w) @ Jx) + ca.mtimes(Jy.T, ca.diag(w) @ Jy)
        f = ca.Function("kinetic_mass", [z], [M])
        _MASS[key] = lambda zz: np.asarray(ca.densify(f(zz)), float)
    return _MASS[key]
