"""Tangent tip stiffness of an equilibrium from the NLP's parametric sensitivity (THEORY §6–7).

At an equilibrium the reduced gradient vanishes, g(z, P) = 0, with z the free nodal angles and P the
NLP parameter vector. Differentiating with respect to the tip loads L = (fx, fy, m_tip) gives
dz/dL = −H_r⁻¹ ∂g/∂L (H_r the reduced Hessian), and the compliance matrix

    C = d(x(1), y(1), θ(1)) / d(fx, fy, m_tip) = −J_tip H_r⁻¹ ∂g/∂L,     J_tip = ∂(x(1), y(1), θ(1))/∂z.

Because the dead-load energy is −fx x(1) − fy y(1) − m θ(1), ∂g/∂L = −J_tipᵀ and C = J H_r⁻¹ Jᵀ is
symmetric (Maxwell–Betti reciprocity): the code computes ∂g/∂L generically from the CasADi
expressions, so the symmetry is a check, not an assumption. Its inverse is the stiffness matrix. The
vertical stiffness dp/dv1 (fx, m_tip held fixed) is 1/C_yy; at φ = 0, p = 0, b ≡ 1, α ≡ 0 it is
THEORY §6's s(h), and in SI units K = s · B0/ℓ³ (:attr:`Scales.stiffness`).

A hard-magnetic rod (THEORY §9) needs nothing special: the derivatives are generic. At φ = 0 with
an axial magnetisation (β = 0) the linearised equation is θ1'' − (2h² + h_r) θ1 + 1 = 0, i.e.
§6's s(h) at h_eff² = h² + h_r/2. Sweeping the field (:func:`stiffness_field_curve`) scales h_r
with H like h (the parameter lens' field rule).

A scene without a tip-force (or tip-moment) term has no such parameter: a *companion scene* with
the term added at value zero is used (a different NLP structure, same equilibrium), and the result
says so in ``notes``.

All CasADi functions here (∂g/∂P, the tip Jacobian, third-derivative contractions for fold
location) are built once per solver (:func:`sensitivities`) and cached.
"""
from __future__ import annotations

import math
import weakref
from dataclasses import dataclass, field, replace
from functools import cached_property
from typing import Dict, List, Optional, Sequence

import casadi as ca
import numpy as np

from actuator_design.analysis.registration import register
from actuator_design.equilibrium.acceptance import graded_for_scenes, residual_problem
from actuator_design.equilibrium.options import SolverOptions
from actuator_design.equilibrium.pipeline import solve
from actuator_design.equilibrium.result import EquilibriumResult
from actuator_design.equilibrium.solver import EquilibriumSolver, get_solver
from actuator_design.model.scene import Scene, UniformField
from actuator_design.physics import parameters as lens
from actuator_design.physics.registry import term_class
from actuator_design.reduced.system import reduced_system
from actuator_design.reference.closed_forms import lowload_stiffness

__all__ = ["Sensitivities", "sensitivities", "TipStiffness", "tip_stiffness",
           "StiffnessCurve", "stiffness_field_curve", "LOAD_NAMES"]

#: Tip loads (the lens entries each term declares conjugate to the free end's x, y and angle) and
#: the tip quantities they are work-conjugate to.
LOAD_NAMES = lens.tip_loads()
TIP_NAMES = ("x", "y", "angle")

_SENS: "weakref.WeakKeyDictionary[EquilibriumSolver, Sensitivities]" = weakref.WeakKeyDictionary()


class Sensitivities:
    """Derivative functions of one built :class:`EquilibriumSolver`, taken from its reduced system
    (:class:`~actuator_design.reduced.ReducedSystem`, built once and cached).

    Attributes
    ----------
    g_P : casadi.Function
        (z_free (n,), P (nP,)) → ∂g/∂P, shape (n, nP): sensitivity of the reduced gradient.
    tip_jac : casadi.Function
        (z_free, P) → ∂(x(1), y(1), θ(1))/∂z_free, shape (3, n).
    """

    def __init__(self, solver: EquilibriumSolver):
        self.solver = solver
        self.layout = solver.layout

    @cached_property
    def system(self):
        return reduced_system(self.solver)

    # each function is built on first use
    @cached_property
    def g_P(self) -> ca.Function:
        return self.system.f_g_P

    @cached_property
    def tip_jac(self) -> ca.Function:
        return self.system.f_tip_jacobian_P


