"""What each estimator needs of its logs, checked before any fit (and when a log is read).

A log the reader accepts can still leave an estimator without a solution: too few rows for
the ARX blocks, a command that never changes (its column and the constant's coincide, and
the normal equations are singular), a rotor that never moves, postures that all share one
deflection. :func:`problem` says, in one phrase, why one experiment cannot be fitted (None
when it can); :func:`set_problem` does the same for what the pipeline needs of several logs
together (two transmission logs of one actuator with distinct CAD inertias, one per
combination). :func:`check` raises :class:`~bipedlab.robots.mabel.sysid.logs.LogError` naming
the file.

==============  =================================================================================
experiment      needs
==============  =================================================================================
bias            :data:`BIAS_MIN_ROWS` samples (16 ARX blocks of 10 ms), a command that varies,
                a rotor that moves, and a full-rank ARX regressor (speed, two command lags, 1)
transmission    a command that varies and a rotor that moves (eq. 7's regressors independent)
leg             every logged command varies and moves its motor
spring          :data:`SPRING_MIN_POSTURES` postures, at least two deflections q_Bsp
balance         :data:`BALANCE_MIN_POSTURES` postures, at least two torso angles (the COM shift
                along and across the torso is then separable)
hopping         :data:`HOP_MIN_ROWS` samples from the release on, and over them every command
                varies and every motor moves
==============  =================================================================================
"""
from __future__ import annotations

import numpy as np

from bipedlab.robots.mabel import tables as tb
from bipedlab.robots.mabel.sysid import arx
from bipedlab.robots.mabel.sysid.logs import Experiment, LogError, motor_encoder
from bipedlab.robots.mabel.sysid.sensors import PERIOD

#: ARX defaults of the pipeline (Appendix A): blocks of 10 samples, two command lags
ARX_BLOCK, ARX_LAGS = 10, 2
#: samples a bias log needs: 4 (lags + 2) blocks of ARX_BLOCK samples, plus one
BIAS_MIN_ROWS = 4 * (ARX_LAGS + 2) * ARX_BLOCK + 1
SPRING_MIN_POSTURES = 3
BALANCE_MIN_POSTURES = 2
HOP_MIN_ROWS = 20
#: smallest singular value of a regressor (columns scaled to unit norm) that counts as full rank
RANK_TOLERANCE = 1e-9


def label(e: Experiment) -> str:
    """The file an experiment was read from, else its name."""
    return e.source or e.name


def _count(n: int, what: str) -> str:
    return f"{n} {what}{'' if n == 1 else 's'}"


def _varies(x) -> bool:
    x = np.asarray(x, float)
    return x.size > 1 and float(np.ptp(x)) > 0.0


def _full_rank(A: np.ndarray) -> bool:
    norms = np.linalg.norm(A, axis=0)
    if A.shape[0] < A.shape[1] or np.any(norms == 0.0) or not np.all(np.isfinite(A)):
        return False
    sv = np.linalg.svd(A / norms, compute_uv=False)
    return bool(sv[-1] > RANK_TOLERANCE * sv[0])


def _command_and_motor(e: Experiment, actuator: str, start: int = 0) -> str | None:
    if not _varies(e.u[actuator][start:]):
        return f"the command u_{actuator} never changes (no excitation: the fit's equations are singular)"
    enc = motor_encoder(actuator)
    if not _varies(e.enc[enc][start:]):
        return f"the motor encoder enc_{enc} never changes (the rotor does not move under u_{actuator})"
    return None


def _bias(e: Experiment) -> str | None:
    a = e.meta["actuator"]
    if len(e.t) < BIAS_MIN_ROWS:
        return (f"has {len(e.t)} samples; the bias fit (ARX on {ARX_BLOCK} ms blocks) needs at least "
                f"{BIAS_MIN_ROWS}")
    bad = _command_and_motor(e, a)
    if bad:
        return bad
    if not _full_rank(arx.bias_regressors(e.u[a], e.enc[motor_encoder(a)], ARX_LAGS, ARX_BLOCK, PERIOD)):
        return ("the ARX regressor (speed, command, lagged command, constant) is rank-deficient: the command "
                "must vary from block to block and the rotor respond")
    return None


