"""The robot's sensors: quantised encoders, commanded torque only, 1 kHz.

MABEL has position encoders on the motors, the joints, the spring pulleys, the torso and the
boom, and no force, torque or acceleration sensor; the computer logs the torque it commands,
not the torque the amplifier delivers. The model here:

* every encoder reads ``round((angle + n) / quantum) * quantum`` with ``quantum = 2 pi /
  2**bits`` (14-bit absolute magnetic encoders by default, on motors and joints alike; the
  boom's two encoders read the hip position as boom angles, ``x / R`` and ``y / R``);
* ``n`` is white Gaussian noise of ``noise`` counts (the noise LEVEL; 1 by default: an
  encoder that jitters by about one count);
* the amplifier adds its bias and white noise of ``noise * torque_noise`` N m (per 1 ms
  sample, held over the sample) to the command before it reaches the motor; the logged
  command carries neither;
* the scale of the spring experiments reads the toe force with ``noise * scale_noise`` N of
  white noise.

``bits = 0`` and ``noise = 0`` give exact readings (the noise-free data of the tests).
"""
from __future__ import annotations

import dataclasses

import numpy as np

#: Logging and control rate of the robot (Hz).
RATE_HZ = 1000.0
PERIOD = 1.0 / RATE_HZ


@dataclasses.dataclass(frozen=True)
class Sensors:
    """Sensor model. bits: encoder resolution (0: exact). noise: the noise LEVEL, encoder
    noise standard deviation in counts; also scales torque_noise (N m) and scale_noise (N).
    seed: of the noise draws."""

    bits: int = 14
    noise: float = 1.0
    torque_noise: float = 2e-3
    scale_noise: float = 0.5
    seed: int = 0

    @property
    def quantum(self) -> float:
        """Encoder resolution (rad); 0 for exact readings."""
        return 2.0 * np.pi / 2.0**self.bits if self.bits else 0.0

    def rng(self, stream: int) -> np.random.Generator:
        """An independent generator per experiment (stream), reproducible from the seed."""
        return np.random.default_rng([self.seed, stream])

    def encoder(self, angle, rng: np.random.Generator) -> np.ndarray:
        """Readings of true angles (rad): noise of ``noise`` counts, then quantisation."""
        angle = np.asarray(angle, float)
        q = self.quantum
        if self.noise > 0 and q > 0:
            angle = angle + self.noise * q * rng.standard_normal(angle.shape)
        return np.round(angle / q) * q if q > 0 else angle

    def torque_disturbance(self, shape, rng: np.random.Generator) -> np.ndarray:
        """Amplifier noise (N m, command units) added to the command, per sample."""
        return self.noise * self.torque_noise * rng.standard_normal(shape)

    def scale(self, force, rng: np.random.Generator) -> np.ndarray:
        force = np.asarray(force, float)
        return force + self.noise * self.scale_noise * rng.standard_normal(force.shape)

    def encoder_sd(self) -> float:
        """Standard deviation of an encoder reading's error (rad): noise and quantisation."""
        q = self.quantum
        return float(np.sqrt((self.noise * q) ** 2 + q**2 / 12.0))


def exact() -> Sensors:
    """Noise-free, unquantised sensors."""
    return Sensors(bits=0, noise=0.0)
