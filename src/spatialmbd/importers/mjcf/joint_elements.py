"""What acts on the imported joints: limits, friction loss, springs and dampers, actuators and
fixed tendons of the compiled MuJoCo model, as spatialmbd force elements and couplers
(docs/import.md, "Joint limits, friction loss and actuators").

Our joint coordinates are zero in the assembled configuration, MuJoCo's in ``qpos = 0``: every
MuJoCo position (a range, a spring reference, a servo's equilibrium) is shifted by the joint's
``qpos`` at assembly (``qref``, MuJoCo's ``qpos0``).

MuJoCo's limits and friction loss are *soft constraints*; ours are force laws. The mapping
(:func:`soft_spring`, :func:`creep_velocity`) follows MuJoCo's documented reference
acceleration a_ref = -b v - k r with impedance d (solref, solimp): on the joint's own inertia
I = 1 / dof_invweight0 (MuJoCo's diagonal approximation, at qpos0) the violation r obeys
r'' = (1 - d) a0 - d (b r' + k r), a spring-damper of stiffness d k I and damping d b I with
the load a0 scaled by (1 - d).
"""
from __future__ import annotations

import math
import re

import numpy as np

from ...errors import ModelError
from ...forces.actuators.mujoco import actuator_spec_from_mujoco
from ...forces.fixed_tendon import MAX_JOINTS
from .report import LeftOut

#: the slide spring's points: P_i this far behind the anchor along the axis (m), so that
#: |P_j - P_i| = SLIDE_LEVER + x stays positive over any reasonable travel x
SLIDE_LEVER = 10.0


def impedance(solimp, r) -> float:
    """MuJoCo's impedance d(r) of solimp (dmin, dmax, width, midpoint, power) at violation r."""
    dmin, dmax, width, mid, power = (float(v) for v in solimp[:5])
    x = min(abs(float(r)) / width, 1.0) if width > 0 else 1.0
    if x >= 1.0:
        y = 1.0
    elif power == 1.0:
        y = x
    elif x <= mid:
        y = x ** power / mid ** (power - 1.0)
    else:
        y = 1.0 - (1.0 - x) ** power / (1.0 - mid) ** (power - 1.0)
    d = dmin + y * (dmax - dmin)
    return min(max(d, 1e-4), 0.9999)              # MuJoCo's mjMINIMP, mjMAXIMP


def reference_gains(mujoco, m, solref, d) -> tuple:
    """(k, b) of MuJoCo's reference acceleration a_ref = -b v - k r for ``solref`` at impedance
    d: timeconst > 0: k = 1 / (d^2 timeconst^2 dampratio^2), b = 2 / (d timeconst), timeconst
    at least 2 timestep unless refsafe is disabled; timeconst < 0: k = -timeconst / d^2,
    b = -dampratio / d (direct stiffness and damping)."""
    tc, dr = float(solref[0]), float(solref[1])
    if tc > 0:
        if not m.opt.disableflags & int(mujoco.mjtDisableBit.mjDSBL_REFSAFE):
            tc = max(tc, 2.0 * float(m.opt.timestep))
        return 1.0 / (d * d * tc * tc * dr * dr), 2.0 / (d * tc)
    return -tc / (d * d), -dr / d


def soft_spring(mujoco, m, solref, solimp, inertia) -> tuple:
    """(stiffness, damping) of the linear stop that gives the free response of MuJoCo's soft
    limit: K = d k I, C = d b I at the deep impedance d = dmax (module docstring)."""
    d = impedance(solimp, math.inf)
    k, b = reference_gains(mujoco, m, solref, d)
    return d * k * inertia, d * b * inertia


def creep_velocity(mujoco, m, solref, solimp, inertia, level) -> float:
    """The creep velocity v_eps of the regularized Coulomb law that creeps as MuJoCo's soft
    friction loss does under a load below the level F: MuJoCo settles at
    v = (1 - d) a0 / (d b) (a0 = load / I, d = d(0) = dmin), the law at v = v_eps load / F,
    so v_eps = (1 - d) F / (d b I)."""
    d = impedance(solimp, 0.0)
    _, b = reference_gains(mujoco, m, solref, d)
    return (1.0 - d) * level / (d * b * inertia)


