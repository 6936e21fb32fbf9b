"""MABEL's published numbers, each with its source.

Sources: Park, Sreenath, Hurst & Grizzle, "Identification and dynamic model of a bipedal robot
with a cable-differential-based compliant drivetrain" (Tables IV-VIII, eqs. 5-6, Fig. 19), and
Sreenath et al., "A compliant hybrid zero dynamics controller ... on MABEL" (eq. 1, boom radius,
actuator torque capacities). Pulley radii are from the lab's public transmission-model notes.

Link frames: a link's frame is the torso frame rotated by the link's angle relative to the torso
(so every link points up at angle 0 and a hanging leg has angle pi); ``com`` is given in that
frame. Table VII's moments of inertia are about the link's joint axis (the boom's about its
pivot): the thigh's 0.1986 kg m^2, for instance, is 0.070 about its COM plus m r^2 = 0.128,
the figure of a 0.5 m bar, and the boom's 20.5 kg m^2 matches a 2.25 m boom whose COM sits at
1.485 m only when taken about the pivot. They are converted to COM inertias below.
"""
from __future__ import annotations

#: Actuator order used everywhere: the hopping controller's h = [q_LA_L, q_mLS_L, q_LA_R, q_mLS_R].
ACTUATORS = ("mLA_L", "mLS_L", "mLA_R", "mLS_R")
SIDES = ("L", "R")

# Table VII: mass (kg), COM [r_x, r_y] (m) in the link frame, inertia about the joint (kg m^2).
LINKS = {
    "torso": (40.8953, (0.01229, 0.18337), 2.3727),
    "csp": (1.8987, (0.0009406, 0.1181), 0.04377),
    "csh": (1.6987, (0.0004345, 0.08684), 0.03223),
    "thigh": (3.2818, (0.0003110, 0.1978), 0.1986),
    "shin": (1.5007, (0.0009671, 0.1570), 0.08813),
}
BOOM = dict(mass=7.2575, com=1.48494153, inertia=20.4951, radius=2.25)
THIGH_LENGTH = 0.5
SHIN_LENGTH = 0.5

# Table VIII: manufacturer rotor inertias and pulley inertias (kg m^2).
ROTOR_INERTIA = {"mLS": 9.0144e-4, "mLA": 4.4928e-4}
PULLEY_INERTIA = {
    "Ath": 1.6680e-3, "Bth": 2.2181e-3, "Dth": 1.0826e-3,
    "Ash": 1.6974e-3, "Bsh": 2.2181e-3, "Dsh": 2.0542e-3,
    "Asp": 2.3464e-3, "Bsp": 1.8686e-3, "Dsp": 1.9313e-3,
    "LSsd": 2.7117e-3, "LAsd": 1.0950e-3,
}

# Table IV: rotor-inertia scale factors and torque constants, in ACTUATORS order.
ALPHA = {"mLS_L": 0.934, "mLA_L": 0.741, "mLS_R": 0.930, "mLA_R": 0.763}
KT = {"mLS_L": 0.995, "mLA_L": 1.332, "mLS_R": 1.287, "mLA_R": 1.269}
# Table V: viscous friction (N m s/rad, motor side) and amplifier bias (N m) from the MIMO fits.
FRICTION = {"mLS_L": 9.844e-3, "mLA_L": 4.316e-3, "mLS_R": 9.027e-3, "mLA_R": 4.615e-3}
BIAS = {"mLS_L": -8.417e-3, "mLA_L": 2.597e-2, "mLS_R": -1.446e-2, "mLA_R": -2.461e-3}

# Eqs. 5-6: identified gear ratios.
GEAR_LA = -23.53   # q_mLA = GEAR_LA q_LA
GEAR_LS = 31.42    # LS -> mLS
GEAR_BSP = 5.18    # LS -> Bsp

# Fig. 19: unilateral spring stiffness (N m/rad at B_sp). Table VI: hard stop and cable stretch.
SPRING_K = {"L": 115.1, "R": 111.7}
SPRING_DAMPING = 1.5      # Kd_B, N m s/rad
HARD_STOP = dict(kd1=100.0, kvd1=1000.0, kvd2=50.0)
CABLE_K = {"mLS_L": 2.9565, "mLA_L": 3.5000, "mLS_R": 2.9565, "mLA_R": 3.8094}      # N m/rad (motor)
CABLE_D = {"mLS_L": 0.0402, "mLA_L": 0.0889, "mLS_R": 0.0804, "mLA_R": 0.3556}      # N m s/rad

# Table VI, ground model (see bipedlab.contact.compliant for the force laws).
# Table VI lists lambda_v^a = 3.0e6, lambda_v^b = 4.5e6, n = 1.5 and k = 4.38e7 without the
# formula. Read with Marhefka-Orin's symbols (k the stiffness, the lambdas dampers for
# compression/restitution), the ground returns about 90 % or more of the energy of a toe
# striking at up to 1 m/s (Hunt-Crossley restitution e ~ 1 - (2/3)(lambda/k) v) and an unloaded toe
# chatters on it, which no rubber-tyred toe does. The default reads lambda_v^a as the
# stiffness and lambda_v^b as the damping of F_N = d^n (lambda_v^a + lambda_v^b d_dot), a
# nearly plastic touchdown (e ~ 0.6 at 0.5 m/s) with 2-3 mm penetration under the robot's
# weight (k = 4.38e7 then has no role); GROUND_LITERAL keeps the other reading for comparison (the hopping controller falls at
# its first landing on it). Friction (LuGre per unit normal force, Plestan et al. 2003):
# sigma_h0 = 260 /m bristle stiffness, sigma_h1 = 2.25 s/m bristle damping; of the three
# alphas, the Coulomb level is alpha_h2 = 0.54, the static (Stribeck peak) level
# alpha_h3 = 0.9 and the viscous coefficient alpha_h0 = 1.71 s/m (a Coulomb coefficient of
# 1.71 would be implausible for a rubber toe). Not in the paper, chosen here: Stribeck
# velocity 0.01 m/s and bristle relaxation 1000 /s off the ground.
_FRICTION = dict(bristle_stiffness=260.0, bristle_damping=2.25, viscous=1.71, coulomb=0.54, static=0.9,
                 stribeck_velocity=0.01, relax=1000.0)
GROUND = dict(stiffness=3.0e6, exponent=1.5, damping_in=4.5e6, damping_out=4.5e6, **_FRICTION)
GROUND_LITERAL = dict(stiffness=4.38e7, exponent=1.5, damping_in=3.0e6, damping_out=4.5e6, **_FRICTION)

# Pulley radii (m), transmission-model notes.
RADII = {
    "m": 0.0190,
    "Ath": 0.0660, "Bth": 0.0660, "Dth": 0.0444,
    "Ash": 0.0660, "Bsh": 0.0660, "Csh": 0.0806, "Dsh": 0.0660,
    "Asp": 0.0660, "Bsp": 0.0413, "Csp": 0.0660, "Dsp": 0.0660,
    "LSsd_big": 0.0889, "LSsd_small": 0.0318, "LAsd_big": 0.0762, "LAsd_small": 0.0210,
}

# HZD paper: peak torque capacities (N m).
TORQUE_CAPACITY = {"mLA": 30.0, "mLS": 55.0}
