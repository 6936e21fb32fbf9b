"""Golden (characterisation) adapter: the ONLY module of tests/golden that imports bipedlab.

After a refactor that moves modules, rewrite the imports below (and only them); every
function returns plain dicts of floats / ints / bools / strings / numpy arrays, so the
recorded data in ``data/`` and the tests stay as they are. Re-record with
``python tests/golden/record.py`` (only when a change of results is intended).

Golden quantities (function -> data/<name>.json; tolerance rel 1e-9, abs floor 1e-12 unless
noted):

* ``five_link_gait()``        shipped five_link_0.8 gait: H0, c, alpha, theta+/-, z-, and the
                              stored design figures incl. the stored Poincaré eigenvalues.
* ``mabel_gait(name)``        shipped MABEL gait files nominal / efficient / fast: decision x,
                              constraints, z-/z+, feedforward beta, design figures, stored
                              Poincaré eigenvalues (hzd / pdff).  (Values read from files:
                              these are exact, compared at 1e-9 like everything else.)
* ``five_link_poincare(c)``   recomputed full Poincaré Jacobian (autodiff, gait.walking.
                              poincare_jacobian) at the shipped fixed point, for c = iolin / pd,
                              its eigenvalue moduli (sorted) and the restricted-map eigenvalue.
                              Eigenvalue moduli: rel 1e-7, abs 1e-9 -- eigenvalues of a
                              non-symmetric matrix amplify rounding of the Jacobian (condition
                              of the eigenproblem); the Jacobian itself is held at 1e-9 (abs
                              floor 1e-10 on entries that are ~0 by cancellation).
* ``mabel_restricted(name)``  recomputed restricted-map (eq. 48) fixed point and eigenvalues
                              of the nominal gait (gait.mabel_poincare.fixed_point); eigenvalue
                              moduli rel 1e-7 (as above). [slow]
* ``mabel_poincare(name)``    MABEL's maps at a shipped gait (nominal and the paper-model gaits)
                              as ``optimize mabel`` computes them: the restricted map (eq. 48)
                              on the gait's design model and the full map (eq. 44) under
                              PD + feedforward, each its fixed point, Jacobian and
                              eigenvalue moduli (rel 1e-7, as above). [slow]
* ``imported_gait(m, g)``     a gait file of a robot read from MJCF/URDF (RABBIT's), read back
                              against the robot file: constraints, fixed point, design figures.
* ``imported_poincare(m, g)`` its full Poincaré Jacobian under the gait's own I/O-linearising
                              gains, eigenvalue moduli, restricted-map eigenvalue. [slow]
* ``imported_walk(m, g, n)``  ``walk model`` on it, n steps: the record. [slow]
* ``imported_design(...)``    ``optimize model`` with its defaults on heron.xml (a file written
                              for the tests): the design record; SLSQP iterates rel 1e-6 as
                              five_link_optimize. [slow]
* ``five_link_restricted()``  the restricted-map eigenvalue alone (the cheap default sibling of
                              five_link_poincare).
* ``five_link_walk(c)``       3 steps of gait.walking.walk from the shipped fixed point
                              (iolin, pd): per-step z-, durations, step lengths, work, y^2.
* ``mabel_walk(c)``           sim.mabel_walk.simulate, 1 step (first 500-sample chunk at least),
                              nominal gait (and paper-575 under pdff / iolin / decentralized),
                              encoders, controllers pdff / iolin: every 50th
                              sample of logs z and u plus the last, and the final state.
* ``seven_link_walk(n)``      sim.seven_link_contact.simulate via studies.walk_seven_link.run_walk,
                              n steps: touchdowns, final state, every 200th log sample of x, u.
* ``atrias_run()``            sim.atrias_run via studies.run_atrias.simulate, 0.5 s flat, one
                              trial: final x, apex records, status.
* ``slip_run()``              sim.slip_run.run, pure spring-mass model, 6 bounces on flat ground.
* ``mabel_hop()``             studies.hop_mabel.run_hops(2): touchdown times and the 28-d
                              states at the touchdowns, final state.
* ``bench_standing()``        sim.scenarios.standing(0.2 s) + sim.rollout.rollout: final state.
* ``sysid_quick()``           sysid estimates per parameter of ``identify mabel --synthetic
                              --quick`` (the CLI record's ``parameters``); see the CLI test.
* ``five_link_optimize()``    studies.hzd_five_link.optimize (SLSQP gait design) figures. [slow]
                              SLSQP iterates: rel 1e-6 -- an iterative solver amplifies
                              1-ulp differences of the derivatives by its conditioning;
                              iteration count compared exactly.

CLI records (``cli_record(argv)``): ``bipedlab <argv> --json`` run in-process, stdout parsed;
compared with :func:`strip_timing` applied (see there for the excluded keys) at rel 1e-9,
abs 1e-12; strings / bools / None exactly; list lengths and dict keys exactly.
Exceptions: identify (rel 1e-6, abs 1e-9: least-squares fits through scipy.optimize with
finite iteration counts; the estimates are iterates, same argument as SLSQP),
optimize (rel 1e-6, see above).
"""
from __future__ import annotations