def sensitivities(solver: EquilibriumSolver) -> Sensitivities:
    """The cached :class:`Sensitivities` of ``solver`` (built on first use)."""
    sens = _SENS.get(solver)
    if sens is None:
        sens = _SENS[solver] = Sensitivities(solver)
    return sens


# -- tip stiffness -------------------------------------------------------------------------------
@dataclass
class TipStiffness:
    """Tangent tip compliance and stiffness of one equilibrium (dimensionless, THEORY §5).

    Attributes
    ----------
    compliance : ndarray, shape (k, k)
        C[i, j] = d tip_i / d load_j, tips (x(1), y(1), θ(1)) and loads (fx, fy, m_tip) (k = 3), or
        the first two of each (k = 2). Units: ℓ per B0/ℓ² = ℓ³/B0 for force/position, 1/(B0/ℓ)
        for moment/angle, ℓ²/B0 for the mixed entries.
    stiffness : ndarray, shape (k, k)
        C⁻¹ (NaN if C is singular).
    vertical : float
        dp/dv1 = 1/C_yy with fx and m_tip fixed: the dimensionless stiffness s of THEORY §6
        (units of B0/ℓ³).
    vertical_N_per_m : float or None
        ``vertical`` · B0/ℓ³ for physical scenes.
    symmetry_error : float
        max |C − Cᵀ| / max |C| (Maxwell–Betti reciprocity; ≈ rounding at a converged state).
    loads, tips : tuple of str
        Row/column names.
    equilibrium : EquilibriumResult
        The state it was computed at.
    companion : bool
        True when a load term absent from the scene was added at value zero (different NLP).
    notes : list of str
    """

    compliance: np.ndarray
    stiffness: np.ndarray
    vertical: float
    vertical_N_per_m: Optional[float]
    symmetry_error: float
    loads: tuple
    tips: tuple
    equilibrium: EquilibriumResult
    companion: bool = False
    notes: List[str] = field(default_factory=list)

    def to_dict(self) -> Dict[str, object]:
        """Plain data (JSON contract of ``actuator-design stiffness --json``)."""
        eq = self.equilibrium
        sc = eq.scene.scales
        out = {
            "vertical_stiffness": float(self.vertical),
            "vertical_stiffness_N_per_m": self.vertical_N_per_m,
            "compliance": self.compliance.tolist(),
            "stiffness": self.stiffness.tolist(),
            "loads": list(self.loads),
            "tips": list(self.tips),
            "symmetry_error": float(self.symmetry_error),
            "companion_scene": bool(self.companion),
            "notes": list(self.notes),
            "equilibrium": {"success": bool(eq.success), "stable": bool(eq.stable),
                            "tip": {k: float(v) for k, v in eq.tip.items()}, "energy": float(eq.energy),
                            "h": float(eq.scene.h), "phi": float(eq.scene.phi), "p": float(eq.scene.p),
                            "morse_index": int(eq.morse_index)},
            "units": {"vertical_stiffness": "B0/l^3", "compliance": "l^3/B0 (force-position), "
                      "1/(B0/l) (moment-angle), l^2/B0 (mixed)"},
        }
        if sc is not None:
            out["stiffness_scale_N_per_m"] = sc.stiffness
        return out


