"""Ready-made models: the text's example, classic mechanisms and benchmark problems.

Each function returns a ModelBuilder (so it can be edited before ``compile()``). The geometry
and its source are stated in each docstring; all values SI. The catalogue is one module per
kind:

- ``textbook``: the chapter 15 pendulum, slider-crank, four-bar, chain, Bricard's linkage;
- ``iftomm``: IFToMM benchmark problems (pendulums, heavy top, N-four-bar, flyball governor,
  robot arm, spatial slider-crank);
- ``andrews``: IFToMM A03, Andrews' squeezer mechanism;
- ``sliding``: sliding joints and couplers (cam and follower, bead on a wire, gear train);
- ``rolling``: rolling without slip (disc, ball on a turntable);
- ``bicycle``: the Whipple bicycle benchmark;
- ``contact``: clearance joints and spheres in a box.

Every function and data table is importable from here (``models.four_bar(...)``).
"""
from __future__ import annotations

from . import andrews, bicycle, contact, iftomm, rolling, sliding, textbook
from .andrews import ANDREWS, ANDREWS_BODIES, andrews_body_angles, andrews_coordinates, \
    andrews_squeezer
from .bicycle import MEIJAARD, bicycle_lean_steer, whipple_bicycle
from .contact import (DOMINO, domino_tipping_speed, dominoes, mixed_pile, slider_crank_clearance,
                      spheres_in_box)
from .iftomm import (HEAVY_TOP, ROBOT_ARM, _slender_inertia, double_pendulum, flyball_governor,
                     heavy_top, n_four_bar, n_four_bar_flat, robot_arm, simple_pendulum_a01,
                     slider_crank_iftomm)
from .rolling import ball_on_turntable, rolling_disc, rolling_disc_steady
from .sliding import bead_on_wire, cam_follower, cam_profile, gear_train
from .textbook import (FOUR_BAR, G_TEXT, bricard, chain, four_bar, four_bar_rocker_direction,
                       pendulum_ch15, slider_crank, slider_crank_exact)

#: Example models by name: name -> (builder function, keyword arguments, suggested analysis).
#: The analysis dict uses the keys of a model file's ``analysis`` section. Listed in the order
#: of the catalogue: the text's examples, the IFToMM problems, sliding joints and couplers,
#: rolling, contact, Andrews' squeezer, the bicycle.
EXAMPLES = {}
for _kind in (textbook, iftomm, sliding, rolling, contact, andrews, bicycle):
    EXAMPLES.update(_kind.EXAMPLES)
del _kind
