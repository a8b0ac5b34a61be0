"""The transcription interface: a discretisation of θ(s) that turns energy terms into an NLP.

A transcription owns the discrete unknowns (θ at its nodes), the quadrature points where densities
are evaluated, how θ' and the positions r(s) = ∫ (cos θ, sin θ) are formed there, and how a discrete
solution is evaluated densely. :meth:`Transcription.transcribe` returns a :class:`DiscreteEnergy`:
the energy as a CasADi expression of (θ nodes, parameter vector) with named parameter packing.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Dict, List, Sequence, Tuple

import casadi as ca
import numpy as np

from actuator_design.physics.kinematics import PlanarKinematics, PlanarTip
from actuator_design.physics.term_protocol import EnergyTerm, node_field_sources, node_field_values

__all__ = ["ParamLayout", "DiscreteEnergy", "Transcription"]


class ParamLayout:
    """Named slices of the NLP parameter vector (never stride slicing by hand).

    Parameters
    ----------
    entries : sequence of (name, size)
    """

    def __init__(self, entries: Sequence[Tuple[str, int]]):
        self.slices: Dict[str, slice] = {}
        offset = 0
        for name, size in entries:
            if name in self.slices:
                continue
            self.slices[name] = slice(offset, offset + size)
            offset += size
        self.size = offset

    def symbols(self, vector: ca.SX) -> Dict[str, ca.SX]:
        """Split a symbolic parameter vector into named pieces (scalars for size 1)."""
        return {k: vector[sl] for k, sl in self.slices.items()}

    def pack(self, values: Dict[str, object]) -> np.ndarray:
        """Pack numerical values by name into one vector; every name must be given."""
        out = np.zeros(self.size)
        for name, sl in self.slices.items():
            if name not in values:
                raise KeyError(f"missing NLP parameter {name!r}")
            v = np.broadcast_to(np.asarray(values[name], float).ravel(), (sl.stop - sl.start,))
            out[sl] = v
        return out


@dataclass
class DiscreteEnergy:
    """The discrete energy of one scene structure on one transcription.

    Attributes
    ----------
    z : SX, shape (n_nodes,)
        θ at the transcription's nodes, rad.
    params : SX, shape (layout.size,)
        Parameter vector (values with named slices in ``layout``).
    energy : SX scalar
        Discrete Ê (units of B0/ℓ).
    layout : ParamLayout
    tip : (θ(1), x(1), y(1)) as SX
    kinematics : PlanarKinematics at the quadrature points (positions built only if a term asked)
    node_fields : tuple of str
        Names of the per-point fields in the layout (each of the quadrature points' length).
    """

    z: ca.SX
    params: ca.SX
    energy: ca.SX
    layout: ParamLayout
    tip: Tuple[ca.SX, ca.SX, ca.SX]
    kinematics: PlanarKinematics
    node_fields: Tuple[str, ...] = ()

    @property
    def uses_positions(self) -> bool:
        """Whether some term read the rod's positions (the energy then couples all unknowns)."""
        return self.kinematics.positions_built


class Transcription:
    """Base class. Subclasses define nodes, quadrature and the discrete operators."""

    name = "base"
    order_description = ""

    # -- geometry of the discretisation (subclasses set these attributes in __init__) -----------
    #: arc lengths of the unknowns θ_i, shape (n_nodes,); nodes[0] = 0 (clamp), nodes[-1] = 1
    _nodes: np.ndarray
    #: arc lengths where densities are evaluated and their weights, shape (n_q,)
    _sq: np.ndarray
    _wq: np.ndarray
    #: lumped mass (quadrature weight carried by each node), shape (n_nodes,): the discrete L²
    #: inner product used to scale gradients and eigenvalues
    _mass: np.ndarray

    @property
    def nodes(self) -> np.ndarray:
        return self._nodes

    @property
    def quadrature_points(self) -> np.ndarray:
        return self._sq

    @property
    def quadrature_weights(self) -> np.ndarray:
        return self._wq

    @property
    def mass(self) -> np.ndarray:
        return self._mass

    @property
    def breakpoints(self) -> np.ndarray:
        """Arc lengths where the θ interpolant may have a kink (element boundaries)."""
        raise NotImplementedError

    # -- discrete operators (symbolic) --------------------------------------------------------
    def point_values(self, z: ca.SX) -> Tuple[ca.SX, ca.SX]:
        """θ and θ' at the quadrature points."""
        raise NotImplementedError

    def point_positions(self, theta_q: ca.SX) -> Tuple[ca.SX, ca.SX]:
        """x, y at the quadrature points from θ there."""
        raise NotImplementedError

    def tip_position(self, theta_q: ca.SX) -> Tuple[ca.SX, ca.SX]:
        w = ca.DM(self.quadrature_weights)
        return ca.dot(w, ca.cos(theta_q)), ca.dot(w, ca.sin(theta_q))

    # -- dense evaluation (numerical) ---------------------------------------------------------
    def theta_dense(self, z: np.ndarray, s: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
        """θ(s) and θ'(s) of the discrete solution at arbitrary s ∈ [0, 1]."""
        raise NotImplementedError

    def structure(self) -> tuple:
        raise NotImplementedError

    # -- the NLP ------------------------------------------------------------------------------
    def transcribe(self, terms: List[EnergyTerm]) -> DiscreteEnergy:
        """Build the discrete energy of ``terms`` (only what they need is built: positions are
        formed only if a term reads them)."""
        nq = self.quadrature_points.size
        entries = [("theta0", 1)]
        for t in terms:
            entries += [(p, 1) for p in t.scalar_params]
        fields = tuple(node_field_sources(terms))
        entries += [(f, nq) for f in fields]
        layout = ParamLayout(entries)
        params = ca.SX.sym("params", layout.size)
        P = layout.symbols(params)

        z = ca.SX.sym("theta", self.nodes.size)
        theta_q, kappa_q = self.point_values(z)
        kin = PlanarKinematics(theta_q, kappa_q, {f: P[f] for f in fields},
                               positions=lambda: self.point_positions(theta_q))
        tip_x, tip_y = self.tip_position(theta_q)
        tip = PlanarTip(theta=z[-1], x=tip_x, y=tip_y)

        w = ca.DM(self.quadrature_weights)
        energy = 0
        for t in terms:
            d = t.density(kin, P)
            if d is not None:
                energy = energy + ca.dot(w, d)
            e = t.tip(tip, P)
            if e is not None:
                energy = energy + e
        return DiscreteEnergy(z=z, params=params, energy=energy, layout=layout,
                              tip=(z[-1], tip_x, tip_y), kinematics=kin, node_fields=fields)

    def node_field_values(self, scene, terms) -> Dict[str, np.ndarray]:
        """The per-point fields ``terms`` read, for ``scene``, at the quadrature points."""
        return node_field_values(terms, scene, self.quadrature_points)