def companion_scene(scene: Scene, moment: bool = True):
    """``scene`` with the tip loads needed for the compliance added at value zero.

    Returns
    -------
    (Scene, list of str)
        The companion scene and notes on what was added (empty when nothing was).
    """
    notes = []
    for name in LOAD_NAMES if moment else LOAD_NAMES[:2]:  # each probe load's term, added at zero
        term = lens.parameter(name).term
        if not term_class(term).present(scene):
            scene = lens.parameter(name).require(scene)
            what = term.replace("_", " ")
            notes.append(f"the scene has no {what} term: a companion scene with a zero {what} was "
                         "built (a different NLP structure, same equilibrium)")
    return scene, notes


def compliance_at(solver: EquilibriumSolver, z: np.ndarray, params: np.ndarray,
                  loads: Sequence[str] = LOAD_NAMES) -> np.ndarray:
    """Compliance matrix −J_tip H_r⁻¹ ∂g/∂L at the node vector ``z`` (shape (n+1,)).

    Parameters
    ----------
    solver : EquilibriumSolver
        Its structure must contain the loads named in ``loads``.
    z : ndarray, shape (n_nodes,)
        An equilibrium (θ at the nodes, z[0] the clamp angle).
    params : ndarray, shape (nP,)
    loads : sequence of str
        Subset of ("fx", "fy", "m_tip"), in order; the rows are the conjugate tip quantities.

    Returns
    -------
    ndarray, shape (len(loads), len(loads))
    """
    sens = sensitivities(solver)
    zr = z[1:]
    _, _, H = solver.f_grad_hess(zr, params)
    H = np.asarray(H, float)
    gP = np.asarray(sens.g_P(zr, params), float)
    J = np.asarray(sens.tip_jac(zr, params), float)
    cols = [solver.layout.slices[name].start for name in loads]
    rows = [LOAD_NAMES.index(name) for name in loads]
    dz = -np.linalg.solve(0.5 * (H + H.T), gP[:, cols])
    return J[rows] @ dz


def tip_stiffness(target, options: Optional[SolverOptions] = None, *, moment: bool = True,
                  initial=None) -> TipStiffness:
    """Tangent tip compliance/stiffness of an equilibrium.

    Parameters
    ----------
    target : EquilibriumResult or Scene
        An equilibrium (its scene and options are used), or a scene to solve first (with
        ``options`` and ``initial``).
    options : SolverOptions, optional
        For a scene target (default ``SolverOptions()``); ignored for a result.
    moment : bool
        Include the tip moment / tip angle (3×3); otherwise forces/positions only (2×2).
    initial : ndarray or EquilibriumResult, optional
        Warm start when ``target`` is a scene.

    Returns
    -------
    TipStiffness
        ``equilibrium.success`` tells whether the state converged; the matrices are computed
        regardless (NaN when the Hessian is singular). A contact equilibrium's compliance is taken by
        central differences of contact solves (:func:`contact_compliance`): a tip resting on an
        obstacle does not move along its normal (infinite stiffness there, NaN with a note).
    """
    if isinstance(target, EquilibriumResult):
        eq = target
    else:
        eq = solve(target, options or SolverOptions(), initial=initial)
    scene, notes = companion_scene(eq.scene, moment)
    companion = scene is not eq.scene
    solver = get_solver(scene, eq.options)
    params = solver.parameter_vector(scene)
    loads = LOAD_NAMES if moment else LOAD_NAMES[:2]
    try:
        if scene.obstacles:
            C = contact_compliance(eq, scene, loads)
            notes.append("a contact equilibrium: compliance by central differences of contact solves "
                         f"(load steps {CONTACT_STEP:g} B0/l^2, B0/l), the contacts sliding and lifting as they do")
        else:
            C = compliance_at(solver, eq.z, params, loads)
    except np.linalg.LinAlgError:
        C = np.full((len(loads),) * 2, np.nan)
        notes.append("the reduced Hessian is singular (a critical state): no tangent stiffness")
    K = _inverse(C, loads, notes)
    scale = float(np.max(np.abs(C))) if np.all(np.isfinite(C)) else np.nan
    sym = float(np.max(np.abs(C - C.T)) / scale) if scale and np.isfinite(scale) else np.nan
    vertical = 1.0 / C[1, 1] if C[1, 1] != 0 else math.inf
    if not eq.stable:
        notes.append("the equilibrium is not stable: the tangent stiffness is not positive definite")
    sc = eq.scene.scales
    return TipStiffness(compliance=C, stiffness=K, vertical=float(vertical),
                        vertical_N_per_m=None if sc is None else float(vertical * sc.stiffness),
                        symmetry_error=sym, loads=tuple(loads), tips=TIP_NAMES[:len(loads)],
                        equilibrium=eq, companion=companion, notes=notes)


