"""Ground contact for planar models: penalty springs (:mod:`.penalty`), compliant
Marhefka–Orin normal force with LuGre friction (:mod:`.compliant`), rigid unilateral contacts
as masked active-set rows with impacts, releases and projection (:mod:`.rigid`), and one
terrain type, a ground height as a function of x (:mod:`.terrain`)."""
from bipedlab.contact import compliant, penalty, rigid, terrain
from bipedlab.contact.penalty import PenaltyGround, anchor_ground, contact_forces, flat, penalty_force

__all__ = ["compliant", "penalty", "rigid", "terrain", "PenaltyGround", "anchor_ground", "contact_forces", "flat",
           "penalty_force"]
