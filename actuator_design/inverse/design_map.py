"""The one map from design values to the forward NLP's parameters, with their effort, bounds and
stability certificate matrix (issue 18: one home for what every design NLP assembles).

The single-pose design NLP (:mod:`actuator_design.inverse.nlp`), the shape fit
(:mod:`actuator_design.inverse.shape`) and the scenario NLP of robust design
(:mod:`actuator_design.robust.design_robust`) optimise one pose, one shape, or K poses sharing a
profile, but they lay out their design vectors, write a pose's values into the forward parameters,
cost them and bound them here, so that the physics they optimise is the same:

* a scalar design value goes into its NLP slot through the parameter lens (h, φ, p);
* a designed field magnitude h moves every group the field drives with it (h_r, h_pos: THEORY §5,
  §9; :func:`couple_field_groups`);
* where each value sits in the design vector is a :class:`DesignVector` (one pose in design order,
  or shared profiles then each pose's scalars);
* a designed profile (α, β) is a Legendre series evaluated at the quadrature points;
* the effort is h² + p² + Σ_k k²(k+1)²/4 · c_k² per profile (∫ profile'² grows like k² c_k²: it
  penalises variation, not the mean angle);
* the certificate's matrix is M^-1/2 H_r M^-1/2 − μ I (THEORY §7), positive definite exactly when
  λ_min(H_r, M) > μ.

The field is one physical field (THEORY §5, §9): h ∝ H, h_pos ∝ H and h_r ∝ H, so a design that
varies h moves every other group the field drives with it, in the NLPs (:func:`couple_field_groups`)
and in the forward scenes they stand for (:func:`coupled_scene`). The groups are read from the
parameter lens (every slot whose ``field_power`` f ≠ 0 besides the field magnitude, ∝ (h/h0)^f), so a
plug-in term's field-driven values follow too.
"""
from __future__ import annotations

from dataclasses import replace
from typing import List, Mapping, Sequence, Tuple

import casadi as ca
import numpy as np

from actuator_design.model.profiles import constant_profile
from actuator_design.model.scene import Scene, UniformField
from actuator_design.physics import parameters as lens
from actuator_design.physics.registry import term_class

__all__ = ["DesignVector", "EFFORT_SCALARS", "design_params", "design_effort", "scalar_bounds", "smoothness_weights",
           "certificate_matrix", "couple_field_groups", "coupled_scene", "driven_values", "field_bound",
           "prepare_scene", "profile_report", "without_soft_coupling"]

#: The design variables (the lens entries flagged designable): scalars written into their NLP slots,
#: and profiles designed as Legendre series (α(s), β(s))
_SCALAR_VARIABLES = tuple(n for n, p in lens.designable().items() if not p.per_point)
_PROFILE_VARIABLES = tuple(n for n, p in lens.designable().items() if p.per_point)

#: The scalar design values whose size the effort costs: the field magnitude and the tip load
#: (the field angle costs nothing).
EFFORT_SCALARS = ("h", "p")


def design_params(P0: ca.SX, values: Mapping[str, ca.SX], slices, vandermonde=None) -> ca.SX:
    """The forward NLP parameters of one pose's design values.

    Parameters
    ----------
    P0 : casadi.SX, shape (n_params,)
        The base scene's parameters (everything not designed).
    values : mapping of str to casadi.SX
        Design values by lens name: scalars (shape (1,)) and profiles (Legendre coefficients,
        shape (n_terms,)). The scalars are written first (in the mapping's order), then the field
        groups are coupled to h, then the profiles are written.
    slices : dict of str to slice
        The NLP layout's slots.
    vandermonde : ndarray, shape (n_quadrature, n_terms), optional
        Legendre basis at the quadrature points (needed when a profile is designed).

    Returns
    -------
    casadi.SX, shape (n_params,)
    """
    P = ca.SX(P0)
    for name, value in values.items():
        par = lens.parameter(name)
        if not par.per_point:
            P[slices[par.slot]] = value
    if "h" in values:
        couple_field_groups(P, P0, values["h"], slices)
    for name, value in values.items():
        par = lens.parameter(name)
        if par.per_point:
            P[slices[par.slot]] = ca.mtimes(ca.DM(vandermonde), value)
    return P


