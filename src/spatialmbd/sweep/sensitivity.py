"""Derivatives of sweep outputs with respect to parameters.

:func:`sensitivities` -- central finite differences run as one sweep. For each parameter x
(nominal x0) and each candidate step h (relative steps times |x0|, or times 1 if x0 = 0):

    D(h)   = (f(x0 + h) - f(x0 - h)) / (2 h)                 error c h^2 + ...
    D(h/2) from the half step; Richardson: R(h) = (4 D(h/2) - D(h)) / 3.

The outputs f are those of a numerical integration, so D(h/2) carries two errors: the
truncation T of the difference quotient, and I, the derivative with respect to x of the
integration error of f (smooth in x, so it does not show in D(h) - D(h/2)). Both are estimated
and ``error`` is their sum, a bound of |D(h/2) - df/dx|:

    T: |D(h) - D(h/2)| / 3     (Richardson: D(h) - D(h/2) = 3 c (h/2)^2 when c h^2 leads)
    I: 2 |D(h/2) - D~(h/2)|    D~ from the same members integrated 100 times tighter (rtol and
                               atol / 100; a fixed step / 4). T cancels in the difference, and
                               if the tighter run's integration error I~ is at most half of I,
                               |I| <= |D - D~| + |I~| <= |D - D~| + |I| / 2, so |I| <= 2 |D - D~|.

The step reported is the candidate with the smallest ``error`` (a step too large shows
truncation error, one too small the integrator's noise amplified by 1/h: both grow the
estimate); the derivative is D(h/2) at the analysis' own tolerance, ``error`` its estimate,
with ``truncation`` and ``integration`` its two parts (Richardson's R(h) is also returned).
Analyses without time integration (kinematic, static, ...) have I = 0 and no tighter members.

:func:`forward_sensitivities` -- direct differentiation: the sensitivity equations
    S' = f_y S + f_p,  S(0) = dy0/dp
integrated with the state as one system, by the analysis' adaptive integrator with the
sensitivities in its error norm, or by classic RK4 steps (the scheme the discrete adjoint
differentiates). The kernels give D but not the derivatives of M, g and gamma with respect to
q, so f_y S and f_p are central differences of the compiled right-hand side (as CVODES does
without a user Jacobian), each Richardson-extrapolated, since the right-hand side of a
constrained system carries round-off far above machine precision (a near point mass on a
revolute joint: about 1e-12 relative, from the constraint torque cancelling the applied one):

* f_y s_j from f(y +- eps s_j) and f(y +- eps s_j / 2), eps = 1e-3 max(1, |y|) / |s_j|;
* f_p from the packed model floats F at x0 +- h and x0 +- h / 4, with h chosen once per
  parameter, at the initial state, from the ladder h_k = relative_delta |x0| 4^k (k = 0..9):
  the step whose extrapolation agrees best with the next step's (a step too small shows the
  round-off amplified by 1/h, one too large the truncation); likewise S(0) from the initial
  states of the same perturbed models, with its own step.

After each step the Euler parameters are renormalised and their sensitivities projected with
(I - p p^T) / |p|.
Outputs: reductions of body state columns (x..e3, vx..wz): final, initial, mean, rms, max, min
(derivative at the extreme sample), peak, trough (s at the interpolated extremum t*: x' = 0
there, so d x(t*(p), p) / dp = s(t*)), period (derivatives of the crossing times, -s / xdot).
"""
from __future__ import annotations

import json
import math
from typing import Optional, Sequence

import numpy as np

from ..errors import ModelError, SpatialMBDError
from ..outputs.vocabulary import BODY_POSITION, BODY_VELOCITY
from .core import SUCCESS, _make_job, sweep
from .outputs import _cubic_root, _poly, cubic_coefficients, parse_outputs, peak_at
from .params import ParameterSpace, get_path, points

__all__ = ["sensitivities", "forward_sensitivities"]

DEFAULT_STEPS = (1e-2, 1e-3, 1e-4)


def _scale(x0: float) -> float:
    return abs(x0) if x0 != 0.0 else 1.0


