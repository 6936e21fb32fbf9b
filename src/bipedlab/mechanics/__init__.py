"""Robot-agnostic planar rigid-body mechanics: tree description, kinematics, dynamics,
ground contact and impacts. Every function is pure and works under jit, vmap and grad."""
from bipedlab.mechanics.tree import Body, Model, Point, Rotor, build_model, REVOLUTE, PRISMATIC
from bipedlab.mechanics.kinematics import (
    body_poses,
    point_jacobian,
    point_jdot_qd,
    point_position,
    point_velocity,
)
from bipedlab.mechanics.dynamics import (
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
from bipedlab.mechanics.impact import impact_map, relabel
from bipedlab.mechanics.mjcf import mjcf_coordinate_order, to_mjcf

__all__ = [
    "Body", "Model", "Point", "Rotor", "build_model", "REVOLUTE", "PRISMATIC",
    "body_poses", "point_jacobian", "point_jdot_qd", "point_position", "point_velocity",
    "angular_momentum", "bias", "com_position", "com_velocity", "forward_dynamics",
    "gravity_forces", "kinetic_energy", "mass_matrix", "potential_energy", "total_mass",
    "impact_map", "relabel", "to_mjcf", "mjcf_coordinate_order",
]
