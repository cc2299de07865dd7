"""Contact and friction (text ch. 11: normal contact and tangential forces): shapes on bodies,
one geometry kernel per pair type (:mod:`.geometry`), normal and friction laws (:mod:`.laws`),
the compiled ``contact`` force element (:mod:`.element`), the ``sphere_set`` of many spheres
found by a broad phase (:mod:`.sphere_set`) and the run-time memory of impact
velocities (:mod:`.memory`). docs/contact.md describes the physics."""
from .element import Contact  # noqa: F401  (registers the "contact" force type)
from .sphere_set import SphereSet  # noqa: F401,E402  (registers the "sphere_set" force type)