def _nominal(model, params) -> dict:
    """{name: nominal value}; None values read from the model dictionary."""
    if isinstance(params, (list, tuple)):
        params = {p: None for p in params}
    out = {}
    data = None
    for name, value in params.items():
        if value is None:
            if data is None:
                job = _make_job(model, points({name: [0.0]}), parse_outputs(["t"]), None,
                                "simulate", {})
                if job.data is None:
                    raise ModelError(f"parameter {name!r}: give its nominal value (a factory "
                                     "has no model file to read it from)")
                data = dict(job.data, analysis=job.analysis)
            value = get_path(data, name)
            if not isinstance(value, (int, float)) or isinstance(value, bool):
                raise ModelError(f"parameter {name!r}: the model holds {value!r}, not a number; "
                                 "address one component (e.g. an index .0)")
        out[name] = float(value)
    if not out:
        raise ModelError("sensitivities need at least one parameter")
    return out


def sensitivities(model, params, outputs, analysis=None, scheduler="serial", *,
                  relative_steps: Sequence[float] = DEFAULT_STEPS, engine="simulate",
                  progress=None, workers=None):
    """d(output)/d(parameter) by central differences with Richardson-checked step selection.

    params: {path: nominal value or None (read from the model)} or a list of paths.
    relative_steps: candidate steps h = r |x0| (r if x0 = 0; each is also halved).
    Returns an xarray Dataset with dims (output, parameter): ``derivative`` (D(h/2) at the
    selected step), ``error`` (its Richardson estimate), ``richardson`` (R(h)), ``step`` (h),
    and ``nominal`` (output values at the nominal point); ``status`` per parameter is "success"
    when at least one candidate step had all four members succeed (``message`` names the
    steps whose members failed, e.g. an inertia pushed past the triangle inequality).
    """
    import xarray as xr
    nominal = _nominal(model, params)
    names = list(nominal)
    outs = parse_outputs(outputs)
    if any(o.series for o in outs):
        raise ModelError("sensitivities are taken of scalar outputs: write reduction(column), "
                         "e.g. final(pendulum.z)")
    steps = [float(r) for r in relative_steps]
    if not steps or any(not r > 0 for r in steps):
        raise ModelError(f"relative_steps must be positive numbers, got {relative_steps!r}")
    base = np.array([nominal[n] for n in names])
    tight = _tighter(model, names[0], base[0], analysis)       # {path: (as given, tighter)}
    extra = list(tight)
    loose = [v[0] for v in tight.values()]
    fracs = (1.0, -1.0, 0.5, -0.5) + ((0.5, -0.5) if tight else ())
    rows = [np.concatenate([base, loose])]
    index = {}
    for j, n in enumerate(names):
        scale = _scale(base[j])
        for k, r in enumerate(steps):
            for s, frac in enumerate(fracs):
                x = np.concatenate([base, [v[int(s >= 4)] for v in tight.values()]])
                x[j] += frac * r * scale
                index[(j, k, s)] = len(rows)
                rows.append(x)
    space = ParameterSpace(names + extra, np.array(rows), "points")
    ds = sweep(model, space, outs, analysis, scheduler, engine=engine, progress=progress,
               workers=workers)
    vals = np.stack([ds[o.name].values for o in outs])              # (n_out, n_members)
    ok = ds["status"].values == SUCCESS
    n_out, n_par = len(outs), len(names)
    deriv, err, rich, step, trunc, integ = (np.full((n_out, n_par), np.nan) for _ in range(6))
    status = np.full(n_par, "failed", dtype=object)
    message = np.full(n_par, "", dtype=object)
    for j in range(n_par):
        scale = _scale(base[j])
        best = np.full(n_out, np.inf)
        skipped = []
        for k, r in enumerate(steps):
            h = r * scale
            ids = [index[(j, k, s)] for s in range(len(fracs))]
            if not all(ok[i] for i in ids):
                bad = [i for i in ids if not ok[i]][0]
                skipped.append(f"step {h:.3g}: {ds['message'].values[bad]}")
                continue
            status[j] = "success"
            d1 = (vals[:, ids[0]] - vals[:, ids[1]]) / (2 * h)
            d2 = (vals[:, ids[2]] - vals[:, ids[3]]) / h
            t_part = np.abs(d1 - d2) / 3.0
            i_part = 2.0 * np.abs(d2 - (vals[:, ids[4]] - vals[:, ids[5]]) / h) if tight \
                else np.zeros(n_out)
            e = t_part + i_part
            better = e < best
            best = np.where(better, e, best)
            for arr, value in ((deriv, d2), (err, e), (rich, (4 * d2 - d1) / 3.0),
                               (step, h), (trunc, t_part), (integ, i_part)):
                arr[:, j] = np.where(better, value, arr[:, j])
        if skipped:
            message[j] = "members failed at " + "; ".join(skipped)
    names_out = [o.name for o in outs]
    out = xr.Dataset(
        dict(derivative=(("output", "parameter"), deriv), error=(("output", "parameter"), err),
             richardson=(("output", "parameter"), rich), step=(("output", "parameter"), step),
             truncation=(("output", "parameter"), trunc),
             integration=(("output", "parameter"), integ),
             nominal=(("output",), vals[:, 0]),
             status=(("parameter",), status.astype(str)),
             message=(("parameter",), message.astype(str))),
        coords=dict(output=names_out, parameter=names,
                    value=(("parameter",), base)),
        attrs=dict(method="central differences, Richardson-checked step; error = truncation "
                   "(Richardson) + integration (2 |D - D at a 100x tighter tolerance|)",
                   tighter=json.dumps({p: v[1] for p, v in tight.items()}),
                   relative_steps=json.dumps(steps), n_members=int(space.n_members),
                   n_failed=int(np.sum(~ok)), wall_time=float(ds.attrs["wall_time"])))
    return out


