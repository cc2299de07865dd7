"""Exudyn peer models for the spatialmbd performance benchmark.

Exudyn (https://github.com/jgerstmayr/EXUDYN, pip package ``exudyn``, pinned to
1.13.6 in the ``bench`` extra) is a C++ multibody code with a Python interface.
Its ``NodeRigidBodyEP`` node uses the same redundant-coordinate formulation as
spatialmbd: 3 position coordinates of the centre of mass plus 4 Euler parameters
per body, with the Euler-parameter normalisation added as an algebraic equation
per body and the joints as further algebraic equations (index-3 DAE).

This module builds the benchmark problems in Exudyn and times its solver so the
benchmark runner can compare them with ours in the same run. Importing it has no
side effects: ``exudyn`` is imported lazily inside the functions.

Public API
----------
``available()``                               exudyn importable?
``pendulum_ch15(h, t_end=10.0)``              Flores (2015) ch. 15 pendulum
``chain(n, joint, h, t_end=1.0)``             N-link spatial chain
``work_precision_pendulum(hs)``               pendulum_ch15 for each h in hs
``work_precision_chain(n, joint, hs)``        chain for each h in hs

Every run returns a dict with (at least) the keys

``wall_time``   seconds of the solve only (``mbs.SolveDynamic``: solver
                initialisation, consistent initial accelerations, all steps);
                model building and ``mbs.Assemble()`` are excluded
``build_time``  seconds to build and assemble the model
``steps``       number of time steps actually taken (from the solver)
``final_com``   final centre-of-mass positions, nested list (n, 3)
``final_p``     final Euler parameters (e0, e1, e2, e3), scalar first, (n, 4)
``h``           the step size, ``integrator`` "generalized-alpha",
                ``solver`` "EigenSparse"

plus diagnostics (``cpu_time``, Newton/Jacobian counts, energies, velocities,
``final_tip`` for chains, ``node_type``, ``spectral_radius``, version ...).

Solver settings (identical for every problem)
---------------------------------------------
* ``exu.DynamicSolverType.GeneralizedAlpha`` (Exudyn's default implicit
  solver, index-3 constraints, Exudyn's default spectral radius
  rho_inf = 0.9, its default modified Newton with relative tolerance 1e-8,
  absolute 1e-10),
* constant step: ``numberOfSteps = round(t_end / h)``, ``adaptiveStep = False``
  (a Newton failure raises instead of silently halving the step),
* sparse LU: ``linearSolver.solverType = exu.LinearSolverType.EigenSparse``,
* one thread: ``parallel.numberOfThreads = 1``,
* no solution or sensor files, no console output (``verboseMode = 0``).

Reference / errors
------------------
The final-position error is computed by the caller against spatialmbd's own
tight-tolerance reference solution; the functions here only return final
positions (and orientations).
"""

from __future__ import annotations

import time
from typing import Iterable

import numpy as np

GRAVITY = 9.81  # m/s^2, along -z in every problem

# Chapter 15 pendulum (P. Flores 2015, Table 15.1)
PENDULUM_MASS = 7.02  # kg
PENDULUM_INERTIA = (0.5855265, 0.0010530, 0.5855265)  # kg m^2, centroidal, body axes
PENDULUM_COM0 = (0.0, 0.5, 0.0)  # m

# N-link chain
LINK_LENGTH = 1.0  # m
LINK_MASS = 1.0  # kg
LINK_INERTIA = (1.0e-4, LINK_MASS * LINK_LENGTH**2 / 12.0, LINK_MASS * LINK_LENGTH**2 / 12.0)

INTEGRATOR = "generalized-alpha"
SOLVER = "EigenSparse"
DEFAULT_SPECTRAL_RADIUS = 0.9  # Exudyn default for timeIntegration.generalizedAlpha

__all__ = [
    "available",
    "pendulum_ch15",
    "chain",
    "work_precision_pendulum",
    "work_precision_chain",
    "REFERENCE_NOTE",
]

REFERENCE_NOTE = (
    "Final-position errors are computed by the caller against spatialmbd's own "
    "tight-tolerance reference; exudyn_peer only returns final positions."
)
reference = REFERENCE_NOTE


