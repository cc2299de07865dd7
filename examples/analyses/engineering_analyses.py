"""The four worked examples of docs/analyses.md in one script:

    python examples/analyses/engineering_analyses.py

1. slider-crank motor torque over a cycle (inverse dynamics) and its energy balance;
2. hanging chain of rods at rest (static equilibrium, pin forces, free spins);
3. double pendulum modes (frequencies in Hz, shapes);
4. quasi-static crank torque that holds the slider-crank against gravity.
"""
import sys
from pathlib import Path

import numpy as np

from spatialmbd import models
from spatialmbd.analyses import inverse_dynamics, modes, quasi_static, static_equilibrium

sys.path.insert(0, str(Path(__file__).resolve().parent))
from make_model_files import double_pendulum_rods, hanging_chain  # noqa: E402


def main():
    crank = models.slider_crank(crank_speed=6.0).compile()
    t = np.linspace(0.0, 2 * np.pi / 6.0, 73)
    inv = inverse_dynamics(crank, t)
    print(inv.summary())
    energy = inv.energy()
    print(f"energy balance error over the cycle: {np.abs(energy['error']).max():.2e} J "
          f"(work of the motor up to any time: max {np.abs(energy['work_efforts']).max():.4f} J)")

    chain = static_equilibrium(hanging_chain().compile())
    print(chain.summary())
    f = chain.reactions["pin0"].force_j[0]
    print(f"left pin pulls the first rod with ({f[0]:.4f}, {f[1]:.4f}, {f[2]:.4f}) N")

    md = modes(double_pendulum_rods().compile())
    print(md.table[["frequency_hz", "omega_n", "damping_ratio", "kind"]])

    qs = quasi_static(crank, t[::6])
    print(qs.efforts.rename(columns={"crank_drive": "holding torque [N m]"}))
    return inv, chain, md, qs


if __name__ == "__main__":
    main()
