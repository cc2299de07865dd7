"""Design optimization: parameters chosen to minimise an output of the run.

    best = optimize(model, "rms(crank_drive.crank.mx)", ["bodies.crank.mass"],
                    constraints=["final(slider.x) >= 0.2"], bounds={...})

objective: a sweep output (``reduction(column)``: peak, trough, rms, mean, max, final, ...; or
a callable f(results) -> float), minimised; ``-spec`` maximises it; a list of specs minimises
the largest of them (the minimax of a peak and a trough, ``["peak(T)", "-trough(T)"]``: the
peak |T| without the kink of ``absmax``) through the epigraph form: minimise s subject to
s >= f_i(x). constraints: ``"spec >= value"``, ``"spec <= value"``, ``"spec == value"`` (or
(spec, op, value) tuples). Gradients by forward sensitivities (method standard/baumgarte,
reductions of body state columns), by the adjoint (the same cases, one forward and one
backward run for all outputs: :mod:`.adjoint`) or central differences, all 2 p + 1 members
of one gradient run as one chunk (:func:`spatialmbd.sweep.core.run_chunk`). jacobian="auto"
takes the adjoint when the parameters outnumber the outputs it differentiates (objective
terms plus constraints; the forward/reverse rule: forward sensitivities cost one system per
parameter, the adjoint one cotangent per output), else forward sensitivities where they
apply, else central differences. SciPy's SLSQP or trust-constr
work in scaled variables u = x / |x0|.
"""
from __future__ import annotations

import re
import time
from dataclasses import dataclass, field
from typing import Optional

import numpy as np

from ..errors import ModelError
from ..sweep.core import SUCCESS, _make_job, run_chunk
from ..sweep.outputs import parse_outputs
from .problem import _body_state_column, start_values

__all__ = ["optimize", "Optimization"]

_CONSTRAINT = re.compile(r"^\s*(.+?)\s*(>=|<=|==)\s*([-+0-9.eE]+)\s*$")


@dataclass
class Optimization:
    """The result of :func:`optimize`."""

    names: list
    start: np.ndarray
    x: np.ndarray
    objective: float
    outputs: dict            # every objective and constraint output at x
    success: bool
    message: str
    n_iterations: int
    n_runs: int
    history: list = field(default_factory=list)     # (x, objective) per evaluation
    failures: list = field(default_factory=list)
    wall_time: float = 0.0
    model_data: Optional[dict] = None
    jacobian: str = ""       # how the gradients were computed: adjoint, forward or fd

    @property
    def values(self) -> dict:
        return dict(zip(self.names, map(float, self.x)))

    def report(self) -> str:
        w = max(len(n) for n in self.names)
        state = "converged" if self.success else "NOT converged"
        lines = [f"optimization: {self.message} ({state}), {self.n_iterations} iterations, "
                 f"{self.n_runs} runs, {self.wall_time:.3g} s, gradients: {self.jacobian}",
                 f"objective {self.objective:.8g}", "",
                 f"{'parameter':<{w}}  {'optimum':>13}  {'start':>11}"]
        lines += [f"{n:<{w}}  {x:13.6g}  {x0:11.4g}"
                  for n, x, x0 in zip(self.names, self.x, self.start)]
        lines += ["", "outputs at the optimum"]
        lines += [f"  {k} = {v:.8g}" for k, v in self.outputs.items()]
        if self.failures:
            lines.append(f"{len(self.failures)} run(s) failed; first: "
                         f"{self.failures[0]['message']}")
        return "\n".join(lines)

    def write_model(self, path):
        """Write the optimised model file (.yaml/.json) with its analysis."""
        from ..io.modelfile import load_model
        from ..io.writer import save_model
        from ..sweep.params import apply
        if self.model_data is None:
            raise ModelError("the model was a factory: set the optimum in it yourself "
                             "(result.values)")
        model, analysis = load_model(apply(self.model_data, {
            n: v for n, v in self.values.items() if not n.startswith("analysis.")}))
        header = "optimized by spatialmbd optimize:\n" + "\n".join(
            f"  {n} = {v:.8g}" for n, v in self.values.items())
        return save_model(model, path, analysis, header=header)