#: the load step of :func:`contact_compliance` (B0/ℓ² for forces, B0/ℓ for the moment), and the
#: relative size below which a difference is round-off of the solves (zero)
CONTACT_STEP, CONTACT_RESOLUTION = 1e-4, 1e-7


def contact_compliance(eq: EquilibriumResult, scene: Scene, loads: Sequence[str] = LOAD_NAMES) -> np.ndarray:
    """Compliance of a contact equilibrium, d tip_i / d load_j by central differences of contact
    solves warm-started from ``eq`` (``scene``: ``eq``'s scene with the load terms present).

    The contact set's own response — a contact point sliding over a curved obstacle, the element
    boundary following it — is in every solve; a point-wise linearisation of the constraints would
    miss the curvature of the distance's envelope (2.7 % on a rod over a peg). A contact that lifts
    off or touches down within a step makes the difference one-sided in truth: the step is small
    (:data:`CONTACT_STEP`) so that only a state exactly at an event is affected.

    Raises
    ------
    numpy.linalg.LinAlgError
        When a perturbed contact solve fails (no differences to take).
    """
    C = np.zeros((len(loads), len(loads)))
    rows = [LOAD_NAMES.index(name) for name in loads]
    for j, name in enumerate(loads):
        tips = []
        for sign in (-1.0, 1.0):
            p = lens.parameter(name)  # the load stepped, the others as they are
            sc = p.write(scene, p.get(scene) + sign * CONTACT_STEP)
            r = solve(sc, eq.options, initial=eq)
            if not r.success:
                raise np.linalg.LinAlgError(f"a contact solve at {name} {sign:+g}·{CONTACT_STEP:g} failed: {r.message}")
            tips.append(np.array([r.tip["x"], r.tip["y"], r.tip["angle"]]))
        C[:, j] = ((tips[1] - tips[0]) / (2 * CONTACT_STEP))[rows]
    # below the differences' resolution (the solves' tolerance over the step): zero, e.g. a tip
    # held by a wall along its normal
    C[np.abs(C) <= CONTACT_RESOLUTION * max(float(np.max(np.abs(C))), 1e-300)] = 0.0
    return C


def _inverse(C: np.ndarray, loads, notes: List[str]) -> np.ndarray:
    """C⁻¹; when a tip quantity does not respond to first order (e.g. x(1) of the straight,
    inextensible rod: a zero row and column of C) the stiffness in that direction is infinite:
    those rows and columns are NaN and the rest is the inverse of the remaining block."""
    K = np.full_like(C, np.nan)
    if not np.all(np.isfinite(C)):
        return K
    scale = float(np.max(np.abs(C))) or 1.0
    keep = np.array([np.max(np.abs(C[i])) > 1e-12 * scale for i in range(C.shape[0])])
    for i in np.flatnonzero(~keep):
        notes.append(f"the tip {TIP_NAMES[i]} does not respond to first order to {loads[i]} (an "
                     f"inextensible straight rod, or a tip held by an obstacle): infinite stiffness, "
                     f"reported as null/NaN")
    if keep.any():
        try:
            K[np.ix_(keep, keep)] = np.linalg.inv(C[np.ix_(keep, keep)])
        except np.linalg.LinAlgError:
            notes.append("the compliance matrix is singular")
    return K


