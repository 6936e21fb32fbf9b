"""The identification pipeline of Park et al. on a set of experiment logs, and its comparison
with a known truth.

:func:`identify` runs the steps in the paper's order, each on its own experiments and each
using what the earlier ones found:

1. amplifier biases, Appendix A (:mod:`.arx`) on the ``bias`` logs;
2. J^exp and mu^exp of every pulley combination by eq. 7, then K_T and alpha by eq. 12
   (:mod:`.transmission`) on the ``transmission`` logs, commands bias-compensated;
3. the leg experiments (:mod:`.friction`): friction (eq. 19, with the actuated motor's bias
   refined by eq. 20 in the same fit) from each SISO experiment, then both biases from the
   MIMO experiment (eq. 20, frictions fixed), which replace Appendix A's in the model;
4. spring stiffness and preload per leg (:mod:`.springs`) on the ``spring`` logs;
5. the COM check of Section VI (:mod:`.balance`) on the ``balance`` logs, and the torso COM
   shift that zeroes it;
6. cable stiffness and damping per motor, then the hard stop and ground (:mod:`.hopping_fit`)
   on the ``hopping`` log;
7. validation: each identified model simulated against its logs (Figs. 15-16, 21-23).

A step whose logs are missing keeps the published values and says so in ``notes``. Every
estimator's preconditions are checked before the first fit (:mod:`.preconditions`), and a fit
that fails on logs that met them, or gives a value that cannot be (a non-positive K_T), raises
:class:`~bipedlab.robots.mabel.sysid.logs.LogError` naming the files.
:func:`compare` lines the estimates up against a truth: per parameter its true value, estimate
and relative error, the largest relative error per group, and the targets of the issue.
"""
from __future__ import annotations

import contextlib
import dataclasses

import numpy as np

from bipedlab.robots.mabel import tables as tb
from bipedlab.robots.mabel.sysid import arx, balance, friction, hopping_fit, rigs, springs
from bipedlab.robots.mabel.sysid import params as P
from bipedlab.robots.mabel.sysid import preconditions
from bipedlab.robots.mabel.sysid import transmission as tr
from bipedlab.robots.mabel.sysid.logs import Experiment, LogError, motor_encoder

#: Targets on synthetic data (largest relative error per group; bias in N m).
TARGETS = {"motor_constant": 0.02, "rotor_inertia_scale": 0.02, "friction": 0.10, "spring_stiffness": 0.02,
           "cable_stretch": 0.10}
BIAS_TARGET_NM = 0.005
GROUPS = ("motor_constant", "rotor_inertia_scale", "friction", "spring_stiffness", "spring_preload",
          "cable_stretch", "cable_damping", "hard_stop", "ground")


@dataclasses.dataclass
class Identification:
    """What :func:`identify` found: the estimated parameter set (published values where a
    step could not run), per-step details (JSON-ready), the objects behind the validation
    figures, per-parameter identifiability (hopping stage), and notes."""

    params: P.MabelParams
    details: dict
    fits: dict
    identified: dict
    notes: list


def _by_kind(experiments) -> dict:
    out = {}
    for e in experiments:
        out.setdefault(e.kind, []).append(e)
    return out


def _combination(e: Experiment) -> int:
    return int(e.meta.get("combination", 0))


@contextlib.contextmanager
def _fitting(experiments, what: str):
    """Turn a numerical failure of a fit into a LogError naming its files (one line)."""
    try:
        yield
    except LogError:
        raise
    except (ValueError, ArithmeticError, np.linalg.LinAlgError) as e:
        why = " ".join(str(e).split()) or e.__class__.__name__
        files = ", ".join(preconditions.label(x) for x in experiments)
        raise LogError(f"{files}: the {what} failed on these data ({why[:200]})") from None


