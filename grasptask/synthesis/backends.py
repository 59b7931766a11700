"""Solving the grasp NLP: Pyomo's NL writer writes it, CasADi imports it (``NlpBuilder.import_nl``) and IPOPT
solves it with exact derivatives; the solution is mapped back onto the Pyomo variables in the writer's order.

The default backend runs CasADi's bundled IPOPT (``nlpsol('ipopt', expand=True)``). The ``cyipopt`` backend
drives the same CasADi-generated objective, constraint, Jacobian and Hessian functions through cyipopt. Both are
built once per model and then re-solved from each start's initial point.
"""

from __future__ import annotations

import io
import os
import sys
import tempfile
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager, redirect_stdout
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

import casadi
import numpy as np
from pyomo.repn.plugins.nl_writer import NLWriter

from grasptask.errors import BadInputError
from grasptask.synthesis.spline import SurrogateSpec, surrogate_terms

_IPOPT_STATUS = {
    "Solve_Succeeded": "optimal",
    "Solved_To_Acceptable_Level": "acceptable",
    "Infeasible_Problem_Detected": "infeasible",
    # the restoration phase found no feasible point near the iterate: locally infeasible in effect (the message
    # column keeps IPOPT's own words)
    "Restoration_Failed": "infeasible",
    "Maximum_Iterations_Exceeded": "max-iter",
    "Maximum_CpuTime_Exceeded": "time-limit",
    "Maximum_WallTime_Exceeded": "time-limit",
}
# cyipopt reports IPOPT's ApplicationReturnStatus as an integer
_IPOPT_CODES = {
    0: "optimal",
    1: "acceptable",
    2: "infeasible",
    -2: "infeasible",  # Restoration_Failed, as above
    -1: "max-iter",
    -4: "time-limit",
    -5: "time-limit",
}
# IPOPT catches Ctrl-C during a solve and stops with this status; it is the user's interrupt, not a result
_USER_STOP_STATUS, _USER_STOP_CODE = "User_Requested_Stop", 5


@dataclass(frozen=True)
class Bounds:
    """The variable and constraint bounds of one solve, in the NL file's order."""

    lbx: np.ndarray
    ubx: np.ndarray
    lbg: np.ndarray
    ubg: np.ndarray


@dataclass
class SolveResult:
    status: str
    iterations: int
    seconds: float
    x: np.ndarray | None
    message: str = ""


#: IPOPT options that would make IPOPT write files of its own, outside the sweep's --out
_FILE_OPTIONS = ("output_file", "print_options_documentation")


@contextmanager
def _quiet_stdout() -> Iterator[None]:
    """Silence IPOPT's own complaints about an option: CasADi prints them through Python's stdout, IPOPT's
    other output goes to the C-level one."""
    sys.stdout.flush()
    saved = os.dup(1)
    with open(os.devnull, "w") as null:
        os.dup2(null.fileno(), 1)
    try:
        with redirect_stdout(io.StringIO()):
            yield
    finally:
        os.dup2(saved, 1)
        os.close(saved)


def check_ipopt_options(options: dict[str, Any], source: str | Path) -> None:
    """Try each IPOPT option on a one-variable problem, so that a name or value IPOPT rejects fails before a
    sweep starts, as one line naming it, and not as an error row on every start."""
    x = casadi.SX.sym("x")
    problem = {"x": x, "f": (x - 1) ** 2}
    for name, value in options.items():
        if name in _FILE_OPTIONS:
            raise BadInputError(source, f"field 'ipopt.{name}': IPOPT would write a file of its own; not allowed")
        settings = {"ipopt.print_level": 0, "ipopt.sb": "yes", f"ipopt.{name}": value}
        try:
            with _quiet_stdout():
                solver = casadi.nlpsol("check", "ipopt", problem, {**settings, "print_time": False})
                solver(x0=0.0)
            rejected = solver.stats().get("return_status") == "Invalid_Option"
        except RuntimeError:
            rejected = True
        if rejected:
            raise BadInputError(source, f"field 'ipopt.{name}': IPOPT rejects the option or its value {value!r}")


def write_nl(model: Any) -> tuple[str, list]:
    """The model as NL text (numeric labels only: symbolic ones break CasADi's import) and its variable order."""
    text, variables, _ = write_nl_rows(model)
    return text, variables


def write_nl_rows(model: Any) -> tuple[str, list, list]:
    """:func:`write_nl`, and the constraints in the order of the NL rows."""
    nl, row, col = io.StringIO(), io.StringIO(), io.StringIO()
    # no linear presolve: it would eliminate variables (e.g. the coupled DIP angles) from the column list
    info = NLWriter().write(model, nl, row, col, symbolic_solver_labels=False, linear_presolve=False)
    return nl.getvalue(), list(info.variables), list(info.constraints)