def _tighter(model, name, value, analysis) -> dict:
    """{analysis path: (value as run, tighter value)} of the integration: rtol and atol / 100
    for an adaptive integrator, the step / 4 for a fixed-step one; {} without integration."""
    from ..integrators.base import INTEGRATORS
    from ..io.analysis import Analysis
    job = _make_job(model, points({name: [value]}), parse_outputs(["t"]), analysis,
                    "simulate", {})
    a = Analysis.from_dict(job.analysis) if job.analysis else Analysis()
    if a.type != "dynamic":
        return {}
    cls = INTEGRATORS.get(a.integrator if isinstance(a.integrator, str) else "")
    options = dict(a.integrator_options or {})
    if (cls is not None and not cls.adaptive) or options.get("fixed_step") or \
            options.get("adaptive") is False:
        step = a.step if a.step is not None else 1e-3      # the fixed-step default
        return {"analysis.integrator.step": (float(step), float(step) / 4.0)}
    rtol = 1e-6 if a.rtol is None else float(a.rtol)
    atol = 1e-9 if a.atol is None else float(a.atol)
    return {"analysis.integrator.rtol": (rtol, rtol / 100.0),
            "analysis.integrator.atol": (atol, atol / 100.0)}


# ------------------------------------------------------------------------- forward sensitivity
_STATE = {c: i for i, c in enumerate(BODY_POSITION)}
_VEL = {c: i for i, c in enumerate(BODY_VELOCITY)}


def _state_index(model, column) -> int:
    parts = column.split(".")
    if len(parts) == 2 and parts[0] in model.body_names:
        k = model.body_names.index(parts[0])
        if parts[1] in _STATE:
            return 7 * k + _STATE[parts[1]]
        if parts[1] in _VEL:
            return 7 * model.nb + 6 * k + _VEL[parts[1]]
    raise ModelError(f"forward sensitivities support body state columns (<body>.x..e3, "
                     f"<body>.vx..wz), not {column!r}; use sensitivities() (finite "
                     "differences) for other outputs")


