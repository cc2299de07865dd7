"""MJCF colliding geoms as contact elements (read_mjcf(..., contacts=True)): which pairs
collide and with which parameters, checked against MuJoCo's own contacts; a sphere and a box
dropped on a plane against MuJoCo (rest height and rebound, with the expected difference of a
soft constraint and a compliant law, docs/import.md)."""
import numpy as np
import pytest

mujoco = pytest.importorskip("mujoco")

from spatialmbd.importers import read_mjcf                       # noqa: E402
from spatialmbd.importers.mjcf import contacts as C              # noqa: E402
from spatialmbd.importers.mjcf.joint_elements import impedance   # noqa: E402
from spatialmbd.simulate import simulate                         # noqa: E402

G = 9.81

# every kind of rule: contype/conaffinity bits, a parent-child pair (filtered), a grandchild
# (not filtered), a weld group (a body welded to its parent), an <exclude>, explicit pairs
# (one replacing a dynamic pair, one between geoms the bitmask filters), priority and solmix
FILTERS = """
<mujoco>
  <worldbody>
    <geom name="floor" type="plane" size="3 3 .1" friction="0.7 0.01 0.001"/>
    <body name="a" pos="0 0 1"><freejoint/>
      <geom name="a1" type="sphere" size="0.1" contype="1" conaffinity="1" friction="0.3"/>
      <geom name="a2" type="capsule" size="0.05 0.1" pos="-0.2 0 0" contype="2"
            conaffinity="0" priority="1" friction="0.9" solref="0.03 0.5"/>
      <body name="b" pos="0.3 0 0"><joint type="hinge"/>
        <geom name="b1" type="sphere" size="0.1" contype="1" conaffinity="2" solmix="3"
              solref="0.01 0.8" solimp="0.8 0.9 0.002 0.5 2"/>
        <body name="c" pos="0.3 0 0"><joint type="hinge"/>
          <geom name="c1" type="sphere" size="0.1" contype="4" conaffinity="4" margin="0.01"
                gap="0.002"/>
          <body name="c_welded" pos="0.1 0 0">
            <geom name="cw" type="box" size="0.05 0.05 0.05"/></body>
        </body>
      </body>
    </body>
    <body name="d" pos="1 0 1"><freejoint/>
      <geom name="d1" type="sphere" size="0.1"/>
      <geom name="d2" type="ellipsoid" size="0.1 0.05 0.05" pos="0 0.2 0" condim="1"/></body>
    <body name="e" pos="2 0 1"><freejoint/>
      <geom name="e1" type="cylinder" size="0.1 0.1" contype="0" conaffinity="0"/>
      <geom name="e2" type="sphere" size="0.05" pos="0 0 0.2"/></body>
  </worldbody>
  <contact>
    <exclude body1="a" body2="d"/>
    <pair geom1="e1" geom2="d1" friction="0.2 0.2 0.01 0.01 0.01" margin="0.003"/>
    <pair geom1="e2" geom2="cw" condim="1" solref="0.05 1"/>
  </contact>
</mujoco>
"""


def _mujoco_contacts(xml, margin):
    """{frozenset(g1, g2): (dim, friction[0], solref, solimp, includemargin)} of MuJoCo's
    contacts at qpos0 with the margins raised so that every candidate pair touches: a default
    geom margin (compiled into the broad phase's bounds; c1 keeps its own) and the explicit
    pairs' margins."""
    xml = xml.replace("<worldbody>", f'<default><geom margin="{margin}"/></default><worldbody>',
                      1)
    m = mujoco.MjModel.from_xml_string(xml)
    m.pair_margin[:] += 2 * margin
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    out = {}
    for c in d.contact[:d.ncon]:
        out[frozenset((int(c.geom[0]), int(c.geom[1])))] = (
            int(c.dim), float(c.friction[0]), np.array(c.solref), np.array(c.solimp),
            float(c.includemargin))
    return m, out


def test_the_pairs_and_their_parameters_are_mujocos():
    m, found = _mujoco_contacts(FILTERS, 10.0)
    pairs = C.candidate_pairs(mujoco, m)
    assert len(found) > 10
    assert {frozenset((g1, g2)) for g1, g2, _ in pairs} == set(found)
    assert len(pairs) == len(found)                  # each pair once
    name = lambda g: mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, g)   # noqa: E731
    names = {frozenset((name(a), name(b))) for a, b, _ in pairs}
    # the rules, spelled out: parent-child filtered, grandchild not; the weld group's box
    # and its own body's sphere never; a-d excluded; e1 (contype 0) only through its pair
    assert frozenset(("a1", "b1")) not in names and frozenset(("b1", "c1")) not in names
    assert frozenset(("a1", "c1")) not in names        # bitmask: 1 & 4, 4 & 1
    assert frozenset(("c1", "cw")) not in names and frozenset(("a1", "d1")) not in names
    assert frozenset(("e1", "d1")) in names and frozenset(("e2", "cw")) in names
    assert frozenset(("a2", "b1")) not in names        # 2 & 2, but parent and child
    assert frozenset(("b1", "d1")) in names            # 1 & 1, no relation
    for g1, g2, ipair in pairs:
        dim, mu, solref, solimp, include = found[frozenset((g1, g2))]
        p = C.pair_parameters(mujoco, m, g1, g2, ipair)
        assert p["condim"] == dim and p["friction"][0] == pytest.approx(mu, abs=1e-15)
        np.testing.assert_allclose(p["solref"], solref, rtol=0, atol=1e-15)
        np.testing.assert_allclose(p["solimp"], solimp, rtol=0, atol=1e-15)
        assert p["margin"] - p["gap"] == pytest.approx(include, abs=1e-12)