def identify(experiments, progress=None, hop_max_nfev: int = 8) -> Identification:
    """Identify MABEL's parameters from experiment logs (see the module docstring)."""
    say = progress or (lambda msg: None)
    preconditions.check(experiments)
    kinds = _by_kind(experiments)
    pub = P.published()
    est = pub
    details, fits, notes, identified = {}, {}, [], {}

    # 1. Appendix A
    bias_arx = est.bias.copy()
    if "bias" in kinds:
        say("Appendix A: amplifier biases by the two-input ARX")
        rows = {}
        for e in kinds["bias"]:
            a = e.meta["actuator"]
            with _fitting([e], "ARX bias fit"):
                r = arx.arx_bias(e.u[a], e.enc[motor_encoder(a)])
            bias_arx[P.actuator_index(a)] = r.bias
            rows[a] = dict(bias_nm=r.bias, a1=r.a1, rotor_J_exp=r.J_exp, rotor_mu_exp=r.mu_exp)
        details["bias_arx"] = rows
        est = est.replace(bias=bias_arx.copy())
    else:
        notes.append("no bias logs: amplifier biases start from the published values")

    # 2. Section IV
    if "transmission" in kinds:
        say("Section IV: first-order fits (eq. 7), K_T and alpha (eq. 12)")
        kt, alpha, tf = est.kt.copy(), est.alpha.copy(), est.trans_friction.copy()
        rows = {}
        for a in P.ACTUATORS:
            exps = sorted([e for e in kinds["transmission"] if e.meta["actuator"] == a], key=_combination)
            if len(exps) < 2:
                notes.append(f"{a}: fewer than two transmission logs, K_T and alpha stay published")
                continue
            k = P.actuator_index(a)
            cad = np.array([float(e.meta.get("cad_inertia", P.combination_inertia(a)[_combination(e) - 1]))
                            for e in exps])
            with _fitting(exps, "transmission fit (eqs. 7, 12)"):
                fo = [tr.fit_first_order(e.u[a] + bias_arx[k], e.enc[motor_encoder(a)]) for e in exps]
                ka = tr.kt_alpha([f.J_exp for f in fo], P.rotor_inertia_manufacturer(a), cad)
            if not (np.isfinite(ka.kt) and ka.kt > 0 and np.isfinite(ka.alpha) and ka.alpha > 0):
                raise LogError(f"{', '.join(preconditions.label(e) for e in exps)}: K_T {ka.kt:.3g} and alpha "
                               f"{ka.alpha:.3g} of {a} from these logs are not both positive (the rotor does not "
                               "follow eq. 7: check the command's sign and the encoder)")
            kt[k], alpha[k] = ka.kt, ka.alpha
            for f, e in zip(fo, exps):
                tf[k, _combination(e) - 1] = f.mu_exp / ka.kt
            rows[a] = dict(J_exp=[f.J_exp for f in fo], mu_exp=[f.mu_exp for f in fo],
                           offset_nm=[f.offset for f in fo], kt=ka.kt, alpha=ka.alpha,
                           eq11_residuals=ka.residuals.tolist())
            fits.setdefault("transmission", {})[a] = list(zip(exps, fo))
        details["transmission"] = rows
        est = est.replace(kt=kt, alpha=alpha, trans_friction=tf)
    else:
        notes.append("no transmission logs: K_T and alpha stay published")

    # 3. Section V
    if "leg" in kinds:
        say("Section V: leg friction and bias (eqs. 19-20, SISO), biases (eq. 20, MIMO)")
        fr, bias = est.friction.copy(), est.bias.copy()
        rows = {}
        for s in tb.SIDES:
            exps = [e for e in kinds["leg"] if e.meta["side"] == s]
            if not exps:
                continue
            rig = rigs.leg_rig(est, s)
            idx = [P.actuator_index(a) for a in rigs.LEG_ACTUATORS[s]]
            side_rows = {}
            for e in exps:
                if len(e.u) != 1:
                    continue
                a = next(iter(e.u))
                var = ("friction_mLA", "bias_mLA") if a.startswith("mLA") else ("friction_mLS", "bias_mLS")
                with _fitting([e], "leg friction fit (eqs. 19-20)"):
                    f = friction.fit_leg(rig, e, var)
                rig = f.rig
                side_rows[e.name] = dict(variables=list(var), values=f.values.tolist(), rms_deg=f.rms_deg[e.name])
            mimo = [e for e in exps if len(e.u) == 2]
            if mimo:
                with _fitting(mimo, "leg bias fit (eq. 20)"):
                    f = friction.fit_leg(rig, mimo, ("bias_mLA", "bias_mLS"))
                rig = f.rig
                side_rows["mimo"] = dict(variables=["bias_mLA", "bias_mLS"], values=f.values.tolist(),
                                         rms_deg=f.rms_deg)
            fr[idx] = np.asarray(rig.friction)
            bias[idx] = np.asarray(rig.bias)
            fits.setdefault("legs", {})[s] = (rig, exps)
            rows[s] = side_rows
        details["legs"] = rows
        est = est.replace(friction=fr, bias=bias)
    else:
        notes.append("no leg logs: the model's friction stays published, biases from Appendix A")

    cad = P.model(pub)
    # 4. Section VII-A
    if "spring" in kinds:
        say("Section VII-A: spring stiffness and preload")
        k_b, pre = est.spring_k.copy(), est.spring_preload.copy()
        rows = {}
        for e in kinds["spring"]:
            with _fitting([e], "spring fit (eq. 24)"):
                f = springs.fit_spring(cad, e)
            j = tb.SIDES.index(f.side)
            k_b[j], pre[j] = f.stiffness, f.preload
            rows[f.side] = dict(stiffness=f.stiffness, preload_nm=f.preload, stiffness_std=f.stiffness_std,
                                eq24_stiffness=f.eq24_stiffness, eq24_preload_nm=f.eq24_preload)
            fits.setdefault("springs", {})[f.side] = f
        details["springs"] = rows
        est = est.replace(spring_k=k_b, spring_preload=pre)
    else:
        notes.append("no spring logs: spring stiffness stays published")

    # 5. Section VI
    if "balance" in kinds:
        say("Section VI: static COM check")
        with _fitting(kinds["balance"], "COM check"):
            check = balance.com_check(cad, kinds["balance"])
            shift = balance.estimate_torso_com(cad, kinds["balance"])
        details["com_check"] = dict(distance_mm={k: v.tolist() for k, v in check.distance_mm.items()},
                                    support=check.support, max_abs_mm=check.max_abs_mm,
                                    torso_com_shift_mm=(1e3 * shift).tolist())
        fits["com_check"] = check
        est = est.replace(torso_com_offset=shift)

    # 6. Section VIII
    hop = kinds.get("hopping", [])
    if hop:
        e = hop[0]
        say("Section VIII: cable stretch per motor (rotor and cable against the joint encoders)")
        ck, cd = est.cable_k.copy(), est.cable_d.copy()
        rows = {}
        for a in P.ACTUATORS:
            with _fitting([e], f"cable fit of {a}"):
                f = hopping_fit.fit_cable(e, est, a)
            k = P.actuator_index(a)
            ck[k], cd[k] = f.stiffness, f.damping
            rows[a] = dataclasses.asdict(f)
        details["cables"] = rows
        est = est.replace(cable_k=ck, cable_d=cd)
        say("Section VIII: hard stop and ground by replaying the hop on the 13-DoF model")
        with _fitting([e], "hopping fit"):
            hf = hopping_fit.fit_hopping(e, est, prior=hopping_fit.hop_values(pub), max_nfev=hop_max_nfev,
                                         progress=say)
        est = hopping_fit.with_hop_values(est, hf.values)
        identified = {k: hf.identified(k) for k in hf.values}
        details["hopping"] = dict(values=hf.values, rel_std=hf.rel_std, prior=hf.prior, rms_deg=hf.rms_deg,
                                  nfev=hf.nfev, identified=identified)
        fits["hopping"] = (e, hf)
    else:
        notes.append("no hopping log: cable, hard-stop and ground parameters stay published")

    # 7. validation
    say("validation: identified models against their logs")
    with _fitting(experiments, "validation"):
        details["validation"] = validate(est, fits)
    return Identification(est, details, fits, identified, notes)