import contextlib
import io
import json

import numpy as np


def _a(x):
    return np.asarray(x, dtype=float)


# ----------------------------------------------------------------------------- gait files
def _hzd_gait(vc, z, design: dict) -> dict:
    """A one-phase HZD gait's record: its constraints, fixed point and design figures."""
    d = {k: _a(getattr(vc, k)) for k in ("H0", "c", "alpha", "theta_plus", "theta_minus")}
    d["z_minus"] = _a(z)
    d["design"] = design
    return d


def five_link_gait() -> dict:
    from bipedlab.gait import gaitfile

    vc, z, rec = gaitfile.shipped("bipedlab.robots.five_link", "five_link_0.8")
    return _hzd_gait(vc, z, rec["design"])


def mabel_gait(name: str) -> dict:
    from bipedlab.robots.mabel.walking import study as walk_mabel

    vc, gains, rec = walk_mabel.load_gait(name)
    d = {"constraints." + k: _a(getattr(vc, k)) for k in vc.__dataclass_fields__}
    d.update(x=_a(rec["x"]), z_minus=_a(rec["z_minus"]), z_plus=_a(rec["z_plus"]), beta=_a(gains.beta),
             speed=rec["speed"], design=rec["design"], poincare=rec["poincare"])
    return d


# ----------------------------------------------------------------------------- Poincaré
def _hzd_poincare(vc, st, ctrl, z, nodes: int) -> dict:
    """A one-phase HZD gait's full Poincaré Jacobian under ``ctrl`` at z (autodiff through the
    hybrid flow), its eigenvalue moduli (sorted) and the restricted map's eigenvalue."""
    import jax

    from bipedlab.gait import walking as gw

    J = np.asarray(jax.jit(lambda z: gw.poincare_jacobian(vc, st, ctrl, z))(z))
    rho = gw.restricted_eigenvalue(vc, st, float(vc.c @ z[st.n:]), nodes=nodes)
    return dict(jacobian=J, eigenvalue_moduli=np.sort(np.abs(np.linalg.eigvals(J)))[::-1],
                restricted_eigenvalue=float(rho))


def five_link_poincare(controller: str) -> dict:
    from bipedlab.robots.five_link import robot as five_link
    from bipedlab.robots.five_link import study as hz

    vc, z, _ = five_link_gait_objects()
    return _hzd_poincare(vc, five_link.stance(), hz.CONTROLLERS[controller], z, hz.NODES)


def five_link_restricted() -> dict:
    from bipedlab.gait import walking as gw
    from bipedlab.robots.five_link import robot as five_link
    from bipedlab.robots.five_link import study as hz

    vc, z, _ = five_link_gait_objects()
    st = five_link.stance()
    return dict(restricted_eigenvalue=gw.restricted_eigenvalue(vc, st, float(vc.c @ z[st.n:]), nodes=hz.NODES))


def five_link_gait_objects():
    from bipedlab.gait import gaitfile

    return gaitfile.shipped("bipedlab.robots.five_link", "five_link_0.8")


def mabel_restricted(name: str = "nominal") -> dict:
    import jax
    import jax.numpy as jnp

    from bipedlab.robots.mabel.walking import design as md
    from bipedlab.robots.mabel.walking import poincare as mp
    from bipedlab.robots.mabel.walking import stance as wk
    from bipedlab.robots.mabel.walking import study as walk_mabel

    _, _, rec = walk_mabel.load_gait(name)
    design = walk_mabel.design_from_record(rec)
    m = wk.walking_model()
    vc = jax.tree_util.tree_map(jnp.asarray, design.vc)
    _, x0 = md.section_state(m, design)
    xs, J, res = mp.fixed_point(lambda x: mp.restricted_map(m, vc, x), x0)
    return dict(fixed_point=_a(xs), jacobian=_a(J), eigenvalue_moduli=np.abs(np.asarray(mp.eigenvalues(J))))


