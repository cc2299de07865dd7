"""Bad input is rejected with errors that name the element, the value and the fix."""
import numpy as np
import pytest

from spatialmbd import ModelBuilder, ModelError
from spatialmbd.motion import ConstantVelocity


def body(b, name="a", **kw):
    args = dict(mass=1.0, inertia=(1, 1, 1))
    args.update(kw)
    return b.add_body(name, **args)


@pytest.mark.parametrize("kw,match", [
    (dict(mass=0.0), r"bodies\['a'\]\.mass: must be positive"),
    (dict(mass=-2), "must be positive"),
    (dict(mass="heavy"), "expected a number"),
    (dict(inertia=[[1, 0.5, 0], [0, 1, 0], [0, 0, 1]]), "not symmetric"),
    (dict(inertia=(1, 1, -1)), "not positive definite"),
    (dict(inertia=(1, 1, 3)), "triangle inequality"),
    (dict(inertia=(1, 1)), "3 principal moments or a 3x3"),
    (dict(p=(1, 0, 0, 0.5)), "far from 1"),
    (dict(p=(1, 0, 0, 0), bryant=(0, 0, 0)), "give one orientation"),
    (dict(A=np.diag([1, 1, -1.0])), "not a rotation matrix"),
    (dict(vectors={"v": (0, 0, 0)}), "zero-length"),
    (dict(omega=(1, 0, 0), omega_local=(1, 0, 0)), "not both"),
])
def test_bad_bodies(kw, match):
    with pytest.raises(ModelError, match=match):
        body(ModelBuilder(), **kw)


def test_slightly_off_euler_parameters_are_normalised():
    b = ModelBuilder()
    body(b, p=(0.70711, 0.70711, 0, 0))
    p = b.bodies["a"].p
    assert abs(np.linalg.norm(p) - 1.0) < 1e-15


def test_names():
    b = ModelBuilder()
    body(b)
    with pytest.raises(ModelError, match="duplicate name 'a'"):
        body(b)
    with pytest.raises(ModelError, match="reserved"):
        body(b, "ground")
    with pytest.raises(ModelError, match="unknown body 'b'"):
        b.add_joint("spherical", "s", "a", "b", point=(0, 0, 0))
    with pytest.raises(ModelError, match="to itself"):
        b.add_joint("spherical", "s", "a", "a", point=(0, 0, 0))
    with pytest.raises(ModelError, match="unknown joint type 'hinge'.*revolute"):
        b.add_joint("hinge", "s", "ground", "a", point=(0, 0, 0))


def test_joint_geometry_errors():
    b = ModelBuilder()
    body(b)
    with pytest.raises(ModelError, match="zero-length axis"):
        b.add_joint("revolute", "r", "ground", "a", point=(0, 0, 0), axis=(0, 0, 0))
    with pytest.raises(ModelError, match="needs axis"):
        b.add_joint("revolute", "r", "ground", "a", point=(0, 0, 0))
    with pytest.raises(ModelError, match="mixes global"):
        b.add_joint("spherical", "s", "ground", "a", point=(0, 0, 0), point_i=(0, 0, 0))
    with pytest.raises(ModelError, match="unknown geometry keyword"):
        b.add_joint("spherical", "s", "ground", "a", pont=(0, 0, 0))
    with pytest.raises(ModelError, match="perpendicular"):
        b.add_joint("universal", "u", "ground", "a", point=(0, 0, 0), axis=(1, 0, 0),
                    axis2=(1, 1, 0))
    with pytest.raises(ModelError, match="link length is 0"):
        b.add_joint("spherical_spherical", "d", "ground", "a", point=(0, 0, 0), point2=(0, 0, 0))
    with pytest.raises(ModelError, match="no point named 'tip'"):
        b.add_joint("spherical", "s", "a", "ground", point_i="tip", point_j=(0, 0, 0))