# ----------------------------------------------------------------------------- helpers
def available() -> bool:
    """True if ``exudyn`` can be imported."""
    try:
        import exudyn  # noqa: F401
    except Exception:
        return False
    return True


def _exu():
    import exudyn as exu
    import exudyn.utilities  # noqa: F401  (registers MainSystem.Create* extensions)

    return exu


def _n_steps(h: float, t_end: float) -> int:
    if not (h > 0.0 and t_end > 0.0):
        raise ValueError(f"need h > 0 and t_end > 0, got h={h}, t_end={t_end}")
    n = int(round(t_end / h))
    if n < 1 or abs(n * h - t_end) > 1e-9 * max(1.0, t_end):
        raise ValueError(f"t_end={t_end} is not an integer multiple of h={h}")
    return n


def _settings(exu, h: float, t_end: float, spectral_radius: float):
    s = exu.SimulationSettings()
    ti = s.timeIntegration
    ti.solverType = exu.DynamicSolverType.GeneralizedAlpha
    ti.numberOfSteps = _n_steps(h, t_end)
    ti.endTime = t_end
    ti.startTime = 0.0
    ti.adaptiveStep = False  # constant step size
    ti.verboseMode = 0
    ti.verboseModeFile = 0
    ti.generalizedAlpha.spectralRadius = spectral_radius
    ti.generalizedAlpha.useNewmark = False
    ti.generalizedAlpha.useIndex2Constraints = False
    s.linearSolver.solverType = exu.LinearSolverType.EigenSparse
    return quiet(s)


def quiet(s):
    """Simulation settings s on one thread, writing and printing nothing (timed runs)."""
    s.parallel.numberOfThreads = 1
    s.solution.file.write = False
    s.solution.sensors.active = False
    s.solution.restart.write = False
    s.show.computationTime = False
    s.show.statistics = False
    return s


def _rigid_body(mbs, exu, mass, inertia_diag, position):
    """Euler-parameter rigid body, reference point = centre of mass, body axes = global axes."""
    from exudyn.rigidBodyUtilities import RigidBodyInertia

    inertia = RigidBodyInertia(
        mass=mass, inertiaTensor=np.diag(inertia_diag), com=np.zeros(3), inertiaTensorAtCOM=True
    )
    d = mbs.CreateRigidBody(
        inertia=inertia,
        referencePosition=list(position),
        referenceRotationMatrix=np.eye(3),
        gravity=[0.0, 0.0, -GRAVITY],
        nodeType=exu.NodeType.RotationEulerParameters,
        show=False,
        returnDict=True,
    )
    return d["bodyNumber"], d["nodeNumber"]


def _node_state(mbs, exu, node):
    ovt = exu.OutputVariableType
    pos = np.array(mbs.GetNodeOutput(node, ovt.Position))
    vel = np.array(mbs.GetNodeOutput(node, ovt.Velocity))
    omega_local = np.array(mbs.GetNodeOutput(node, ovt.AngularVelocityLocal))
    # ODE2 coordinates of the node are displacements w.r.t. the reference coordinates
    q_ref = np.array(mbs.GetNodeParameter(node, "referenceCoordinates"), dtype=float)
    q = np.array(mbs.GetNodeOutput(node, ovt.Coordinates), dtype=float)
    p = (q_ref + q)[3:7]
    return pos, vel, omega_local, p


def _energy(mass, inertia_diag, pos, vel, omega_local):
    J = np.asarray(inertia_diag)
    kin = 0.5 * mass * float(vel @ vel) + 0.5 * float(omega_local @ (J * omega_local))
    pot = mass * GRAVITY * float(pos[2])
    return kin + pot


