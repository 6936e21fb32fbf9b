"""Synthetic identification experiments on MABEL, as the paper runs them on the robot.

Each generator takes a "true" parameter set (:mod:`.params`), the sensor model
(:mod:`.sensors`) and an experiment :class:`Design`, and returns :class:`Experiment` logs that
hold only what the robot logs: time, commanded torques, encoder angles (and the scale's
reading in the spring experiments), plus the experiment's metadata.

* ``bias`` (Appendix A): each motor with its cable disconnected (the rotor alone), an
  unbiased sinusoidal command; the amplifier bias makes the rotor drift.
* ``transmission`` (Section IV, Figs. 9-10): each motor with 1, 3, 5 (leg angle) or 1, 3, 4
  (leg shape) pulleys connected, under the modified chirp of Section IV-C: 0.5 to 50 Hz in 17
  geometric steps, 10 periods each, the magnitude rising with frequency so that the motor
  speed stays near ``chirp_velocity``.
* ``leg`` (Section V): per leg, the torso fixed and B_spring blocked, two SISO experiments
  (the other motor mechanically locked: leg shape at ``ls_lock_deg``, or leg angle at 180
  deg) and one MIMO experiment; chirps plus a constant offset that holds the leg against
  gravity, magnitudes designed on the CAD model's linearisation for about
  ``leg_amplitude_deg`` of joint motion (the workspace limit the paper mentions).
* ``spring`` (Section VII-A): per leg, the robot balanced on that toe on a scale, leg angle
  180 deg, leg shape 10 to 30 deg, the other leg folded and tied; the scale reads the toe
  force, encoders read the torso, leg and B_spring angles. The true deflection is the static
  equilibrium of the 13-DoF model with a preloaded spring ``K_B q + tau_0``.
* ``balance`` (Section VI): 10 postures balanced on the right toe (robot with boom) and 7
  with the hip fixed and the torso balanced upright (robot without boom); the true torso
  angle puts the true centre of mass over the toe (hip).
* ``hopping`` (Section VIII): the 13-DoF model under the hopping controller of Appendix C
  (1 ms, quantised encoders), held at rest 2 cm above the floor for ``hop_hold`` s, then
  released: ``hop_seconds`` of the drop, landing, kick-off and flight that follow.

Truth simulations integrate more finely than the estimators (``leg``: RK4 at 0.25 ms;
``hopping``: the model's semi-implicit step at 0.05 ms), and the amplifier adds the sensor
model's torque noise to each held command.
"""
from __future__ import annotations

import dataclasses
import zlib

import jax
import jax.numpy as jnp
import numpy as np

from bipedlab.robots.mabel.hopping import controller as hop
from bipedlab.robots.mabel import dynamics as md
from bipedlab.robots.mabel import model as mm
from bipedlab.robots.mabel import tables as tb
from bipedlab.robots.mabel.hopping import study as hm
from bipedlab.robots.mabel.sysid import balance, springs
from bipedlab.robots.mabel.sysid import params as P
from bipedlab.robots.mabel.sysid import rigs
from bipedlab.robots.mabel.sysid.logs import HOP_ENCODERS, KINDS, Experiment, motor_encoder
from bipedlab.robots.mabel.sysid.sensors import PERIOD, Sensors
from bipedlab.sim import loop

_H = {c: i for i, c in enumerate(mm.COORDS_13)}
#: Hop simulation step and steps per 1 ms sample (as in studies.hop_mabel).
HOP_DT = hm.DT
HOP_SUBSTEPS = hm.SUBSTEPS


@dataclasses.dataclass(frozen=True)
class Design:
    """Sizes and signals of the experiments (defaults: the paper's where it gives them)."""

    chirp_f0: float = 0.5
    chirp_f1: float = 50.0
    chirp_steps: int = 17
    chirp_periods: int = 10
    chirp_velocity: float = 10.0       # rad/s of motor speed the magnitude aims at
    bias_seconds: float = 10.0
    bias_frequency: float = 2.0
    leg_f0: float = 0.5
    leg_f1: float = 2.5
    leg_steps: int = 7
    leg_periods: int = 3
    leg_amplitude_deg: float = 10.0
    ls_lock_deg: float = 15.0
    ls_offset_deg: float = 18.0
    spring_ls_deg: tuple = (10.0, 15.0, 20.0, 25.0, 30.0)
    balance_stance: int = 10
    balance_hanging: int = 7
    hop_seconds: float = 0.6
    hop_hold: float = 1.0