# -- stiffness against field ----------------------------------------------------------------------
@dataclass
class StiffnessCurve:
    """Vertical tip stiffness along a field sweep (dimensionless; SI columns for physical scenes).

    Attributes
    ----------
    h : ndarray, shape (n,)
        Field group h (THEORY §5).
    vertical : ndarray, shape (n,)
        dp/dv1 at the stable equilibrium followed along h (units of B0/ℓ³).
    tip_angle : ndarray, shape (n,)
    stable : ndarray of bool, shape (n,)
    success : ndarray of bool, shape (n,)
    lowload : ndarray, shape (n,)
        THEORY §6's closed form s(h) (exact only for φ = 0, p = 0, b ≡ 1, α ≡ 0, no other loads;
        ``lowload_applies`` says whether the scene is that one).
    lowload_applies : bool
    field_A_per_m, vertical_N_per_m : ndarray or None
        SI values for physical scenes (H = h/h_ref · H0 with h_ref the scene's h at H0).
    """

    h: np.ndarray
    vertical: np.ndarray
    tip_angle: np.ndarray
    stable: np.ndarray
    success: np.ndarray
    lowload: np.ndarray
    lowload_applies: bool
    field_A_per_m: Optional[np.ndarray] = None
    vertical_N_per_m: Optional[np.ndarray] = None
    notes: List[str] = field(default_factory=list)

    def to_dict(self) -> Dict[str, object]:
        return {"h": self.h.tolist(), "vertical_stiffness": self.vertical.tolist(),
                "tip_angle": self.tip_angle.tolist(), "stable": self.stable.tolist(),
                "success": self.success.tolist(), "lowload_s": self.lowload.tolist(),
                "lowload_applies": bool(self.lowload_applies),
                "field_A_per_m": None if self.field_A_per_m is None else self.field_A_per_m.tolist(),
                "vertical_stiffness_N_per_m": (None if self.vertical_N_per_m is None
                                               else self.vertical_N_per_m.tolist()),
                "notes": list(self.notes)}

    def table(self):
        """(column names, rows) for CSV output."""
        cols = ["h", "vertical_stiffness", "lowload_s", "tip_angle", "stable", "success"]
        data = [self.h, self.vertical, self.lowload, self.tip_angle, self.stable, self.success]
        if self.field_A_per_m is not None:
            cols += ["field_A_per_m", "vertical_stiffness_N_per_m"]
            data += [self.field_A_per_m, self.vertical_N_per_m]
        return cols, list(zip(*[np.asarray(d).tolist() for d in data]))


def lowload_applies(scene: Scene) -> bool:
    """Whether THEORY §6's s(h) is the exact low-load stiffness of ``scene``: φ = 0 uniform field,
    b ≡ 1, α ≡ 0, θ0 = 0, and every other term without effect (each scalar value of a term present
    other than the field's is 0: no load, moment, remanent magnetisation or plug-in term)."""
    field_term = lens.parameter("h").term
    others = [p for p in lens.parameters().values()
              if not p.per_point and p.term is not None and p.term != field_term and term_class(p.term).present(scene)]
    return (isinstance(scene.field, UniformField) and math.isclose(math.cos(2 * scene.phi), 1.0)
            and scene.fibres.is_constant and scene.fibres.value == 0 and scene.stiffness.is_constant
            and scene.stiffness.value == 1 and scene.theta0 == 0 and all(p.get(scene) == 0 for p in others))