def _solve(mbs, exu, settings):
    import os

    try:
        import psutil

        proc = psutil.Process(os.getpid())
    except Exception:  # psutil is optional
        proc = None
    c0 = time.process_time()
    t0 = time.perf_counter()
    ok = mbs.SolveDynamic(settings)
    wall = time.perf_counter() - t0
    cpu = time.process_time() - c0
    if not ok:
        raise RuntimeError("exudyn SolveDynamic failed")
    solver = mbs.sys["dynamicSolver"]
    it = solver.it
    t_final = float(mbs.systemData.GetTime())
    info = {
        "wall_time": wall,
        "cpu_time": cpu,
        # it.currentStepIndex is the (1-based) index of the step that would come
        # next: 11 after 10 steps (checked with a pre-step counter)
        "steps": int(it.currentStepIndex) - 1,
        "steps_requested": int(settings.timeIntegration.numberOfSteps),
        "t_final": t_final,
        "newton_iterations": int(it.newtonStepsCount),
        "jacobian_evaluations": int(it.newtonJacobiCount),
        "rss_mb": (proc.memory_info().rss / 2**20) if proc is not None else None,
    }
    if abs(t_final - settings.timeIntegration.endTime) > 1e-9:
        raise RuntimeError(f"exudyn stopped at t={t_final}")
    return info


def _common(exu, h, spectral_radius, n_bodies, n_constraints):
    return {
        "h": h,
        "integrator": INTEGRATOR,
        "solver": SOLVER,
        "code": "exudyn",
        "exudyn_version": getattr(exu, "__version__", "?"),
        "node_type": "RotationEulerParameters (NodeRigidBodyEP)",
        "spectral_radius": spectral_radius,
        "threads": 1,
        "n_bodies": n_bodies,
        "n_constraints": n_constraints,
    }


# ----------------------------------------------------------------------------- problems
def pendulum_ch15(
    h: float, t_end: float = 10.0, *, spectral_radius: float = DEFAULT_SPECTRAL_RADIUS
) -> dict:
    """Chapter 15 spatial pendulum (P. Flores 2015, Table 15.1) in Exudyn.

    Problem (identical to spatialmbd's):

    * one rigid body, mass 7.02 kg, centroidal principal inertias
      (Ixx, Iyy, Izz) = (0.5855265, 0.0010530, 0.5855265) kg m^2 about the body
      axes (a 1 m solid cylinder along body y);
    * revolute joint to ground at the global origin, joint axis = global x
      (``MainSystem.CreateRevoluteJoint`` -> ``ObjectJointRevoluteZ``);
    * initial state: centre of mass at (0, 0.5, 0), body axes parallel to the
      global axes (Euler parameters (1, 0, 0, 0)), at rest: the body lies
      horizontally along +y;
    * gravity 9.81 m/s^2 along -z; simulated 0 .. t_end (default 10 s);
    * body node: ``exu.NodeType.RotationEulerParameters`` (same formulation as
      ours), generalized-alpha (rho_inf = 0.9, Exudyn's default), constant step h,
      EigenSparse, one thread.

    Returns the dict described in the module docstring with (1, 3) ``final_com``,
    (1, 4) ``final_p`` and additionally ``final_vel``, ``final_omega_local``,
    ``energy_initial``, ``energy_final`` (total mechanical energy, J).
    """
    exu = _exu()
    t0 = time.perf_counter()
    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    ground = mbs.CreateGround(referencePosition=[0.0, 0.0, 0.0], show=False)
    body, node = _rigid_body(mbs, exu, PENDULUM_MASS, PENDULUM_INERTIA, PENDULUM_COM0)
    mbs.CreateRevoluteJoint(
        itemNumbers=[ground, body], position=[0.0, 0.0, 0.0], axis=[1.0, 0.0, 0.0],
        useGlobalFrame=True, show=False,
    )
    mbs.Assemble()
    settings = _settings(exu, h, t_end, spectral_radius)
    build = time.perf_counter() - t0

    pos0, vel0, om0, _ = _node_state(mbs, exu, node)
    e0 = _energy(PENDULUM_MASS, PENDULUM_INERTIA, pos0, vel0, om0)
    info = _solve(mbs, exu, settings)
    pos, vel, om, p = _node_state(mbs, exu, node)
    e1 = _energy(PENDULUM_MASS, PENDULUM_INERTIA, pos, vel, om)

    out = _common(exu, h, spectral_radius, 1, 5 + 1)
    out.update(info)
    out.update(
        problem="pendulum_ch15",
        t_end=t_end,
        build_time=build,
        final_com=[pos.tolist()],
        final_p=[p.tolist()],
        final_vel=[vel.tolist()],
        final_omega_local=[om.tolist()],
        energy_initial=e0,
        energy_final=e1,
    )
    return out