def quick_design() -> Design:
    """A reduced design for tests and the noise study (shorter chirps and hop segment)."""
    return Design(chirp_periods=3, bias_seconds=5.0, leg_steps=4, leg_periods=2, hop_seconds=0.45, hop_hold=0.05)


def _stream(name: str) -> int:
    return zlib.crc32(name.encode())


def _times(n: int) -> np.ndarray:
    return np.arange(n) * PERIOD


# ----- signals ----------------------------------------------------------------------------
def chirp_frequencies(f0: float, f1: float, steps: int) -> np.ndarray:
    return np.geomspace(f0, f1, steps)


def modified_chirp(freqs, amps, periods: int, h: float = PERIOD) -> np.ndarray:
    """Section IV-C's input: a sinusoid held ``periods`` periods at each frequency (Hz), with
    magnitude amps[i] at freqs[i]; each step starts at zero phase."""
    out = []
    for f, a in zip(freqs, amps):
        n = int(round(periods / f / h))
        out.append(a * np.sin(2.0 * np.pi * f * np.arange(n) * h))
    return np.concatenate(out)


def _lumped(kt, J, mu, f):
    """|K_T (J j w + mu)|: command amplitude per rad/s of speed at f Hz."""
    return kt * np.abs(J * 2j * np.pi * np.asarray(f) + mu)


# ----- Appendix A and Section IV ------------------------------------------------------------
def bias_experiment(p: P.MabelParams, actuator: str, sensors: Sensors, design: Design = Design()) -> Experiment:
    """The rotor alone under an unbiased sinusoid (Appendix A, Fig. 24)."""
    k = P.actuator_index(actuator)
    pub = P.published()
    J_nom = pub.alpha[k] * P.rotor_inertia_manufacturer(actuator)
    amp = design.chirp_velocity * _lumped(pub.kt[k], J_nom, pub.motor_friction[k], design.bias_frequency)
    n = int(round(design.bias_seconds / PERIOD))
    u = amp * np.sin(2.0 * np.pi * design.bias_frequency * _times(n))
    name = f"bias_{actuator}"
    rng = sensors.rng(_stream(name))
    tau = (u + p.bias[k] + sensors.torque_disturbance(n, rng)) / p.kt[k]
    theta = rigs.motor_rig(p.alpha[k] * P.rotor_inertia_manufacturer(actuator), p.motor_friction[k], tau)
    return Experiment(name, "bias", _times(n), {actuator: u}, {motor_encoder(actuator): sensors.encoder(theta, rng)},
                      meta=dict(actuator=actuator, setup="rotor alone, cable disconnected",
                                signal=f"sinusoid {design.bias_frequency:g} Hz"))


def transmission_experiments(p: P.MabelParams, actuator: str, sensors: Sensors,
                             design: Design = Design()) -> list[Experiment]:
    """The three pulley combinations of one motor under the modified chirp (Section IV)."""
    k = P.actuator_index(actuator)
    pub = P.published()
    J_man = P.rotor_inertia_manufacturer(actuator)
    J_cad = P.combination_inertia(actuator)
    freqs = chirp_frequencies(design.chirp_f0, design.chirp_f1, design.chirp_steps)
    out = []
    for i, pulleys in enumerate(P.COMBINATIONS[actuator[:3]]):
        amps = design.chirp_velocity * _lumped(pub.kt[k], pub.alpha[k] * J_man + J_cad[i], pub.trans_friction[k, i], freqs)
        u = modified_chirp(freqs, amps, design.chirp_periods)
        n = len(u)
        name = f"transmission_{actuator}_{pulleys}"
        rng = sensors.rng(_stream(name))
        tau = (u + p.bias[k] + sensors.torque_disturbance(n, rng)) / p.kt[k]
        theta = rigs.motor_rig(p.alpha[k] * J_man + J_cad[i], p.trans_friction[k, i], tau)
        out.append(Experiment(name, "transmission", _times(n), {actuator: u},
                              {motor_encoder(actuator): sensors.encoder(theta, rng)},
                              meta=dict(actuator=actuator, combination=i + 1, pulleys=pulleys,
                                        cad_inertia=float(J_cad[i]),
                                        signal=f"modified chirp {design.chirp_f0:g}-{design.chirp_f1:g} Hz, "
                                               f"{design.chirp_steps} steps, {design.chirp_periods} periods")))
    return out