def _signed(spec):
    if isinstance(spec, str) and spec.strip().startswith("-"):
        return -1.0, spec.strip()[1:].strip()
    return 1.0, spec


def _constraints(constraints):
    out = []
    for c in constraints or []:
        if isinstance(c, str):
            m = _CONSTRAINT.match(c)
            if not m:
                raise ModelError(f"constraint {c!r}: write 'output >= value', 'output <= "
                                 "value' or 'output == value', e.g. 'final(slider.x) >= 0.2'")
            spec, op, value = m.group(1), m.group(2), float(m.group(3))
        else:
            try:
                spec, op, value = c
                value = float(value)
            except (TypeError, ValueError):
                raise ModelError(f"constraint {c!r}: expected (output, op, value)") from None
            if op not in (">=", "<=", "=="):
                raise ModelError(f"constraint {c!r}: op must be >=, <= or ==")
        out.append((spec, op, value))
    return out


class _Failed(Exception):
    pass


def optimize(model, objective, params, *, constraints=None, bounds: Optional[dict] = None,
             method: str = "SLSQP", analysis=None, jacobian: str = "auto",
             engine: str = "simulate", fd_step: float = 1e-5, tol: float = 1e-8,
             max_iterations: int = 100) -> Optimization:
    """Minimise ``objective`` over the parameters ``params`` (paths, or {path: start}).

    model: a model file, Model, ModelBuilder, model dict or factory; objective: an output
    spec, ``-spec`` (maximise), a callable f(results) -> float, or a list of specs (minimise
    the largest); constraints: strings ``"spec >= v"`` / ``<=`` / ``==`` or tuples; bounds:
    {path: (low, high)}; method: "SLSQP" or "trust-constr"; analysis: default the model's;
    jacobian: "auto" (the adjoint when the parameters outnumber the outputs, else forward
    sensitivities, where they apply; central differences elsewhere), "adjoint", "forward"
    or "fd"; fd_step:
    relative step of the central differences; tol: the method's tolerance.
    """
    from scipy import optimize as so
    if method not in ("SLSQP", "trust-constr"):
        raise ModelError(f"method must be 'SLSQP' or 'trust-constr', got {method!r}")
    if jacobian not in ("auto", "adjoint", "forward", "fd"):
        raise ModelError(f"jacobian must be 'auto', 'adjoint', 'forward' or 'fd', got "
                         f"{jacobian!r}")
    start_time = time.perf_counter()
    given = dict(params) if isinstance(params, dict) else \
        {p: None for p in ([params] if isinstance(params, str) else params)}
    names = list(given)
    if not names:
        raise ModelError("optimize: name at least one parameter")
    terms = [_signed(o) for o in (objective if isinstance(objective, (list, tuple))
                                  else [objective])]
    cons = _constraints(constraints)
    specs = {f"objective {k}": spec for k, (_, spec) in enumerate(terms)}
    specs.update({f"constraint {k}": spec for k, (spec, _, _) in enumerate(cons)})
    outs = parse_outputs(specs)
    job = _make_job(model, _space(names, np.zeros(len(names))), outs, analysis, engine, {})
    x0 = start_values(job, names, given)
    scale = np.where(x0 != 0, np.abs(x0), 1.0)
    lo, hi = np.full(len(names), -np.inf), np.full(len(names), np.inf)
    for name, (a, b) in (bounds or {}).items():
        if name not in names:
            raise ModelError(f"bounds: {name!r} is not one of the parameters {names}")
        j = names.index(name)
        lo[j] = -np.inf if a is None else float(a)
        hi[j] = np.inf if b is None else float(b)
        if not lo[j] <= x0[j] <= hi[j]:
            raise ModelError(f"bounds of {name!r}: ({lo[j]:g}, {hi[j]:g}) exclude the start "
                             f"value {x0[j]:g}")
    method_name = (job.analysis.get("method") or {}).get("name") \
        if isinstance(job.analysis.get("method"), dict) else job.analysis.get("method")
    forward_ok = (job.data is not None and method_name in ("standard", "baumgarte") and
                  all(o.function is None and o.reduction is not None and
                      _body_state_column(o.column) for o in outs))
    if jacobian == "forward" and not forward_ok:
        raise ModelError("forward sensitivities need the 'standard' or 'baumgarte' method and "
                         "reductions of body state columns; use jacobian='fd'")
    adjoint_ok = forward_ok and not any(n.startswith("analysis.") for n in names)
    if jacobian == "adjoint" and not adjoint_ok:
        raise ModelError("the adjoint needs the 'standard' or 'baumgarte' method, reductions "
                         "of body state columns and no analysis.* parameter; use "
                         "jacobian='fd'")
    kind = jacobian if jacobian != "auto" else (
        "adjoint" if adjoint_ok and len(names) > len(outs) else
        "forward" if forward_ok else "fd")
    adjoint = {}
    forward_steps = {}          # the f_p steps of the first forward run, used again
    failures, history, counter = [], [], {"runs": 0}
    cache = {}

    def evaluate(x, grad):
        key = (x.tobytes(), grad)
        if key in cache:
            return cache[key]
        if not grad and (x.tobytes(), True) in cache:
            return cache[(x.tobytes(), True)]
        p = x.size
        if kind == "adjoint":
            from .adjoint import Adjoint, output_gradients
            counter["runs"] += 2 if grad else 1
            try:
                if "a" not in adjoint:
                    adjoint["a"] = Adjoint(dict(job.data, analysis=job.analysis), names)
                vals, G = output_gradients(adjoint["a"], list(outs), x, grad)
            except ModelError as exc:
                failures.append(dict(parameters=dict(zip(names, map(float, x))),
                                     message=f"{type(exc).__name__}: {exc}"))
                raise _Failed(failures[-1]["message"]) from None
        elif kind == "forward":
            from ..sweep.sensitivity import forward_sensitivities
            data = dict(job.data, analysis=job.analysis)
            counter["runs"] += 1 + 2 * p
            try:
                fw = forward_sensitivities(data, dict(zip(names, map(float, x))),
                                           {k: f"{o.reduction}({o.column})" for k, o in
                                            zip(specs, outs)}, scheme="rk4",
                                           parameter_steps=forward_steps.get("x"))
                forward_steps.setdefault("x", fw.attrs["parameter_steps"])
            except Exception as exc:
                failures.append(dict(parameters=dict(zip(names, map(float, x))),
                                     message=f"{type(exc).__name__}: {exc}"))
                raise _Failed(failures[-1]["message"]) from None
            vals, G = fw["nominal"].values, fw["derivative"].values
        else:
            h = fd_step * np.maximum(np.abs(x), 1e-8)
            X = np.repeat(x[None, :], 1 + 2 * p if grad else 1, axis=0)
            if grad:
                for j in range(p):
                    X[1 + 2 * j, j] += h[j]
                    X[2 + 2 * j, j] -= h[j]
            rows = run_chunk(job, X)
            counter["runs"] += len(rows)
            for i, (status, message, _, _) in enumerate(rows):
                if status != SUCCESS:
                    failures.append(dict(parameters=dict(zip(names, map(float, X[i]))),
                                         message=message))
                    raise _Failed(message)
            Y = np.array([[float(v) for v in row[2]] for row in rows])
            vals = Y[0]
            G = np.stack([(Y[1 + 2 * j] - Y[2 + 2 * j]) / (2 * h[j]) for j in range(p)],
                         axis=1) if grad else None
        if not np.all(np.isfinite(vals)):
            bad = [k for k, v in zip(specs, vals) if not np.isfinite(v)]
            failures.append(dict(parameters=dict(zip(names, map(float, x))),
                                 message=f"{bad[0]} ({specs[bad[0]]}) is not finite"))
            raise _Failed(failures[-1]["message"])
        cache[(x.tobytes(), grad or kind == "forward")] = (vals, G)
        return vals, G

    nt = len(terms)
    sign = np.array([s for s, _ in terms])
    minimax = nt > 1
    # variables: u = x / scale (and the epigraph variable s when minimax)

    def x_of(z):
        return z[:len(names)] * scale

    def f(z):
        if minimax:
            return z[-1]
        vals, _ = evaluate(x_of(z), False)
        history.append((x_of(z).copy(), float(sign[0] * vals[0])))
        return float(sign[0] * vals[0])

    def fgrad(z):
        if minimax:
            g = np.zeros(z.size)
            g[-1] = 1.0
            return g
        _, G = evaluate(x_of(z), True)
        return sign[0] * G[0] * scale

    scipy_cons = []
    for k, (spec, op, value) in enumerate(cons):
        row = nt + k
        s_ = -1.0 if op == "<=" else 1.0

        def c_fun(z, row=row, s_=s_, value=value):
            vals, _ = evaluate(x_of(z), False)
            return s_ * (vals[row] - value)

        def c_jac(z, row=row, s_=s_):
            _, G = evaluate(x_of(z), True)
            g = s_ * G[row] * scale
            return np.append(g, 0.0) if minimax else g
        scipy_cons.append(dict(type="eq" if op == "==" else "ineq", fun=c_fun, jac=c_jac))
    if minimax:
        def e_fun(z):
            vals, _ = evaluate(x_of(z), False)
            history.append((x_of(z).copy(), float(np.max(sign * vals[:nt]))))
            return z[-1] - sign * vals[:nt]

        def e_jac(z):
            _, G = evaluate(x_of(z), True)
            out = np.zeros((nt, z.size))
            out[:, :-1] = -(sign[:, None] * G[:nt]) * scale[None, :]
            out[:, -1] = 1.0
            return out
        scipy_cons.append(dict(type="ineq", fun=e_fun, jac=e_jac))
    u0 = x0 / scale
    ub = [(None if not np.isfinite(a) else a / s_, None if not np.isfinite(b) else b / s_)
          for a, b, s_ in zip(lo, hi, scale)]
    try:
        vals0, _ = evaluate(x0, False)
    except _Failed as exc:
        raise ModelError(f"optimize: the model does not run at the start values "
                         f"{dict(zip(names, x0.tolist()))}: {exc}") from None
    z0 = np.append(u0, np.max(sign * vals0[:nt])) if minimax else u0
    if minimax:
        ub.append((None, None))
    if method == "trust-constr":
        scipy_cons = [so.NonlinearConstraint(c["fun"], 0.0, 0.0 if c["type"] == "eq"
                                             else np.inf, jac=c["jac"]) for c in scipy_cons]
    try:
        sol = so.minimize(f, z0, jac=fgrad, bounds=ub, constraints=scipy_cons, method=method,
                          tol=tol, options=dict(maxiter=max_iterations))
        z, success, message = sol.x, bool(sol.success), str(sol.message)
        nit = int(getattr(sol, "nit", 0))
    except _Failed as exc:
        best = min(history, key=lambda h: h[1]) if history else (x0, np.nan)
        z = np.append(best[0] / scale, best[1]) if minimax else best[0] / scale
        success, message, nit = False, f"stopped: a run failed ({exc})", len(history)
    x = x_of(z)
    vals, _ = evaluate(x, False)
    objective_value = float(np.max(sign * vals[:nt]))
    return Optimization(
        names=names, start=x0, x=x, objective=objective_value,
        outputs={_label(specs[k]): float(v) for k, v in zip(specs, vals)}, success=success,
        message=message, n_iterations=nit, n_runs=counter["runs"], history=history,
        failures=failures, wall_time=time.perf_counter() - start_time,
        model_data=None if job.data is None else dict(job.data, analysis=job.analysis),
        jacobian=kind)


def _label(spec) -> str:
    return spec if isinstance(spec, str) else getattr(spec, "__name__", "objective")


def _space(names, x):
    from ..sweep.params import points
    return points({n: [float(v)] for n, v in zip(names, x)})
