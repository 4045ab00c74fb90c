# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""A simulated IMU at a body's centre of mass: what it measures, with seeded noise.

The ideal measurement is the body's angular velocity and its specific force a - g, both in the
body frame, from ``Simulation.accelerations`` (the integrator's own acceleration, contacts
included). Noise, per axis, as the usual continuous-time IMU model has it (gz-sim and Kalibr
name the same quantities):

* white noise, a standard deviation per sample (rad/s for the gyroscope, m/s^2 for the
  accelerometer);
* a bias that walks: b_k = b_{k-1} + sigma_b sqrt(t_k - t_{k-1}) n_k, sigma_b in rad/s/sqrt(s)
  or m/s^2/sqrt(s); at the first sample, the initial bias b_0 (a constant per axis, rad/s or
  m/s^2: a sensor's turn-on bias; zero by default).

Deterministic: each body draws from its own stream (numpy's PCG64 seeded with (seed, body
index)), 12 normals a sample whatever the settings, so a run's noise depends only on the seed
and the steps it was sampled at, and a recording replays bit for bit.
"""

from __future__ import annotations

from dataclasses import dataclass
import math

import numpy as np


# The largest standard deviation taken (rad/s, m/s^2, per sample or per sqrt(s)): far above any
# sensor, and small enough that what is derived from it stays finite (its square, the covariance
# published; a bias walked for years; a sample plus its noise).
MAX_SIGMA = 1.0e6

_BATCH = 64  # samples' normals drawn at once


@dataclass(frozen=True)
class ImuNoise:
    """Standard deviations of the white noise and of the bias walks, and the seed."""

    gyro_noise: float = 0.0  # rad/s per sample
    accel_noise: float = 0.0  # m/s^2 per sample
    gyro_bias_walk: float = 0.0  # rad/s/sqrt(s)
    accel_bias_walk: float = 0.0  # m/s^2/sqrt(s)
    seed: int = 0
    gyro_bias: tuple = (0.0, 0.0, 0.0)  # rad/s, at the first sample
    accel_bias: tuple = (0.0, 0.0, 0.0)  # m/s^2, at the first sample

    def __post_init__(self) -> None:
        for name in ('gyro_noise', 'accel_noise', 'gyro_bias_walk', 'accel_bias_walk'):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or \
                    not math.isfinite(v) or not 0.0 <= v <= MAX_SIGMA:
                raise ValueError(f'imu {name} must be a number from 0 to {MAX_SIGMA:g}, got '
                                 f'{v!r}')
        for name in ('gyro_bias', 'accel_bias'):
            v = getattr(self, name)
            if not isinstance(v, tuple) or len(v) != 3 or not all(
                    isinstance(c, (int, float)) and not isinstance(c, bool) and
                    math.isfinite(c) and abs(c) <= MAX_SIGMA for c in v):
                raise ValueError(f'imu {name} must be 3 numbers from -{MAX_SIGMA:g} to '
                                 f'{MAX_SIGMA:g}, got {v!r}')
        if isinstance(self.seed, bool) or not isinstance(self.seed, int) or \
                not 0 <= self.seed < 2 ** 63:
            raise ValueError(f'imu seed must be an integer from 0 to 2^63 - 1, got '
                             f'{self.seed!r}')

    @property
    def noisy(self) -> bool:
        return any((self.gyro_noise, self.accel_noise, self.gyro_bias_walk,
                    self.accel_bias_walk, *self.gyro_bias, *self.accel_bias))


def specific_force(linear_acceleration, gravity):
    """a - g (m/s^2), what an accelerometer measures: +9.81 up at rest on the ground, 0 in free
    fall. World frame in, world frame out."""
    return tuple(a - g for a, g in zip(linear_acceleration, gravity))


class ImuSensor:
    """The noise of one body's IMU, sample after sample (see the module doc)."""

    def __init__(self, noise: ImuNoise, body_index: int) -> None:
        self.noise = noise
        self._rng = np.random.Generator(np.random.PCG64(np.random.SeedSequence(
            [noise.seed, body_index])))
        self._gyro_bias = tuple(float(c) for c in noise.gyro_bias)
        self._accel_bias = tuple(float(c) for c in noise.accel_bias)
        self._noisy = noise.noisy
        self._last_ns: int | None = None
        self._undo: tuple | None = None
        # The stream's normals, drawn _BATCH samples at a time (the same numbers as 12 a
        # sample: numpy's normals take no state across calls), and where the next sample's
        # start.
        self._normals: list[float] = []
        self._next = 0

    def sample(self, time_ns: int):
        """The noise of the sample at sim time ``time_ns``: (gyroscope rad/s, accelerometer
        m/s^2) to add to the true body-frame values; None without noise. Call it once for
        every sample, in time order (``undo`` takes back one that could not be sent): the
        noise stream then depends on the samples' times only."""
        n = self.noise
        if not self._noisy:
            return None
        gb, ab = self._gyro_bias, self._accel_bias
        i = self._next
        if i == len(self._normals):
            self._normals, i = self._rng.standard_normal(12 * _BATCH).tolist(), 0
        self._undo = (gb, ab, self._last_ns)
        self._next = i + 12
        g0, g1, g2, a0, a1, a2, wg0, wg1, wg2, wa0, wa1, wa2 = self._normals[i:i + 12]
        root = math.sqrt((time_ns - self._last_ns) * 1e-9) if self._last_ns is not None \
            else 0.0
        self._last_ns = time_ns
        kg, ka = n.gyro_bias_walk * root, n.accel_bias_walk * root
        gb = self._gyro_bias = (gb[0] + kg * wg0, gb[1] + kg * wg1, gb[2] + kg * wg2)
        ab = self._accel_bias = (ab[0] + ka * wa0, ab[1] + ka * wa1, ab[2] + ka * wa2)
        sg, sa = n.gyro_noise, n.accel_noise
        return ((gb[0] + sg * g0, gb[1] + sg * g1, gb[2] + sg * g2),
                (ab[0] + sa * a0, ab[1] + sa * a1, ab[2] + sa * a2))

    def undo(self) -> None:
        """Take back the last ``sample`` (its sample was not sent): the stream is as before."""
        if self._undo is not None:
            self._gyro_bias, self._accel_bias, self._last_ns = self._undo
            self._next -= 12
            self._undo = None