# ----- Section V ----------------------------------------------------------------------------
def leg_experiments(p: P.MabelParams, side: str, sensors: Sensors, design: Design = Design(),
                    substeps: int = 4) -> list[Experiment]:
    """SISO (leg angle, leg shape) and MIMO experiments on one leg, torso fixed (Section V)."""
    nominal = rigs.leg_rig(P.published(), side)
    truth = rigs.leg_rig(p, side)
    acts = rigs.LEG_ACTUATORS[side]
    freqs = chirp_frequencies(design.leg_f0, design.leg_f1, design.leg_steps)
    deg = np.deg2rad
    plans = [
        ("siso_mLA", (True, False), (np.pi, deg(design.ls_lock_deg)), 1.0, 1.0),
        ("siso_mLS", (False, True), (np.pi, deg(design.ls_offset_deg)), 1.0, 1.0),
        ("mimo", (True, True), (np.pi, deg(design.ls_offset_deg)), 0.7, 1.17),
    ]
    out = []
    for label, active, (la, ls), scale, shift in plans:
        q_eq = np.array(rigs.leg_motor_angles(la, ls))
        u0 = np.asarray(rigs.gravity_equilibrium_command(nominal, q_eq))
        M, K = rigs.linearisation(nominal, q_eq)
        cols = []
        for j in range(2):
            if not active[j]:
                cols.append(np.zeros(0))
                continue
            f = freqs * (shift if j == 1 else 1.0)
            w = 2.0 * np.pi * f
            gear = abs(tb.GEAR_LA) if j == 0 else tb.GEAR_LS
            dyn = np.abs(K[j, j] - M[j, j] * w**2 + 1j * float(nominal.friction[j]) * w)
            amps = scale * deg(design.leg_amplitude_deg) * gear * float(nominal.kt[j]) * dyn
            cols.append(modified_chirp(f, amps, design.leg_periods))
        n = max(len(c) for c in cols)
        U = np.zeros((n, 2))
        for j in range(2):
            if active[j]:
                U[: len(cols[j]), j] = cols[j]
                U[:, j] += u0[j]
        name = f"leg_{label}_{side}"
        rng = sensors.rng(_stream(name))
        W = sensors.torque_disturbance((n, 2), rng) * np.asarray(active, float)
        x0 = jnp.concatenate([jnp.asarray(q_eq), jnp.zeros(2)])
        Y = np.asarray(_sim_leg(truth, x0, jnp.asarray(U + W), jnp.asarray(active, dtype=float), substeps))
        enc = {motor_encoder(a): sensors.encoder(Y[:, j], rng) for j, a in enumerate(acts)}
        u = {a: U[:, j] for j, a in enumerate(acts) if active[j]}
        locked = [motor_encoder(a) for j, a in enumerate(acts) if not active[j]]
        out.append(Experiment(name, "leg", _times(n), u, enc, meta=dict(
            side=side, mode="mimo" if all(active) else "siso", actuated=" ".join(a for j, a in enumerate(acts) if active[j]),
            locked=" ".join(locked) if locked else "none", torso="fixed", b_spring="blocked",
            signal=f"chirp {design.leg_f0:g}-{design.leg_f1:g} Hz plus offset")))
    return out


_sim_leg = jax.jit(rigs.simulate_leg, static_argnames=("substeps", "h"))


# ----- Section VII-A and Section VI ---------------------------------------------------------
#: Folded, tied-up leg of the spring experiments (leg angle, leg shape), rad.
FOLDED = (np.pi - 0.4, 0.9)


def _with_torso(q, tor):
    return q.at[_H["tor"]].set(tor)


