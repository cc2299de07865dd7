"""Models and costs of the adjoint-gradient tests (tests/design/test_adjoint.py): a pendulum,
a closed-loop slider-crank and one small model per force-element kind, each with the
parameters the design layer varies in it."""
from __future__ import annotations

import copy

import numpy as np

ANALYSIS = dict(type="dynamic", t_end=0.4, output_step=0.02, method=dict(name="standard"),
                integrator=dict(name="rk4", step=0.004))


def link(forces, *, joint="revolute", omega=(2.0, 0.0, 0.0), velocity=(0.0, 0.0, 0.0)):
    """A 1.5 kg link hinged (revolute about x) or sliding (translational along y) on the
    ground at the origin, its centre of mass 0.4 m out along y, with ``forces``."""
    return {
        "spatialmbd": 1, "name": "link", "gravity": [0.0, 0.0, -9.81],
        "bodies": [{"name": "link", "mass": 1.5, "inertia": [0.09, 0.006, 0.085],
                    "position": [0.0, 0.4, 0.0], "angular_velocity": list(omega),
                    "velocity": list(velocity)}],
        "joints": [{"name": "pin", "type": joint, "body_i": "ground", "body_j": "link",
                    "point": [0.0, 0.0, 0.0],
                    "axis": [1.0, 0.0, 0.0] if joint == "revolute" else [0.0, 1.0, 0.0]}],
        "forces": forces, "analysis": copy.deepcopy(ANALYSIS)}


SLIDE = dict(joint="translational", omega=(0.0, 0.0, 0.0), velocity=(0.0, 0.3, 0.0))

#: kind -> (model, {parameter path: value}): the parameters of each kind that the adjoint
#: varies (force-law values -- a point force's or torque's magnitude, an actuator's command
#: or reference -- live in the work arrays and are refused, see LAW_VALUES)
KINDS = {
    "body": (link([]), {"bodies.link.mass": 1.5, "bodies.link.inertia.0": 0.09,
                        "bodies.link.angular_velocity.0": 2.0, "gravity.2": -9.81}),
    "joint_geometry": (link([]), {"joints.pin.point.1": 0.0, "joints.pin.point.2": 0.0}),
    "spring_damper": (link([{"name": "s", "type": "spring_damper", "body_i": "ground",
                             "body_j": "link", "point_i": [0.0, 0.3, 0.5],
                             "point_j": [0.0, 0.7, 0.0], "stiffness": 40.0, "damping": 1.5,
                             "natural_length": 0.3}]),
                      {"forces.s.stiffness": 40.0, "forces.s.damping": 1.5,
                       "forces.s.natural_length": 0.3, "forces.s.point_i.2": 0.5}),
    "rotational_spring_damper": (
        link([{"name": "r", "type": "rotational_spring_damper", "joint": "pin",
               "stiffness": 8.0, "damping": 0.3, "rest_angle": 0.2}]),
        {"forces.r.stiffness": 8.0, "forces.r.damping": 0.3, "forces.r.rest_angle": 0.2}),
    "bushing": (link([{"name": "b", "type": "bushing", "body_i": "ground", "body_j": "link",
                       "point_i": [0.0, 0.4, 0.0], "point_j": [0.0, 0.0, 0.0],
                       "stiffness": [30.0, 40.0, 50.0], "damping": [0.5, 0.6, 0.7],
                       "rotational_stiffness": [2.0, 3.0, 4.0],
                       "rotational_damping": [0.05, 0.06, 0.07]}]),
                {"forces.b.stiffness.2": 50.0, "forces.b.damping.2": 0.7,
                 "forces.b.rotational_stiffness.0": 2.0, "forces.b.rotational_damping.0": 0.05}),
    "point_force": (link([{"name": "push", "type": "point_force", "body": "link",
                           "point": [0.0, 0.5, 0.0], "direction": [0.0, 0.0, 1.0],
                           "magnitude": 3.0}]),
                    {"forces.push.point.1": 0.5, "forces.push.point.2": 0.0}),
    "torque": (link([{"name": "tq", "type": "torque", "body": "link",
                      "direction": [1.0, 0.3, 0.0], "magnitude": 1.2}]),
               {"forces.tq.direction.0": 1.0}),
    "motor": (link([{"name": "m", "type": "motor", "joint": "pin", "gear": 2.0,
                     "command": 0.7}]), {"forces.m.gear": 2.0}),
    "position_servo": (link([{"name": "ps", "type": "position_servo", "joint": "pin",
                              "kp": 20.0, "kv": 1.0, "reference": 0.5}]),
                       {"forces.ps.kp": 20.0, "forces.ps.kv": 1.0}),
    "velocity_servo": (link([{"name": "vs", "type": "velocity_servo", "joint": "pin",
                              "kv": 2.0, "reference": 1.0}]),
                       {"forces.vs.kv": 2.0}),
    "general": (link([{"name": "ga", "type": "general", "joint": "pin", "gain": 1.5,
                       "bias": [0.2, -3.0, -0.4], "command": 0.5}]),
                {"forces.ga.gain": 1.5, "forces.ga.bias.1": -3.0, "forces.ga.bias.2": -0.4}),
    "joint_friction": (link([{"name": "fr", "type": "joint_friction", "joint": "pin",
                              "friction": "stribeck", "frictionloss": 0.4,
                              "static_frictionloss": 0.5, "stribeck_velocity": 0.1,
                              "viscous": 0.2}], **SLIDE),
                       {"forces.fr.frictionloss": 0.4, "forces.fr.static_frictionloss": 0.5,
                        "forces.fr.viscous": 0.2}),
    "joint_limit": (link([{"name": "stop", "type": "joint_limit", "joint": "pin",
                           "lower": -1.0, "upper": -0.01, "law": "linear",
                           "stiffness": 200.0, "damping": 2.0},
                          {"name": "load", "type": "point_force", "body": "link",
                           "direction": [0.0, 1.0, 0.0], "magnitude": 20.0}], **SLIDE),
                    {"forces.stop.stiffness": 200.0, "forces.stop.damping": 2.0,
                     "forces.stop.upper": -0.01}),
}


