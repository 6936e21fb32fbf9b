"""Running controller: flight LQR, momentum-compensated reference, stance inverse dynamics,
sliding transition, and short closed-loop runs on flat and rough ground."""
import jax
import jax.numpy as jnp
import numpy as np
import pytest
import scipy.linalg

from bipedlab.robots.atrias import controller_model as rm
from bipedlab.robots.atrias import study as ra

MP = rm.ModelParams(m=59.0, I_t=1.37, I_m=1.0, d=0.1, mu=0.8)


def test_flight_lqr_gain_equals_scipy_riccati():
    A, B = rm.flight_reduced_system(MP.I_t, MP.I_m)
    # the reduced system is controllable (the full 6-state one is rank deficient by 2)
    ctrb = np.hstack([np.linalg.matrix_power(A, k) @ B for k in range(4)])
    assert np.linalg.matrix_rank(ctrb) == 4
    A6 = np.zeros((6, 6)); A6[:3, 3:] = np.eye(3)
    B6 = np.zeros((6, 2)); B6[3, :] = -1 / MP.I_t; B6[4, 0] = B6[5, 1] = 1 / MP.I_m
    assert np.linalg.matrix_rank(np.hstack([np.linalg.matrix_power(A6, k) @ B6 for k in range(6)])) == 4
    Q, R = np.diag([4e5, 4e5, 100.0, 100.0]), np.eye(2)
    X = scipy.linalg.solve_continuous_are(A, B, Q, R)
    K_ref = np.linalg.solve(R, B.T @ X)
    np.testing.assert_allclose(rm.lqr_gain(A, B, Q, R), K_ref, rtol=1e-8)
    assert np.all(np.linalg.eigvals(A - B @ K_ref).real < 0)


def test_compensated_reference_minimises_on_the_reachable_set():
    th_star, C, H = np.deg2rad(10.0), 1.37 * 0.2 + 1.0 * (2 * np.pi + 0.3), 0.7
    th, _ = rm.compensated_reference(MP, th_star, C, H, 4.0, 1.0)
    grid = np.linspace(-1, 1, 200001)
    phi = (C - MP.I_t * grid) / (2 * MP.I_m)
    cost = 4.0 * (grid - th_star) ** 2 + (phi - np.pi) ** 2
    assert float(th) == pytest.approx(grid[np.argmin(cost)], abs=2e-5)


def _constrained_forward(q6, qd6, u):
    """Forward dynamics of eq. (3) with the foot held (eq. 6): accelerations and GRF."""
    M, J = np.asarray(rm.mass6(MP)), np.asarray(rm.jac6(MP, q6))
    K = np.block([[M, -J.T], [J, np.zeros((2, 2))]])
    rhs = np.concatenate([np.asarray(rm.select6()) @ u - np.asarray(rm.bias6(MP)),
                          -np.asarray(rm.jdot_qd6(MP, q6, qd6))])
    sol = np.linalg.solve(K, rhs)
    return sol[:6], sol[6:]


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_stance_inverse_dynamics_produces_the_commanded_grf(seed):
    rng = np.random.default_rng(seed)
    q6 = jnp.array([0.1, 0.92, 0.17, np.pi + 0.2 * rng.uniform(-1, 1), np.pi + 0.3 * rng.uniform(-1, 1), 0.82])
    qd6 = jnp.asarray(rng.standard_normal(6))
    F = np.array([rng.uniform(-400, 400), rng.uniform(300, 3000)])
    thdd = rng.uniform(-20, 20)
    z = np.asarray(rm.inverse_dynamics(MP, q6, qd6, jnp.asarray(F), thdd))
    acc, grf = _constrained_forward(q6, qd6, z[:3])
    np.testing.assert_allclose(grf, F, rtol=1e-9, atol=1e-7)
    assert acc[2] == pytest.approx(thdd, abs=1e-8)
    np.testing.assert_allclose(acc[[0, 1, 3, 4, 5]], z[3:], atol=1e-8)


def test_sliding_solve_satisfies_friction_and_vertical_contact():
    q6 = jnp.array([0.0, 0.93, 0.17, np.pi - 0.3, np.pi + 0.3, 0.83])
    qd6 = jnp.array([4.9, -1.5, 0.1, 2.0, -3.0, -0.5])
    tau_a, Fy, ldd = 250.0, 900.0, -3.0
    w = np.asarray(rm.sliding_dynamics(MP, q6, qd6, tau_a, Fy, ldd, 1.0))
    qdd = np.array([w[2], w[3], w[4], w[5], w[6], ldd])
    M, J, S = (np.asarray(a) for a in (rm.mass6(MP), rm.jac6(MP, q6), rm.select6()))
    u = np.array([tau_a, w[0], w[1]])
    F = np.array([w[7], Fy])
    np.testing.assert_allclose(M @ qdd + np.asarray(rm.bias6(MP)), S @ u + J.T @ F, atol=1e-8)
    assert w[7] == pytest.approx(-MP.mu * Fy)
    assert J[1] @ qdd + float(rm.jdot_qd6(MP, q6, qd6)[1]) == pytest.approx(0.0, abs=1e-9)


