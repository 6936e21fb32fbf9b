"""Sensor stages for the sampled-data loop (:mod:`bipedlab.sim.loop`): pure functions a
robot composes into its ``sensor(params, sensor_state, x, t)``.

* :func:`quantise` / :func:`encoder` - an encoder's reading, rounded to its resolution;
* :func:`filtered_difference` - the first-order filtered backward difference of a reading;
* :func:`observer_blend` - a model prediction of the rate blended with the backward difference
  moved to the end of the period (no lag at the filter's strength);
* :class:`Delay`, :func:`delay_init`, :func:`delay_push` - a whole-sample delay line;
  :func:`delay_read` - a delay line of fixed length read back by a (traced) number of samples;
* :func:`held_noise` - noise redrawn every ``hold`` samples and held in between.
"""
from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp


def quantise(v, resolution):
    """``v`` rounded to a multiple of ``resolution`` (same units)."""
    return resolution * jnp.round(v / resolution)


def encoder(v, counts: int, exact=False):
    """Angle(s) read by an encoder of ``counts`` counts per revolution (exact when ``exact``)."""
    res = 2 * jnp.pi / counts
    return jnp.where(exact, v, jnp.round(v / res) * res)


def filtered_difference(v_prev, q, q_prev, period, pole):
    """v = F v_prev + (1 - F) (q - q_prev) / T, with F = ``pole`` in [0, 1)."""
    return pole * v_prev + (1.0 - pole) * ((q - q_prev) / period)


def observer_blend(v_prev, acceleration, q, q_prev, period, gain):
    """O (v_prev + a T) + (1 - O) ((q - q_prev) / T + a T / 2): the model's prediction over
    the period blended with the backward difference moved from mid-period to its end."""
    diff = (q - q_prev) / period
    return gain * (v_prev + period * acceleration) + (1.0 - gain) * (diff + 0.5 * period * acceleration)


@jax.tree_util.register_dataclass
@dataclasses.dataclass(frozen=True)
class Delay:
    """A delay line of ``buffer.shape[0]`` samples; ``head`` is the slot written next."""

    buffer: jax.Array
    head: jax.Array


def delay_init(value, samples: int) -> Delay:
    """A delay of ``samples`` whole samples (>= 1) prefilled with ``value``."""
    value = jnp.asarray(value)
    return Delay(jnp.broadcast_to(value, (samples,) + value.shape), jnp.asarray(0))


def delay_push(d: Delay, value):
    """Write ``value`` and read the value written ``samples`` samples ago: (delay, out)."""
    out = d.buffer[d.head]
    buf = d.buffer.at[d.head].set(value)
    return Delay(buf, (d.head + 1) % d.buffer.shape[0]), out


def delay_read(d: Delay, value, n):
    """Write ``value`` into the delay line and read the value written ``n`` samples ago
    (``value`` itself for n = 0, the prefill before n writes; 0 <= n < the line's length):
    (delay line, out). ``n`` may be traced, so one compiled program serves every delay up to
    the line's length; for n >= 1 the same values as a :func:`delay_push` line of n samples."""
    size = d.buffer.shape[0]
    buf = d.buffer.at[d.head].set(value)
    return Delay(buf, (d.head + 1) % size), buf[(d.head - n) % size]


def held_noise(key, k, hold: int, held, draw):
    """Noise redrawn by ``draw(key)`` when sample index ``k`` is a multiple of ``hold`` and held
    otherwise; ``held`` is the value in force. Returns the value for this sample."""
    fresh = draw(jax.random.fold_in(key, k // hold))
    return jnp.where(k % hold == 0, fresh, held)