def forward_sensitivities(model, params, outputs, analysis=None, *, step: Optional[float] = None,
                          relative_delta: float = 1e-6, scheme: str = "analysis",
                          parameter_steps=None):
    """d(output)/d(parameter) by the forward sensitivity equations (direct differentiation).

    model, params, outputs, analysis: as :func:`sensitivities` (dynamic analysis; method
    standard or baumgarte -- the model-file default, projection, is refused; a model that the
    batch engine takes). The state and sensitivities are integrated together, as one
    system, by the package's integrators (:mod:`spatialmbd.integrators`):

    * ``scheme="analysis"`` (default): by the analysis' integrator -- adaptive (rk45, the
      default, or dop853: the one compiled adaptive driver) with its rtol and atol and the
      sensitivities in the error norm (atol / |x0| for the sensitivities to parameter x:
      a simultaneous corrector, as CVODES' ``CV_SIMULTANEOUS`` with error control on the
      sensitivities), so the step sizes resolve the sensitivities too; or rk4 with its step;
    * ``scheme="rk4"``, or ``step`` given: classic RK4 with ``step`` (s; default the
      analysis' step, else 1e-3) -- the scheme the discrete adjoint (:mod:`spatialmbd.design`)
      differentiates, whose derivative this is.

    relative_delta: the smallest parameter step tried for f_p and S(0) (times |x0|, or 1 if
    x0 = 0); the steps chosen, relative to |x0| as relative_delta, are returned in
    ``attrs["parameter_steps"]`` (p, 2): those of f_p and of S(0) (see the module docstring).
    parameter_steps: those of an earlier call, used again without the ladder's model builds
    (identification and optimization pass them from one iterate to the next).
    Returns a Dataset (output, parameter) with ``derivative`` and ``nominal``, the
    sensitivity time series ``S`` (time, state, parameter) and the state ``y`` (time, state)
    of the same integration (what :mod:`spatialmbd.design` fits to measurements).
    """
    import xarray as xr
    from .batch import BatchSetup
    from ..dynamics.standard import rhs_standard
    from ..simulate import output_times
    nominal = _nominal(model, params)
    names = list(nominal)
    outs = parse_outputs(outputs)
    job = _make_job(model, points({n: [v] for n, v in nominal.items()}), outs, analysis,
                    "batch", {})
    m0, an = job.build(nominal)
    if an.type != "dynamic":
        raise ModelError("forward sensitivities need a dynamic analysis")
    if an.method not in ("standard", "baumgarte"):
        what = {"auto": "the default 'auto' runs the recursive (joint coordinates) or the "
                        "projection method",
                "projection": "the projection step of 'projection' is not differentiated"
                }.get(an.method, f"method {an.method!r} is not differentiated")
        raise ModelError(f"forward sensitivities integrate the equations of the 'standard' or "
                         f"'baumgarte' method ({what}); set the analysis method to "
                         "'standard'")
    integ = _sensitivity_integrator(an, step, scheme)
    setup = BatchSetup(m0, an.method, an.method_options)
    F0 = setup.pack_F(m0)
    y0 = setup.initial_state(m0, F0, an)
    n, npar = y0.size, len(names)
    I, mpar = setup.system.I, setup.mp
    W = setup.system.W.copy()
    nb = m0.nb

    def f(t, y, F):
        out = np.empty(n)
        if rhs_standard(t, np.ascontiguousarray(y), out, F, I, W, mpar) < 0:
            raise ModelError(f"t = {t:.6g} s: the right-hand side failed during the forward "
                             "sensitivity integration")
        return out

    S0 = np.zeros((n, npar))
    # per parameter: the F of f_p's stencil ((+h, -h), (+h/4, -h/4)); the relative steps of
    # f_p and S(0)
    stencils, steps = [], []
    if parameter_steps is not None and np.shape(parameter_steps) != (npar, 2):
        raise ModelError(f"forward sensitivities: parameter_steps of shape "
                         f"{np.shape(parameter_steps)} for {npar} parameters; give those of an "
                         "earlier call, attrs['parameter_steps'] (one row per parameter)")
    r = _ParameterLadder.RATIO
    for j, name in enumerate(names):
        if parameter_steps is None:                 # the ladder, and the best step of each
            ladder = _ParameterLadder(job, setup, nominal, name,
                                      relative_delta * r ** np.arange(_ParameterLadder.RUNGS), 3)
            kf = ladder.best(lambda F, y0p: f(0.0, y0, F))[0]
            ks, S0[:, j] = ladder.best(lambda F, y0p: y0p)
        else:                                       # the steps of an earlier call
            hf, hs = (float(v) for v in parameter_steps[j])
            ladder = _ParameterLadder(job, setup, nominal, name, [hf / r, hf, hs / r, hs], 4)
            kf, ks = 1, 3
            S0[:, j] = ladder.estimate(ks, lambda F, y0p: y0p)
        stencils.append(ladder.pairs(kf))
        steps.append((ladder.h[kf] / _scale(nominal[name]), ladder.h[ks] / _scale(nominal[name])))

    def g(t, y, S):
        fy = f(t, y, F0)
        dS = np.empty_like(S)
        ny = max(1.0, float(np.linalg.norm(y)))
        for j in range(npar):
            s = S[:, j]
            ns = float(np.linalg.norm(s))
            jv = _richardson(lambda e: f(t, y + e * s, F0), 1e-3 * ny / ns, 2.0) \
                if ns > 0 else 0.0
            (Fa, Fb), (Fc, Fd) = stencils[j]
            h = steps[j][0] * _scale(nominal[names[j]])
            dS[:, j] = jv + _extrapolate((f(t, y, Fa) - f(t, y, Fb)) / (2 * h),
                                         (f(t, y, Fc) - f(t, y, Fd)) * (r / (2 * h)), r)
        return fy, dS

    def rhs(t, z):                                 # the state and its sensitivities
        fy, dS = g(t, z[:n], z[n:].reshape(n, npar))
        return np.concatenate([fy, dS.ravel()])

    def project(t, z):
        """Unit Euler parameters, their sensitivities projected with (I - p p^T) / |p|."""
        z = z.copy()
        y, S = z[:n], z[n:].reshape(n, npar)
        for b in range(nb):
            o = 7 * b + 3
            p = y[o:o + 4].copy()
            norm = float(np.linalg.norm(p))
            ph = p / norm
            Sp = S[o:o + 4].copy()
            S[o:o + 4] = (Sp - np.outer(ph, ph @ Sp)) / norm
            y[o:o + 4] = ph
        return z

    from ..integrators import ODEProblem
    t_out = output_times(an.t_end, an.output_step, an.t_eval, 0.0)
    if integ.adaptive:                              # the sensitivities in the error norm
        scales = np.array([_scale(nominal[nm]) for nm in names])
        atol = np.concatenate([np.full(n, integ.atol), (integ.atol / scales)[None, :]
                               .repeat(n, axis=0).ravel()])
        integ = type(integ)(rtol=integ.rtol, atol=atol, max_step=integ.max_step)
    res = integ.integrate(ODEProblem(rhs, project=project), 0.0,
                          np.concatenate([y0, S0.ravel()]), t_out)
    if not res.success:
        raise ModelError(f"forward sensitivities: {res.message}")
    Y = res.y[:, :n]
    SS = res.y[:, n:].reshape(t_out.size, n, npar)
    deriv = np.full((len(outs), npar), np.nan)
    nominal_out = np.full(len(outs), np.nan)
    for i, o in enumerate(outs):
        if o.series or o.function is not None:
            raise ModelError(f"output {o.name!r}: forward sensitivities take reductions of "
                             "body state columns, e.g. final(pendulum.z)")
        c = _state_index(m0, o.column)
        x = Y[:, c]
        nominal_out[i], deriv[i] = _reduce_derivative(o.reduction, t_out, x, SS[:, c, :])
    return xr.Dataset(
        dict(derivative=(("output", "parameter"), deriv), nominal=(("output",), nominal_out),
             S=(("time", "state", "parameter"), SS), y=(("time", "state"), Y)),
        coords=dict(output=[o.name for o in outs], parameter=names, time=t_out,
                    value=(("parameter",), np.array([nominal[nm] for nm in names]))),
        attrs=dict(method=f"forward sensitivity equations, {integ.name}"
                   + (" (sensitivities in the error norm)" if integ.adaptive else ""),
                   step=float(getattr(integ, "step", math.nan)),
                   rtol=float(getattr(integ, "rtol", math.nan)),
                   steps=int(res.counters.steps), nfev=int(res.counters.nfev),
                   parameter_steps=np.array(steps)))