def validate(est: P.MabelParams, fits: dict) -> dict:
    """rms (deg) of the identified models' responses against the logs: leg experiments
    (q_LA, q_LS from the motor encoders), the hop replayed open loop (torso, leg angles and
    leg shapes), and the cable stretch predicted from the joint side (motor deg)."""
    out = {}
    for s, (rig, exps) in fits.get("legs", {}).items():
        rig = rigs.leg_rig(est, s)
        for e in exps:
            _, _, _, Y = friction.experiment_arrays(e, s)
            Ys = friction.simulate(rig, e)
            cols = [j for j, a in enumerate(rigs.LEG_ACTUATORS[s]) if a in e.u]
            gears = np.array([abs(tb.GEAR_LA), tb.GEAR_LS])[cols]
            out[e.name] = float(np.rad2deg(np.sqrt(np.mean(((Ys[:, cols] - Y[:, cols]) / gears) ** 2))))
    if "hopping" in fits:
        e, hf = fits["hopping"]
        q = hopping_fit.measured_coordinates(e)[hopping_fit.release_index(e):]
        qs = hopping_fit.replay_log(e, est)
        cols = [hopping_fit.INDEX[c] for c in ("tor", "la_L", "ls_L", "la_R", "ls_R")]
        out["hopping"] = float(np.rad2deg(np.sqrt(np.mean((qs[:, cols] - q[:, cols]) ** 2))))
        for a in P.ACTUATORS:
            sim = hopping_fit.simulate_cable(e, est, a)
            meas = hopping_fit.cable_inputs(e, a)[3]
            out[f"hopping_cable_{a}"] = float(np.rad2deg(np.sqrt(np.mean((sim - meas) ** 2))))
    return out