def chain(
    n: int, joint: str, h: float, t_end: float = 1.0, *,
    spectral_radius: float = DEFAULT_SPECTRAL_RADIUS,
) -> dict:
    """N-link spatial chain in Exudyn.

    Problem (identical to spatialmbd's):

    * n identical slender links, each of length L = 1 m and mass m = 1 kg, a rod
      along its local x axis with centroidal inertia
      diag(1e-4, m L^2/12, m L^2/12) = diag(1e-4, 0.0833333..., 0.0833333...) kg m^2;
    * released at rest, horizontal along +x: link k (k = 0 .. n-1) has its
      centre of mass at ((k + 0.5) L, 0, 0), body axes = global axes;
    * joint 0 connects ground at the origin to the left end of link 0; joint k
      (k >= 1) connects the right end of link k-1 to the left end of link k at
      the global point (k L, 0, 0);
    * ``joint="spherical"``: spherical joints (``ObjectJointSpherical``, 3
      equations each); ``joint="revolute"``: revolute joints about global y
      (``ObjectJointRevoluteZ``, 5 equations each; the chain swings in xz);
    * gravity 9.81 m/s^2 along -z; simulated 0 .. t_end (default 1 s);
    * Euler-parameter nodes, generalized-alpha (rho_inf = 0.9), constant step h,
      EigenSparse, one thread.

    Returns the dict of the module docstring with (n, 3) ``final_com``,
    (n, 4) ``final_p``, plus ``final_tip`` (global position of the free right
    end of the last link), ``energy_initial`` and ``energy_final``.
    """
    if joint not in ("spherical", "revolute"):
        raise ValueError(f"joint must be 'spherical' or 'revolute', got {joint!r}")
    n = int(n)
    if n < 1:
        raise ValueError("n must be >= 1")
    exu = _exu()
    L = LINK_LENGTH
    t0 = time.perf_counter()
    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    ground = mbs.CreateGround(referencePosition=[0.0, 0.0, 0.0], show=False)
    bodies, nodes = [], []
    prev = ground
    for k in range(n):
        body, node = _rigid_body(mbs, exu, LINK_MASS, LINK_INERTIA, ((k + 0.5) * L, 0.0, 0.0))
        pos = [k * L, 0.0, 0.0]
        if joint == "spherical":
            mbs.CreateSphericalJoint(itemNumbers=[prev, body], position=pos, useGlobalFrame=True, show=False)
        else:
            mbs.CreateRevoluteJoint(
                itemNumbers=[prev, body], position=pos, axis=[0.0, 1.0, 0.0], useGlobalFrame=True, show=False
            )
        bodies.append(body)
        nodes.append(node)
        prev = body
    mbs.Assemble()
    settings = _settings(exu, h, t_end, spectral_radius)
    build = time.perf_counter() - t0

    def energy():
        e = 0.0
        for node in nodes:
            pos, vel, om, _ = _node_state(mbs, exu, node)
            e += _energy(LINK_MASS, LINK_INERTIA, pos, vel, om)
        return e

    e0 = energy()
    info = _solve(mbs, exu, settings)
    com, ps = [], []
    for node in nodes:
        pos, _, _, p = _node_state(mbs, exu, node)
        com.append(pos.tolist())
        ps.append(p.tolist())
    tip = mbs.GetObjectOutputBody(
        bodies[-1], exu.OutputVariableType.Position, localPosition=[0.5 * L, 0.0, 0.0]
    )
    out = _common(exu, h, spectral_radius, n, n * ((3 if joint == "spherical" else 5) + 1))
    out.update(info)
    out.update(
        problem=f"chain_{joint}",
        joint=joint,
        n=n,
        t_end=t_end,
        build_time=build,
        final_com=com,
        final_p=ps,
        final_tip=list(map(float, tip)),
        energy_initial=e0,
        energy_final=energy(),
    )
    return out