def _extrapolate(d_h, d_hr, r):
    """Richardson's (r^2 D(h / r) - D(h)) / (r^2 - 1) of central differences D."""
    return (r * r * d_hr - d_h) / (r * r - 1.0)


def _richardson(fun, h, r):
    """:func:`_extrapolate` of D(h) = (fun(h) - fun(-h)) / (2 h) and D(h / r)."""
    return _extrapolate((fun(h) - fun(-h)) / (2 * h), (fun(h / r) - fun(-h / r)) * (r / (2 * h)),
                        r)


class _ParameterLadder:
    """One parameter perturbed to x0 +- h_k for the relative steps ``rungs`` (times |x0|, or 1
    if x0 = 0): the packed floats F and the initial state of each perturbed model. The
    Richardson estimate R_k of a quantity computed from them pairs rung k with rung k - 1,
    which must be h_k / RATIO; :meth:`best` picks the k whose R_k agrees best with R_(k+1)."""

    RUNGS, RATIO = 10, 4.0

    def __init__(self, job, setup, nominal, name, rungs, required):
        """required: how many rungs must build (past them the ladder ends at the first step
        the model refuses)."""
        self.points = []
        for h in np.asarray(rungs, dtype=float) * _scale(nominal[name]):
            pair = []
            for sign in (1.0, -1.0):
                values = dict(nominal)
                values[name] += sign * h
                try:
                    model, an = job.build(values)
                    F = setup.pack_F(model)
                    pair.append((F, setup.initial_state(model, F, an)))
                except SpatialMBDError as exc:  # a model the step makes invalid, a start
                    if len(self.points) < required:   # the correction cannot reach
                        raise ModelError(f"forward sensitivities: parameter {name!r} at "
                                         f"{values[name]!r} (step {h:.3g}): {exc}") from exc
                    break
            if len(pair) < 2:
                break
            self.points.append(pair)
        self.h = np.asarray(rungs, dtype=float)[:len(self.points)] * _scale(nominal[name])

    def _difference(self, k, quantity):
        (p, m), h = self.points[k], self.h[k]
        return (quantity(*p) - quantity(*m)) / (2 * h)

    def estimate(self, k, quantity):
        """R_k of quantity(F, initial state)."""
        return _extrapolate(self._difference(k, quantity), self._difference(k - 1, quantity),
                            self.RATIO)

    def best(self, quantity):
        """(k, R_k) of the k whose estimate agrees best with the next one's."""
        R = [None] + [self.estimate(k, quantity) for k in range(1, len(self.points))]
        gaps = [float(np.max(np.abs(R[k] - R[k + 1]))) for k in range(1, len(R) - 1)]
        k = 1 + int(np.argmin(gaps))
        return k, R[k]

    def pairs(self, k):
        """((F at +h_k, F at -h_k), (F at +h_(k-1), F at -h_(k-1)))."""
        (p, m), (pc, mc) = self.points[k], self.points[k - 1]
        return (p[0], m[0]), (pc[0], mc[0])


