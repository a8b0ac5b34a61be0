"""Safe arithmetic expressions from YAML: parsed by a whitelist over Python's AST, never ``eval``.

An expression such as ``"0.3*sin(pi*s) + 0.1"`` or ``"x/(x**2+y**2)"`` is parsed once into a small
tree and can then be evaluated with numpy (numbers, arrays) or with CasADi (symbols), so fields and
profiles written by users get exact symbolic derivatives.

Allowed: numbers, the named variables, ``+ - * / **``, unary ``+ -``, parentheses, the constants
``pi`` and ``e``, and the functions listed in :data:`FUNCTIONS`.

Bounds (a hostile expression fails at once with one line): at most :data:`MAX_LENGTH` characters,
at most :data:`MAX_DEPTH` nested operations, and every constant part (``1/0``, ``10**10**10``)
must evaluate to a finite number. Numerical evaluation is in float64, so an overflow gives ±inf or
NaN (for the caller's finiteness check), never an exception or a huge integer.
"""
from __future__ import annotations

import ast
import math
from dataclasses import dataclass
from typing import Mapping, Sequence

import numpy as np

__all__ = ["Expression", "ExpressionError", "FUNCTIONS", "MAX_LENGTH", "MAX_DEPTH"]

#: Longest expression text, characters.
MAX_LENGTH = 10_000
#: Deepest nesting of operations and calls in an expression.
MAX_DEPTH = 200