def spring_experiment(p: P.MabelParams, side: str, sensors: Sensors, design: Design = Design()) -> Experiment:
    """Static spring experiment on one leg (Section VII-A, Fig. 18)."""
    m = P.model(p)
    k = tb.SIDES.index(side)
    other = "R" if side == "L" else "L"
    name = f"spring_{side}"
    rng = sensors.rng(_stream(name))
    rows = {c: [] for c in ("tor", f"la_{side}", f"ls_{side}", f"bsp_{side}", f"la_{other}", f"ls_{other}")}
    W = []
    weight = (float(sum(m.body.tree.mass)) + balance.boom_mass()) * 9.81
    for ls in np.deg2rad(design.spring_ls_deg):
        q = jnp.zeros(13).at[_H[f"la_{side}"]].set(np.pi).at[_H[f"ls_{side}"]].set(ls)
        q = q.at[_H[f"la_{other}"]].set(FOLDED[0]).at[_H[f"ls_{other}"]].set(FOLDED[1])
        tor = balance.balance_torso(m, q, f"toe_{side}")
        q = _with_torso(q, tor)
        tau = springs.spring_torque(m, q, side, weight)
        bsp = (tau - p.spring_preload[k]) / p.spring_k[k]
        for c, v in (("tor", tor), (f"la_{side}", np.pi), (f"ls_{side}", ls), (f"bsp_{side}", bsp),
                     (f"la_{other}", FOLDED[0]), (f"ls_{other}", FOLDED[1])):
            rows[c].append(v)
        W.append(weight)
    enc = {c: sensors.encoder(np.array(v), rng) for c, v in rows.items()}
    n = len(W)
    return Experiment(name, "spring", np.arange(n, dtype=float), {}, enc, scale=sensors.scale(np.array(W), rng),
                      meta=dict(side=side, setup="balanced on the toe on a scale, leg angle 180 deg, other leg tied",
                                rows="one posture per row"))


def balance_experiments(p: P.MabelParams, sensors: Sensors, design: Design = Design(), seed: int = 7) -> list[Experiment]:
    """Static balance postures (Section VI): on the right toe, and hanging from the fixed hip."""
    m = P.model(p)
    rng_pose = np.random.default_rng(seed)
    deg = np.deg2rad
    out = []
    for label, support, count in (("stance", "toe_R", design.balance_stance), ("hanging", "hip", design.balance_hanging)):
        name = f"balance_{label}"
        rng = sensors.rng(_stream(name))
        cols = {c: [] for c in ("tor", "la_L", "ls_L", "la_R", "ls_R")}
        for _ in range(count):
            q = jnp.zeros(13)
            if support == "hip":
                pose = dict(la_L=np.pi + deg(rng_pose.uniform(-25, 25)), ls_L=deg(rng_pose.uniform(5, 40)),
                            la_R=np.pi + deg(rng_pose.uniform(-25, 25)), ls_R=deg(rng_pose.uniform(5, 40)))
            else:
                pose = dict(la_R=np.pi + deg(rng_pose.uniform(-8, 8)), ls_R=deg(rng_pose.uniform(10, 30)),
                            la_L=np.pi + deg(rng_pose.uniform(-30, 30)), ls_L=deg(rng_pose.uniform(10, 40)))
            for c, v in pose.items():
                q = q.at[_H[c]].set(v)
            tor = balance.balance_torso(m, q, support)
            cols["tor"].append(tor)
            for c, v in pose.items():
                cols[c].append(v)
        enc = {c: sensors.encoder(np.array(v), rng) for c, v in cols.items()}
        out.append(Experiment(name, "balance", np.arange(count, dtype=float), {}, enc,
                              meta=dict(support=support, rows="one posture per row",
                                        setup="balanced by hand on the right toe" if support != "hip"
                                        else "hip fixed, legs hanging, torso balanced upright")))
    return out


# ----- Section VIII -------------------------------------------------------------------------
def _hop_sensor(params, sensor_state, x, t):
    m, hp, W = params
    return sensor_state, hm.sense(m, hp, x)


def _hop_controller(params, c, y, t):
    m, hp, W = params
    return hop.update(hp, c, *y)


def _hop_noise(params, x, t):
    """The amplifier noise of the sample starting at t (row k of W, k = t / PERIOD)."""
    m, hp, W = params
    return W[jnp.round(t / PERIOD).astype(int)]


