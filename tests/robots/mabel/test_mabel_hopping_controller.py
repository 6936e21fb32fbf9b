"""The hopping controller of the identification paper's Appendix C: references (37)-(43),
phase transitions, the torso update (44), encoder quantisation and the PD law (34)."""
from __future__ import annotations

import jax.numpy as jnp
import numpy as np
import pytest

import bipedlab  # noqa: F401  (float64)
from bipedlab.robots.mabel.hopping import controller as hop

D = np.deg2rad


@pytest.fixture
def p():
    return hop.paper_params(encoder_counts=0.0, velocity_filter=0.0)


def _state(p, phase, **kw):
    c = hop.initial_state(p, jnp.zeros(4))
    fields = {f: getattr(c, f) for f in c.__dataclass_fields__}
    fields["phase"] = jnp.asarray(phase)
    fields.update({k: jnp.asarray(v) for k, v in kw.items()})
    return hop.HopState(**fields)


def test_nominal_targets_are_eq_37(p):
    """x^d = [pi - dLA/2 - hTor, 31.42 hLS_L, pi + dLA/2 - hTor, 31.42 hLS_R] with (46)."""
    xd = np.asarray(hop.nominal_targets(p, p.h_tor0))
    assert xd == pytest.approx([np.pi - D(15) - D(8), 31.42 * D(12), np.pi + D(15) - D(8), 31.42 * D(12)], abs=1e-12)
    # the legs are then symmetric about the vertical whatever the torso lean
    assert (xd[0] + D(8)) + (xd[2] + D(8)) == pytest.approx(2 * np.pi)


def test_references_of_every_phase(p):
    """Eqs. (38)-(43): stance LA references hold the torso at hTor and the splay at dLA;
    kick-off extends by delta-, lift-off retracts by delta+, IV/V freeze the LA references."""
    tor, la_r = D(5.0), D(190.0)
    h = jnp.asarray([0.0, 0.0, la_r, 0.0])
    g = 31.42
    xd = np.asarray(hop.nominal_targets(p, p.h_tor0))
    frozen = np.array([1.1, 2.2])
    c = _state(p, hop.FLIGHT, la_frozen=frozen, h_tor=p.h_tor0)
    ref = lambda ph: np.asarray(hop.reference(p, c, ph, tor, h))  # noqa: E731
    assert ref(hop.FLIGHT) == pytest.approx(xd)
    stance_l, stance_r = tor + la_r - D(8) - D(30), tor + la_r - D(8)
    assert ref(hop.TOUCHDOWN) == pytest.approx([stance_l, xd[1], stance_r, xd[3]])
    assert ref(hop.KICKOFF) == pytest.approx([stance_l, xd[1] - g * D(5), stance_r, xd[3] - g * D(13)])
    assert ref(hop.LEFT_UP) == pytest.approx([1.1, xd[1] + g * D(5), 2.2, xd[3] - g * D(13)])
    assert ref(hop.RIGHT_UP) == pytest.approx([1.1, xd[1] - g * D(5), 2.2, xd[3] + g * D(5)])
    assert ref(hop.RETRACT) == pytest.approx([1.1, xd[1] + g * D(5), 2.2, xd[3] + g * D(5)])


def _step(p, c, toes=(0.01, 0.01), phi_h=0.0, vrate=-1.0, h=(np.pi, 6.0, np.pi, 6.0), tor=0.1):
    return hop.update(p, c, jnp.asarray(h), jnp.asarray(tor), jnp.asarray(toes), jnp.asarray(phi_h),
                      jnp.asarray(vrate))


def test_landing_needs_both_toes(p):
    """S_I->II (38): touchdown is declared only when both toes are on the ground."""
    c = _state(p, hop.FLIGHT)
    c1, _ = _step(p, c, toes=(-0.001, 0.002))
    assert int(c1.phase) == hop.FLIGHT
    c2, _ = _step(p, c, toes=(-0.001, -0.0005))
    assert int(c2.phase) == hop.TOUCHDOWN and int(c2.touchdowns) == 1