# ----- what the logs cannot identify ----------------------------------------------------------
NEEDS_BIAS = "needs a bias log of the actuator (Appendix A) or a leg log commanding it (Section V)"
NEEDS_TRANSMISSION = ("needs two or more transmission logs of the actuator, of different pulley combinations "
                      "(Section IV, eq. 12)")
NEEDS_COMBINATION = "needs a transmission log of that pulley combination (Section IV, eq. 7)"
NEEDS_LEG = "needs a SISO leg log commanding the actuator (Section V, eq. 19)"
NEEDS_SPRING = "needs a spring log of that side (Section VII-A)"
NEEDS_HOP = "needs a hopping log (Section VIII)"


def coverage(experiments) -> dict:
    """{parameter of :func:`parameter_table`: why these logs cannot identify it} from the logs'
    kinds and metadata alone, before any fit (the parameters absent keep the published
    values). The hopping fit may leave some of its variables undetermined as well: see
    :func:`not_identified`."""
    kinds = _by_kind(experiments)
    legs = kinds.get("leg", [])
    trans = {a: {_combination(e) for e in kinds.get("transmission", []) if e.meta["actuator"] == a}
             for a in P.ACTUATORS}
    siso = {next(iter(e.u)) for e in legs if len(e.u) == 1}
    mimo = {a for e in legs if len(e.u) == 2 for a in rigs.LEG_ACTUATORS[e.meta["side"]]}
    biased = {e.meta["actuator"] for e in kinds.get("bias", [])} | siso | mimo
    springs = {e.meta["side"] for e in kinds.get("spring", [])}
    why = {}
    for a in P.ACTUATORS:
        combos = trans[a] if len(trans[a]) >= 2 else set()
        if not combos:
            why[f"kt_{a}"] = why[f"alpha_{a}"] = NEEDS_TRANSMISSION
        for c in (1, 2, 3):
            if c not in combos:
                why[f"trans_friction_{a}_{c}"] = NEEDS_COMBINATION if combos else NEEDS_TRANSMISSION
        if a not in siso:
            why[f"friction_{a}"] = NEEDS_LEG
        if a not in biased:
            why[f"bias_{a}"] = NEEDS_BIAS
    for s in tb.SIDES:
        if s not in springs:
            why[f"spring_k_{s}"] = why[f"spring_preload_{s}"] = NEEDS_SPRING
    if not kinds.get("hopping"):
        for a in P.ACTUATORS:
            why[f"cable_k_{a}"] = why[f"cable_d_{a}"] = NEEDS_HOP
        for name in hopping_fit.HOP_VARIABLES:
            why[name] = NEEDS_HOP
    return why


def unfitted(ident: "Identification", before: dict) -> dict:
    """``before`` (:func:`coverage` of the logs) with the hopping fit's undetermined variables
    added, each with its 1-sigma relative error."""
    rel_std = ident.details.get("hopping", {}).get("rel_std", {})
    why = dict(before)
    for name, ok in ident.identified.items():
        if not ok:
            sd = rel_std.get(name)
            size = "unbounded" if sd is None or not np.isfinite(sd) else f"{sd:.0%}"
            why[name] = (f"the hop does not determine it (1-sigma relative error {size}, identified below "
                         f"{hopping_fit.IDENTIFIABLE:.0%}): the estimate stays near the published value the fit "
                         "starts from")
    return why


def not_identified(why: dict) -> list[dict]:
    """Per group of :func:`parameter_table` (its order), the parameters in ``why`` and the
    reasons: ``[{group, parameters, why}]``, nothing for a group identified in full."""
    rows: dict = {}
    for name, group, _, _ in parameter_table(P.published()):
        if name in why:
            row = rows.setdefault(group, dict(group=group, parameters=[], why=[]))
            row["parameters"].append(name)
            if why[name] not in row["why"]:
                row["why"].append(why[name])
    return [dict(r, why="; ".join(r["why"])) for r in rows.values()]


def identifies_nothing(experiments, why: dict) -> bool:
    """Whether logs with this :func:`coverage` determine nothing at all (no parameter, no
    COM check): every estimate would be a published value."""
    return len(why) == len(parameter_table(P.published())) and not any(e.kind == "balance" for e in experiments)