class DesignVector:
    """Where each design value sits in a design NLP's vector d: the one design-vector map.

    A designed profile (α, β: a per-point lens entry) is ``terms`` Legendre coefficients shared by
    every pose; a scalar (h, φ, p) is one entry per pose. The single-pose NLP stores its values in
    design order (:meth:`single`); the scenario NLP stores the shared profiles first, then each
    pose's scalars (:meth:`poses`). ``dmap[name]`` is the slice of ``name`` (pose 0's for a scalar).

    Parameters
    ----------
    entries : sequence of (str, int or None)
        (name, pose) in storage order; pose ``None`` for a shared profile.
    terms : int
        Coefficients of each profile.
    n_poses : int
        Poses the vector stands for (at least those its entries name).
    """

    def __init__(self, entries: Sequence[Tuple[str, object]], terms: int, n_poses: int = 1):
        self.terms = int(terms)
        self._slices, off = {}, 0
        for name, pose in entries:
            size = self.terms if lens.parameter(name).per_point else 1
            self._slices[(name, pose)] = slice(off, off + size)
            off += size
        #: length of the design vector
        self.size = off
        self.profiles = tuple(n for n, pose in self._slices if pose is None)
        self.scalars = tuple(dict.fromkeys(n for n, pose in self._slices if pose is not None))
        #: poses the vector stands for (each sees the shared profiles and its own scalars)
        self.n_poses = max([int(n_poses)] + [pose + 1 for _, pose in self._slices if pose is not None])

    @classmethod
    def single(cls, vary: Sequence[str], terms: int) -> "DesignVector":
        """One pose, the values in the order of ``vary``."""
        return cls([(v, None if lens.parameter(v).per_point else 0) for v in vary], terms)

    @classmethod
    def poses(cls, profiles: Sequence[str], scalars: Sequence[str], n_poses: int, terms: int) -> "DesignVector":
        """``n_poses`` poses: the shared ``profiles``, then pose 0's ``scalars``, pose 1's, …"""
        return cls([(v, None) for v in profiles] + [(v, k) for k in range(n_poses) for v in scalars], terms,
                   n_poses)

    def slice(self, name: str, pose: int = 0) -> slice:
        """Where pose ``pose``'s value ``name`` sits (a profile's coefficients whatever the pose)."""
        return self._slices[(name, None)] if (name, None) in self._slices else self._slices[(name, pose)]

    def __getitem__(self, name: str) -> slice:
        return self.slice(name)

    def __contains__(self, name: str) -> bool:
        return name in self.profiles or name in self.scalars

    def pose_values(self, d, pose: int = 0) -> dict:
        """Pose ``pose``'s scalar values by name (each shape (1,)), in storage order."""
        return {v: d[self.slice(v, pose)] for v in self.scalars}

    def shared_values(self, d) -> dict:
        """The shared profiles' coefficients by name, in storage order."""
        return {v: d[self.slice(v)] for v in self.profiles}

    def values(self, d, pose: int = 0) -> dict:
        """Every value pose ``pose`` sees, by name in storage order (what
        :func:`design_params` writes and :func:`design_effort` costs)."""
        return {n: d[sl] for (n, p), sl in self._slices.items() if p is None or p == pose}

    def effort(self, d):
        """The effort of a design vector (:func:`design_effort`): every pose's scalars, then the
        shared profiles once."""
        total = 0
        for k in range(self.n_poses):
            total = design_effort(self.pose_values(d, k), total)
        return design_effort(self.shared_values(d), total)

    def bounds(self, bounds: Mapping[str, float]) -> Tuple[np.ndarray, np.ndarray]:
        """Lower and upper bounds of the design vector, shape (size,) each: every pose's scalars
        (:func:`scalar_bounds`); the profiles are bounded by rows at the quadrature points."""
        lo, hi = np.full(self.size, -np.inf), np.full(self.size, np.inf)
        for (name, pose), sl in self._slices.items():
            if pose is not None:
                lo[sl], hi[sl] = scalar_bounds(name, bounds)
        return lo, hi

    def fix_gauge(self, d: np.ndarray) -> np.ndarray:
        """A copy of ``d`` moved along the fibre gauge's orbit to α's mean c_0 = 0: c_0 taken from α
        and from every pose's φ (the same equilibria: :mod:`actuator_design.inverse.gauge`)."""
        d = np.array(d, float)
        i0 = self.slice("alpha").start
        c0, d[i0] = d[i0], 0.0
        for (name, pose), sl in self._slices.items():
            if name == "phi":
                d[sl] -= c0
        return d

    def move(self, d: np.ndarray, pose: int, into: "DesignVector", out: np.ndarray, into_pose: int = 0) -> np.ndarray:
        """Copy pose ``pose``'s values (and the shared profiles) of ``d`` into ``out``, laid out by
        ``into`` as its pose ``into_pose``; values ``into`` does not hold are dropped. Returns ``out``."""
        for (name, p), sl in into._slices.items():
            if (p is None or p == into_pose) and name in self:
                out[sl] = d[self.slice(name, pose)]
        return out