def mabel_poincare(name: str) -> dict:
    """MABEL's step-to-step maps at a shipped gait, recomputed as ``optimize mabel`` computes
    them (walking.study.poincare: the restricted map, eq. 48, on the gait's design model, and
    the full map, eq. 44, on the walking model under PD + feedforward): each map's fixed
    point, Jacobian and eigenvalue moduli."""
    import jax
    import jax.numpy as jnp

    from bipedlab.robots.mabel.walking import design as md
    from bipedlab.robots.mabel.walking import poincare as mp
    from bipedlab.robots.mabel.walking import stance as wk
    from bipedlab.robots.mabel.walking import study as walk_mabel

    _, gains, rec = walk_mabel.load_gait(name)
    design = walk_mabel.design_from_record(rec)
    m = wk.walking_model()
    model = rec.get("design_model", "full")
    m_zd = m if model == "full" else md.design_model(m, model)
    vc = jax.tree_util.tree_map(jnp.asarray, design.vc)
    z0, x0 = md.section_state(m_zd, design)

    def found(xs, J):  # a search that left the walking range has no finite Jacobian: recorded so
        if not np.all(np.isfinite(np.asarray(J))):
            return dict(fixed_point_found=False)
        return dict(fixed_point=_a(xs), jacobian=_a(J), eigenvalue_moduli=np.abs(np.asarray(mp.eigenvalues(J))))

    out = {}
    xs, J, _ = mp.fixed_point(mp.restricted_at, x0, args=(m_zd, vc))
    out["restricted"] = found(xs, J)
    # the full map under PD + feedforward only, as optimize mabel: under eq. 42 at the gaits' own
    # eps per output (0.0031 on the stance leg shape) the Newton search leaves the walking range
    # from every one of these gaits (tried), which the stance model's 100-step walks do not
    zs, J, _ = mp.fixed_point(mp.full_map_at("pdff"), z0, args=(m, gains, vc))
    out["pdff"] = found(zs, J)
    return out


def _imported_files(model: str, gait: str):
    from importlib import resources

    here = resources.files("bipedlab.robots.imported").joinpath("data")
    return str(here.joinpath(model)), str(here.joinpath(gait))


def imported_gait(model: str, gait: str) -> dict:
    """A gait file of a robot read from MJCF/URDF (the shipped RABBIT's): its constraints,
    fixed point and stored design figures, as read back against the robot file."""
    from bipedlab.robots.imported import study as imported_study

    s, vc, z, rec = imported_study.load_gait(*_imported_files(model, gait))
    return _hzd_gait(vc, z, {k: v for k, v in rec["design"].items() if k not in ("stance", "swing")})


def imported_poincare(model: str, gait: str) -> dict:
    """The full Poincaré Jacobian (autodiff through the hybrid flow) of an imported robot's gait
    under its own I/O-linearising gains, at the stored fixed point; its eigenvalue moduli and
    the restricted map's eigenvalue."""
    from bipedlab.gait import study as hs
    from bipedlab.robots.imported import study as imported_study

    s, vc, z, rec = imported_study.load_gait(*_imported_files(model, gait))
    return _hzd_poincare(vc, s.study.stance, hs.controller_of(s.study, rec, "iolin"), z, s.study.nodes)


def imported_walk(model: str, gait: str, steps: int = 3) -> dict:
    """``walk model`` on an imported robot's gait (its record, timings left out)."""
    from bipedlab.robots.imported import study as imported_study

    rec = imported_study.walk(*_imported_files(model, gait), steps=steps)
    rec.pop("file", None)
    return rec


def imported_design(model: str, stance: str, swing: str, speed: float) -> dict:
    """``optimize model`` with its defaults (default clearance and the retry) on a robot file
    written for the tests (tests/robots/imported/data): the design record, file path left out."""
    import os

    from bipedlab.robots.imported import study as imported_study

    path = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "robots", "imported", "data", model)
    rec = imported_study.optimize(path, stance, swing, speed)
    rec.pop("file", None)
    return rec


# ----------------------------------------------------------------------------- closed loops
def five_link_walk(controller: str, steps: int = 3) -> dict:
    import jax
    import jax.numpy as jnp

    from bipedlab.gait import walking as gw
    from bipedlab.robots.five_link import robot as five_link
    from bipedlab.robots.five_link import study as hz

    vc, z, _ = five_link_gait_objects()
    st = five_link.stance()
    w = jax.jit(lambda z: gw.walk(vc, st, hz.CONTROLLERS[controller], z, steps))(jnp.asarray(z))
    return dict(z_minus=_a(w.z_minus), duration=_a(w.duration), step_length=_a(w.step_length),
                positive_work=_a(w.positive_work), y_sq=_a(w.y_sq), status=np.asarray(w.status).tolist())


def _rows(a, every: int):
    a = np.asarray(a)
    idx = np.unique(np.r_[np.arange(0, len(a), every), len(a) - 1])
    return idx, a[idx]