def _pitch_after(out, trial, t_after=1.0):
    t, th = out["log"]["t"][trial], out["log"]["q"][trial][:, 2]
    return np.max(np.abs(np.rad2deg(th[t > t_after]) - 10.0))


def test_flat_ground_closed_loop_tracks_the_gait_and_rejects_a_pitch_push():
    """bipedlab's controller (the paper's with its two additions). Two trials batched:
    nominal start and a 10 deg trunk perturbation. Steady state (the last six apexes of 8 s,
    seed 0, measured -0.1 cm / +0.4 cm/s) within the paper's 1.8 cm and 0.8 cm/s; pitch back
    within 2 deg of the reference after two steps."""
    st = ra.Settings(terrain="flat", seconds=8.0, energy="conservation", controller="bipedlab")
    out, _ = ra.simulate(st, 2, theta0_offsets_deg=[0.0, 10.0], log=True)
    assert np.all(out["status"] == 0)
    k = out["n_apex"][0]
    b, v = out["bounce"][0, k - 6:k], out["speed"][0, k - 6:k]
    assert abs(b.mean() - 1.05) <= 0.018
    assert abs(v.mean() - 5.0) <= 0.008
    assert b.std() < 0.005 and v.std() < 0.02
    # pitch perturbation: rejected within about two steps (1 s)
    th = out["log"]["q"][1][:, 2]
    assert abs(np.rad2deg(th[0]) - 20.0) < 0.5
    assert _pitch_after(out, 1) < 2.0


def test_system_com_matches_the_plant_and_flight_predictor_is_ballistic():
    from bipedlab.robots.atrias import controller as rc
    from bipedlab.robots.atrias import robot as at
    from bipedlab.robots.atrias import loop as ar
    rp = at.AtriasParams()
    mp = MP.replace(m_f=rp.m_f)
    rng = np.random.default_rng(0)
    q = jnp.array([0.3, 1.0, 0.2, np.pi - 0.4, np.pi + 0.5, 0.9, 0.6])
    qd = jnp.asarray(rng.standard_normal(7))
    for a, b in zip(rm.system_com(mp, q, qd), ar.system_com(rp, q, qd)):
        np.testing.assert_allclose(np.asarray(a), np.asarray(b), atol=1e-12)
    _, cp, _, _ = ra.build(ra.Settings())
    cp = cp.replace(delay=0.01)
    qp, qdp = rc.predict_flight(cp, q, qd)
    assert float(qp[1]) == pytest.approx(float(q[1] + 0.01 * qd[1] - 0.5 * 9.81 * 1e-4))
    assert float(qdp[1]) == pytest.approx(float(qd[1] - 9.81 * 0.01))
    assert float(qp[0]) == pytest.approx(float(q[0] + 0.01 * qd[0]))


def test_the_papers_controller_rejects_a_pitch_push_and_holds_the_apex_energy_on_flat_ground(paper_flat_run):
    """The paper's controller as published (no energy integral, no landing-angle trim): the 10 deg trunk perturbation settles as in the nominal trial (after
    1.5 s, about four steps, the perturbed pitch stays as close to the reference as the
    unperturbed one's, within 0.5 deg), and with the stance spring about the stance's fixed
    foot point the proportional energy feedback holds the apex energy of the whole robot
    (M g y_apex + M v^2 / 2) at the target: measured -1.5 to -2.2 J over the last six apexes
    (seed 0; apex +3.0 to +3.3 cm, speed -6.6 to -7.1 cm/s, the split of that energy that
    remains), where the spring measured from the sinking foot left it 53 J below (steady speed
    -22 cm/s)."""
    out, (rp, _, _, _) = paper_flat_run  # flat, 8 s, energy conservation, 0 and 10 deg (conftest)
    assert np.all(out["status"] == 0)
    assert _pitch_after(out, 1, 1.5) <= _pitch_after(out, 0, 1.5) + 0.5
    k = out["n_apex"][0]
    b, v = out["bounce"][0, k - 6:k], out["speed"][0, k - 6:k]
    M = rp.m + 2 * rp.m_f
    de = M * 9.81 * (b - 1.05) + 0.5 * M * (v ** 2 - 25.0)
    assert np.all(np.abs(de) < 5.0) and v.std() < 0.02