def test_imported_contacts_name_their_pairs_and_laws():
    with pytest.warns(UserWarning, match="approximated: "):
        imp = read_mjcf(FILTERS, contacts=True)
    forces = imp.builder.forces
    contacts = {n: f for n, f in forces.items() if f.type == "contact"}
    m = imp.mj_model
    assert len(contacts) == len(C.candidate_pairs(mujoco, m))
    pair = contacts["contact_d1-e1"].params
    assert pair["mu"] == 0.2 and pair["margin"] == pytest.approx(0.003)
    assert "friction" not in contacts["contact_cw-e2"].params          # condim 1
    # condim the larger (the floor's 3), friction the larger (d2's default 1 over 0.7)
    assert contacts["contact_floor-d2"].params["mu"] == 1.0
    kinds = {item.kind for item in imp.approximated}
    assert kinds == {"contact approximation"}
    assert imp.builder.compile().summary().count("linear, K = ") == len(contacts)


DROP = """
<mujoco>
  <option timestep="1e-4"/>
  <worldbody>
    <geom name="floor" type="plane" size="2 2 .1"/>
    <body name="body" pos="0 0 0.3"><freejoint/>{geom}</body>
  </worldbody>
</mujoco>
"""


def _mujoco_drop(xml, T):
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    n = int(round(T / m.opt.timestep))
    z, vz = np.empty(n), np.empty(n)
    for i in range(n):
        mujoco.mj_step(m, d)
        z[i], vz[i] = d.qpos[2], d.qvel[2]
    return z, vz


def _rebound(vz):
    """(impact speed, rebound speed) of the first touch from a velocity history."""
    i = int(np.argmin(vz))
    return -vz[i], float(np.max(vz[i:]))


@pytest.mark.parametrize("geom, half, points", [
    ('<geom type="sphere" size="0.1" mass="1" solref="0.02 0.2"/>', 0.1, 1),
    ('<geom type="box" size="0.1 0.1 0.05" mass="1" solref="0.02 0.2"/>', 0.05, 4)])
def test_drop_on_a_plane_against_mujoco(geom, half, points):
    xml = DROP.format(geom=geom)
    z_mj, vz_mj = _mujoco_drop(xml, 1.5)
    with pytest.warns(UserWarning):
        imp = read_mjcf(xml, contacts=True)
    model = imp.builder.compile()
    res = simulate(model, 1.5, output_step=1e-4, rtol=1e-9, atol=1e-12)
    m = imp.mj_model
    par = C.pair_parameters(mujoco, m, 0, 1, -1)
    # mixed with the floor's defaults (solmix 1 each): solref (0.02, 0.6)
    np.testing.assert_allclose(par["solref"], (0.02, 0.6), rtol=1e-15)
    dmax = impedance(par["solimp"], np.inf)
    k = 1 / (dmax ** 2 * 0.02 ** 2 * 0.6 ** 2)
    # ours: the linear law K = dmax^2 k m per point rests at g / (points dmax^2 k)
    ours = half - res.q[-1, 0, 2]
    assert abs(ours - G / (points * dmax ** 2 * k)) < 1e-9
    # MuJoCo's soft contact: (1 - I) g / (points I^2 k), I = d(r) its impedance there
    r = 1e-4
    for _ in range(200):
        imp_r = impedance(par["solimp"], r)
        r = (1 - imp_r) * G / (points * imp_r ** 2 * k)
    assert abs((half - z_mj[-1]) - r) < 1e-3 * r
    # the documented difference: MuJoCo sinks (1 - I) (dmax / I)^2 as deep
    assert (half - z_mj[-1]) / ours == pytest.approx((1 - imp_r) * (dmax / imp_r) ** 2,
                                                     rel=2e-3)
    # the rebound (the documented difference): on one point the law rebounds as MuJoCo's
    # contact (0.232 and 0.247); a face's n points give n K and n c, a stiffer and more damped
    # response, while MuJoCo's face rebounds as one constraint (0.099 and 0.244)
    v_in, v_out = _rebound(vz_mj)
    v_in_ours, v_out_ours = _rebound(res.v[:, 0, 2])
    assert v_in_ours == pytest.approx(v_in, rel=1e-3)
    if points == 1:
        assert abs(v_out_ours / v_in_ours - v_out / v_in) < 0.03
    else:
        assert v_out_ours / v_in_ours < 0.5 * v_out / v_in


def test_shapes_without_a_contact_counterpart_are_left_out():
    xml = """
    <mujoco><asset><hfield name="h" nrow="3" ncol="3" size="1 1 0.1 0.1"/></asset>
      <worldbody><geom name="terrain" type="hfield" hfield="h"/>
        <body name="b" pos="0 0 1"><freejoint/><geom name="ball" type="sphere" size="0.1"/>
        </body></worldbody></mujoco>"""
    with pytest.warns(UserWarning, match="left out: 1 colliding geom"):
        imp = read_mjcf(xml, contacts=True)
    (item,) = imp.left_out
    assert item.element == "terrain-ball" and "hfield geom has no contact shape" in item.detail
    assert not any(f.type == "contact" for f in imp.builder.forces.values())