FUNCTIONS = (
    "sin", "cos", "tan", "exp", "log", "sqrt", "tanh", "sinh", "cosh",
    "arctan", "arcsin", "arccos", "atan2", "abs", "fmin", "fmax",
)
_BINARY_FUNCTIONS = ("atan2", "fmin", "fmax")
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
        text = str(self.text).strip()
        if len(text) > MAX_LENGTH:
            raise ExpressionError(f"expression too long ({len(text)} characters, at most {MAX_LENGTH})")
        if _paren_depth(text) > MAX_DEPTH:
            raise ExpressionError(f"expression nested deeper than {MAX_DEPTH} levels")
        try:
            tree = ast.parse(text, mode="eval")
        except SyntaxError as err:
            raise ExpressionError(f"cannot parse {_cut(self.text)!r}: {err.msg}") from None
        except (MemoryError, RecursionError):
            raise ExpressionError(f"expression nested deeper than {MAX_DEPTH} levels") from None
        if _tree_depth(tree.body) > MAX_DEPTH:
            raise ExpressionError(f"expression nested deeper than {MAX_DEPTH} levels")
        self._check(tree.body)
        object.__setattr__(self, "_tree", tree.body)
        self._check_constant_parts(tree.body)

    def _check_constant_parts(self, root) -> None:
        """Every sub-expression free of variables must be finite in float64 (``1/0``, ``10**10**10``
        and ``log(0)`` are rejected here, before any evaluation on a grid). One bottom-up pass."""
        value: dict = {}  # id(node) -> float64 for constant nodes, None for variable ones
        stack = [(root, False)]
        while stack:
            node, done = stack.pop()
            kids = _children(node)
            if not done and kids:
                stack.append((node, True))
                stack.extend((k, False) for k in kids)
                continue
            if isinstance(node, ast.Constant):
                try:
                    value[id(node)] = np.float64(node.value)
                except OverflowError:  # an integer literal beyond float64
                    value[id(node)] = np.float64(np.inf)
                if not np.isfinite(value[id(node)]):
                    raise ExpressionError(f"{_cut(repr(node.value))} is not a finite float64 number")
            elif isinstance(node, ast.Name):
                value[id(node)] = None if node.id in self.variables else np.float64(CONSTANTS[node.id])
            elif any(value[id(k)] is None for k in kids):
                value[id(node)] = None
            else:
                args = [value[id(k)] for k in kids]
                with np.errstate(all="ignore"):
                    if isinstance(node, ast.BinOp):
                        v = _apply(_BINOPS[type(node.op)], *args)
                    elif isinstance(node, ast.UnaryOp):
                        v = -args[0] if isinstance(node.op, ast.USub) else args[0]
                    else:
                        v = _numpy_fn(node.func.id)(*args)
                if not np.all(np.isfinite(v)):
                    part = ast.get_source_segment(str(self.text).strip(), node) or "a constant part"
                    raise ExpressionError(f"{_cut(part)!r} is not a finite number (overflow, division "
                                          "by zero or a function outside its domain)")
                value[id(node)] = np.float64(v)

    def _check(self, node):
        if isinstance(node, ast.Constant):
            if not isinstance(node.value, (int, float)) or isinstance(node.value, bool):
                raise ExpressionError(f"{_cut(self.text)!r}: only numbers are allowed as constants")
        elif isinstance(node, ast.Name):
            if node.id not in self.variables and node.id not in CONSTANTS:
                allowed = ", ".join(list(self.variables) + list(CONSTANTS))
                raise ExpressionError(f"{_cut(self.text)!r}: unknown name {node.id!r} (allowed: {allowed})")
        elif isinstance(node, ast.BinOp):
            if type(node.op) not in _BINOPS:
                raise ExpressionError(f"{_cut(self.text)!r}: operator {type(node.op).__name__} is not allowed")
            self._check(node.left)
            self._check(node.right)
        elif isinstance(node, ast.UnaryOp):
            if not isinstance(node.op, (ast.UAdd, ast.USub)):
                raise ExpressionError(f"{_cut(self.text)!r}: operator {type(node.op).__name__} is not allowed")
            self._check(node.operand)
        elif isinstance(node, ast.Call):
            if not isinstance(node.func, ast.Name) or node.func.id not in FUNCTIONS or node.keywords:
                raise ExpressionError(
                    f"{_cut(self.text)!r}: only the functions {', '.join(FUNCTIONS)} may be called")
            arity = 2 if node.func.id in _BINARY_FUNCTIONS else 1
            if len(node.args) != arity:
                raise ExpressionError(f"{_cut(self.text)!r}: {node.func.id} takes {arity} argument"
                                      f"{'s' if arity > 1 else ''}, got {len(node.args)}")
            for arg in node.args:
                self._check(arg)
        else:
            raise ExpressionError(f"{_cut(self.text)!r}: {type(node).__name__} is not allowed in an expression")

    def evaluate(self, values: Mapping[str, object], backend: str = "numpy"):
        """Evaluate with numbers/arrays (``backend="numpy"``, float64: overflow gives inf/NaN) or
        CasADi symbols (``"casadi"``)."""
        fn = _numpy_fn if backend == "numpy" else _casadi_fn
        return self._walk(self._tree, values, fn, np.float64 if backend == "numpy" else float)

    def _walk(self, root, values, fn, number=np.float64):
        # an explicit stack, not recursion: depth is bounded, but this keeps Python's own limit
        # out of the picture
        out: dict = {}
        stack = [(root, False)]
        while stack:
            node, done = stack.pop()
            if isinstance(node, ast.Constant):
                out[id(node)] = number(node.value)
            elif isinstance(node, ast.Name):
                out[id(node)] = values[node.id] if node.id in self.variables else CONSTANTS[node.id]
            elif not done:
                stack.append((node, True))
                stack.extend((child, False) for child in _children(node))
            elif isinstance(node, ast.BinOp):
                a, b = out[id(node.left)], out[id(node.right)]
                out[id(node)] = _apply(_BINOPS[type(node.op)], a, b)
            elif isinstance(node, ast.UnaryOp):
                v = out[id(node.operand)]
                out[id(node)] = -v if isinstance(node.op, ast.USub) else v
            else:
                out[id(node)] = fn(node.func.id)(*[out[id(a)] for a in node.args])
        return out[id(root)]


def _apply(op: str, a, b):
    if op == "add":
        return a + b
    if op == "sub":
        return a - b
    if op == "mul":
        return a * b
    if op == "div":
        return a / b
    return a**b


def _children(node) -> list:
    if isinstance(node, ast.BinOp):
        return [node.left, node.right]
    if isinstance(node, ast.UnaryOp):
        return [node.operand]
    if isinstance(node, ast.Call):
        return list(node.args)
    return []


def _paren_depth(text: str) -> int:
    depth = deepest = 0
    for ch in text:
        if ch == "(":
            depth += 1
            deepest = max(deepest, depth)
        elif ch == ")":
            depth -= 1
    return deepest


def _tree_depth(root) -> int:
    """Depth of an AST, iteratively (the tree of a 10 000-character text can be 5 000 deep)."""
    deepest, stack = 0, [(root, 1)]
    while stack:
        node, depth = stack.pop()
        deepest = max(deepest, depth)
        if depth > MAX_DEPTH:
            return depth
        stack.extend((child, depth + 1) for child in ast.iter_child_nodes(node))
    return deepest


def _cut(text: str, limit: int = 60) -> str:
    text = str(text)
    return text if len(text) <= limit else text[:limit] + "..."