def test_flat_ground_with_10ms_sensing_delay_tracks_the_gait():
    """10 ms delay with --delay-compensation (the controller knows its delay): the flight predictor, the delay-capped leg-length PD and the spring on the
    predicted leg length keep the gait (without them the speed ran away by +3 m/s in 8 s or the
    robot fell). Under the delay a stance still adds about 57 J at zero energy error (the
    paper's controller settles 93 J high, +21 cm/s); the spring measured from the sinking foot
    used to hide most of it, and with the spring about the stance's fixed foot point the energy
    integral takes about 8 s to remove it (measured seed 0, last four apexes of 9 s: +1.2 to
    +1.6 cm, -2.9 to -2.1 cm/s; at 5 s still -7 cm/s)."""
    st = ra.Settings(terrain="flat", seconds=9.0, energy="conservation", delay_ms=10.0, delay_compensation=True,
                     controller="bipedlab")
    out, _ = ra.simulate(st, 1)
    assert out["status"][0] == 0
    k = out["n_apex"][0]
    b, v = out["bounce"][0, k - 4:k], out["speed"][0, k - 4:k]
    assert np.all(np.abs(b - 1.05) < 0.02) and np.all(np.abs(v - 5.0) < 0.05)


def test_the_papers_controller_under_a_10ms_delay_settles_faster_and_lower_on_flat_ground():
    """Sec. IV-C: under a 10 ms delay the controller, not knowing it, runs "significantly lower
    and faster" (+71.9 cm/s, -7.2 cm on rough terrain). The late spring force adds energy in
    every stance, and eq. 7's stiffness modulation, unlimited as in the paper, takes it out
    again at a higher speed: on flat ground the speed settles (seed 0, 9 s, the length of the
    delay-compensation test below, so that both run on one compiled program; with the modulation
    limited to 150 J and 50 % of k0, as bipedlab's controller once had it, it ran away by about
    0.3 m/s a step and fell). Where it settles depends on the CPU's rounding: on a two-core Intel
    Xeon the last four apexes of 8 s lay within +83.5 to +84.3 cm/s; on a two-core AMD EPYC the
    apex speed alternates between about +82 and +85 cm/s from step to step (8, 9 and 12 s alike).
    Asserted: no fall; settled, i.e. no drift (the last four apexes' mean within 1 cm/s of the
    four before) and no runaway (the last eight within 5 cm/s of each other, a sixth of one
    step's runaway); the error within a factor of two of the paper's +71.9 cm/s; the apex below
    the target."""
    st = ra.Settings(terrain="flat", seconds=9.0, energy="conservation", delay_ms=10.0)
    out, _ = ra.simulate(st, 1)
    assert out["status"][0] == 0
    k = out["n_apex"][0]
    b, v = out["bounce"][0, k - 4:k], out["speed"][0, k - 8:k]
    assert abs(v[4:].mean() - v[:4].mean()) < 0.01
    assert np.ptp(v) < 0.05
    v = v[4:]
    assert 0.719 / 2 <= v.mean() - 5.0 <= 0.719 * 2
    assert np.all(b < 1.05)


def test_rough_terrain_short_run_survives():
    st = ra.Settings(terrain="rough", step_height=0.25, distance=20.0, seed=3)
    out, _ = ra.simulate(st, 4)
    assert np.all(out["status"] == 0)
    assert np.all(out["x"] >= 20.0)


def _stance_q(mp, com, vcom, theta, foot, vfoot):
    """Local stance coordinates q6, qd6 putting the COM at com (moving at vcom, no pitch rate)
    and the stance foot at foot (moving at vfoot)."""
    hip = com - mp.d * np.array([np.sin(theta), np.cos(theta)])
    w, wd = foot - hip, vfoot - vcom
    l = np.linalg.norm(w)
    g = np.arctan2(w[0], w[1])
    q6 = jnp.array([com[0], com[1], theta, g, 2 * np.pi - g, l])
    qd6 = jnp.array([vcom[0], vcom[1], 0.0, (wd[0] * w[1] - wd[1] * w[0]) / l ** 2, 0.0, w @ wd / l])
    return q6, qd6