def _sensitivity_integrator(an, step, scheme):
    """The integrator of the forward sensitivities (:func:`forward_sensitivities`)."""
    from ..integrators import get_integrator
    if scheme not in ("analysis", "rk4"):
        raise ModelError(f"forward sensitivities: scheme {scheme!r} must be 'analysis' or "
                         "'rk4'")
    name = an.integrator if isinstance(an.integrator, str) else "rk45"
    if step is not None or scheme == "rk4" or name == "rk4":
        return get_integrator("rk4", step=float(step if step is not None else
                                                (an.step or 1e-3)))
    if name not in ("rk45", "dop853"):
        raise ModelError(f"forward sensitivities integrate with rk45, dop853 or rk4, not "
                         f"{name!r}; set the analysis integrator")
    options = {k: v for k, v in (("rtol", an.rtol), ("atol", an.atol)) if v is not None}
    return get_integrator(name, **options)


def _reduce_derivative(reduction, t, x, s):
    """(value, d value / dp) of a reduction of x(t) with sensitivities s (nt, npar)."""
    if reduction == "final":
        return x[-1], s[-1]
    if reduction == "initial":
        return x[0], s[0]
    if reduction == "mean":
        return float(np.mean(x)), s.mean(axis=0)
    if reduction == "rms":                                    # d sqrt(mean(x^2)) / dp
        rms = float(np.sqrt(np.mean(np.square(x))))
        return rms, (x[:, None] * s).mean(axis=0) / rms
    if reduction in ("max", "min", "absmax"):
        k = int(np.argmax(x) if reduction == "max" else np.argmin(x) if reduction == "min"
                else np.argmax(np.abs(x)))
        sign = 1.0 if reduction != "absmax" else float(np.sign(x[k]))
        return float(sign * x[k]), sign * s[k]
    if reduction in ("peak", "trough"):
        sign = 1.0 if reduction == "peak" else -1.0
        t = np.ascontiguousarray(t, dtype=float)
        value, j, at = peak_at(t, np.ascontiguousarray(sign * x, dtype=float))
        return sign * value, np.array([_poly(cubic_coefficients(
            t, np.ascontiguousarray(s[:, i]), j)[1], at)[0] for i in range(s.shape[1])])
    if reduction == "period":
        from .outputs import period
        idx = np.nonzero((x[:-1] < 0.0) & (x[1:] >= 0.0))[0]
        if idx.size < 2:
            return math.nan, np.full(s.shape[1], np.nan)
        dts = []
        for k in (int(idx[0]), int(idx[-1])):
            tc = _cubic_root(t, x, k)                         # as outputs.period does
            a, c = cubic_coefficients(t, x, k)
            xdot = _poly(c, tc - a)[1]
            sc = np.array([_poly(cubic_coefficients(t, s[:, j], k)[1], tc - a)[0]
                           for j in range(s.shape[1])])
            dts.append(-sc / xdot)                            # x(t_c(p), p) = 0
        return period(t, x), (dts[1] - dts[0]) / (idx.size - 1)
    raise ModelError(f"forward sensitivities: reduction {reduction!r} not supported")
