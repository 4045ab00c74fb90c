# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""The integrators compared: rb_sim_ros's methods, MuJoCo's (one free joint) and scipy DOP853.

Each runner simulates a Scene with a step dt (DOP853: a tolerance) and returns (R, omega world)
at the scene's sample times; ``seconds_per_sim_second`` times a whole run without sampling.
"""

from __future__ import annotations

import time

import mujoco
import numpy as np
from scipy.integrate import solve_ivp

from rb_sim_ros import multistep, RigidBody, so3, State, Stepper, Wrench
import scenes as sc


class Ours:
    kind = 'rb_sim_ros'

    def __init__(self, method: str) -> None:
        self.method = method
        self.name = f'rb_sim_ros {method}'
        self.order = multistep.method_by_name(method).order

    def _stepper(self, scene, dt):
        return Stepper(RigidBody(1.0, list(scene.moments)), dt,
                       State(angular_velocity=scene.omega0), method=self.method)

    def run(self, scene, dt):
        s = self._stepper(scene, dt)
        out, times = [], list(scene.sample_times())
        for t0, t1, tau in scene.torque_segments():
            s.set_wrench(Wrench(torque=tau))
            while times and times[0] <= t1 + 1e-12:
                s.step(round(times.pop(0) / dt) - s.step_count)
                st = s.state
                out.append((st.rotation, st.angular_velocity))
            s.step(round(t1 / dt) - s.step_count)
        return out

    def seconds_per_sim_second(self, scene, dt, repeats=3):
        best = float('inf')
        for _ in range(repeats):
            s = self._stepper(scene, dt)
            t = time.perf_counter()
            for t0, t1, tau in scene.torque_segments():
                s.set_wrench(Wrench(torque=tau))
                s.step(round(t1 / dt) - s.step_count)
            best = min(best, time.perf_counter() - t)
        return best / scene.t_end


class MuJoCo:
    kind = 'mujoco'
    ORDERS = {'Euler': 1, 'implicitfast': 1, 'RK4': 4}

    def __init__(self, integrator: str) -> None:
        self.integrator = integrator
        self.name = f'MuJoCo {integrator}'
        self.order = self.ORDERS[integrator]

    def _model(self, scene, dt):
        i1, i2, i3 = scene.moments
        xml = (f'<mujoco><option timestep="{dt!r}" integrator="{self.integrator}" '
               'gravity="0 0 0"><flag contact="disable"/></option><worldbody>'
               '<body name="b"><freejoint/><inertial pos="0 0 0" mass="1" '
               f'diaginertia="{i1!r} {i2!r} {i3!r}"/></body></worldbody></mujoco>')
        m = mujoco.MjModel.from_xml_string(xml)
        d = mujoco.MjData(m)
        d.qvel[3:6] = scene.omega0  # free joint: angular velocity in the body frame; R(0) = I
        return m, d

    @staticmethod
    def _state(d):
        w, x, y, z = d.qpos[3:7]
        rot = so3.matrix_from_quaternion_xyzw((x, y, z, w))
        return rot, rot @ d.qvel[3:6]

    def run(self, scene, dt):
        m, d = self._model(scene, dt)
        out, times, steps = [], list(scene.sample_times()), 0
        for t0, t1, tau in scene.torque_segments():
            d.xfrc_applied[1, 3:6] = tau  # world-frame torque on the body
            while times and times[0] <= t1 + 1e-12:
                n = round(times.pop(0) / dt) - steps
                mujoco.mj_step(m, d, nstep=n)
                steps += n
                out.append(self._state(d))
            n = round(t1 / dt) - steps
            if n:
                mujoco.mj_step(m, d, nstep=n)
                steps += n
        return out

    def seconds_per_sim_second(self, scene, dt, repeats=3):
        best = float('inf')
        for _ in range(repeats):
            m, d = self._model(scene, dt)
            t, steps = time.perf_counter(), 0
            for t0, t1, tau in scene.torque_segments():
                d.xfrc_applied[1, 3:6] = tau
                n = round(t1 / dt) - steps
                mujoco.mj_step(m, d, nstep=n)
                steps += n
            best = min(best, time.perf_counter() - t)
        return best / scene.t_end


class Dop853:
    kind = 'scipy'
    name = 'scipy DOP853'
    order = None

    def run(self, scene, rtol):
        return sc.dop853(scene, scene.sample_times(), rtol=rtol, atol=rtol * 1e-2)

    def seconds_per_sim_second(self, scene, rtol, repeats=3):
        best = float('inf')
        for _ in range(repeats):
            y = np.concatenate([np.eye(3).reshape(9), scene.omega0])
            t = time.perf_counter()
            for t0, t1, tau in scene.torque_segments():
                y = solve_ivp(sc._rhs(scene.moments, tau), (t0, t1), y, method='DOP853',
                              rtol=rtol, atol=rtol * 1e-2).y[:, -1]
            best = min(best, time.perf_counter() - t)
        return best / scene.t_end


def errors(states, ref):
    """Orientation angle (rad) and |omega error| (rad/s): at the final time and the max."""
    angle = [so3.angle_between(r, rr) for (r, _), (rr, _) in zip(states, ref)]
    omega = [float(np.linalg.norm(w - wr)) for (_, w), (_, wr) in zip(states, ref)]
    return {'angle_final': angle[-1], 'omega_final': omega[-1], 'angle_max': max(angle),
            'omega_max': max(omega)}