class CasadiNLP:
    """The NL model imported into CasADi once: its functions, bounds and variable order, and the derivatives
    IPOPT asks for (``x``, ``sigma`` and ``lam`` symbols; the objective's gradient, the constraints' Jacobian and
    the upper triangle of the Lagrangian's Hessian). Without a surrogate all of it is one expanded SX graph.
    With one, its placeholder rows become the B-spline surface: the rest keeps SX derivatives, called from MX,
    and the spline's derivatives are added as :func:`grasptask.synthesis.spline.surrogate_terms` writes them."""

    def __init__(self, nl_text: str, surrogate: SurrogateSpec | None = None):
        with tempfile.TemporaryDirectory() as tmp:
            path = os.path.join(tmp, "model.nl")
            with open(path, "w") as handle:
                handle.write(nl_text)
            builder = casadi.NlpBuilder()
            builder.import_nl(path, {"verbose": False})
        self.bounds = Bounds(
            np.array(builder.x_lb, float),
            np.array(builder.x_ub, float),
            np.array(builder.g_lb, float),
            np.array(builder.g_ub, float),
        )
        self.expandable = surrogate is None
        whole = casadi.Function("nlp", [casadi.vertcat(*builder.x)], [builder.f, casadi.vertcat(*builder.g)])
        whole = whole.expand()  # CasADi's import gives MX
        n_x, n_g = len(self.bounds.lbx), len(self.bounds.lbg)
        # SX symbols, or MX ones with a surrogate (untyped here: CasADi's stubs keep the two apart)
        self.x: Any = casadi.SX.sym("x", n_x)
        self.sigma: Any = casadi.SX.sym("sigma")
        self.lam: Any = casadi.SX.sym("lambda", n_g)
        self.f, self.g = whole(self.x)
        self._derivatives: tuple | None = None
        if surrogate is None:
            return  # its derivatives are made when asked for: CasADi's nlpsol makes its own
        x, sigma, lam = self.x, self.sigma, self.lam
        grad, jac, hess = self.derivatives()
        self.x, self.sigma, self.lam = casadi.MX.sym("x", n_x), casadi.MX.sym("sigma"), casadi.MX.sym("lambda", n_g)
        terms = surrogate_terms(self.x, self.lam, surrogate, n_g)
        self.f, g = whole(self.x)
        self.g = g + terms.correction
        self._derivatives = (
            casadi.Function("gradient", [x], [grad])(self.x),
            casadi.Function("jacobian", [x], [jac])(self.x) + terms.jacobian,
            casadi.Function("hessian", [x, sigma, lam], [hess])(self.x, self.sigma, self.lam) + terms.hessian,
        )

    def derivatives(self) -> tuple[Any, Any, Any]:
        """The objective's gradient, the constraints' Jacobian, the upper triangle of the Lagrangian's Hessian."""
        if self._derivatives is None:
            x, f, g = self.x, self.f, self.g
            hess = casadi.triu(casadi.hessian(self.sigma * f + casadi.dot(self.lam, g), x)[0])
            self._derivatives = (casadi.gradient(f, x), casadi.jacobian(g, x), hess)
        return self._derivatives

    def derivative_functions(self) -> dict[str, casadi.Function]:
        """``grad_f``, ``jac_g`` and ``hess_lag`` in the form CasADi's IPOPT interface takes them."""
        p: Any = (casadi.SX if self.expandable else casadi.MX).sym("p", 0, 1)
        grad, jac, hess = self.derivatives()
        return {
            "grad_f": casadi.Function("grad_f", [self.x, p], [self.f, grad]),
            "jac_g": casadi.Function("jac_g", [self.x, p], [self.g, jac]),
            "hess_lag": casadi.Function("hess_lag", [self.x, p, self.sigma, self.lam], [hess]),
        }


