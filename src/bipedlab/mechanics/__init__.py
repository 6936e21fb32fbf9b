"""Robot-agnostic planar rigid-body mechanics: tree description, kinematics, dynamics,
ground contact and impacts. Every function is pure and works under jit, vmap and grad."""
from .tree import Body, Model, Point, Rotor, build_model, REVOLUTE, PRISMATIC
from .kinematics import (
    body_poses,
    point_jacobian,
    point_jdot_qd,
    point_position,
    point_velocity,
)
from .dynamics import (
    angular_momentum,
    bias,
    com_position,
    com_velocity,
    forward_dynamics,
    gravity_forces,
    kinetic_energy,
    mass_matrix,
    potential_energy,
    total_mass,
)
from .impact import impact_map, relabel
from .mjcf import mjcf_coordinate_order, to_mjcf
from .contact import PenaltyGround, anchor_ground, contact_forces, flat, penalty_force

__all__ = [
    "Body", "Model", "Point", "Rotor", "build_model", "REVOLUTE", "PRISMATIC",
    "body_poses", "point_jacobian", "point_jdot_qd", "point_position", "point_velocity",
    "angular_momentum", "bias", "com_position", "com_velocity", "forward_dynamics",
    "gravity_forces", "kinetic_energy", "mass_matrix", "potential_energy", "total_mass",
    "impact_map", "relabel", "to_mjcf", "mjcf_coordinate_order",
    "PenaltyGround", "anchor_ground", "contact_forces", "flat", "penalty_force",
]