# ----- comparison with a truth --------------------------------------------------------------
def parameter_table(p: P.MabelParams) -> list[tuple]:
    """(name, group, value, unit) of every identified parameter of a set."""
    rows = []
    for k, a in enumerate(P.ACTUATORS):
        rows += [(f"kt_{a}", "motor_constant", p.kt[k], "N m/N m"),
                 (f"alpha_{a}", "rotor_inertia_scale", p.alpha[k], "-"),
                 (f"bias_{a}", "bias", p.bias[k], "N m"),
                 (f"friction_{a}", "friction", p.friction[k], "N m s/rad")]
        rows += [(f"trans_friction_{a}_{i + 1}", "friction", p.trans_friction[k, i], "N m s/rad") for i in range(3)]
    for j, s in enumerate(tb.SIDES):
        rows += [(f"spring_k_{s}", "spring_stiffness", p.spring_k[j], "N m/rad"),
                 (f"spring_preload_{s}", "spring_preload", p.spring_preload[j], "N m")]
    for k, a in enumerate(P.ACTUATORS):
        rows += [(f"cable_k_{a}", "cable_stretch", p.cable_k[k], "N m/rad"),
                 (f"cable_d_{a}", "cable_damping", p.cable_d[k], "N m s/rad")]
    rows += [("spring_d", "hard_stop", p.spring_d, "N m s/rad"), ("kd1", "hard_stop", p.kd1, "N m/rad^3"),
             ("kvd1", "hard_stop", p.kvd1, "N m s/rad"), ("kvd2", "hard_stop", p.kvd2, "N m (s/rad)^0.5")]
    rows += [("ground_stiffness", "ground", p.ground["stiffness"], "N/m^1.5"),
             ("ground_damping", "ground", p.ground["damping_in"], "N s/m^2.5"),
             ("ground_bristle_stiffness", "ground", p.ground["bristle_stiffness"], "1/m"),
             ("ground_coulomb", "ground", p.ground["coulomb"], "-")]
    return [(n, g, float(v), u) for n, g, v, u in rows]


def _hop_name(name: str) -> str | None:
    return name if name in hopping_fit.HOP_VARIABLES else None


def compare(truth: P.MabelParams | None, ident: Identification) -> dict:
    """Parameters (true, estimate, relative error) and the largest error per group."""
    est_rows = parameter_table(ident.params)
    true_rows = parameter_table(truth) if truth is not None else [(n, g, None, u) for n, g, _, u in est_rows]
    rel_std = ident.details.get("hopping", {}).get("rel_std", {})
    params, groups, groups_id, bias_err = [], {}, {}, []
    for (name, group, t, unit), (_, _, e, _) in zip(true_rows, est_rows):
        row = dict(name=name, group=group, unit=unit, true=t, estimate=e,
                   rel_error=None if t is None else abs(e - t) / abs(t))
        if t is not None and group == "bias":
            row["abs_error"] = abs(e - t)
            bias_err.append(abs(e - t))
        h = _hop_name(name)
        if h is not None and h in rel_std:
            row["rel_std"] = rel_std[h]
            row["identified"] = bool(ident.identified.get(h, False))
        params.append(row)
        if t is not None and group != "bias":
            groups[group] = max(groups.get(group, 0.0), row["rel_error"])
            if row.get("identified", True):
                groups_id[group] = max(groups_id.get(group, 0.0), row["rel_error"])
    out = dict(parameters=params)
    if truth is None:
        return out
    arx_bias = ident.details.get("bias_arx", {})
    out["max_rel_error"] = {g: groups.get(g) for g in GROUPS}
    out["max_rel_error_identified"] = {g: groups_id.get(g) for g in GROUPS}
    out["max_abs_bias_error_nm"] = max(bias_err) if bias_err else None
    out["max_abs_bias_error_arx_nm"] = (max(abs(v["bias_nm"] - truth.bias[P.actuator_index(a)])
                                            for a, v in arx_bias.items()) if arx_bias else None)
    met = {g: (groups.get(g) is not None and groups[g] <= t) for g, t in TARGETS.items()}
    met["bias"] = out["max_abs_bias_error_nm"] is not None and out["max_abs_bias_error_nm"] <= BIAS_TARGET_NM
    out["targets"] = dict(TARGETS, bias_nm=BIAS_TARGET_NM)
    out["targets_met"] = met
    if "com_check" in ident.details:
        shift = np.asarray(ident.details["com_check"]["torso_com_shift_mm"])
        out["torso_com_shift_error_mm"] = float(np.max(np.abs(shift - 1e3 * truth.torso_com_offset)))
    return out
