"""The experimental setup of the seven-link biped (``--setup boom``): what the planar model
lacks and the paper names (Section V-C, Fig. 6 and Fig. 8 captions), added to the plant.

The controller keeps the planar model of Table I (as on the hardware, whose eq. 7 used
Table I's M and A); only the plant changes:

1. **The boom** (Section IV: "constrained to walk in a circular path of 1.6 m radius by a
   mechanical tether attached at the hip joint", ball bearings passing no moment in the
   plane of walking; Section V-C: "a mechanical boom which can significantly alter the
   dynamics"). The paper gives the radius R = 1.6 m (the "small diameter" is 3.2 m) but no
   mass: we take a uniform arm of :data:`BOOM_ARM_MASS` = 2 kg (an assumption: a 1.6 m tube
   with its hip fitting), pivoted at the mast. Its inertia about the vertical axis, m R^2 / 3,
   adds ``I / R^2 = m / 3`` to the hip's horizontal (arc-length) inertia; pitching about the
   mast pivot, it adds the same m / 3 to the hip's vertical inertia, and half its weight,
   m g / 2, rests on the hip. The robot's own yaw inertia (about 0.3 kg m^2 / R^2 = 0.1 kg)
   and the inner and outer feet's different radii are left out.
2. **Turning the feet on the ground** (Section V-C: "considerable energy loss in turning the
   feet while on the ground"). Walking the circle, the robot's heading turns with the boom at
   ``x_dot / R``, and a foot on the ground, rigid in yaw with the leg, twists on the floor
   against a torsional friction ``mu F_n r_eff``: per step of length L the stance foot turns
   through ``L / R`` rad (= 360 deg L / (pi x 3.2 m)) and dissipates ``mu F_n r_eff L / R``.
   Seen through the boom this is a horizontal force ``-mu r_eff / R F_n`` on the hip, with
   F_n the total normal force on the feet (both feet twist in double support), solved
   exactly with the contact forces (:func:`bipedlab.robots.seven_link.contact.solve`).
   r_eff = (a + b) / 4 = 0.046 m: a foot flat on the floor, loaded evenly along its length
   and twisting about its middle (the mean lever |s| over a line contact of length l is
   l / 4). mu = :data:`FRICTION_COEFFICIENT` = 0.8, an assumption for the "silicon rubber
   pads with high frictional properties" (Section IV-C2); the same mu is the friction cone
   against which the no-slip contacts' tangential/normal ratio is reported.
3. **Coulomb friction in the drives** (Fig. 6 caption: "the difference in the low velocity
   area is mainly due to the Coulomb friction and the cabling which is neglected in the
   simulations"), identified from the free swing by :func:`identify_drive_friction`: an
   oscillator of stiffness k with a Coulomb torque F_c loses ``4 F_c / k`` of amplitude per
   cycle (linearly, unlike the viscous model's geometric decay), so ``F_c = (loss per cycle)
   k / 4``, k the swing's gravitational stiffness about the hanging posture. The paper's text
   gives no numbers for the Fig. 6 traces; :data:`FIG6_DECAY_DEG` is our reading of the
   figure's low-velocity tail, where the recorded swings stop while the viscous-only model
   keeps swinging: about 4 deg of amplitude lost per cycle at the hip and 6 deg at the knee
   (assumed values; the record reports the sensitivity). The ankle, whose free swing the
   paper did not record, gets the hip's torque: the same motor and the same 21:1 gearhead.
   The identified torques (0.22 N m at the hip and ankle, 0.11 N m at the knee; k = 12.8 and
   4.4 N m/rad) are of
   the order of a Maxon RE40's no-load friction (about 4 mN m) times the gear ratio plus the
   gearhead's losses. Viscous friction stays Table I's b (identified by the authors).
   The Coulomb law is regularised, ``F_c tanh(phi_dot / 0.05 rad/s)``: at the walking
   joint rates (rad/s) it is the full Coulomb torque, and the RK4 step of 1 ms stays stable
   (the smallest joint inertia is the knee's reflected rotor, 0.0022 kg m^2).
4. **The knee lock torque** (Fig. 8 caption: "a small positive constant torque was applied
   to the knees at single support when locked, which sets a threshold for them to go
   unlocked"): :data:`KNEE_LOCK_TORQUE` = 1 N m (the caption gives no size; 1 N m is small
   beside the stance knee couple's 6 N m/rad and the knee's 4-14 N m peak torques),
   applied by the controller on a locked knee in S1 (the existing
   ``Gains.knee_lock_torque`` of :mod:`bipedlab.robots.seven_link.controller`).

Contacts stay rigid and no-slip (slip is not modelled): the record reports the friction
coefficient and the peak tangential/normal ratio beside it.

Result (``bipedlab walk seven-link --params paper --setup boom --steps 30``, Table II as
published, not retuned, the default start at 0.5 m/s): 30 steps without a fall at 0.892 m/s,
0.716 m steps, 1.245 Hz, c_mt 0.446 (positive work 0.304), 10.8 contact events per step; a
heel strike every step and a rolling double support (trailing foot on its toe, leading foot
landing on its heel) in 17 of the 22 steps of the gait window (0.095 s of double support),
the trailing heel lifting at the strike (0.002 s after it on average) rather than before it,
push-off ankle work 8.2 J per step; the stance knee within 1.7 deg of full extension while
its heel is down (99.5 % of those samples extended); peak no-slip tangential/normal ratio
3.47 (mu 0.8: the feet would slip). The paper: 0.5 m/s, 0.5 m, 1 Hz, c_mt 0.31.

Before the contact-sequence fixes it fell after 2 touchdowns with 24.5 contact events per
touchdown: the swing knee's lock at 0.384 s lifted the stance knee 0.001 deg off its stop,
the controller read it as unlocked (lock torque off, eq. 7 with a free knee asking -4.5 N m of
it) and it flexed to 30 deg by 0.61 s; and eq. 7 with every touching element in A asked toes,
heels and knee stops to pull, so they chattered. The fixes: the stance-knee latch of the lock
torque (:data:`bipedlab.robots.seven_link.controller.STANCE_KNEE_LATCH_DEG`) and the unilateral
check for Table II (:data:`bipedlab.robots.seven_link.study.UNILATERAL_CHECK`); the event log
is :func:`bipedlab.robots.seven_link.study.contact_sequence`.

Part by part (:func:`bipedlab.robots.seven_link.study.parts_table`, Table II, 30 steps
requested; each part alone on the planar model, then all; the knee lock row is the lock torque
with its latch)::

    row               steps  fell  m/s     step m  Hz     c_mt   rolling DS  push-off J  events/step
    planar             5     yes   0.051   0.051   1.003  18.8   0.00        33.2        8.2
    + boom inertia     4     yes  -0.126  -0.125   1.007  -      0.00        -3.5        11.8
    + foot turning    16     yes   0.535   0.465   1.150  1.049  0.56        14.8        48.4
    + drive friction   5     yes   1.057   0.473   2.237  0.463  0.00        1.7         9.6
    + knee lock        1     yes   -       -       -      -      -           -           28.0
    boom (all)        30     no    0.892   0.716   1.245  0.446  0.77        8.2         10.8

(figures of a walk that fell are over its last few steps). No single part makes Table II
walk; all four together do. With both fixes, Table II on the planar
model (no boom losses, no lock torque) falls after 5 touchdowns; before, it walked at 1.058
m/s only through the chatter's losses. The sensitivity and part-by-part figures below this
line were measured before the fixes:

* each part switched off in turn still falls: without the boom inertia after 5 touchdowns,
  without the drive friction after 6, without the knee lock after 2; without the foot
  turning it stumbles 12 touchdowns at -0.28 m/s (no gait);
* the assumed sizes did not change this: arm 1 or 4 kg, drive friction x0.5 or x2, mu 0.6
  or 1.0, knee lock 0.5 or 2 N m all fell within 2-4 touchdowns;
* energy: along the planar Table II gait, the drive Coulomb friction would dissipate 0.014
  and the foot turning 0.018-0.023 (robot weight x metre), beside the actuators' 0.331 and
  Table I's viscous 0.033.
"""
from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from bipedlab.robots.seven_link import catalog
from bipedlab.robots.seven_link import robot as sl