def test_bottom_then_liftoff_branches(p):
    """(39): kick-off once the vertical boom rate stops falling; (40): IV_a, IV_b or V
    according to which toe leaves first; (41)-(42): V once the other one leaves."""
    c = _state(p, hop.TOUCHDOWN)
    assert int(_step(p, c, toes=(-1e-3, -1e-3), vrate=-0.5)[0].phase) == hop.TOUCHDOWN
    assert int(_step(p, c, toes=(-1e-3, -1e-3), vrate=-0.005)[0].phase) == hop.KICKOFF
    k = _state(p, hop.KICKOFF)
    assert int(_step(p, k, toes=(1e-3, -1e-3))[0].phase) == hop.LEFT_UP
    assert int(_step(p, k, toes=(-1e-3, 1e-3))[0].phase) == hop.RIGHT_UP
    both, _ = _step(p, k, toes=(1e-3, 1e-3))
    assert int(both.phase) == hop.RETRACT
    assert int(_step(p, _state(p, hop.LEFT_UP), toes=(1e-3, 1e-3))[0].phase) == hop.RETRACT
    assert int(_step(p, _state(p, hop.RIGHT_UP), toes=(1e-3, 1e-3))[0].phase) == hop.RETRACT


def test_liftoff_freezes_the_stance_leg_angle_references(p):
    """H1 h_III^ref(t_III->IV) and H3 h_III^ref are held through IV and V."""
    k = _state(p, hop.KICKOFF)
    c, _ = _step(p, k, toes=(1e-3, -1e-3), tor=D(4.0), h=(3.0, 6.0, D(195.0), 6.0))
    expect = np.asarray(hop._stance_la(p, p.h_tor0, D(4.0), D(195.0)))
    assert np.asarray(c.la_frozen) == pytest.approx(expect)


def test_retract_lasts_50_ms(p):
    """S_V->I (43): back to flight 0.05 s after entering V."""
    c = _state(p, hop.RETRACT, t=1.0, t_retract=1.0)
    for _ in range(49):
        c, _ = _step(p, c, toes=(0.05, 0.05))
        assert int(c.phase) == hop.RETRACT
    c, _ = _step(p, c, toes=(0.05, 0.05))
    assert int(c.phase) == hop.FLIGHT


def test_torso_update_is_eq_44(p):
    """h_Tor^d[k] = h_Tor^d0 + K_Tor (delta phi_h[k] - delta phi_h^d) at each touchdown after
    the first; nothing changes with the update switched off."""
    down = (-1e-3, -1e-3)
    c = _state(p, hop.FLIGHT)
    c, _ = _step(p, c, toes=down, phi_h=0.30)          # first touchdown: only remembered
    assert float(c.h_tor) == pytest.approx(float(p.h_tor0))
    c = _state(p, hop.FLIGHT, phi_last=c.phi_last, seen=True)
    c, _ = _step(p, c, toes=down, phi_h=0.30 - 0.08)   # travelled -0.08 rad of boom angle
    expect = float(p.h_tor0) + float(p.k_tor) * (-0.08 - D(-6.9))
    assert float(c.h_tor) == pytest.approx(expect)
    off = p.replace(torso_update=jnp.asarray(0.0))
    c = _state(off, hop.FLIGHT, phi_last=0.30, seen=True)
    c, _ = _step(off, c, toes=down, phi_h=0.22)
    assert float(c.h_tor) == pytest.approx(float(p.h_tor0))


def test_pd_law_signs_quantisation_and_saturation():
    """(34) with a 14-bit encoder: readings are multiples of 2 pi / 2^14; the leg-angle
    motor turns against q_LA (q_mLA = -23.53 q_LA), so a positive q_LA error gives a
    negative leg-angle command; commands saturate at the limits."""
    p = hop.paper_params(velocity_filter=0.0)
    q = 2 * np.pi / 2**14
    assert float(hop.quantise(p, jnp.asarray(10.3 * q))) == pytest.approx(10 * q)
    xd = np.asarray(hop.nominal_targets(p, p.h_tor0))
    c = hop.initial_state(p, jnp.asarray(xd))
    h = xd + np.array([-0.01, -0.5, 0.0, 0.0])
    _, u = _step(p, c, h=tuple(h), toes=(0.05, 0.05))
    u = np.asarray(u)
    assert u[0] < 0 and u[1] > 0          # LA below target -> push q_LA up through a negative gear
    big = xd + np.array([-5.0, -50.0, 5.0, 50.0])
    _, u = _step(p, c, h=tuple(big), toes=(0.05, 0.05))
    assert np.abs(np.asarray(u)) == pytest.approx(np.asarray(p.torque_limit))
