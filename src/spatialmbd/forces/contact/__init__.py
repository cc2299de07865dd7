"""Contact and friction (text ch. 11: normal contact and tangential forces): shapes on bodies,
one geometry kernel per pair type (:mod:`.geometry`), normal and friction laws (:mod:`.laws`),
the compiled ``contact`` force element (:mod:`.element`), the ``sphere_set`` of many spheres
found by a broad phase (:mod:`.sphere_set`), its convex-shape counterpart
(:mod:`.shape_set`), a convex shape against a triangle mesh or a
height field (:mod:`.mesh_contact`) and the run-time memory of impact
velocities (:mod:`.memory`). docs/contact.md describes the physics."""
from .element import Contact  # noqa: F401  (registers the "contact" force type)
from .sphere_set import SphereSet  # noqa: F401,E402  (registers the "sphere_set" force type)
from .mesh_contact import MeshContact  # noqa: F401,E402  (registers the "mesh_contact" type)
from .shape_set import ShapeSet  # noqa: F401,E402  (registers the "shape_set" force type)
