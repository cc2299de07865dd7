"""A stack of boxes settling on the floor: each at the rigid answer less the static
compression of the contacts below it.

N equal boxes (mass m, half height h) are stacked, each let go at its rigid height on the one
below, a little off centre and turned a little. Each face rests on four contact points of
stiffness K (a box on the floor: its four lower corners; a box on a box: the four points of
the face manifold), so interface j (the floor j = 0) carries the weight of the N - j boxes
above it and closes by (N - j) m g / (4 K). Box i (from 0 at the bottom) settles at

    z_i = (2 i + 1) h - sum_{j <= i} (N - j) m g / (4 K)

    python examples/box_stack.py               # the heights against the closed form

tests/test_contact_examples.py checks the heights to 1e-6 m (the issue asks 1 mm) and that
the stack is at rest.
"""
import numpy as np

from spatialmbd import ModelBuilder
from spatialmbd.simulate import simulate

G = 9.81
N_BOXES = 4
MASS, HALF = 0.5, (0.1, 0.08, 0.05)      # kg; half extents, m
K = 1e5                                  # per contact point, N/m
MU = 0.5


def settled_heights(n: int = N_BOXES) -> np.ndarray:
    """The closed form above (m)."""
    h = HALF[2]
    drops = np.cumsum([(n - j) * MASS * G / (4 * K) for j in range(n)])
    return np.array([(2 * i + 1) * h for i in range(n)]) - drops


def box_stack(n: int = N_BOXES) -> ModelBuilder:
    b = ModelBuilder("box_stack", gravity=(0, 0, -G))
    a, c, h = HALF
    inertia = MASS / 3 * np.array([c * c + h * h, a * a + h * h, a * a + c * c])
    zeta = 0.7
    damping = 2 * zeta * np.sqrt(K * MASS / 4)
    rng = np.random.default_rng(3)
    for i in range(n):
        turn = rng.uniform(-0.05, 0.05)                  # rad about z
        A = np.array([[np.cos(turn), -np.sin(turn), 0], [np.sin(turn), np.cos(turn), 0],
                      [0, 0, 1.0]])
        shift = rng.uniform(-0.01, 0.01, 2)
        b.add_body(f"box{i}", MASS, tuple(inertia), r=(shift[0], shift[1], (2 * i + 1) * h),
                   A=A)
        shape = {"type": "box", "half_extents": list(HALF)}
        below = "ground" if i == 0 else f"box{i - 1}"
        lower = {"type": "plane", "normal": [0, 0, 1]} if i == 0 else shape
        b.add_force("contact", f"on{i}", body_i=below, body_j=f"box{i}", shape_i=lower,
                    shape_j=shape, law="linear", stiffness=K, damping=damping,
                    friction="coulomb", mu=MU, creep_velocity=1e-3)
    return b


def run(t_end: float = 1.0):
    model = box_stack().compile()
    return model, simulate(model, t_end, output_step=0.01, rtol=1e-8, atol=1e-11)


if __name__ == "__main__":
    model, res = run()
    z = res.q[-1, :, 2]
    for i, (zi, ref) in enumerate(zip(z, settled_heights())):
        print(f"box{i}: z = {zi:.7f} m, closed form {ref:.7f} m, difference {zi - ref:.1e} m")
