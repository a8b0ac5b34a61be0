"""Safe arithmetic expressions from YAML: parsed by a whitelist over Python's AST, never ``eval``.

An expression such as ``"0.3*sin(pi*s) + 0.1"`` or ``"x/(x**2+y**2)"`` is parsed once into a small
tree and can then be evaluated with numpy (numbers, arrays) or with CasADi (symbols), so fields and
profiles written by users get exact symbolic derivatives.

Allowed: numbers, the named variables, ``+ - * / **``, unary ``+ -``, parentheses, the constants
``pi`` and ``e``, and the functions listed in :data:`FUNCTIONS`.
"""
from __future__ import annotations

import ast
import math
from dataclasses import dataclass
from typing import Mapping, Sequence

import numpy as np

__all__ = ["Expression", "ExpressionError", "FUNCTIONS"]

FUNCTIONS = (
    "sin", "cos", "tan", "exp", "log", "sqrt", "tanh", "sinh", "cosh",
    "arctan", "arcsin", "arccos", "atan2", "abs", "fmin", "fmax",
)
CONSTANTS = {"pi": math.pi, "e": math.e}
_BINOPS = {ast.Add: "add", ast.Sub: "sub", ast.Mult: "mul", ast.Div: "div", ast.Pow: "pow"}


class ExpressionError(ValueError):
    """An expression is not in the allowed grammar."""


def _numpy_fn(name):
    return {"arctan": np.arctan, "arcsin": np.arcsin, "arccos": np.arccos, "atan2": np.arctan2,
            "abs": np.abs, "fmin": np.fmin, "fmax": np.fmax}.get(name) or getattr(np, name)


def _casadi_fn(name):
    import casadi as ca
    return {"arctan": ca.atan, "arcsin": ca.asin, "arccos": ca.acos, "atan2": ca.atan2,
            "abs": ca.fabs, "fmin": ca.fmin, "fmax": ca.fmax}.get(name) or getattr(ca, name)


@dataclass(frozen=True)
class Expression:
    """A parsed expression in the given variables.

    Parameters
    ----------
    text : str
        The expression as written by the user.
    variables : sequence of str
        Names it may use (e.g. ``("x", "y")`` or ``("s",)``).
    """

    text: str
    variables: Sequence[str]

    def __post_init__(self):
        try:
            tree = ast.parse(str(self.text).strip(), mode="eval")
        except SyntaxError as err:
            raise ExpressionError(f"cannot parse {self.text!r}: {err.msg}") from None
        self._check(tree.body)
        object.__setattr__(self, "_tree", tree.body)

    def _check(self, node):
        if isinstance(node, ast.Constant):
            if not isinstance(node.value, (int, float)) or isinstance(node.value, bool):
                raise ExpressionError(f"{self.text!r}: only numbers are allowed as constants")
        elif isinstance(node, ast.Name):
            if node.id not in self.variables and node.id not in CONSTANTS:
                allowed = ", ".join(list(self.variables) + list(CONSTANTS))
                raise ExpressionError(f"{self.text!r}: unknown name {node.id!r} (allowed: {allowed})")
        elif isinstance(node, ast.BinOp):
            if type(node.op) not in _BINOPS:
                raise ExpressionError(f"{self.text!r}: operator {type(node.op).__name__} is not allowed")
            self._check(node.left)
            self._check(node.right)
        elif isinstance(node, ast.UnaryOp):
            if not isinstance(node.op, (ast.UAdd, ast.USub)):
                raise ExpressionError(f"{self.text!r}: operator {type(node.op).__name__} is not allowed")
            self._check(node.operand)
        elif isinstance(node, ast.Call):
            if not isinstance(node.func, ast.Name) or node.func.id not in FUNCTIONS or node.keywords:
                raise ExpressionError(
                    f"{self.text!r}: only the functions {', '.join(FUNCTIONS)} may be called")
            for arg in node.args:
                self._check(arg)
        else:
            raise ExpressionError(f"{self.text!r}: {type(node).__name__} is not allowed in an expression")

    def evaluate(self, values: Mapping[str, object], backend: str = "numpy"):
        """Evaluate with numbers/arrays (``backend="numpy"``) or CasADi symbols (``"casadi"``)."""
        fn = _numpy_fn if backend == "numpy" else _casadi_fn

        def walk(node):
            if isinstance(node, ast.Constant):
                return float(node.value)
            if isinstance(node, ast.Name):
                return values[node.id] if node.id in self.variables else CONSTANTS[node.id]
            if isinstance(node, ast.BinOp):
                a, b = walk(node.left), walk(node.right)
                op = _BINOPS[type(node.op)]
                return {"add": lambda: a + b, "sub": lambda: a - b, "mul": lambda: a * b,
                        "div": lambda: a / b, "pow": lambda: a**b}[op]()
            if isinstance(node, ast.UnaryOp):
                v = walk(node.operand)
                return -v if isinstance(node.op, ast.USub) else v
            return fn(node.func.id)(*[walk(a) for a in node.args])

        return walk(self._tree)