def test_driver_errors():
    b = ModelBuilder()
    body(b)
    b.add_joint("spherical", "s", "ground", "a", point=(0, 0, 0))
    with pytest.raises(ModelError, match="cannot take an angle driver.*revolute"):
        b.add_driver("angle", "d", ConstantVelocity(1.0), joint="s")
    with pytest.raises(ModelError, match="coordinate 'q'"):
        b.add_driver("coordinate", "d", 0.0, body="a", coordinate="q")
    with pytest.raises(ModelError, match="unknown driver kind"):
        b.add_driver("speed", "d", 0.0, joint="s")
    with pytest.raises(ModelError, match="unknown motion law"):
        b.add_driver("coordinate", "d", {"type": "sine"}, body="a", coordinate="x")


def test_force_errors():
    b = ModelBuilder()
    body(b)
    with pytest.raises(ModelError, match="unknown force type"):
        b.add_force("magnet", "m")
    with pytest.raises(ModelError, match="stiffness: must be >= 0"):
        b.add_force("spring_damper", "s", body_i="ground", body_j="a", stiffness=-1.0)
    with pytest.raises(ModelError, match="unknown parameter"):
        b.add_force("point_force", "f", body="a", direction=(0, 0, 1), colour="red")


def test_empty_model():
    with pytest.raises(ModelError, match="no bodies"):
        ModelBuilder().compile()


def test_model_is_frozen():
    b = ModelBuilder()
    body(b)
    m = b.compile()
    with pytest.raises(Exception):
        m.mass[0] = 3.0
    with pytest.raises(Exception):
        m.name = "other"


def test_orientation_forms_agree():
    from spatialmbd.rotations import A_from_bryant, p_from_A
    ang = (0.3, -0.4, 1.1)
    b = ModelBuilder()
    body(b, "x", bryant=ang)
    body(b, "y", A=A_from_bryant(np.array(ang)))
    body(b, "z", p=p_from_A(A_from_bryant(np.array(ang))))
    assert np.allclose(b.bodies["x"].p, b.bodies["y"].p, atol=1e-14)
    assert np.allclose(b.bodies["x"].p, b.bodies["z"].p, atol=1e-14)


def test_omega_local_is_converted_to_global():
    from spatialmbd.rotations import A_from_p
    b = ModelBuilder()
    body(b, bryant=(0.0, 0.0, np.pi / 2), omega_local=(1.0, 0, 0))
    assert np.allclose(b.bodies["a"].omega, A_from_p(b.bodies["a"].p) @ [1, 0, 0])


def test_python_and_file_vocabulary_agree():
    """add_driver(kind, name) as add_joint(type, name); add_body takes the file's names."""
    import warnings
    from spatialmbd.io.modelfile import load_model, model_to_dict
    b = ModelBuilder("v", gravity=(0, 0, -9.81))
    b.add_body("a", 1.0, (0.1, 0.1, 0.1), position=(0, 1, 0), velocity=(0.5, 0, 0),
               angular_velocity=(1.0, 0, 0), bryant_deg=(30, 0, 0))
    b.add_joint("revolute", "pin", "ground", "a", point=(0, 0, 0), axis=(1, 0, 0))
    b.add_driver("angle", "motor", 0.0, joint="pin")
    spec = b.bodies["a"]
    assert np.allclose(spec.r, (0, 1, 0)) and np.allclose(spec.rdot, (0.5, 0, 0))
    with warnings.catch_warnings():
        warnings.simplefilter("error", DeprecationWarning)
        c = ModelBuilder("v", gravity=(0, 0, -9.81))
        c.add_body("a", 1.0, (0.1, 0.1, 0.1), r=(0, 1, 0), rdot=(0.5, 0, 0), omega=(1.0, 0, 0),
                   bryant=(np.radians(30), 0, 0))
    assert np.allclose(spec.p, c.bodies["a"].p)
    # the file's body entry builds the same body
    d = model_to_dict(b)
    again, _ = load_model(d)
    assert np.allclose(again.q0, b.compile().q0)
    with pytest.raises(ModelError, match="not both"):
        c.add_body("b", 1.0, (0.1, 0.1, 0.1), r=(0, 0, 0), position=(1, 0, 0))
    # the old argument order still works, with a deprecation warning
    with pytest.warns(DeprecationWarning, match="kind comes first"):
        c.add_joint("revolute", "pin", "ground", "a", point=(0, 1, 0), axis=(1, 0, 0))
        c.add_driver("motor", "angle", 0.0, joint="pin")
    assert c.drivers["motor"].kind == "angle"
