"""The incline friction example (examples/design/incline_friction.py): the model against the
closed-form motion of a rigid block with Coulomb and viscous friction, and the friction
coefficients identified from that motion plus noise."""
import importlib.util
from pathlib import Path

import numpy as np

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "design" / "incline_friction.py"
spec = importlib.util.spec_from_file_location("incline_friction", EXAMPLE)
inc = importlib.util.module_from_spec(spec)
spec.loader.exec_module(inc)


def test_model_follows_the_closed_form_motion():
    from spatialmbd.sweep import points, sweep
    an = dict(type="dynamic", t_end=1.5, t_eval=list(inc.T), method=dict(name="projection"),
              integrator=dict(name="rk45", rtol=1e-8, atol=1e-10))
    ds = sweep(inc.MODEL, points({k: [v] for k, v in inc.TRUTH.items()}), ["block.x"], an)
    x = ds["block.x"].values[0]
    exact = inc.exact_position(inc.T, *inc.TRUTH.values())
    assert np.abs(x - exact).max() < 2e-6          # compliance and creep: 0.5 um here
    assert x[-1] > 0.7                              # it slides all the way (tan a > mu)


def test_friction_coefficients_recovered_within_their_standard_errors():
    fit = inc.fit(seed=0)
    truth = np.array(list(inc.TRUTH.values()))
    z = (fit.estimates - truth) / fit.standard_errors
    assert np.all(np.abs(z) < 3.0), fit.report()
    assert np.all(fit.standard_errors < 0.01 * truth)    # both well determined