def work_precision_pendulum(hs: Iterable[float], t_end: float = 10.0, **kw) -> list[dict]:
    """``pendulum_ch15(h, t_end)`` for every h in ``hs``; errors are computed by the caller."""
    return [pendulum_ch15(h, t_end, **kw) for h in hs]


def work_precision_chain(n: int, joint: str, hs: Iterable[float], t_end: float = 1.0, **kw) -> list[dict]:
    """``chain(n, joint, h, t_end)`` for every h in ``hs``; errors are computed by the caller."""
    return [chain(n, joint, h, t_end, **kw) for h in hs]


# ----------------------------------------------------------------------------- self-check
def _pendulum_reference(t_end: float = 10.0):
    """Planar reference for the ch. 15 pendulum (scipy, rtol 1e-12).

    The body turns about the global x axis (a principal axis through the joint),
    so the motion is planar: I_O phi'' = -m g d cos(phi), I_O = Ixx + m d^2,
    d = 0.5 m, and the centre of mass is d (0, cos phi, sin phi).
    """
    from scipy.integrate import solve_ivp

    m, d = PENDULUM_MASS, PENDULUM_COM0[1]
    I_O = PENDULUM_INERTIA[0] + m * d * d
    sol = solve_ivp(
        lambda t, y: [y[1], -m * GRAVITY * d * np.cos(y[0]) / I_O],
        (0.0, t_end), [0.0, 0.0], method="DOP853", rtol=1e-13, atol=1e-13,
    )
    phi = sol.y[0, -1]
    return np.array([0.0, d * np.cos(phi), d * np.sin(phi)])


def _main() -> None:  # pragma: no cover - manual benchmark
    if not available():
        print("exudyn is not installed: pip install 'exudyn==1.13.6' psutil")
        return
    np.set_printoptions(precision=17)
    ref = _pendulum_reference()
    print(f"Exudyn {_exu().__version__}, single thread, generalized-alpha rho_inf=0.9, EigenSparse")
    print("\nCh. 15 pendulum, t_end = 10 s")
    print(f"{'h':>8} {'steps':>7} {'build s':>8} {'wall s':>8} {'|com-ref|':>10} {'E0':>11} {'E_end':>11}  final com")
    for h in (1e-3, 1e-4):
        r = pendulum_ch15(h)
        err = np.linalg.norm(np.array(r["final_com"][0]) - ref)
        print(
            f"{h:8.0e} {r['steps']:7d} {r['build_time']:8.3f} {r['wall_time']:8.3f} {err:10.2e} "
            f"{r['energy_initial']:11.6f} {r['energy_final']:11.6f}  {r['final_com'][0]!r}"
        )
    print(f"{'planar ref':>8} {'':7} {'':8} {'':8} {'':10} {'':11} {'':11}  {ref.tolist()!r}")

    print("\nN-link chains, h = 1e-3, t_end = 1 s")
    print(f"{'joint':>10} {'N':>5} {'steps':>6} {'build s':>8} {'wall s':>8} {'newton':>7} {'jac':>5} {'E_end-E0 J':>11}")
    for joint in ("spherical", "revolute"):
        for n in (4, 16, 64, 256, 1024):
            r = chain(n, joint, 1e-3)
            de = r["energy_final"] - r["energy_initial"]
            print(
                f"{joint:>10} {n:5d} {r['steps']:6d} {r['build_time']:8.3f} {r['wall_time']:8.3f} "
                f"{r['newton_iterations']:7d} {r['jacobian_evaluations']:5d} {de:11.2e}"
            )
            if n == 256 and 4.5 * r["wall_time"] > 30.0:
                print(f"{joint:>10} {1024:5d}  skipped (estimated > 30 s)")
                break
    r = chain(4, "spherical", 1e-4)
    print(f"\nN=4 spherical chain, h=1e-4, t=1 s: tip = {r['final_tip']!r}")
    print(f"                                   com[-1] = {r['final_com'][-1]!r}")


if __name__ == "__main__":
    _main()