def _leg(e: Experiment) -> str | None:
    for a in e.u:
        bad = _command_and_motor(e, a)
        if bad:
            return bad
    return None


def _spring(e: Experiment) -> str | None:
    side = e.meta["side"]
    if len(e.t) < SPRING_MIN_POSTURES:
        return f"has {_count(len(e.t), 'posture')}; the spring fit needs at least {SPRING_MIN_POSTURES}"
    if len(np.unique(e.enc[f"bsp_{side}"])) < 2:
        return f"enc_bsp_{side} has one value over all postures; the spring fit needs two deflections or more"
    return None


def _balance(e: Experiment) -> str | None:
    if len(e.t) < BALANCE_MIN_POSTURES:
        return f"has {_count(len(e.t), 'posture')}; the COM check needs at least {BALANCE_MIN_POSTURES}"
    if len(np.unique(e.enc["tor"])) < 2:
        return "enc_tor has one value over all postures; the torso COM estimate needs two torso angles or more"
    return None


def release_row(e: Experiment) -> int:
    """Row of a hopping log's release (metadata release_s, default 0)."""
    return int(round(float(e.meta.get("release_s", 0.0)) / PERIOD))


def _hopping(e: Experiment) -> str | None:
    k = release_row(e)
    if len(e.t) - k < HOP_MIN_ROWS:
        return (f"has {max(len(e.t) - k, 0)} samples from the release (release_s {e.meta.get('release_s', 0)}) on; "
                f"the hopping fits need at least {HOP_MIN_ROWS}")
    for a in tb.ACTUATORS:
        bad = _command_and_motor(e, a, k)
        if bad:
            return bad + " after the release"
    return None


def _transmission(e: Experiment) -> str | None:
    return _command_and_motor(e, e.meta["actuator"])


_CHECKS = dict(bias=_bias, transmission=_transmission, leg=_leg, spring=_spring, balance=_balance, hopping=_hopping)


def problem(e: Experiment) -> str | None:
    """Why the estimator of this experiment cannot fit it (one phrase), or None."""
    return _CHECKS[e.kind](e)


def cad_inertia(e: Experiment) -> float:
    """A transmission log's CAD inertia of its pulley combination (kg m^2): the metadata's
    ``cad_inertia``, else the CAD model's."""
    from bipedlab.robots.mabel.sysid import params as P

    a = e.meta["actuator"]
    return float(e.meta.get("cad_inertia", P.combination_inertia(a)[int(e.meta["combination"]) - 1]))


def set_problem(experiments) -> tuple[Experiment, str] | None:
    """(an experiment, why) when logs that are each fine cannot be fitted together, or None:
    two transmission logs of one actuator for one combination, or with one CAD inertia
    (eq. 12's two columns would coincide)."""
    seen: dict[str, list] = {}
    for e in experiments:
        if e.kind != "transmission":
            continue
        a, comb, J = e.meta["actuator"], str(e.meta["combination"]), cad_inertia(e)
        for other, c2, J2 in seen.get(a, []):
            if c2 == comb:
                return e, f"a second transmission log of {a} for combination {comb} (the first: {label(other)})"
            if abs(J - J2) <= 1e-9 * max(abs(J), abs(J2)):
                return e, (f"cad_inertia {J:g} kg m^2 equals that of {label(other)} (combination {c2}): "
                           f"K_T and alpha of {a} need distinct CAD inertias")
        seen.setdefault(a, []).append((e, comb, J))
    return None


def check(experiments) -> None:
    """LogError naming the file unless every estimator can fit its logs."""
    for e in experiments:
        why = problem(e)
        if why:
            raise LogError(f"{label(e)}: {why}")
    bad = set_problem(experiments)
    if bad:
        raise LogError(f"{label(bad[0])}: {bad[1]}")