def stiffness_field_curve(scene: Scene, options: Optional[SolverOptions] = None,
                          h_values: Sequence[float] = (), *, moment: bool = False) -> StiffnessCurve:
    """Vertical tip stiffness against the field group h, following the stable equilibrium.

    The equilibrium at the first h is solved with ``options`` (IPOPT + ensure_stable by default),
    each next one by a warm-started Newton solve from the previous state (one NLP build).

    Parameters
    ----------
    scene : Scene
        Uniform-field scene (other values are kept; h is swept).
    options : SolverOptions, optional
    h_values : sequence of float, shape (n,)
        Field groups h ≥ 0, in sweep order.
    moment : bool
        Compute the 3×3 compliance (the vertical stiffness is the same either way).

    Returns
    -------
    StiffnessCurve
    """
    h_values = np.asarray(h_values, float)
    if h_values.ndim != 1 or h_values.size == 0 or np.any(~np.isfinite(h_values)) or np.any(h_values < 0):
        raise ValueError("h_values: need a non-empty list of finite h >= 0")
    options = options or SolverOptions()
    # the other groups the field drives, of the terms present (a hard rod's h_r, THEORY §9)
    driven = [p.name for p, _ in lens.field_groups(magnitude=False)
              if p.term is not None and term_class(p.term).present(scene)]
    if driven and scene.h <= 0:
        names = ", ".join(driven)
        raise ValueError(f"h_values: the scene's h is 0, so a field sweep in h cannot scale its {names} "
                         f"(THEORY §9: {names} ∝ H); give the scene h > 0 or continue in {driven[0]} instead")
    comp, notes = companion_scene(scene if driven else scene.with_values(h=float(h_values[0])), moment)

    def at_field(h: float) -> Scene:  # h and every group it drives ∝ H (the lens' field rule)
        return lens.apply_values(comp, {"h": h}) if driven else comp.with_values(h=h)

    # one mesh for the sweep, graded for its strongest field (the layer ~1/(√2 h) at the clamp)
    options = graded_for_scenes([at_field(float(h)) for h in h_values], options)
    track = replace(options, method="newton", ensure_stable=False)
    solver = get_solver(comp, options)
    n = h_values.size
    vert, ang, stab, succ = (np.full(n, np.nan), np.full(n, np.nan), np.zeros(n, bool), np.zeros(n, bool))
    prev = None
    for i, h in enumerate(h_values):
        sc = at_field(float(h))
        eq = solve(sc, options if prev is None else track, initial=prev, solver=solver)
        if not eq.stable and eq.success and prev is not None:
            eq = solve(sc, replace(options, ensure_stable=True), initial=eq, solver=solver)
        st = tip_stiffness(eq, moment=moment)
        why = residual_problem(eq) if eq.success else None  # the accuracy promise of solve
        vert[i], ang[i], stab[i], succ[i] = st.vertical, eq.tip["angle"], eq.stable, eq.success and why is None
        if why is not None and not any(nt.startswith("inaccurate") for nt in notes):
            notes.append(f"inaccurate from h = {h:.6g}: {why}; refine the mesh (solver.elements)")
        if eq.success:
            prev = eq
    applies = lowload_applies(scene)
    if not applies:
        notes.append("s(h) of THEORY §6 is the low-load stiffness of the phi = 0, p = 0, alpha = 0, "
                     "b = 1 scene only: it is drawn for reference")
    out = StiffnessCurve(h=h_values, vertical=vert, tip_angle=ang, stable=stab, success=succ,
                         lowload=np.asarray(lowload_stiffness(h_values), float),
                         lowload_applies=applies, notes=notes)
    sc = scene.scales
    if sc is not None:
        out.vertical_N_per_m = vert * sc.stiffness
        if scene.h > 0 and sc.field > 0:
            out.field_A_per_m = h_values / scene.h * sc.field
        else:
            out.notes.append("the scene has no field scale: SI field values are not available")
            out.field_A_per_m = np.full(n, np.nan)
    return out


@register("stiffness")
def run_stiffness(scene, options, moment: bool = True, **settings) -> dict:
    """Registered analysis: tip stiffness at the equilibrium of ``scene`` (flat dict)."""
    if settings:
        raise ValueError(f"stiffness: unknown settings {sorted(settings)} (allowed: moment)")
    st = tip_stiffness(scene, options, moment=bool(moment))
    out = st.to_dict()
    eq = out.pop("equilibrium")
    out.update({"success": eq["success"], "stable": eq["stable"], "tip_x": eq["tip"]["x"],
                "tip_y": eq["tip"]["y"], "tip_angle": eq["tip"]["angle"], "energy": eq["energy"]})
    out.pop("units")
    return out