def smoothness_weights(n_terms: int) -> np.ndarray:
    """k²(k+1)²/4 for k = 0 … n_terms − 1: a Legendre coefficient's share of ∫ profile'² ds."""
    k = np.arange(n_terms, dtype=float)
    return k**2 * (k + 1) ** 2 / 4.0


def design_effort(values: Mapping[str, ca.SX], total=0):
    """``total`` plus the effort of one set of design values (see the module docstring): the
    squares of :data:`EFFORT_SCALARS`, then each profile's smoothness, in lens order."""
    for name in EFFORT_SCALARS:
        if name in values:
            total += values[name] ** 2
    for name, value in values.items():
        if lens.parameter(name).per_point:
            total += ca.dot(ca.DM(smoothness_weights(value.numel())), value**2)
    return total


def scalar_bounds(name: str, bounds: Mapping[str, float]) -> Tuple[float, float]:
    """(lower, upper) of a scalar design value: 0 ≤ h ≤ h_max, |p| ≤ p_max (unbounded when
    ``bounds`` has no p_max; ``DesignSettings.bounds()`` always gives one),
    and |φ| ≤ 2π — the energy is π-periodic in φ; the bound keeps φ from wandering and is wide
    enough for continuous rotating schedules."""
    if name == "h":
        return 0.0, float(bounds["h_max"])
    if name == "p":
        p_max = float(bounds.get("p_max", np.inf))
        return -p_max, p_max
    if name == "phi":
        return -2 * np.pi, 2 * np.pi
    raise ValueError(f"{name} is not a scalar design variable")


def certificate_matrix(H: ca.SX, mass: np.ndarray, margin=None) -> ca.SX:
    """M^-1/2 H M^-1/2 (− μ I with ``margin`` μ): the matrix whose LDLᵀ pivots certify
    λ_min(H, M) ≥ μ (THEORY §7). ``H`` (n, n) the reduced Hessian, ``mass`` (n,) the lumped mass."""
    Ms = ca.DM(1.0 / np.sqrt(np.asarray(mass, float)))
    A = ca.diag(Ms) @ H @ ca.diag(Ms)
    return A if margin is None else A - margin * ca.SX.eye(H.shape[0])


def couple_field_groups(P, P0, h, slices) -> None:
    """Write the groups the field drives besides h into the NLP parameter vector ``P`` (CasADi SX,
    in place): g = h·g0/h0 for g in (h_r, h_pos), with g0, h0 the base scene's values in ``P0``
    (unchanged where h0 = 0)."""
    h0 = P0[slices["h"]]
    for p, f in lens.field_groups(magnitude=False):
        g = p.slot
        if g in slices:
            moved = h * P0[slices[g]] / h0 if f == 1 else (h / h0) ** f * P0[slices[g]]
            P[slices[g]] = ca.if_else(h0 > 0, moved, P0[slices[g]])


def field_bound(h_max: float, base: Scene, vary=None) -> Tuple[float, List[str]]:
    """The bound on the designed h and the notes that explain it.

    A remanent group moves with h (h_r = h·h_r0/h0, THEORY §9) and enters the equations as h² does
    (θ'' ~ h_r against θ'' ~ h²), so the field is bounded where either reaches its limit:
    h ≤ min(h_max, h_max²·h0/h_r0). When h is designed, a physical scene's field is also kept below
    the one its magnetisation model holds to (:func:`~actuator_design.physics.parameters.model_field_bound`)."""
    notes: List[str] = []
    for q in lens.remanent_groups(base):
        if q.get(base) > 0 and base.h > 0:
            h_max = min(h_max, h_max ** 2 * base.h / q.get(base))
    bound = lens.model_field_bound(base)
    if bound is not None and 0.0 < bound[0] < h_max and (vary is None or "h" in vary):
        h_max = bound[0]
        notes.append(f"the field is bounded by h <= {bound[0]:.6g} ({bound[1]})")
    return h_max, notes


def without_soft_coupling(scene: Scene) -> bool:
    """A rod with remanence and no soft coupling (h_r > 0, h = 0; on a physical scene at zero field,
    per unit field): the field acts through its remanent groups alone, so it has no h to design
    (THEORY §9)."""
    return bool(lens.remanent_groups(scene)) and not lens.soft_coupled(scene)