def _hop_plant_step(params, x, u, w, h, t):
    m, hp, W = params
    return jax.lax.fori_loop(0, HOP_SUBSTEPS, lambda _, x: md.step(m, x, u + w, HOP_DT), x)


def _hop_log(params, x_before, y, u, x, c):
    return x_before, u


#: The hopping study's closed loop with amplifier noise added to each held command; params
#: (model, hopping parameters, noise W (steps, 4)); logs the state at t_k and the command u_k.
HOP_LOOP = loop.SampledLoop(plant_step=_hop_plant_step, sensor=_hop_sensor, controller=_hop_controller,
                            fell=lambda params, x_before, y, u, x: jnp.asarray(False), sample_time=PERIOD,
                            log=_hop_log, exogenous=_hop_noise)


def _hop_loop(m: mm.Mabel, p: hop.HopParams, x0, c0, W):
    """Closed loop with amplifier noise W (steps, 4): states at t_k and commands u_k."""
    return loop.run(HOP_LOOP, (m, p, W), loop.initial_state(x0, None, c0), W.shape[0])[1]


_hop_loop_jit = jax.jit(_hop_loop)


def hop_encoders(x: np.ndarray) -> dict:
    """True values of the hopping encoders from states (N, 28)."""
    R = tb.BOOM["radius"]
    out = {"boom_h": x[:, _H["x"]] / R, "boom_v": x[:, _H["y"]] / R}
    for c in HOP_ENCODERS[2:]:
        out[c] = x[:, _H[c]]
    return out


def hopping_experiment(p: P.MabelParams, sensors: Sensors, design: Design = Design()) -> Experiment:
    """Two-legged hopping under the Appendix C controller: held at rest 2 cm above the floor
    for ``hop_hold`` s (commands zero), then released: drop, landing, kick-off and flight."""
    m = P.model(p)
    hp = hop.paper_params()
    x0 = hm.initial_state(m, hp)
    c0 = hop.initial_state(hp, hm.sense(m, hp, x0)[0])
    n = int(round(design.hop_seconds / PERIOD))
    hold = int(round(design.hop_hold / PERIOD))
    name = "hopping"
    rng = sensors.rng(_stream(name))
    W = sensors.torque_disturbance((n, 4), rng)
    xs, us = _hop_loop_jit(m, hp, x0, c0, jnp.asarray(W))
    xs = np.concatenate([np.repeat(np.asarray(x0)[None], hold, axis=0), np.asarray(xs)])
    us = np.concatenate([np.zeros((hold, 4)), np.asarray(us)])
    enc = {c: sensors.encoder(v, rng) for c, v in hop_encoders(xs).items()}
    return Experiment(name, "hopping", _times(hold + n), {a: us[:, k] for k, a in enumerate(P.ACTUATORS)}, enc,
                      meta=dict(setup="held at rest 2 cm above the floor, released, Appendix C hopping controller",
                                release_s=hold * PERIOD, boom_radius=tb.BOOM["radius"]))


# ----- everything ---------------------------------------------------------------------------
def generate(p: P.MabelParams, sensors: Sensors, design: Design = Design(), progress=None,
             kinds=KINDS) -> list[Experiment]:
    """Every experiment of the identification on the robot p (kinds selects some)."""
    say = progress or (lambda msg: None)
    out = []
    if "bias" in kinds:
        say("generating the Appendix A bias experiments")
        out += [bias_experiment(p, a, sensors, design) for a in P.ACTUATORS]
    if "transmission" in kinds:
        say("generating the transmission experiments (Section IV)")
        for a in P.ACTUATORS:
            out += transmission_experiments(p, a, sensors, design)
    if "leg" in kinds:
        say("generating the SISO and MIMO leg experiments (Section V)")
        for s in tb.SIDES:
            out += leg_experiments(p, s, sensors, design)
    if "spring" in kinds:
        say("generating the static spring and balance experiments (Sections VI, VII-A)")
        out += [spring_experiment(p, s, sensors, design) for s in tb.SIDES]
    if "balance" in kinds:
        out += balance_experiments(p, sensors, design)
    if "hopping" in kinds:
        say("generating the hopping experiment (Section VIII)")
        out.append(hopping_experiment(p, sensors, design))
    return out