def slider_crank():
    """The slider-crank of examples/slider_crank.yaml without its driver (a closed loop of a
    revolute, a spherical, a universal and a translational joint), falling under gravity
    from a crank rate of 6 rad/s, with a rotational damper at the crank and a spring on the
    slider."""
    from pathlib import Path

    import yaml
    path = Path(__file__).resolve().parents[2] / "examples" / "slider_crank.yaml"
    data = yaml.safe_load(path.read_text())
    data.pop("drivers")
    data["bodies"][0]["angular_velocity"] = [6.0, 0.0, 0.0]
    data["forces"] = [
        {"name": "crank_damper", "type": "rotational_spring_damper", "joint": "A",
         "stiffness": 0.05, "damping": 0.002},
        {"name": "slider_spring", "type": "spring_damper", "body_i": "ground",
         "body_j": "slider", "point_i": [0.5, 0.0, 0.0], "point_j": [0.0, 0.0, 0.0],
         "stiffness": 20.0, "damping": 0.5, "natural_length": 0.25}]
    data["analysis"] = dict(ANALYSIS, t_end=0.3, output_step=0.01,
                            integrator=dict(name="rk4", step=0.001))
    params = {"bodies.crank.mass": 0.12, "bodies.rod.mass": 0.5, "bodies.slider.mass": 2.0,
              "bodies.rod.inertia.1": 0.004, "forces.crank_damper.damping": 0.002,
              "forces.slider_spring.stiffness": 20.0, "forces.slider_spring.damping": 0.5,
              "bodies.crank.angular_velocity.0": 6.0}
    return data, params


def misfit_weights(Y, columns, target):
    """d/dY of 1/2 sum over samples and columns of (Y[:, c] - target)^2 and its value."""
    W = np.zeros(Y.shape)
    value = 0.0
    for c in columns:
        r = Y[:, c] - target
        W[:, c] = r
        value += 0.5 * float(r @ r)
    return value, W


#: force-law values the adjoint refuses (jacobian="fd" differentiates them): kind -> path
LAW_VALUES = {"point_force": "forces.push.magnitude", "motor": "forces.m.command",
              "position_servo": "forces.ps.reference"}