def mabel_walk(controller: str, steps: int = 1, sensing: str = "encoders", gait: str = "nominal") -> dict:
    import jax.numpy as jnp

    from bipedlab.robots.mabel.walking import stance as wk
    from bipedlab.robots.mabel.walking import loop as sw
    from bipedlab.robots.mabel.walking import study as wm

    vc, gains, rec = wm.load_gait(gait)
    setup = wm.setup_for(vc, gains, rec["design"]["period"], sensing=sensing)
    s, log = sw.simulate(wk.walking_model(), controller, setup, jnp.asarray(rec["z_plus"]), steps)
    idx, z = _rows(log["z"], 50)
    return dict(samples=len(log["z"]), rows=idx, z=z, u=_a(log["u"])[idx], final_z=_a(s.x.z), final_t=float(s.t),
                steps=int(s.x.step), fell=bool(sw.fell_flag(s)), distance=float(s.x.distance),
                work_pos=float(s.x.work_pos))


def seven_link_walk(steps: int = 1) -> dict:
    from bipedlab.robots.seven_link import study as w7

    r = w7.run_walk(steps, "tuned")
    n, nl = int(r.n_touchdowns), int(r.n_log_used)
    idx, x = _rows(np.asarray(r.log_x)[:nl], 200)
    return dict(status=int(r.status), t_end=float(r.t_end), x_end=_a(r.x_end), n_touchdowns=n,
                td_time=_a(r.td_time)[:n], td_hip_x=_a(r.td_hip_x)[:n], td_work=_a(r.td_work)[:n],
                work_abs=_a(r.work_abs), n_events=int(r.n_events), n_log_used=nl, log_rows=idx,
                log_t=_a(r.log_t)[idx], log_x=x, log_u=_a(r.log_u)[idx])


def atrias_run(seconds: float = 0.5) -> dict:
    from bipedlab.robots.atrias import study as ra

    # bipedlab's controller: the default before the paper's controller became the default
    out, _ = ra.simulate(ra.Settings(seconds=seconds, controller="bipedlab"), 1)
    k = int(out["n_apex"][0])
    return dict(status=int(out["status"][0]), x=float(out["x"][0]), n_apex=k,
                bounce=_a(out["bounce"][0, :k]), speed=_a(out["speed"][0, :k]), apex_y=_a(out["apex_y"][0, :k]),
                apex_x=_a(out["apex_x"][0, :k]), pitch_rms=float(out["pitch_rms"][0]))


def slip_run(n_steps: int = 6) -> dict:
    import jax

    from bipedlab.control import slip
    from bipedlab.robots.atrias import robot as at
    from bipedlab.robots.atrias import slip_run as sr
    from bipedlab.contact import terrain as tr

    p = slip.SlipParams(m=at.AtriasParams().m)
    gait = slip.Gait(1.05, 5.0)
    pol, _ = slip.swing_policy(p, gait)
    r = jax.jit(lambda: sr.run(p, gait, pol, tr.flat(20.0), n_steps))()
    return dict(bounce=_a(r.bounce), speed=_a(r.speed), apex_y=_a(r.apex_y), x=_a(r.x),
                steps_done=int(r.steps_done), fell=bool(r.fell))


def mabel_hop(hops: int = 2) -> dict:
    from bipedlab.robots.mabel.hopping import study as hm

    run = hm.run_hops(hops)
    idx = np.searchsorted(run.t, run.touchdowns)
    idx = np.minimum(idx, len(run.t) - 1)
    return dict(touchdowns=_a(run.touchdowns), states_at_touchdowns=_a(run.x[idx]), final_state=_a(run.x[-1]),
                samples=len(run.t), fell=bool(run.fell), peak_torques=np.abs(run.u).max(axis=0))


def bench_standing(seconds: float = 0.2) -> dict:
    import jax

    from bipedlab.robots.five_link import scenario as sc
    from bipedlab.sim.rollout import rollout

    params, x0, spec = sc.standing(seconds=seconds)
    res = jax.jit(lambda p, x: rollout(sc.flow, sc.pd_policy, sc.fell, spec, p, x))(params, x0)
    return dict(final=_a(res.final), status=int(res.status), failed_at=int(res.failed_at))


def sysid_quick(record: dict | None = None) -> dict:
    """Per-parameter estimates of the quick synthetic identification (from the CLI record,
    or running it)."""
    record = record or cli_record(["identify", "mabel", "--synthetic", "--quick"])
    return {"parameters": record["parameters"]}


def five_link_optimize() -> dict:
    from bipedlab.robots.five_link import study as hz

    return hz.optimize(0.8, "torque", "iolin")


# ----------------------------------------------------------------------------- CLI
def cli_record(argv) -> dict:
    """``bipedlab <argv> --json`` in-process; the parsed JSON record."""
    from bipedlab import cli

    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        rc = cli.main(list(argv) + ["--json"])
    assert rc == 0, rc
    return json.loads(buf.getvalue())