def test_stance_spring_is_conservative_about_the_touchdown_point_when_the_foot_sinks():
    """Eq. (7)'s spring acts about the spring-mass model's fixed foot point (sensed touchdown
    height, x where sliding stopped), not the real foot: with the foot sinking 1.5 cm into the
    ground and creeping 1 cm over the stance (as on the damped ground), the target GRF is
    k0 (l_rest - |r|) r / |r| with r from that point to the COM, and l_v' is the COM velocity
    along r. A point mass of the robot's mass driven by it through a whole stance keeps its
    energy plus the spring's, within 0.2 J; the same spring measured from the moving foot (the
    former reading) loses more than 10 J of it to the sinking foot."""
    from bipedlab.robots.atrias import controller as rc
    _, cp, _, _ = ra.build(ra.Settings(controller="paper"))
    mp, k0, m, g = cp.mp, float(cp.smm.k0), float(cp.mp.m), float(cp.mp.g)
    p_st = np.array([0.02, -0.0005])
    cs = rc.init_state(cp).replace(mode=jnp.asarray(rc.STANCE), l_rest=jnp.asarray(1.0), dE=jnp.asarray(0.0),
                                   x_st=jnp.asarray(p_st[0]), y_td=jnp.asarray(p_st[1]))
    spring = jax.jit(lambda q6, qd6: rc._spring_force(cp, cs, q6, qd6))
    theta = np.deg2rad(10.0)
    vf = np.array([-0.08, -0.12])                       # the foot creeps back and sinks

    def independent(com, vcom, ref):
        r = com - ref
        lv = np.linalg.norm(r)
        return max(k0 * (1.0 - lv), 0.0) * r / lv, r @ vcom / lv

    def stance(from_foot):
        com, v = np.array([-0.27, 0.9628]), np.array([4.9, -1.6])
        e0, dt, t = 0.5 * m * v @ v + m * g * com[1], 1e-4, 0.0
        while True:
            foot = p_st + vf * t
            if from_foot:
                F, _ = independent(com, v, foot)
            else:
                q6, qd6 = _stance_q(mp, com, v, theta, foot, vf)
                F, lv, lvd = map(np.asarray, spring(q6, qd6))
                F_ind, lvd_ind = independent(com, v, p_st)
                np.testing.assert_allclose(F, F_ind, atol=1e-9)
                assert float(lvd) == pytest.approx(lvd_ind, abs=1e-12)
            v = v + dt * (F / m - np.array([0.0, g]))
            com = com + dt * v
            t += dt
            lv = np.linalg.norm(com - (foot if from_foot else p_st))
            if lv >= 1.0 and (com - p_st) @ v > 0:
                return 0.5 * m * v @ v + m * g * com[1] + 0.5 * k0 * min(1.0 - lv, 0.0) ** 2 - e0, t

    de, t = stance(False)
    assert 0.09 < t < 0.15 and abs(de) < 0.2
    de_foot, _ = stance(True)
    assert de_foot < -10.0


def test_flight_feedforward_makes_the_reduced_system_follow_the_landing_reference():
    """III-C's u = u-dagger - K (x_r - x_r-dagger): u-dagger gives the reduced system (A_r, B_r)
    the reference's own acceleration (theta-dagger'' = 0, the landing hip angle's second
    derivative along a*(t), here by central differences), so started on the reference it stays
    there; without it the LQR lags the accelerating reference."""
    from bipedlab.control import slip
    from bipedlab.robots.atrias import controller as rc
    _, cp, _, _ = ra.build(ra.Settings(controller="paper"))
    theta, K = np.deg2rad(10.0), np.asarray(cp.K)
    A, B = rm.flight_reduced_system(float(cp.mp.I_t), float(cp.mp.I_m))
    gam = lambda t: float(rc.landing_hip_angle(cp, theta, slip.policy_angle(cp.policy, t)))
    t0, h = 0.5 * (cp.policy.t_min + cp.policy.t_max), 1e-4
    gdd = (gam(t0 + h) - 2 * gam(t0) + gam(t0 - h)) / h ** 2
    uff = jax.jit(lambda t: rc.flight_feedforward(cp, theta, t, 0.0))
    u = np.asarray(uff(t0))
    np.testing.assert_allclose(B @ u, [0.0, 0.0, 0.0, gdd], atol=1e-3 * abs(gdd) + 1e-9)

    def track(feedforward, t_end=0.03, dt=1e-4):
        ref = lambda t: np.array([theta, gam(t), 0.0, (gam(t + h) - gam(t - h)) / (2 * h)])
        x, t = ref(t0), t0
        while t < t0 + t_end:
            u = np.asarray(uff(t)) if feedforward else 0.0
            x = x + dt * (A @ x + B @ (u - K @ (x - ref(t))))
            t += dt
        return abs(x[1] - ref(t)[1])

    assert track(True) < 0.1 * track(False)
