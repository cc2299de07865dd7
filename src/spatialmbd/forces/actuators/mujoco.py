"""MJCF actuators -> actuator specs: the builder keywords of the kind that reproduces one
compiled MuJoCo actuator exactly (for the MJCF importer).

MuJoCo compiles every actuator on a joint to gain/bias form, force = gain ctrl + bias0 +
bias1 L + bias2 L' (L = gear qpos), clipped to forcerange, ctrl clipped to ctrlrange, and the
joint receives gear force -- the law of :mod:`.common`. The shorthand elements come back as:

    <motor>     gain 1, no bias                -> motor
    <position>  gain kp, bias (0, -kp, -kv)    -> position_servo (velocity_feedforward: false)
    <velocity>  gain kv, bias (0, 0, -kv)      -> velocity_servo
    anything else with fixed gain and affine or no bias -> general (gain, bias)

Actuators with activation dynamics (dyntype other than none), other gain or bias types, or a
transmission other than a hinge or slide joint raise ModelError naming the actuator.
"""
from __future__ import annotations

from ...errors import ModelError


def actuator_spec_from_mujoco(mj_model, actuator_id: int, joint_name: str,
                              joint_offset: float = 0.0) -> dict:
    """The builder keywords (``type`` and the parameters; ``ModelBuilder.add_force(
    spec.pop("type"), name, **spec)``) of MuJoCo actuator ``actuator_id`` of ``mj_model``,
    acting on the joint named ``joint_name`` in the spatialmbd model.

    joint_offset: the MuJoCo joint coordinate (qpos - qpos0 convention aside: the value of
    qpos) at which the spatialmbd joint coordinate is zero, i.e. the assembled configuration
    (rad or m); a position-type actuator then gets the bias b0 that keeps its equilibrium
    where MuJoCo has it (and is returned as ``general``).
    """
    import mujoco
    m, a = mj_model, int(actuator_id)
    name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_ACTUATOR, a) or f"actuator {a}"
    what = f"MJCF actuator {name!r}"
    if int(m.actuator_trntype[a]) != int(mujoco.mjtTrn.mjTRN_JOINT):
        raise ModelError(f"{what}: only joint transmissions map to spatialmbd actuators "
                         f"(this one has transmission type {int(m.actuator_trntype[a])})")
    if int(m.actuator_dyntype[a]) != int(mujoco.mjtDyn.mjDYN_NONE):
        raise ModelError(f"{what}: activation dynamics (dyntype "
                         f"{mujoco.mjtDyn(int(m.actuator_dyntype[a])).name}) are not supported; "
                         "only direct actuators (dyntype none) map")
    if int(m.actuator_gaintype[a]) != int(mujoco.mjtGain.mjGAIN_FIXED):
        raise ModelError(f"{what}: gain type {mujoco.mjtGain(int(m.actuator_gaintype[a])).name}"
                         " is not supported (only fixed gains)")
    bias_type = int(m.actuator_biastype[a])
    if bias_type not in (int(mujoco.mjtBias.mjBIAS_NONE), int(mujoco.mjtBias.mjBIAS_AFFINE)):
        raise ModelError(f"{what}: bias type {mujoco.mjtBias(bias_type).name} is not supported "
                         "(only none and affine)")
    jid = int(m.actuator_trnid[a, 0])
    jtype = int(m.jnt_type[jid])
    if jtype == int(mujoco.mjtJoint.mjJNT_HINGE):
        coordinate = "angle"
    elif jtype == int(mujoco.mjtJoint.mjJNT_SLIDE):
        coordinate = "translation"
    else:
        raise ModelError(f"{what}: acts on a {mujoco.mjtJoint(jtype).name} joint; only hinge "
                         "and slide joints have one coordinate to actuate")
    gear = float(m.actuator_gear[a, 0])
    gain = float(m.actuator_gainprm[a, 0])
    bias = [float(x) for x in m.actuator_biasprm[a, :3]] \
        if bias_type == int(mujoco.mjtBias.mjBIAS_AFFINE) else [0.0, 0.0, 0.0]
    spec = dict(joint=joint_name, coordinate=coordinate)
    if gear != 1.0:
        spec["gear"] = gear
    if bool(m.actuator_ctrllimited[a]):
        spec["ctrlrange"] = [float(x) for x in m.actuator_ctrlrange[a]]
    if bool(m.actuator_forcelimited[a]):
        spec["forcerange"] = [float(x) for x in m.actuator_forcerange[a]]
    b0, b1, b2 = bias
    b0 += b1 * gear * float(joint_offset)       # L_mujoco = gear (q + offset)
    if b0 == 0.0 and b1 == 0.0 and b2 == 0.0 and gain == 1.0:
        return dict(type="motor", **spec)
    if b0 == 0.0 and b1 == -gain and b2 <= 0.0 and gain > 0.0:
        return dict(type="position_servo", kp=gain, kv=-b2, velocity_feedforward=False,
                    **spec)
    if b0 == 0.0 and b1 == 0.0 and b2 == -gain and gain > 0.0:
        return dict(type="velocity_servo", kv=gain, **spec)
    return dict(type="general", gain=gain, bias=[b0, b1, b2], **spec)
