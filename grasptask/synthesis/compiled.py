"""Pyomo expressions turned into one CasADi function of a few input variables.

Placement evaluates every defined variable of the NLP (link frames, contacts, normals, cone edges, Jacobians)
and the collision margins several times per start; walking the Pyomo expression trees each time is slow, so
the trees are converted once, when a worker builds its model (timings in docs/design/synthesis.md).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import casadi
import numpy as np
import pyomo.environ as pyo
from pyomo.core.expr.numeric_expr import SumExpression, UnaryFunctionExpression
from pyomo.core.expr.numvalue import native_numeric_types
from pyomo.core.expr.visitor import StreamBasedExpressionVisitor

from grasptask.objects.distance_grid import DistanceGrid
from grasptask.synthesis.spline import distance_function, gradient_function
from grasptask.synthesis.surfaces import SurrogateLink

_UNARY = {
    "cos": casadi.cos,
    "sin": casadi.sin,
    "tan": casadi.tan,
    "exp": casadi.exp,
    "log": casadi.log,
    "sqrt": casadi.sqrt,
    "abs": casadi.fabs,
}


class _ToCasadi(StreamBasedExpressionVisitor):
    """A Pyomo expression as a CasADi SX expression, its variables looked up in ``symbols`` (by ``id``).

    Sub-expressions shared between Pyomo trees (a sample point inside each of a GP's hundreds of kernel terms)
    are converted once: without that memo the walk, and the SX graph, grew with every repetition."""

    def __init__(self, symbols: dict):
        super().__init__()
        self.symbols = symbols
        # id(node) -> (node, SX); the node is kept so that its id is not reused
        self.memo: dict[int, tuple[Any, Any]] = {}

    def _known(self, node):
        """``(True, value)`` for a number, variable, parameter or converted sub-expression, else ``(False, None)``."""
        if node.__class__ in native_numeric_types:
            return True, node
        if id(node) in self.memo:
            return True, self.memo[id(node)][1]
        if node.is_expression_type():
            return False, None
        if node.is_variable_type():
            try:
                return True, self.symbols[id(node)]
            except KeyError:
                raise ValueError(f"{node.name} is neither an input nor defined before it is used") from None
        return True, pyo.value(node)  # parameters and other constants

    def initializeWalker(self, expr):
        known, value = self._known(expr)
        return (False, value) if known else (True, expr)

    def beforeChild(self, node, child, child_idx):
        known, value = self._known(child)
        return (False, value) if known else (True, None)

    def exitNode(self, node, values):
        if isinstance(node, UnaryFunctionExpression):  # its own operation calls math.cos and the like
            result = _UNARY[node.getname()](values[0])
        elif isinstance(node, SumExpression) and len(values) > 2:
            result = casadi.sum1(casadi.vertcat(*values))  # one call, not one Python-level addition per term
        else:
            result = node._apply_operation(values)
        self.memo[id(node)] = (node, result)
        return result


class _Surrogate:
    """The B-spline distance and its gradient at a surrogate link's point, each point evaluated once."""

    def __init__(self, grid: DistanceGrid):
        self.distance = distance_function(grid)
        self.gradient = gradient_function(self.distance)
        self.memo: dict[tuple[int, ...], Any] = {}

    def __call__(self, link: SurrogateLink, symbols: dict) -> Any:
        key = (link.component is None, *(id(v) for v in link.point))
        if key not in self.memo:
            point = casadi.vertcat(*[symbols[id(v)] for v in link.point])
            self.memo[key] = self.distance(point) if link.component is None else self.gradient(point)
        out = self.memo[key]
        return out if link.component is None else out[link.component]


class CompiledExpressions:
    """``inputs`` (Pyomo variables) -> the values of ``definitions`` (``(variable, expression)`` pairs in
    dependency order, each expression in terms of the inputs and earlier defined variables) and of ``extra``
    expressions (in terms of either), all in one call."""

    def __init__(self, inputs: Sequence, definitions: Sequence, extra: Sequence = (), grid: DistanceGrid | None = None):
        self.inputs = list(inputs)
        self.defined = [var for var, _ in definitions]
        # a surrogate surface is a B-spline, which only MX can call
        x: Any = (casadi.MX if grid is not None else casadi.SX).sym("x", len(self.inputs))
        symbols = {id(var): x[k] for k, var in enumerate(self.inputs)}
        to_casadi = _ToCasadi(symbols)
        surrogate = _Surrogate(grid) if grid is not None else None
        values = []
        for var, expression in definitions:
            if isinstance(expression, SurrogateLink):
                assert surrogate is not None, "a surrogate link without its grid"
                value = surrogate(expression, symbols)
            else:
                value = to_casadi.walk_expression(expression)
            symbols[id(var)] = value
            values.append(value)
        extra_values = [to_casadi.walk_expression(e) for e in extra]
        self._defined = casadi.Function("defined", [x], [casadi.vertcat(*values)])
        self._extra = casadi.Function("extra", [x], [casadi.vertcat(*extra_values)])

    def input_values(self) -> np.ndarray:
        return np.array([var.value for var in self.inputs], dtype=float)

    def assign_defined(self, inputs: np.ndarray) -> None:
        """Set every defined variable from the input values ``inputs``."""
        for var, value in zip(self.defined, np.asarray(self._defined(inputs)).ravel(), strict=True):
            var.set_value(float(value), skip_validation=True)

    def extra(self, inputs: np.ndarray) -> np.ndarray:
        return np.asarray(self._extra(inputs)).ravel()