#: Boom radius (m), Section IV.
BOOM_RADIUS = 1.6
#: Boom arm mass (kg): assumed (the paper gives none), a uniform arm pivoted at the mast.
BOOM_ARM_MASS = 2.0
#: Friction coefficient of the foot pads on the floor: assumed (Section IV-C2's "high
#: frictional properties" silicone rubber).
FRICTION_COEFFICIENT = 0.8
#: Lever of the torsional friction of a twisting foot (m): (a + b) / 4 of Table I's foot.
FOOT_TURN_ARM = (sl.FOOT["a"] + sl.FOOT["b"]) / 4.0
#: Assumed reading of Fig. 6's low-velocity decay: amplitude lost per cycle (deg).
FIG6_DECAY_DEG = {"hip": 4.0, "knee": 6.0}
#: The stance knee's lock torque (N m), Fig. 8 caption (size assumed).
KNEE_LOCK_TORQUE = 1.0
#: Regularising rates of the Coulomb drive friction (rad/s) and of the turning loss (m/s).
COULOMB_RATE = 0.05
TURN_RATE = 0.01
SETUPS = catalog.SETUPS
#: The boom setup's losses and additions that :func:`boom` can switch off one at a time.
PARTS = ("boom_inertia", "foot_turning", "drive_friction", "knee_lock")