def _disabled(mujoco, m, flag) -> bool:
    return bool(m.opt.disableflags & int(getattr(mujoco.mjtDisableBit, flag)))


class JointElements:
    """Adds the elements acting on the imported joints to ``builder``.

    joint_of: MuJoCo joint id -> (our joint name, our joint type) for every imported joint;
    single: MuJoCo joint id -> our joint, for a hinge or slide imported alone (one coordinate);
    local_of(body, x): a global point in our body's axes; fresh(name): a unique name;
    qref: (nq,) MuJoCo's qpos in the assembled configuration; ctrl: (nu,) the commands.
    """

    def __init__(self, mujoco, m, d, builder, *, joint_of, single, local_of, fresh, jname,
                 left_out, qref, ctrl):
        self.mujoco, self.m, self.d, self.builder = mujoco, m, d, builder
        self.joint_of, self.single, self.local_of = joint_of, single, local_of
        self.fresh, self.jname, self.left_out = fresh, jname, left_out
        self.qref, self.ctrl = np.asarray(qref, dtype=float), np.asarray(ctrl, dtype=float)
        self.J = mujoco.mjtJoint

    def leave(self, kind, element, detail) -> None:
        self.left_out.append(LeftOut(kind, element, detail))

    # ------------------------------------------------------------------------- joints
    def add_joint_features(self) -> None:
        """Limits, friction loss, springs and dampers of every MuJoCo joint."""
        for j in range(self.m.njnt):
            if int(self.m.jnt_type[j]) == int(self.J.mjJNT_FREE):
                continue
            self._limit(j)
            self._friction(j)
            self._spring(j)
            self._armature(j)

    def _where(self, j):
        """(our joint name or None, 'single' / 'ball' / 'combined' / None)."""
        if j in self.single:
            return self.single[j], "single"
        if j not in self.joint_of:
            return None, None
        name, kind = self.joint_of[j]
        if kind == "spherical" and int(self.m.jnt_type[j]) == int(self.J.mjJNT_BALL):
            return name, "ball"
        return name, "combined"

    def _offset(self, j) -> float:
        return float(self.qref[self.m.jnt_qposadr[j]])

    def _inertia(self, j) -> float:
        return 1.0 / float(self.m.dof_invweight0[self.m.jnt_dofadr[j]])

    def _limit(self, j) -> None:
        m, jn = self.m, self.jname(j)
        if not m.jnt_limited[j] or _disabled(self.mujoco, m, "mjDSBL_LIMIT"):
            return
        lo, hi = (float(x) for x in m.jnt_range[j])
        ours, where = self._where(j)
        if where == "ball":
            self._ball_limit(j, jn, ours, lo, hi)
            return
        if where != "single":
            reason = {"combined": f"part of the combined joint {ours!r}",
                      None: "its joint is not imported"}[where]
            self.leave("joint limit", jn, f"range {lo:.6g} .. {hi:.6g}: {reason}")
            return
        margin = float(m.jnt_margin[j])
        lower, upper = lo + margin - self._offset(j), hi - margin - self._offset(j)
        hinge = int(m.jnt_type[j]) == int(self.J.mjJNT_HINGE)
        if hinge and upper - lower >= 2 * math.pi:
            self.leave("joint limit", jn, f"range {lo:.6g} .. {hi:.6g} rad is a turn or more "
                       "(a joint_limit reads the angle within one turn); it is not reached "
                       "before the joint has turned a full turn")
            return
        stiffness, damping = soft_spring(self.mujoco, m, m.jnt_solref[j], m.jnt_solimp[j],
                                         self._inertia(j))
        try:
            self.builder.add_force("joint_limit", self.fresh(f"{jn}_limit"), joint=ours,
                                   lower=lower, upper=upper, law="linear",
                                   stiffness=stiffness, damping=damping)
        except ModelError as exc:          # e.g. a range of zero width (margins included)
            self.leave("joint limit", jn, f"range {lo:.6g} .. {hi:.6g}: {exc}")
            return
        self.leave("limit approximation", jn, f"range {lo:.6g} .. {hi:.6g}: MuJoCo's soft "
                   f"limit (solref, solimp) as a linear stop, stiffness {stiffness:.6g}, "
                   f"damping {damping:.6g}")

    def _ball_limit(self, j, jn, ours, lo, hi) -> None:
        """MuJoCo limits a ball joint's rotation angle |quat2vel(qpos)| (swing and twist) by
        max(range) (range[0] is unused): the joint_limit on the coordinate ``rotation`` (the
        angle of the relative rotation from the assembly) when the assembly is qpos = identity,
        with the soft constraint mapped as for hinges on :meth:`_ball_inertia`."""
        m = self.m
        adr = int(m.jnt_qposadr[j])
        quat = self.qref[adr:adr + 4]
        if np.abs(np.abs(quat) - (1.0, 0.0, 0.0, 0.0)).max() > 1e-12:
            self.leave("joint limit", jn, f"range {lo:.6g} .. {hi:.6g}: a ball joint's range "
                       "bounds the rotation from qpos = identity; the assembled configuration "
                       "(the keyframe's) is rotated from it")
            return
        upper = max(lo, hi) - float(m.jnt_margin[j])
        if not 0.0 < upper < math.pi:
            self.leave("joint limit", jn, f"range {lo:.6g} .. {hi:.6g}: a ball joint's limit "
                       "angle (less the margin) must lie in (0, pi) rad")
            return
        stiffness, damping = soft_spring(self.mujoco, m, m.jnt_solref[j], m.jnt_solimp[j],
                                         self._ball_inertia(j))
        self.builder.add_force("joint_limit", self.fresh(f"{jn}_limit"), joint=ours,
                               coordinate="rotation", upper=upper, law="linear",
                               stiffness=stiffness, damping=damping)
        self.leave("limit approximation", jn, f"ball range {max(lo, hi):.6g} rad: MuJoCo's "
                   "soft limit (solref, solimp) as a linear stop on the rotation angle, "
                   f"stiffness {stiffness:.6g}, damping {damping:.6g}")

    def _ball_inertia(self, j) -> float:
        """The largest inertia of a ball joint's rotation at the assembly, 1 / the smallest
        eigenvalue of its 3 x 3 block of M^-1 (MuJoCo's own dof_invweight0 averages the three,
        which a slender body's twist dominates): the swing's, where a limit is usually hit; a
        twist reaching it meets a stiffer stop than MuJoCo's."""
        m, dof = self.m, int(self.m.jnt_dofadr[j])
        unit = np.zeros((m.nv, 3))
        unit[dof:dof + 3] = np.eye(3)
        out = np.zeros((3, m.nv))
        self.mujoco.mj_solveM(m, self.d, out, np.ascontiguousarray(unit.T))
        block = 0.5 * (out[:, dof:dof + 3] + out[:, dof:dof + 3].T)
        return 1.0 / float(np.linalg.eigvalsh(block).min())

    def _armature(self, j) -> None:
        """MuJoCo's armature (J added to the joint-space mass diagonal) of a hinge or slide:
        an armature element on our joint's angle or translation (exact, forces.armature)."""
        m, jn = self.m, self.jname(j)
        dof = int(m.jnt_dofadr[j])
        ndof = 3 if int(m.jnt_type[j]) == int(self.J.mjJNT_BALL) else 1
        values = np.asarray(m.dof_armature[dof:dof + ndof], dtype=float)
        if not np.any(values != 0):
            return
        ours, where = self._where(j)
        hinge = int(m.jnt_type[j]) == int(self.J.mjJNT_HINGE)
        coordinate = None
        if where == "combined" and self.builder.joints[ours].type == "cylindrical":
            coordinate = "angle" if hinge else "translation"
        elif where != "single":
            reason = {"ball": "a rotor inertia on a ball joint's three rotations has no "
                              "counterpart here",
                      "combined": f"part of the combined joint {ours!r}",
                      None: "its joint is not imported"}[where]
            self.leave("armature", jn, f"{float(values.max()):.6g} "
                       f"{'kg m^2' if ndof == 3 or hinge else 'kg'}: {reason}")
            return
        extra = {} if coordinate is None else {"coordinate": coordinate}
        self.builder.add_force("armature", self.fresh(f"{jn}_armature"), joint=ours,
                               inertia=float(values[0]), **extra)

    def _friction(self, j) -> None:
        m, jn = self.m, self.jname(j)
        dof = int(m.jnt_dofadr[j])
        ndof = 3 if int(m.jnt_type[j]) == int(self.J.mjJNT_BALL) else 1
        levels = np.asarray(m.dof_frictionloss[dof:dof + ndof], dtype=float)
        if not np.any(levels != 0) or _disabled(self.mujoco, m, "mjDSBL_FRICTIONLOSS"):
            return
        ours, where = self._where(j)
        level = float(levels.max())
        if where != "single":
            reason = {"ball": "MuJoCo bounds each of the three components apart (a box); the "
                              "joint_friction of a spherical joint bounds the moment's "
                              "magnitude",
                      "combined": f"part of the combined joint {ours!r}",
                      None: "its joint is not imported"}[where]
            self.leave("frictionloss", jn, f"{level:.6g}: {reason}")
            return
        v_eps = creep_velocity(self.mujoco, m, m.dof_solref[dof], m.dof_solimp[dof],
                               self._inertia(j), level)
        self.builder.add_force("joint_friction", self.fresh(f"{jn}_friction"), joint=ours,
                               frictionloss=level, creep_velocity=v_eps)
        self.leave("frictionloss approximation", jn, f"{level:.6g}: MuJoCo's soft friction "
                   "loss (solref, solimp) as regularized Coulomb friction, creep velocity "
                   f"{v_eps:.6g}")

    def _spring(self, j) -> None:
        m, jn = self.m, self.jname(j)
        dof = int(m.jnt_dofadr[j])
        ball = int(m.jnt_type[j]) == int(self.J.mjJNT_BALL)
        k = 0.0 if _disabled(self.mujoco, m, "mjDSBL_SPRING") else float(m.jnt_stiffness[j])
        dampings = np.zeros(3 if ball else 1) if _disabled(self.mujoco, m, "mjDSBL_DAMPER") \
            else np.asarray(m.dof_damping[dof:dof + (3 if ball else 1)], dtype=float)
        c = float(dampings.max())
        if k == 0 and c == 0:
            return
        ours, where = self._where(j)
        if where not in ("single", "ball"):
            self.leave("joint spring", jn, f"part of the combined joint {ours!r}" if where
                       else "its joint is not imported")
            return
        if where == "ball":
            self._ball_spring(j, jn, ours, k, dampings)
            return
        adr = int(m.jnt_qposadr[j])
        rest = float(m.qpos_spring[adr]) - self._offset(j)
        if int(m.jnt_type[j]) == int(self.J.mjJNT_HINGE):
            self.builder.add_force("rotational_spring_damper", self.fresh(f"{jn}_spring"),
                                   joint=ours, stiffness=k, damping=c, rest_angle=rest)
            return
        # a slide: a spring-damper between a point SLIDE_LEVER behind the anchor on the
        # parent and the anchor on the child; while the joint holds both stay on the axis, so
        # its length is SLIDE_LEVER + x and its force -k (x - rest) - c x' along the axis
        spec = self.builder.joints[ours]
        anchor, axis = (np.asarray(self.d.xanchor[j], dtype=float),
                        np.asarray(self.d.xaxis[j], dtype=float))
        self.builder.add_force(
            "spring_damper", self.fresh(f"{jn}_spring"), body_i=spec.body_i,
            body_j=spec.body_j, point_i=self.local_of(spec.body_i, anchor - SLIDE_LEVER * axis),
            point_j=self.local_of(spec.body_j, anchor), stiffness=k, damping=c,
            natural_length=SLIDE_LEVER + rest)

    def _ball_spring(self, j, jn, ours, k, dampings) -> None:
        """MuJoCo's ball spring -k log(R_rel) (reference qpos0 = the assembly) is a bushing's
        isotropic rotational stiffness exactly (J_l^-T theta = theta); its damper -c w_rel is
        the viscous joint_friction on the rotation, exactly."""
        spec = self.builder.joints[ours]
        adr = int(self.m.jnt_qposadr[j])
        if k != 0 and np.abs(self.qref[adr:adr + 4] - self.m.qpos_spring[adr:adr + 4]).max() > 0:
            self.leave("joint spring", jn, "ball joint spring: its reference (qpos0) is not "
                       "the assembled configuration (the keyframe's)")
            k = 0.0
        if np.ptp(dampings) != 0:
            self.leave("joint spring", jn, f"ball joint with unequal dampings "
                       f"{dampings.tolist()} (only an isotropic damper maps)")
            dampings = np.zeros(3)
        if k != 0:
            anchor = np.asarray(self.d.xanchor[j], dtype=float)
            self.builder.add_force("bushing", self.fresh(f"{jn}_spring"), body_i=spec.body_i,
                                   body_j=spec.body_j,
                                   point_i=self.local_of(spec.body_i, anchor),
                                   point_j=self.local_of(spec.body_j, anchor),
                                   rotational_stiffness=k)
        if dampings[0] != 0:
            self.builder.add_force("joint_friction", self.fresh(f"{jn}_damper"), joint=ours,
                                   friction="viscous", viscous=float(dampings[0]))

    # ------------------------------------------------------------------------- actuators
    def add_actuators(self) -> None:
        """Each MuJoCo actuator on a single hinge or slide, via actuator_spec_from_mujoco, with
        its constant command ctrl (0 unless a keyframe gives one)."""
        m, OBJ = self.m, self.mujoco.mjtObj
        off = _disabled(self.mujoco, m, "mjDSBL_ACTUATION")
        clamped = set()
        for u in range(m.nu):
            name = self.mujoco.mj_id2name(m, OBJ.mjOBJ_ACTUATOR, u) or f"actuator{u}"
            if off:
                self.leave("actuator", name, "actuation is disabled in the file")
                continue
            j = int(m.actuator_trnid[u, 0])
            if int(m.actuator_trntype[u]) == int(self.mujoco.mjtTrn.mjTRN_TENDON):
                reason = self._tendon_actuator(u, name, j)
                if reason:
                    self.leave("actuator", name, reason)
                continue
            joint = self.single.get(j) if int(m.actuator_trntype[u]) == int(
                self.mujoco.mjtTrn.mjTRN_JOINT) else None
            if joint is None and int(m.actuator_trntype[u]) == int(
                    self.mujoco.mjtTrn.mjTRN_JOINT):
                self.leave("actuator", name, f"acts on joint {self.jname(j)!r}, which is not "
                           "a single hinge or slide here")
                continue
            try:
                spec = actuator_spec_from_mujoco(m, u, joint or "",
                                                 self._offset(j) if joint else 0.0)
            except ModelError as exc:
                self.leave("actuator", name, str(exc))
                continue
            kind = spec.pop("type")
            key = "reference" if kind in ("position_servo", "velocity_servo") else "command"
            if self.ctrl[u] != 0:
                spec[key] = float(self.ctrl[u])
            self.builder.add_force(kind, self.fresh(re_name(name)), **spec)
            if joint is not None and m.jnt_actfrclimited[j] and j not in clamped:
                clamped.add(j)
                lo, hi = (float(x) for x in m.jnt_actfrcrange[j])
                self.leave("actuator force range", self.jname(j),
                           f"the joint's actuatorfrcrange {lo:.6g} .. {hi:.6g} (the sum of "
                           "its actuators is not clamped)")

    # ------------------------------------------------------------------------- tendons
    def fixed_tendon(self, t):
        """([our joint names], [coefficients], shift) of fixed tendon t -- its length from
        the assembly is L_mujoco - shift -- or a string saying why it is not one we take."""
        m = self.m
        adr, num = int(m.tendon_adr[t]), int(m.tendon_num[t])
        if any(int(m.wrap_type[w]) != int(self.mujoco.mjtWrap.mjWRAP_JOINT)
               for w in range(adr, adr + num)):
            return "a spatial tendon (only fixed tendons import)"
        if num > MAX_JOINTS:
            return f"a fixed tendon of {num} joints (at most {MAX_JOINTS} import)"
        joints = [int(m.wrap_objid[w]) for w in range(adr, adr + num)]
        if any(j not in self.single for j in joints):
            return "its joints must each be a single hinge or slide"
        coefs = [float(m.wrap_prm[w]) for w in range(adr, adr + num)]
        shift = sum(c * self._offset(j) for c, j in zip(coefs, joints))
        return [self.single[j] for j in joints], coefs, shift

    def _tendon_actuator(self, u, name, t):
        """Add actuator u on fixed tendon t as a ``fixed_tendon`` force with the actuator's
        gain, affine bias, ranges and command (gear folded into the coefficients: L = gear
        L_tendon, each joint's effort gear c_m f), or return why not."""
        m, mj = self.m, self.mujoco
        tendon = self.fixed_tendon(t)
        if isinstance(tendon, str):
            return f"pulls tendon {self.mujoco.mj_id2name(m, mj.mjtObj.mjOBJ_TENDON, t)!r}: " \
                   + tendon
        if int(m.actuator_dyntype[u]) != int(mj.mjtDyn.mjDYN_NONE) \
                or int(m.actuator_gaintype[u]) != int(mj.mjtGain.mjGAIN_FIXED) \
                or int(m.actuator_biastype[u]) not in (int(mj.mjtBias.mjBIAS_NONE),
                                                       int(mj.mjtBias.mjBIAS_AFFINE)):
            return "activation dynamics, a non-fixed gain or a non-affine bias"
        joints, coefs, shift = tendon
        gear = float(m.actuator_gear[u, 0])
        bias = [float(x) for x in m.actuator_biasprm[u, :3]] if int(
            m.actuator_biastype[u]) == int(mj.mjtBias.mjBIAS_AFFINE) else [0.0, 0.0, 0.0]
        bias[0] += bias[1] * gear * shift            # L_mujoco = gear (L + shift)
        spec = dict(joints=joints, coefficients=[gear * c for c in coefs],
                    gain=float(m.actuator_gainprm[u, 0]), bias=bias)
        if bool(m.actuator_ctrllimited[u]):
            spec["ctrlrange"] = [float(x) for x in m.actuator_ctrlrange[u]]
        if bool(m.actuator_forcelimited[u]):
            spec["forcerange"] = [float(x) for x in m.actuator_forcerange[u]]
        if self.ctrl[u] != 0:
            spec["command"] = float(self.ctrl[u])
        try:
            self.builder.add_force("fixed_tendon", self.fresh(re_name(name)), **spec)
        except ModelError as exc:
            return str(exc)
        return None

    def _tendon_spring(self, t, tname):
        """Add the stiffness, damping, limit and friction loss of fixed tendon t as a
        ``fixed_tendon`` force (two spring lengths: its dead band); return what of the tendon
        is left out (its armature). The limit's soft constraint (solref_lim, solimp_lim)
        becomes a linear stop and the friction loss regularized Coulomb friction as a joint's
        do (:func:`soft_spring`, :func:`creep_velocity`), on the tendon's own inertia
        1 / tendon_invweight0."""
        m = self.m
        rest = [float(x) for x in m.tendon_lengthspring[t]]
        k = 0.0 if _disabled(self.mujoco, m, "mjDSBL_SPRING") else float(m.tendon_stiffness[t])
        c = 0.0 if _disabled(self.mujoco, m, "mjDSBL_DAMPER") else float(m.tendon_damping[t])
        limited = bool(m.tendon_limited[t]) and not _disabled(self.mujoco, m, "mjDSBL_LIMIT")
        level = 0.0 if _disabled(self.mujoco, m, "mjDSBL_FRICTIONLOSS") \
            else float(m.tendon_frictionloss[t])
        left = [what for what, on in (
            ("armature", float(getattr(m, "tendon_armature", np.zeros(m.ntendon))[t]) != 0),
            ) if on]
        if k == 0 and c == 0 and not limited and level == 0:
            return left
        tendon = self.fixed_tendon(t)
        if isinstance(tendon, str):
            return ["stiffness/damping/limit (" + tendon + ")"] + left
        joints, coefs, shift = tendon
        # two spring lengths: a dead band [a, b] (no spring force between them)
        spec = dict(joints=joints, coefficients=coefs, stiffness=k, damping=c,
                    rest_length=rest[0] - shift if rest[0] == rest[1]
                    else [rest[0] - shift, rest[1] - shift])
        inertia = 1.0 / float(m.tendon_invweight0[t])
        if level:
            v_eps = creep_velocity(self.mujoco, m, m.tendon_solref_fri[t],
                                   m.tendon_solimp_fri[t], inertia, level)
            spec.update(frictionloss=level, creep_velocity=v_eps)
            self.leave("frictionloss approximation", tname, f"tendon {level:.6g}: MuJoCo's "
                       "soft friction loss (solref, solimp) as regularized Coulomb friction, "
                       f"creep velocity {v_eps:.6g}")
        if limited:
            lo, hi = (float(x) for x in m.tendon_range[t])
            margin = float(m.tendon_margin[t])
            stiffness, damping = soft_spring(self.mujoco, m, m.tendon_solref_lim[t],
                                             m.tendon_solimp_lim[t], inertia)
            spec.update(range=[lo + margin - shift, hi - margin - shift],
                        limit_stiffness=stiffness, limit_damping=damping)
            self.leave("limit approximation", tname, f"tendon range {lo:.6g} .. {hi:.6g}: "
                       "MuJoCo's soft limit (solref, solimp) as a linear stop, stiffness "
                       f"{stiffness:.6g}, damping {damping:.6g}")
        try:
            self.builder.add_force("fixed_tendon", self.fresh(re_name(tname) + "_spring"),
                                   **spec)
        except ModelError as exc:
            return [f"stiffness/damping/limit ({exc})"] + left
        return left

    def add_tendons(self) -> None:
        """A fixed tendon over two single hinges/slides held by a tendon equality with one
        tendon, c_a q_a + c_b q_b - L0 = a0, is the exact coupler c_a x_a + c_b x_b = a0 (x
        from the assembly). A fixed tendon's stiffness, damping, limit and friction loss (over
        1 to 4 single hinges or slides) become a ``fixed_tendon`` force, as do the actuators
        pulling it (:meth:`_tendon_actuator`). Its armature, spatial tendons and other tendon
        equalities are left out."""
        m, OBJ, EQ = self.m, self.mujoco.mjtObj, self.mujoco.mjtEq
        coupled = set()
        for e in range(m.neq):
            if int(m.eq_type[e]) != int(EQ.mjEQ_TENDON):
                continue
            ename = self.mujoco.mj_id2name(m, OBJ.mjOBJ_EQUALITY, e) or f"equality{e}"
            reason = self._tendon_equality(e, ename)
            if reason:
                self.leave("equality", ename, f"tendon equality: {reason}")
            else:
                coupled.add(int(m.eq_obj1id[e]))
        for t in range(m.ntendon):
            tname = self.mujoco.mj_id2name(m, OBJ.mjOBJ_TENDON, t) or f"tendon{t}"
            own = self._tendon_spring(t, tname)
            if own:
                self.leave("tendon", tname, f"its {', '.join(own)}")

    def _tendon_equality(self, e, ename):
        """Add the coupler of tendon equality e, or return why not."""
        m = self.m
        if not m.eq_active0[e]:
            return "inactive (constraints cannot be switched)"
        t, t2 = int(m.eq_obj1id[e]), int(m.eq_obj2id[e])
        if t2 >= 0:
            return "between two tendons"
        poly = np.asarray(m.eq_data[e][:5], dtype=float)   # one tendon: only a0 acts
        adr, num = int(m.tendon_adr[t]), int(m.tendon_num[t])
        if num != 2 or any(int(m.wrap_type[w]) != int(self.mujoco.mjtWrap.mjWRAP_JOINT)
                           for w in range(adr, adr + num)):
            return "its tendon is not a fixed tendon of two joints"
        joints = [int(m.wrap_objid[w]) for w in range(adr, adr + num)]
        coefs = [float(m.wrap_prm[w]) for w in range(adr, adr + num)]
        if any(j not in self.single for j in joints):
            return "its joints must each be a single hinge or slide"
        # lengths from qpos0 (MuJoCo's tendon_length0); ours from the assembly = qpos0
        shift = sum(c * (self._offset(j) - float(m.qpos0[m.jnt_qposadr[j]]))
                    for c, j in zip(coefs, joints))
        try:
            self.builder.add_coupler("coupler", self.fresh(ename), self.single[joints[0]],
                                     self.single[joints[1]], c1=coefs[0], c2=coefs[1],
                                     c0=float(poly[0]) - shift)
        except ModelError as exc:
            return str(exc)
        return None


def re_name(name: str) -> str:
    """An MJCF name as ours (``.`` and spaces -> ``_``)."""
    return re.sub(r"[.\s]", "_", name)