def coupled_scene(base: Scene, sc: Scene) -> Scene:
    """``sc`` (``base`` with a designed h) with h_r and h_pos moved with h like the field they share,
    as :func:`couple_field_groups` does in the NLP."""
    if not base.h > 0:  # no ratio at zero field: a physical scene's groups per field (else none)
        return lens.apply_values(replace(sc, h=0.0), {"h": sc.h}) if lens.per_field(sc) else sc

    return lens.scale_field(sc, sc.h / base.h, source=base, magnitude=False)


def driven_values(scene: Scene) -> dict:
    """The nonzero groups the field drives besides h in ``scene`` ({name: value}, registration
    order; h_pos, h_r: THEORY §5, §9), for a report: a design that varies h moves them with it
    (:func:`coupled_scene`), so h alone does not reproduce the designed state."""
    return {p.name: float(p.get(scene)) for p, _ in lens.field_groups(magnitude=False)
            if (p.term is None or term_class(p.term).present(scene)) and p.get(scene) != 0.0}


def profile_report(scene: Scene, profiles: Mapping[str, np.ndarray], vary) -> dict:
    """The design's profiles as its report gives them: {name: {"s", "value", "legendre_coefficients"}}
    with the profile of ``scene`` (rad) at 201 points of s ∈ [0, 1] and its Legendre coefficients
    from ``profiles`` (by lens name). The fibre layout α(s) always (coefficients empty when it is not
    designed: the JSON contract), every other profile (β(s), THEORY §9) when ``vary`` designs it."""
    s = np.linspace(0.0, 1.0, 201)
    return {v: {"s": s.tolist(), "value": p.profile(scene)(s).tolist(),
                "legendre_coefficients": [float(c) for c in profiles.get(v, ())]}
            for v, p in lens.designable().items() if p.per_point and (v == "alpha" or v in vary)}


def fibres_fixed(scene: Scene) -> bool:
    """Whether the scene's fibre layout is the user's (given in a config, or any layout other than
    the default straight fibres α = 0): inverse design then keeps it unless asked to vary it."""
    f = scene.fibres
    return bool(scene.fibres_given or not (f.kind == "constant" and f.value == 0.0))


def prepare_scene(scene: Scene, vary: Sequence[str]) -> Scene:
    """Make sure the scene contains the terms the design varies (through the parameter lens: a
    field for ``h``/``phi``, which must be uniform for ``phi``, a tip force for ``p``, the
    hard-magnetic term for ``magnetization``) and a profile the Legendre series can replace for
    ``alpha`` and ``magnetization``.

    Raises
    ------
    ValueError
        A variable its parameter says cannot be designed on this scene (``Parameter.design_check``:
        β(s) without remanence), or h on a rod whose field acts through its remanence alone.
    """
    for v in vary:
        check = lens.parameter(v).design_check
        problem = check(scene) if check is not None else None
        if problem:
            raise ValueError(f"--vary {v}: {problem}")
    groups = lens.remanent_groups(scene)
    if "h" in vary and groups and not lens.soft_coupled(scene):  # the field acts through them alone
        profiles = [v for v in _PROFILE_VARIABLES if lens.parameter(v).term in {p.term for p in groups}]
        raise ValueError("--vary h: this rod has no soft-magnetic coupling (h = 0): the field acts on it "
                         f"through {', '.join(p.name for p in groups)} alone; design phi"
                         f"{''.join(' and/or ' + v for v in profiles)} at the scene's field magnitude")
    if ("h" in vary or "phi" in vary) and scene.field is None:
        scene = replace(scene, field=UniformField(phi=0.0))  # keeps the scene's h as a start
    if "h" in vary and not scene.h > 0 and lens.per_field(scene).get("h", 0.0) > 0:
        # at zero field the design NLP could not move the other groups with h (their ratio to h is
        # 0/0): the base at a field of 1 A/m gives it the physical scene's ratios (h is designed)
        scene = lens.set_field(scene, 1.0)
    try:
        scene = lens.prepare_scene(scene, [v for v in vary if v in _SCALAR_VARIABLES], "design variable")
    except ValueError as err:
        raise ValueError(f"--vary {err}") from None
    for v in _PROFILE_VARIABLES:  # a profile the Legendre series can replace
        par = lens.parameter(v)
        if v in vary and par.profile(scene).kind not in ("constant", "legendre"):
            scene = par.with_profile(scene, constant_profile(0.0))
    return scene