# ----------------------------------------------------------------------------- Fig. 6
def swing_case(joint: str):
    """(posture q (9,), direction e (9,)) of the Fig. 6 free swing of ``joint``: the hip case
    swings the whole leg (knee on its stop, ankle locked) about a fixed upright body; the knee
    case swings shank and foot below a thigh held horizontal and forward (phi_2 = -90 deg at
    rest)."""
    hang = np.array([0.0, 1.0, np.pi / 2, np.pi / 2, np.pi / 2, 0.0, np.pi / 2, np.pi / 2, 0.0])
    if joint == "hip":
        return hang, np.array([0, 0, 0, 1, 1, 1, 0, 0, 0], float)
    if joint == "knee":
        pose = hang.copy()
        pose[3] = np.pi
        return pose, np.array([0, 0, 0, 0, 1, 1, 0, 0, 0], float)
    raise ValueError(f"no free swing for {joint!r}")


def swing_stiffness(joint: str, r: sl.SevenLink | None = None) -> float:
    """Gravitational stiffness k (N m/rad) of the Fig. 6 swing about its hanging rest posture:
    ``e^T (d^2 V / dq^2) e``."""
    r = r or sl.model()
    q0, e = (jnp.asarray(v) for v in swing_case(joint))
    return float(_curvature(r, q0, e))


@jax.jit
def _curvature(r, q0, e):
    """d^2 V(q0 + e s) / ds^2 at s = 0, compiled: one small program for both joints (run op by
    op, the Hessian compiled some 70 one-operation programs per joint)."""
    return jax.hessian(lambda s: sl.potential_energy(r, q0 + e * s))(jnp.asarray(0.0))


def coulomb_from_decay(loss_per_cycle_rad, stiffness):
    """Coulomb torque (N m) of an oscillator of stiffness k (N m/rad) whose amplitude falls by
    ``loss_per_cycle_rad`` each full cycle: ``F_c = loss k / 4`` (the energy ``F_c (A_1 + A_2)``
    lost per half cycle equals ``k (A_1^2 - A_2^2) / 2``, so each half cycle loses 2 F_c / k)."""
    return loss_per_cycle_rad * stiffness / 4.0


