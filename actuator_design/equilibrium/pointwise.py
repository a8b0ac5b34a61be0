"""Evaluate a pointwise CasADi SX function at many points at once with numpy.

The balance check (:mod:`actuator_design.equilibrium.balance`) evaluates each energy term's pointwise loads at
a few hundred arc lengths per state. CasADi's virtual machine runs the function's instructions
once per point (about 0.6 µs a point for the bending + field loads); replaying the same
instruction list once on numpy arrays of all the points costs one vectorised operation per
instruction instead, 5–10× less at study sizes. :class:`VectorisedSX` reads the function's
algorithm (``instruction_id``/``_input``/``_output``/``_constant``) once and replays it; a function
using an operation it does not know is refused at construction (:class:`NotVectorisable`), and
the caller keeps CasADi's own evaluation.
"""
from __future__ import annotations

from typing import Callable, Dict, List, Sequence

import casadi as ca
import numpy as np

__all__ = ["VectorisedSX", "NotVectorisable"]


class NotVectorisable(ValueError):
    """The function uses an operation :class:`VectorisedSX` does not replay."""


def _binary(fn: Callable) -> Callable:
    return lambda a, b: fn(a, b)


_UNARY: Dict[int, Callable] = {
    ca.OP_ASSIGN: lambda a: a, ca.OP_NEG: np.negative, ca.OP_EXP: np.exp, ca.OP_LOG: np.log,
    ca.OP_SQRT: np.sqrt, ca.OP_SQ: np.square, ca.OP_TWICE: lambda a: 2.0 * a,
    ca.OP_SIN: np.sin, ca.OP_COS: np.cos, ca.OP_TAN: np.tan, ca.OP_ASIN: np.arcsin,
    ca.OP_ACOS: np.arccos, ca.OP_ATAN: np.arctan, ca.OP_FLOOR: np.floor, ca.OP_CEIL: np.ceil,
    ca.OP_FABS: np.abs, ca.OP_SIGN: np.sign, ca.OP_INV: lambda a: 1.0 / a, ca.OP_SINH: np.sinh,
    ca.OP_COSH: np.cosh, ca.OP_TANH: np.tanh, ca.OP_ASINH: np.arcsinh, ca.OP_ACOSH: np.arccosh,
    ca.OP_ATANH: np.arctanh, ca.OP_LOG1P: np.log1p, ca.OP_EXPM1: np.expm1,
    ca.OP_NOT: lambda a: np.logical_not(a).astype(float),
}
_BINARY: Dict[int, Callable] = {
    ca.OP_ADD: np.add, ca.OP_SUB: np.subtract, ca.OP_MUL: np.multiply, ca.OP_DIV: np.divide,
    ca.OP_POW: np.power, ca.OP_CONSTPOW: np.power, ca.OP_ATAN2: np.arctan2,
    ca.OP_FMIN: np.fmin, ca.OP_FMAX: np.fmax, ca.OP_FMOD: np.fmod, ca.OP_HYPOT: np.hypot,
    ca.OP_COPYSIGN: np.copysign,
    ca.OP_LT: lambda a, b: np.less(a, b).astype(float),
    ca.OP_LE: lambda a, b: np.less_equal(a, b).astype(float),
    ca.OP_EQ: lambda a, b: np.equal(a, b).astype(float),
    ca.OP_NE: lambda a, b: np.not_equal(a, b).astype(float),
    ca.OP_AND: lambda a, b: np.logical_and(a, b).astype(float),
    ca.OP_OR: lambda a, b: np.logical_or(a, b).astype(float),
    ca.OP_IF_ELSE_ZERO: lambda c, a: np.where(c != 0, a, 0.0),
}


class VectorisedSX:
    """A scalar-in, scalar-out SX function replayed on numpy arrays of points.

    Parameters
    ----------
    fn : casadi.Function
        An SX function whose inputs are scalars per point, except those named in ``shared``
        (vectors common to all points, e.g. the NLP parameters), and whose outputs are scalars.
    shared : sequence of int
        Indices of the inputs given once for all points.

    Raises
    ------
    NotVectorisable
        ``fn`` is not an SX function, has a non-scalar point input or output, or uses an
        operation without a numpy counterpart here.
    """

    def __init__(self, fn: ca.Function, shared: Sequence[int] = ()):
        if not fn.is_a("SXFunction"):
            raise NotVectorisable(f"{fn.name()} is not an SX function")
        self.shared = set(int(i) for i in shared)
        for i in range(fn.n_in()):
            if i not in self.shared and fn.nnz_in(i) != 1:
                raise NotVectorisable(f"input {i} of {fn.name()} is not a scalar per point")
        for i in range(fn.n_out()):
            if fn.nnz_out(i) != 1:
                raise NotVectorisable(f"output {i} of {fn.name()} is not a scalar per point")
        self.n_in, self.n_out, self.n_work = fn.n_in(), fn.n_out(), fn.sz_w()
        program: List[tuple] = []
        for k in range(fn.n_instructions()):
            op, ins, outs = fn.instruction_id(k), fn.instruction_input(k), fn.instruction_output(k)
            if op == ca.OP_INPUT:
                program.append(("in", outs[0], ins[0], ins[1]))
            elif op == ca.OP_OUTPUT:
                program.append(("out", ins[0], outs[0]))
            elif op == ca.OP_CONST:
                program.append(("const", outs[0], float(fn.instruction_constant(k))))
            elif op in _UNARY:
                program.append(("f", outs[0], _UNARY[op], (ins[0],)))
            elif op in _BINARY:
                program.append(("f", outs[0], _BINARY[op], (ins[0], ins[1])))
            else:
                raise NotVectorisable(f"{fn.name()} uses CasADi operation {op}, not replayed here")
        self.program = program

    def __call__(self, *args) -> List[np.ndarray]:
        """The outputs at every point, each of the points' common (broadcast) shape.

        ``args``: one entry per input: an array of the points' values, or, for a shared input,
        its vector of values (shape (n_shared,)) or one vector per column of the points
        (shape (m, n_shared) against points of shape (k, m)).
        """
        inputs = [np.asarray(a, float) for a in args]
        shape = np.broadcast_shapes(*(a.shape for i, a in enumerate(inputs) if i not in self.shared))
        w: List = [0.0] * self.n_work
        out: List = [None] * self.n_out
        with np.errstate(all="ignore"):  # as CasADi: inf/nan propagate, the caller checks
            for step in self.program:
                kind = step[0]
                if kind == "f":
                    w[step[1]] = step[2](*(w[j] for j in step[3]))
                elif kind == "in":
                    x = inputs[step[2]]
                    w[step[1]] = x[..., step[3]] if step[2] in self.shared else x
                elif kind == "const":
                    w[step[1]] = step[2]
                else:
                    out[step[2]] = w[step[1]]
        return [np.broadcast_to(np.asarray(o, float), shape).copy() if o is not None
                else np.zeros(shape) for o in out]
