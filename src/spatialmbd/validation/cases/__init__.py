"""The validation cases. Each ``case_*(full)`` returns a :class:`CaseResult`; ``full=False`` is
the short version run in CI (shorter runs, looser integrator tolerances, the tolerances of the
checks following from them), ``full=True`` the complete one.

Tolerances: see :mod:`.core` (integration_bound: N accepted steps x (rtol scale + atol)).
Reference values and their provenance: validation/data/references.json (:mod:`.references`).

One module per family: ``adams`` (Adams and Chrono tables), ``free_bodies`` (torque-free
bodies and tops), ``iftomm`` (IFToMM benchmarks), ``bicycles``, ``closed_form`` (mechanisms
against closed-form results); ``common`` holds what they share (the run, with the method of
the whole suite, and the checks).
"""
from __future__ import annotations

from ..core import CaseResult, Timer
from ..references import ADAMS_CASES, MODEL_CASES
from .adams import adams_case, chrono_model_case
from .bicycles import case_basu_mandal_bicycle, case_iftomm_bicycle, case_meijaard_bicycle
from .closed_form import case_cam_follower, case_hertz_impact, case_slider_crank_kinematics
from .free_bodies import (case_free_asymmetric, case_free_symmetric, case_heavy_top,
                          case_heavy_top_nutation)
from .iftomm import (case_a01, case_a02, case_a03, case_a04, case_a05, case_double_pendulum,
                     case_robot_arm, case_spatial_slider_crank)

CASES = {
    **{f"adams_{n.lower()}": (lambda full, n=n: adams_case(n, full)) for n in ADAMS_CASES},
    **{f"adams_{n.lower()}": (lambda full, n=n: chrono_model_case(n, full))
       for n in MODEL_CASES},
    "free_symmetric": case_free_symmetric,
    "free_asymmetric": case_free_asymmetric,
    "heavy_top": case_heavy_top,
    "heavy_top_nutation": case_heavy_top_nutation,
    "slider_crank_kinematics": case_slider_crank_kinematics,
    "iftomm_a01": case_a01,
    "iftomm_a02": case_a02,
    "iftomm_a03": case_a03,
    "iftomm_a04": case_a04,
    "iftomm_a05": case_a05,
    "spatial_slider_crank": case_spatial_slider_crank,
    "meijaard_bicycle": case_meijaard_bicycle,
    "iftomm_bicycle": case_iftomm_bicycle,
    "basu_mandal_bicycle": case_basu_mandal_bicycle,
    "double_pendulum": case_double_pendulum,
    "robot_arm": case_robot_arm,
    "hertz_impact": case_hertz_impact,
    "cam_follower": case_cam_follower,
}


def run_case(key: str, full: bool) -> CaseResult:
    with Timer() as timer:
        try:
            result = CASES[key](full)
        except Exception as exc:                          # reported, not raised
            result = CaseResult(key, "", "", error=f"{type(exc).__name__}: {exc}")
    result.runtime = timer.elapsed
    return result