def identify_drive_friction(decay_deg: dict | None = None) -> dict:
    """Coulomb drive friction (N m) of hip, knee and ankle from the Fig. 6 decays
    (:data:`FIG6_DECAY_DEG`, deg per cycle); the ankle takes the hip's (same drive)."""
    decay_deg = FIG6_DECAY_DEG if decay_deg is None else decay_deg
    out = {}
    for joint in ("hip", "knee"):
        out[joint] = float(coulomb_from_decay(np.deg2rad(decay_deg[joint]), swing_stiffness(joint)))
    out["ankle"] = out["hip"]
    return out


def decay_per_cycle(t, s, min_peak: float = 1e-3) -> float:
    """Mean amplitude lost per full cycle (rad) of a swing s(t) about zero: successive peaks
    of the same sign, over the peaks above ``min_peak`` (rad) and the release."""
    s = np.asarray(s)
    ds = np.diff(s)
    turn = np.flatnonzero((np.sign(ds[1:]) != np.sign(ds[:-1])) & (ds[:-1] != 0.0)) + 1
    peaks = np.concatenate([[abs(s[0])], np.abs(s[turn])])
    peaks = peaks[peaks > min_peak]
    if len(peaks) < 3:
        return float("nan")
    return float(np.mean(peaks[:-2] - peaks[2:]))


# ----------------------------------------------------------------------------- the setup
def boom(boom_inertia: bool = True, foot_turning: bool = True, drive_friction: bool = True,
         arm_mass: float = BOOM_ARM_MASS, radius: float = BOOM_RADIUS, mu: float = FRICTION_COEFFICIENT,
         friction_scale: float = 1.0) -> sl.Setup:
    """The boom setup's additions (:class:`~bipedlab.robots.seven_link.robot.Setup`); each part
    can be switched off (the zero additions of a part leave its terms exactly zero)."""
    # the friction's identification (two swing stiffnesses by automatic differentiation, 3 s
    # on a first call) only where the part is on: off, its torques are zero
    fc = identify_drive_friction() if drive_friction else dict(hip=0.0, knee=0.0, ankle=0.0)
    coulomb = np.tile([fc["hip"], fc["knee"], fc["ankle"]], 2) * friction_scale * float(drive_friction)
    m = arm_mass * float(boom_inertia)
    f = lambda v: jnp.asarray(v, jnp.float64)  # noqa: E731
    return sl.Setup(mass_x=f(m / 3.0), mass_y=f(m / 3.0), load_y=f(m * sl.GRAVITY / 2.0), coulomb=f(coulomb),
                    coulomb_rate=f(COULOMB_RATE), turn_drag=f(mu * FOOT_TURN_ARM / radius * float(foot_turning)),
                    turn_rate=f(TURN_RATE))


def plant(setup: sl.Setup | None = None, robot: sl.SevenLink | None = None) -> sl.SevenLink:
    """The planar model of Table I (or ``robot``: one of :func:`~bipedlab.robots.seven_link.robot.model`'s
    scaled tables) with the setup's additions (default :func:`boom`)."""
    return (sl.model() if robot is None else robot).replace(setup=boom() if setup is None else setup)


def describe(setup: sl.Setup, knee_lock_torque: float) -> dict:
    """The setup's numbers for the walk record."""
    c = np.asarray(setup.coulomb)
    return dict(
        boom_radius_m=BOOM_RADIUS, boom_arm_mass_kg=BOOM_ARM_MASS,
        added_mass_horizontal_kg=float(setup.mass_x), added_mass_vertical_kg=float(setup.mass_y),
        boom_load_on_hip_n=float(setup.load_y),
        foot_turn_lever_m=FOOT_TURN_ARM, foot_turn_drag_per_normal_force=float(setup.turn_drag),
        turn_per_step_deg_per_m=float(np.rad2deg(1.0 / BOOM_RADIUS)),
        drive_coulomb_nm=dict(hip=float(c[0]), knee=float(c[1]), ankle=float(c[2])),
        drive_coulomb_rate_radps=float(setup.coulomb_rate),
        fig6_decay_read_deg_per_cycle=dict(FIG6_DECAY_DEG),
        fig6_swing_stiffness_nm_per_rad={j: swing_stiffness(j) for j in ("hip", "knee")},
        knee_lock_torque_nm=knee_lock_torque)
