"""The result of analyses.linearize: the linear model in independent coordinates."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Optional

import numpy as np


@dataclass
class LinearModel:
    """M z'' + C z' + K z = B_u u in independent coordinates z, and the first-order form
    x' = A x + B u, y = C_out x + D_out u with x = [z, z'].

    basis (6 nb, n): dx = basis @ z maps z to body tangent coordinates (translation m,
    rotation vector rad, per body, global axes). coordinates: names of z. inputs, outputs:
    names. q, v, t: the reference. fd_error: estimated error of the differenced parts.
    input_reference: the reference value of each input (the effort an input driver delivers
    at the reference, N m or N; 0 for force inputs, whose reference is part of the model); u
    is the deviation from it.

    With nonholonomic constraints (rolling) the velocities are fewer than the positions and
    there is no second-order form: C and K are None and x = [z, w], where dx = basis @ z
    (n positions) and dv = velocity_map @ z + velocity_basis @ w (n_velocity velocities,
    named velocity_coordinates); M = velocity_basis^T M velocity_basis and B_u are in w.
    """

    model: object
    q: np.ndarray
    v: np.ndarray
    t: float
    M: np.ndarray
    C: np.ndarray
    K: np.ndarray
    B_u: np.ndarray
    A: np.ndarray
    B: np.ndarray
    C_out: np.ndarray
    D_out: np.ndarray
    basis: np.ndarray
    coordinates: list
    inputs: list
    outputs: list
    steady: bool
    fd_error: float = 0.0
    messages: list = field(default_factory=list)
    input_reference: np.ndarray = None
    velocity_basis: Optional[np.ndarray] = None
    velocity_map: Optional[np.ndarray] = None
    velocity_coordinates: Optional[list] = None
    frame_rate: Optional[np.ndarray] = None
    _reduced: object = field(default=None, repr=False, compare=False)

    @property
    def n(self) -> int:
        """Number of independent position coordinates z."""
        return self.basis.shape[1]

    @property
    def nonholonomic(self) -> bool:
        return self.velocity_basis is not None

    @property
    def n_velocity(self) -> int:
        """Number of independent velocities (n without nonholonomic constraints)."""
        return self.velocity_basis.shape[1] if self.nonholonomic else self.n

    def frames(self) -> dict:
        """The matrices as labelled DataFrames: M, C, K (not with nonholonomic constraints),
        B_u, A, B, C_out, D_out."""
        import pandas as pd
        z = list(self.coordinates)
        w = list(self.velocity_coordinates) if self.nonholonomic else z
        x = z + (w if self.nonholonomic else [f"d({c})/dt" for c in z])
        out = dict(M=pd.DataFrame(self.M, index=w, columns=w))
        if not self.nonholonomic:
            out.update(C=pd.DataFrame(self.C, index=z, columns=z),
                       K=pd.DataFrame(self.K, index=z, columns=z))
        out.update(B_u=pd.DataFrame(self.B_u, index=w, columns=self.inputs),
                   A=pd.DataFrame(self.A, index=x, columns=x),
                   B=pd.DataFrame(self.B, index=x, columns=self.inputs),
                   C_out=pd.DataFrame(self.C_out, index=self.outputs, columns=x),
                   D_out=pd.DataFrame(self.D_out, index=self.outputs, columns=self.inputs))
        return out

    def reduced(self):
        """The state matrix with the ignorable modes deflated (:mod:`.deflation`): rigid
        motions of the whole mechanism and bodies spinning alone about their centres of mass,
        where nothing depends on them, and their rates. Its eigenvalues are simple where the
        full A has defective zeros, so stability verdicts and critical parameters computed
        from them do not depend on the rounding. Computed once."""
        if self._reduced is None:
            from .deflation import deflate
            self._reduced = deflate(self)
        return self._reduced

    def eigenvalues(self) -> np.ndarray:
        """Eigenvalues (1/s) of A: those of the ignorable block (zeros: see
        ReducedSystem.deflated_eigenvalues), then those of the reduced matrix."""
        red = self.reduced()
        return np.concatenate([red.deflated_eigenvalues(), red.eigenvalues])

    def summary(self) -> str:
        red = self.reduced()
        ev = self.eigenvalues()
        coords = (f"{self.n} independent position and {self.n_velocity} velocity coordinates "
                  "(nonholonomic)" if self.nonholonomic else
                  f"{self.n} independent coordinates")
        lines = [f"linearization about {'a steady motion' if self.steady else 'an equilibrium'}"
                 f" at t = {self.t:.6g} s: {coords}, "
                 f"{len(self.inputs)} inputs, {len(self.outputs)} outputs",
                 f"largest real part of the eigenvalues of A: "
                 f"{ev.real.max() if ev.size else 0.0:.6g} 1/s"
                 + (f" ({red.k} ignorable states deflated)" if red.k else "")]
        lines.extend(self.messages)
        return "\n".join(lines)
