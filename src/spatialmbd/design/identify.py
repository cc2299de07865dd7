"""Parameter identification: the model's parameters fitted to measured time series.

    fit = identify("examples/design/pendulum_damped.yaml", "rig.csv",
                   ["bodies.pendulum.mass", "forces.pivot_damper.damping"],
                   outputs=["pivot.angle"], noise={"pivot.angle": 0.01})
    fit.estimates, fit.standard_errors, fit.correlation, fit.warnings
    print(fit.report()); fit.plot_residuals("residuals.png"); fit.write_model("fit.yaml")

The residual of experiment e, column c, sample i is w_c (y_sim(t_i; x) - y_meas(t_i)), with
w_c = 1 / sigma_c when noise levels are given, else the relative ``weights`` (default 1);
SciPy's ``least_squares`` (trust-region reflective, bounds, robust ``loss``) minimises the sum
of their squares (or of the robust loss) with the Jacobian of :class:`.problem.Problem`.

Standard errors (Gauss-Newton, at the estimate x*, J the weighted Jacobian (m x p)):
    cov = s^2 (J^T J)^-1,   s^2 = 1 with noise levels given (absolute sigma), else
    s^2 = sum(r^2) / (m - p)  (the residual variance);
    standard error_j = sqrt(cov_jj), correlation_jk = cov_jk / (se_j se_k).
With a robust loss the same formula is applied to the weighted residuals and Jacobian as
they are (SciPy does not return the loss-weighted ones): read the errors as approximate.
Identifiability: the rank of J^T (columns scaled to unit length, so units do not matter) by
the project's one rank decision :func:`spatialmbd.rank.row_rank`; a dependent row is a
parameter whose effect on the outputs is a combination of the others' (it cannot be told from
them with these data): its standard error is infinite and a warning names the combination.
Correlations beyond 0.99 are also named.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Optional

import numpy as np

from ..errors import ModelError
from ..rank import row_rank
from .problem import Experiment, Problem, read_data, start_values

__all__ = ["identify", "Identification"]

#: |correlation| above which a warning names the pair
HIGH_CORRELATION = 0.99


@dataclass
class Identification:
    """The result of :func:`identify` (arrays indexed like ``names``)."""

    names: list
    start: np.ndarray
    estimates: np.ndarray
    standard_errors: np.ndarray
    covariance: np.ndarray
    correlation: np.ndarray
    rank: int
    warnings: list
    residuals: list          # per experiment (nt, ncol): simulated - measured, unweighted
    fitted: list             # per experiment (nt, ncol): simulated at the estimates
    experiments: list
    jacobian: np.ndarray     # (m, p) of the weighted residuals
    residual_variance: float
    cost: float
    success: bool
    message: str
    n_runs: int
    failures: list = field(default_factory=list)
    wall_time: float = 0.0
    model_data: Optional[dict] = None

    @property
    def values(self) -> dict:
        return dict(zip(self.names, map(float, self.estimates)))

    def table(self):
        """A DataFrame: start, estimate, standard error, relative standard error."""
        import pandas as pd
        return pd.DataFrame({"start": self.start, "estimate": self.estimates,
                             "standard_error": self.standard_errors,
                             "relative": self.standard_errors / np.abs(self.estimates)},
                            index=self.names)

    def report(self) -> str:
        """Estimates +- standard errors, correlations, warnings and failures as text."""
        w = max(len(n) for n in self.names)
        state = "converged" if self.success else "NOT converged"
        lines = [f"identification: {self.message} ({state}), {self.n_runs} runs, "
                 f"{self.wall_time:.3g} s",
                 f"residual rms {np.sqrt(self.residual_variance):.4g} (weighted), rank "
                 f"{self.rank} of {len(self.names)}", "",
                 f"{'parameter':<{w}}  {'estimate':>13}  {'std error':>11}  {'start':>11}"]
        for n, x, s, x0 in zip(self.names, self.estimates, self.standard_errors, self.start):
            lines.append(f"{n:<{w}}  {x:13.6g}  {s:11.3g}  {x0:11.4g}")
        if len(self.names) > 1:
            lines += ["", "correlation"]
            for j, n in enumerate(self.names):
                lines.append(f"{n:<{w}}  " + " ".join(f"{c:+7.3f}" for c in self.correlation[j]))
        for text in self.warnings:
            lines.append(f"warning: {text}")
        if self.failures:
            lines.append(f"{len(self.failures)} trial run(s) failed (the optimizer stepped "
                         f"back); first: {self.failures[0]['message']} at "
                         f"{self.failures[0]['parameters']}")
        return "\n".join(lines)

    def plot_residuals(self, path=None):
        """One panel per fitted column: the residuals (simulated - measured) against time,
        one line per experiment. Returns the matplotlib Figure (saved to ``path`` if given)."""
        import matplotlib
        if path is not None:
            matplotlib.use("Agg", force=False)
        import matplotlib.pyplot as plt
        columns = list(dict.fromkeys(c for e in self.experiments for c in e.columns))
        fig, axes = plt.subplots(len(columns), 1, figsize=(7, 2.4 * len(columns)),
                                 squeeze=False, sharex=True)
        for ax, col in zip(axes[:, 0], columns):
            for e, r in zip(self.experiments, self.residuals):
                if col in e.columns:
                    ax.plot(e.t, r[:, e.columns.index(col)], ".", ms=2, label=e.name)
            ax.axhline(0.0, color="k", lw=0.5)
            ax.set_ylabel(f"{col}\nresidual")
            if len(self.experiments) > 1:
                ax.legend(fontsize=7)
        axes[-1, 0].set_xlabel("t [s]")
        fig.tight_layout()
        if path is not None:
            fig.savefig(path)
            plt.close(fig)
        return fig

    def fitted_model(self) -> dict:
        """The model-file dictionary with the estimates set (model files only)."""
        from ..sweep.params import apply
        if self.model_data is None:
            raise ModelError("the model was a factory: set the estimates in it yourself "
                             "(fit.values)")
        data = apply(self.model_data, {n: v for n, v in self.values.items()
                                       if not n.startswith("analysis.")})
        return data

    def write_model(self, path, header: Optional[str] = None):
        """Write the fitted model file (.yaml/.json) with its analysis."""
        from ..io.modelfile import load_model
        from ..io.writer import save_model
        model, analysis = load_model(self.fitted_model())
        text = header or "fitted by spatialmbd identify:\n" + "\n".join(
            f"  {n} = {x:.8g} +- {s:.3g}" for n, x, s in
            zip(self.names, self.estimates, self.standard_errors))
        return save_model(model, path, analysis, header=text)


def _experiments(data, experiments, outputs, noise):
    if (data is None) == (experiments is None):
        raise ModelError("identify: give data (one experiment) or experiments=[(variant, "
                         "data), ...], not both")
    pairs = [({}, data)] if experiments is None else list(experiments)
    if not pairs:
        raise ModelError("identify: experiments is empty")
    out = []
    for k, item in enumerate(pairs):
        if isinstance(item, tuple) and len(item) == 2:
            variant, d = item
        else:
            variant, d = {}, item
        name = f"experiment {k}" if experiments is not None else "data"
        t, cols, vals = read_data(d, outputs, name)
        if isinstance(variant, dict):            # the experiment's own values
            overrides, model = dict(variant), None
        else:                                    # a model of its own
            overrides, model = {}, variant
        if noise is None:
            sigma = np.full(len(cols), np.nan)
        elif isinstance(noise, dict):
            missing = [c for c in cols if c not in noise]
            if missing:
                raise ModelError(f"noise: no level for column {missing[0]!r}; give one per "
                                 "fitted column (or one number for all)")
            sigma = np.array([float(noise[c]) for c in cols])
        else:
            sigma = np.full(len(cols), float(noise))
        if np.any(~(sigma > 0)) and noise is not None:
            raise ModelError(f"noise levels must be positive, got {list(sigma)}")
        out.append(Experiment(name, t, cols, vals, overrides, sigma, model))
    return out


def _bounds(names, x0, bounds):
    lo, hi = np.full(len(names), -np.inf), np.full(len(names), np.inf)
    for name, pair in (bounds or {}).items():
        if name not in names:
            raise ModelError(f"bounds: {name!r} is not one of the fitted parameters "
                             f"{names}")
        try:
            a, b = (float(v) if v is not None else None for v in pair)
        except (TypeError, ValueError):
            raise ModelError(f"bounds of {name!r}: expected (low, high), got {pair!r}") from None
        j = names.index(name)
        lo[j] = -np.inf if a is None else a
        hi[j] = np.inf if b is None else b
        if not lo[j] < hi[j]:
            raise ModelError(f"bounds of {name!r}: low {lo[j]} must be below high {hi[j]}")
        if not lo[j] <= x0[j] <= hi[j]:
            raise ModelError(f"bounds of {name!r}: ({lo[j]:g}, {hi[j]:g}) exclude the start "
                             f"value {x0[j]:g}; widen the bounds or give a start inside them")
    return lo, hi


def _weights(experiments, weights):
    out = []
    for e in experiments:
        if np.all(np.isfinite(e.sigma)):
            out.append(1.0 / e.sigma)
            continue
        w = np.ones(len(e.columns))
        for j, c in enumerate(e.columns):
            if weights and c in weights:
                w[j] = float(weights[c])
        if np.any(~(w > 0)):
            raise ModelError(f"weights must be positive, got {dict(zip(e.columns, w))}")
        out.append(w)
    return out


def covariance(J, r, absolute: bool, rank_rtol=None):
    """(covariance, rank, dependent rows, coefficients, residual variance) of a least-squares
    fit with weighted Jacobian J (m, p) and weighted residuals r (m,)."""
    m, p = J.shape
    norms = np.linalg.norm(J, axis=0)
    Js = J / np.where(norms > 0, norms, 1.0)
    rr = row_rank(Js.T) if rank_rtol is None else row_rank(Js.T, rank_rtol)
    s2 = float(r @ r) / max(m - p, 1)
    cov = np.full((p, p), np.nan)
    ind = rr.independent
    if ind.size:
        Ji = Js[:, ind]
        inv = np.linalg.inv(Ji.T @ Ji) / np.outer(norms[ind], norms[ind])
        cov[np.ix_(ind, ind)] = inv * (1.0 if absolute else s2)
    for k in rr.dependent:
        cov[k, k] = np.inf
    return cov, rr, s2


def identify(model, data=None, params=(), *, outputs=None, weights: Optional[dict] = None,
             noise=None, bounds: Optional[dict] = None, loss: str = "linear",
             f_scale: float = 1.0, experiments=None, analysis=None, jacobian: str = "auto",
             engine: str = "simulate", fd_step: float = 1e-4, tol: float = 1e-8,
             max_runs: Optional[int] = None, rank_rtol: Optional[float] = None
             ) -> Identification:
    """Fit model parameters to measured time series by least squares.

    model: a model file, Model, ModelBuilder, model dict or factory (keyword arguments).
    data: measurements of one experiment: a DataFrame, {column: array} or CSV path with time
      column ``t`` (s) and result columns (``pendulum.wx``, ``pivot.angle`` (a joint output
      request of the model), ``slider.x``, ...; docs/sweeps.md#outputs).
    params: parameter paths (start values from the model) or {path: start value}.
    outputs: the columns to fit (default every data column but t).
    weights: {column: relative weight}; noise: {column: sigma} or one sigma (the data's
      units) -- with noise levels the standard errors use them (absolute), else the residual
      variance.
    bounds: {path: (low, high)} (None for an open side); loss, f_scale: SciPy's robust losses
      ("linear", "soft_l1", "huber", "cauchy", "arctan").
    experiments: [(variant, data), ...] fitted together: variant a {path: value} dict of the
      experiment's own values (initial state, load) or a model of its own.
    analysis: the analysis (default the model's); its output times become the time stamps.
    jacobian: "auto", "adjoint", "forward" or "fd" (:mod:`.problem`); engine: the sweep
      engine of the runs; fd_step: relative step of the differences; tol: ftol = xtol = gtol.
    """
    from scipy.optimize import least_squares
    start_time = time.perf_counter()
    if isinstance(params, str):
        params = [params]
    given = dict(params) if isinstance(params, dict) else {p: None for p in params}
    names = list(given)
    if not names:
        raise ModelError("identify: name at least one parameter, e.g. bodies.link.mass")
    exps = _experiments(data, experiments, outputs, noise)
    problem = Problem(model, names, exps, analysis, jacobian=jacobian, engine=engine,
                      fd_step=fd_step)
    x0 = start_values(problem.base_job, names, given)
    lo, hi = _bounds(names, x0, bounds)
    w = _weights(exps, weights)
    absolute = all(np.all(np.isfinite(e.sigma)) for e in exps)

    def fun(x):
        sims, _ = problem.evaluate(x)
        return np.concatenate([((s - e.values) * wk).ravel()
                               for s, e, wk in zip(sims, exps, w)])

    def jac(x):
        _, jacs = problem.evaluate(x, jacobian=True)
        return np.concatenate([(J * wk[None, :, None]).reshape(-1, len(names))
                               for J, wk in zip(jacs, w)])

    r0 = fun(x0)
    if not np.all(np.isfinite(r0)):
        first = problem.failures[0]["message"] if problem.failures else "non-finite values"
        raise ModelError(f"identify: the model does not run at the start values "
                         f"{dict(zip(names, x0.tolist()))}: {first}")
    if r0.size < len(names):
        raise ModelError(f"identify: {r0.size} residuals cannot determine {len(names)} "
                         "parameters; give more samples")
    scale = np.where(x0 != 0, np.abs(x0), 1.0)
    sol = least_squares(fun, x0, jac=jac, bounds=(lo, hi), loss=loss, f_scale=f_scale,
                        x_scale=scale, ftol=tol, xtol=tol, gtol=tol, method="trf",
                        max_nfev=max_runs)
    x = sol.x
    r = fun(x)
    J = jac(x)
    cov, rr, s2 = covariance(J, r, absolute, rank_rtol)
    se = np.sqrt(np.diag(cov))
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = cov / np.outer(se, se)
    warn = []
    for k, c in zip(rr.dependent, rr.coefficients):
        combo = " + ".join(f"{ci:.3g} x [{names[j]}]" for ci, j in zip(c, rr.independent)
                           if abs(ci) > 1e-12) or "zero"
        warn.append(f"{names[k]!r} is not identifiable from these data: its effect on the "
                    f"outputs (scaled) equals {combo}; fix it or add an experiment that "
                    "separates them")
    for j in range(len(names)):
        for k in range(j):
            if np.isfinite(corr[j, k]) and abs(corr[j, k]) > HIGH_CORRELATION:
                warn.append(f"{names[k]!r} and {names[j]!r} are correlated "
                            f"({corr[j, k]:+.4f}): the data determine a combination of them "
                            "better than either")
    sims, _ = problem.evaluate(x)
    return Identification(
        names=names, start=x0, estimates=x, standard_errors=se, covariance=cov,
        correlation=corr, rank=int(rr.rank), warnings=warn,
        residuals=[s - e.values for s, e in zip(sims, exps)], fitted=list(sims),
        experiments=exps, jacobian=J, residual_variance=s2, cost=float(sol.cost),
        success=bool(sol.success), message=str(sol.message), n_runs=problem.n_runs,
        failures=problem.failures, wall_time=time.perf_counter() - start_time,
        model_data=None if problem.base_job.data is None else
        dict(problem.base_job.data, analysis=problem.base_job.analysis))
