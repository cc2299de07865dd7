"""Contact and friction (text ch. 11: normal contact and tangential forces): shapes on bodies,
one geometry kernel per pair type (:mod:`.geometry`), normal and friction laws (:mod:`.laws`),
the compiled ``contact`` force element (:mod:`.element`) and the run-time memory of impact
velocities (:mod:`.memory`). docs/contact.md describes the physics."""
from .element import Contact  # noqa: F401  (registers the "contact" force type)
