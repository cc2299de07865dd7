"""The slider-crank with a clearance revolute joint (models.slider_crank_clearance, issue 10
item 4): the contact force history is reported, the contact only pushes, and the slider
follows the ideal mechanism within what the clearance allows."""
import math

import numpy as np
import pytest

from spatialmbd import models
from spatialmbd.simulate import RedundantConstraintsWarning
from spatialmbd.simulate import simulate


def test_clearance_joint_follows_the_ideal_mechanism_within_the_clearance():
    c, speed, L1, L2 = 5e-4, 20.0, 0.05, 0.12
    T = 2 * math.pi / speed
    opts = dict(output_step=T / 200, rtol=1e-8, atol=1e-10)
    res = simulate(models.slider_crank_clearance(c, speed).compile(), T, **opts)
    with pytest.warns(RedundantConstraintsWarning):   # planar, built from spatial joints
        ideal = simulate(models.slider_crank_clearance(c, speed, ideal=True).compile(), T,
                         **opts)
    assert res.status == "success" and ideal.status == "success"
    hist = res.contacts()["C"]
    fN = hist["normal_force"]
    assert np.all(fN >= 0.0) and np.any(fN > 0.0)                 # compressive, and in contact
    assert np.all(fN[hist["active"] == 0] == 0.0)
    assert np.all(hist["penetration"][fN > 0] > 0)
    # the journal centre stays within c (plus the contact's compression) of the bearing's, so
    # the slider differs from the ideal one by at most c (1 + L1 / L2) plus that compression
    delta = hist["penetration"].max()
    dx = np.abs(res.q[:, 2, 0] - ideal.q[:, 2, 0])
    assert dx.max() <= c * (1 + L1 / L2) + delta
    assert dx.max() > 0.2 * c                                       # the clearance shows