class CasadiBackend:
    name = "casadi"

    def __init__(self, nl_text: str, ipopt_options: dict, surrogate: SurrogateSpec | None = None):
        self.nlp = CasadiNLP(nl_text, surrogate)
        options: dict[str, Any] = {f"ipopt.{k}": v for k, v in ipopt_options.items()}
        options.update({"expand": self.nlp.expandable, "print_time": False, "error_on_fail": False})
        if not self.nlp.expandable:  # CasADi would differentiate the MX graph itself, several times slower
            options.update(self.nlp.derivative_functions())
        self.solver = casadi.nlpsol("grasp", "ipopt", {"x": self.nlp.x, "f": self.nlp.f, "g": self.nlp.g}, options)

    def solve(self, x0: np.ndarray, bounds: Bounds | None = None) -> SolveResult:
        b = bounds or self.nlp.bounds
        start = time.perf_counter()
        try:
            out = self.solver(x0=x0, lbx=b.lbx, ubx=b.ubx, lbg=b.lbg, ubg=b.ubg)
        except RuntimeError as exc:  # an evaluation error inside IPOPT, or CasADi's own report of Ctrl-C
            if "interrupt" in str(exc).lower():
                raise KeyboardInterrupt from exc
            return SolveResult("error", 0, time.perf_counter() - start, None, str(exc).splitlines()[-1][:200])
        stats = self.solver.stats()
        if stats.get("return_status") == _USER_STOP_STATUS:
            raise KeyboardInterrupt
        status = _IPOPT_STATUS.get(stats.get("return_status", ""), "error")
        return SolveResult(
            status,
            int(stats.get("iter_count", 0)),
            time.perf_counter() - start,
            np.array(out["x"]).ravel(),
            str(stats.get("return_status", "")),
        )


class CyipoptBackend:
    """The same CasADi functions (objective, constraints, their Jacobian and the Lagrangian's Hessian) behind
    cyipopt's interface."""

    name = "cyipopt"

    def __init__(self, nl_text: str, ipopt_options: dict, surrogate: SurrogateSpec | None = None):
        import cyipopt  # installed by `make setup-cyipopt`

        self.cyipopt = cyipopt
        nlp = self.nlp = CasadiNLP(nl_text, surrogate)
        x = nlp.x
        grad, jac, upper = nlp.derivatives()
        hess = upper.T  # cyipopt takes the lower triangle
        self._f = casadi.Function("objective", [x], [nlp.f])
        self._grad = casadi.Function("objective_gradient", [x], [grad])
        self._g = casadi.Function("constraints", [x], [nlp.g])
        # an NLP without constraints has an empty Jacobian, which cyipopt then never asks for
        self._jac = casadi.Function("constraint_jacobian", [x], [jac.nz[:] if jac.nnz() else casadi.DM(0, 1)])
        self._jac_rc = jac.sparsity().get_triplet()
        self._hess = casadi.Function("lagrangian_hessian", [x, nlp.sigma, nlp.lam], [hess.nz[:]])
        self._hess_rc = hess.sparsity().get_triplet()
        self.options = ipopt_options

    def solve(self, x0: np.ndarray, bounds: Bounds | None = None) -> SolveResult:
        backend = self
        iterations = [0]

        class Problem:
            def intermediate(self, alg_mod, iter_count, *args):
                iterations[0] = int(iter_count)
                return True

            def objective(self, x):
                return float(backend._f(x))

            def gradient(self, x):
                return np.array(backend._grad(x)).ravel()

            def constraints(self, x):
                return np.array(backend._g(x)).ravel()

            def jacobian(self, x):
                return np.array(backend._jac(x)).ravel()

            def jacobianstructure(self):
                return tuple(np.array(v) for v in backend._jac_rc)

            def hessian(self, x, lagrange, obj_factor):
                return np.array(backend._hess(x, obj_factor, lagrange)).ravel()

            def hessianstructure(self):
                return tuple(np.array(v) for v in backend._hess_rc)

        b = bounds or self.nlp.bounds
        problem = self.cyipopt.Problem(
            n=len(x0), m=len(b.lbg), problem_obj=Problem(), lb=b.lbx, ub=b.ubx, cl=b.lbg, cu=b.ubg
        )
        for key, value in self.options.items():
            problem.add_option(key, value)
        start = time.perf_counter()
        try:
            x, info = problem.solve(np.clip(x0, b.lbx, b.ubx))
        except Exception as exc:  # noqa: BLE001 - any failure inside IPOPT is a recorded status
            return SolveResult("error", 0, time.perf_counter() - start, None, str(exc)[:200])
        if int(info["status"]) == _USER_STOP_CODE:
            raise KeyboardInterrupt
        status = _IPOPT_CODES.get(int(info["status"]), "error")
        message = info["status_msg"]
        message = message.decode() if isinstance(message, bytes) else str(message)
        return SolveResult(status, iterations[0], time.perf_counter() - start, np.asarray(x), message)


class Backend(Protocol):
    name: str
    nlp: CasadiNLP

    def solve(self, x0: np.ndarray, bounds: Bounds | None = None) -> SolveResult: ...


BACKENDS: dict[str, Callable[..., Backend]] = {"casadi": CasadiBackend, "cyipopt": CyipoptBackend}
