# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""The integrators compared: rb_sim_ros's methods, MuJoCo's and scipy's DOP853.

Every runner simulates a ``Scene`` with a fixed step dt (s) (DOP853: a relative tolerance)
and has the same two calls:

* ``run(scene, step, times)``: [(R body to world, omega world (rad/s))] at ``times`` (s), each a
  multiple of dt; raises ``Diverged`` if the state stops being finite (or MuJoCo flags it);
* ``seconds_per_sim_second(scene, step, repeats)``: wall time of a whole run without sampling,
  the minimum of ``repeats`` runs, divided by the simulated time.

MuJoCo's model is one body on a free joint with the scene's mass and full inertia, gravity
off, contacts off. Its conventions, checked by the order test before anything is timed:
qpos[3:7] is the orientation quaternion (w, x, y, z), body to world; qvel[3:6] is the angular
velocity in the body (local) frame; data.xfrc_applied[body, 3:6] is a world-frame torque about
the centre of mass.
"""

from __future__ import annotations

import math
import time

import mujoco
import numpy as np

from bench import references
from bench.scenes import Scene
from rb_sim_ros import IntegrationError, METHODS, RigidBody, State, Stepper, Wrench
from rb_sim_ros.core import so3

# MuJoCo prints its warnings (and appends them to MUJOCO_LOG.TXT in the working directory)
# unless a handler takes them; the runners read the warning counters instead.
MUJOCO_WARNINGS: list[str] = []


def quiet_mujoco() -> None:
    """Collect MuJoCo's warnings in MUJOCO_WARNINGS instead of printing them."""
    if mujoco.get_mju_user_warning() is None:
        mujoco.set_mju_user_warning(MUJOCO_WARNINGS.append)


# MuJoCo resets the simulation after any of these.
BAD_STATE_WARNINGS = (mujoco.mjtWarning.mjWARN_BADQPOS, mujoco.mjtWarning.mjWARN_BADQVEL,
                      mujoco.mjtWarning.mjWARN_BADQACC)


class Diverged(RuntimeError):
    """A run stopped being finite (or MuJoCo reset it); ``step`` is where, if known."""

    def __init__(self, message: str, step: int | None = None) -> None:
        super().__init__(message)
        self.step = step


def _events(scene: Scene, dt: float, times) -> list[tuple[int, str, object]]:
    """Step indices at which something happens, in order: ('torque', tau) at each segment's
    start, ('sample', None) at each time in ``times``. Every time must be a multiple of dt."""
    def index(t):
        k = round(t / dt)
        if abs(k * dt - t) > 1e-9 * max(1.0, t):
            raise ValueError(f'{t} s is not a multiple of dt = {dt} s')
        return k
    events = [(index(t0), 0, 'torque', tau) for t0, _, tau in scene.segments()]
    events += [(index(float(t)), 1, 'sample', None) for t in times]
    return [(k, what, arg) for k, _, what, arg in sorted(events, key=lambda e: e[:2])]


class Ours:
    """rb_sim_ros's Stepper with one of multistep.METHODS."""

    kind = 'rb_sim_ros'

    def __init__(self, method: str) -> None:
        self.method = method
        self.name = f'rb_sim_ros {method}'
        self.order = METHODS[method].order

    def stepper(self, scene: Scene, dt: float) -> Stepper:
        state = State(rotation=scene.rotation0, angular_velocity=scene.omega0_world)
        return Stepper(RigidBody(scene.mass, scene.inertia_body), dt, state,
                       method=self.method)

    def run(self, scene: Scene, dt: float, times=None) -> list:
        times = scene.sample_times() if times is None else times
        s = self.stepper(scene, dt)
        out = []
        try:
            for k, what, tau in _events(scene, dt, times):
                s.step(k - s.step_count)
                if what == 'torque':
                    s.set_wrench(Wrench(torque=tau))
                else:
                    st = s.state
                    out.append((st.rotation, st.angular_velocity))
        except IntegrationError as e:
            raise Diverged(str(e), e.step) from None
        return out

    def seconds_per_sim_second(self, scene: Scene, dt: float, repeats: int = 3) -> float:
        best = math.inf
        events = _events(scene, dt, [])
        end = round(scene.t_end / dt)
        for _ in range(repeats):
            s = self.stepper(scene, dt)
            t = time.perf_counter()
            for k, _, tau in events:
                s.step(k - s.step_count)
                s.set_wrench(Wrench(torque=tau))
            s.step(end - s.step_count)
            best = min(best, time.perf_counter() - t)
        return best / scene.t_end


class MuJoCo:
    """One free body in MuJoCo with ``integrator`` 'Euler', 'implicitfast' or 'RK4'.

    ``nested`` puts the inertia on a welded child of a massless free body (the form of
    mujoco#3553) instead of on the free body itself.
    """

    kind = 'mujoco'
    ORDERS = {'Euler': 1, 'implicitfast': 1, 'implicit': 1, 'RK4': 4}

    def __init__(self, integrator: str, nested: bool = False) -> None:
        self.integrator = integrator
        self.nested = nested
        self.name = f'MuJoCo {integrator}' + (' (nested inertia)' if nested else '')
        self.order = self.ORDERS[integrator]

    def model(self, scene: Scene, dt: float):
        i = scene.inertia_body
        inertial = (f'<inertial pos="0 0 0" mass="{float(scene.mass)!r}" fullinertia="'
                    + ' '.join(repr(float(c)) for c in (i[0, 0], i[1, 1], i[2, 2], i[0, 1],
                                                        i[0, 2], i[1, 2])) + '"/>')
        payload = f'<body name="payload">{inertial}</body>' if self.nested else inertial
        xml = (f'<mujoco><option timestep="{float(dt)!r}" integrator="{self.integrator}" '
               'gravity="0 0 0"><flag contact="disable"/></option><worldbody>'
               f'<body name="b"><freejoint/>{payload}</body></worldbody></mujoco>')
        quiet_mujoco()
        m = mujoco.MjModel.from_xml_string(xml)
        d = mujoco.MjData(m)
        d.qpos[3:7] = references.quaternion_wxyz(scene.rotation0)
        d.qvel[3:6] = scene.omega0_body  # free joint: angular velocity in the body frame
        return m, d

    @staticmethod
    def state(d) -> tuple[np.ndarray, np.ndarray]:
        """(R, omega world) of the free body."""
        rot = references.matrix_from_wxyz(d.qpos[3:7])
        return rot, rot @ d.qvel[3:6]

    @staticmethod
    def flagged(d) -> str | None:
        """The name of the first 'bad value' warning MuJoCo raised (it then resets the state to
        the model's initial one, so the state stays finite), or None."""
        for warning in BAD_STATE_WARNINGS:
            if d.warning[warning].number:
                return warning.name
        return None

    @classmethod
    def advance(cls, m, d, n: int, done: int) -> None:
        """n more steps; Diverged if MuJoCo flagged a bad position, velocity or acceleration
        (and reset the simulation), or the state is not finite."""
        if n:
            mujoco.mj_step(m, d, nstep=n)
        flag = cls.flagged(d)
        if flag or not (np.all(np.isfinite(d.qpos)) and np.all(np.isfinite(d.qvel))):
            raise Diverged(f'MuJoCo: {flag or "non-finite state"} (simulation reset) within '
                           f'steps {done}..{done + n}', done)

    def run(self, scene: Scene, dt: float, times=None) -> list:
        times = scene.sample_times() if times is None else times
        m, d = self.model(scene, dt)
        out, steps = [], 0
        for k, what, tau in _events(scene, dt, times):
            self.advance(m, d, k - steps, steps)
            steps = k
            if what == 'torque':
                d.xfrc_applied[1, 3:6] = tau
            else:
                out.append(self.state(d))
        return out

    def seconds_per_sim_second(self, scene: Scene, dt: float, repeats: int = 3) -> float:
        best = math.inf
        events = _events(scene, dt, [])
        end = round(scene.t_end / dt)
        for _ in range(repeats):
            m, d = self.model(scene, dt)
            t, steps = time.perf_counter(), 0
            for k, _, tau in events:
                if k > steps:
                    mujoco.mj_step(m, d, nstep=k - steps)
                steps = k
                d.xfrc_applied[1, 3:6] = tau
            mujoco.mj_step(m, d, nstep=end - steps)
            best = min(best, time.perf_counter() - t)
        return best / scene.t_end


class Dop853:
    """scipy's DOP853 on unit quaternion + Euler's equations in the body frame (the usual way
    to write it, and not the reference's world-frame form), step chosen by ``rtol``."""

    kind = 'scipy'
    name = 'scipy DOP853'
    order = None

    @staticmethod
    def run(scene: Scene, rtol: float, times=None) -> list:
        times = scene.sample_times() if times is None else times
        return references.integrate(scene, times, rtol=rtol, atol=1e-3 * rtol,
                                    formulation='quaternion')

    @staticmethod
    def seconds_per_sim_second(scene: Scene, rtol: float, repeats: int = 3) -> float:
        best = math.inf
        for _ in range(repeats):
            t = time.perf_counter()
            references.integrate(scene, [], rtol=rtol, atol=1e-3 * rtol,
                                 formulation='quaternion')
            best = min(best, time.perf_counter() - t)
        return best / scene.t_end


def steppers() -> list:
    """Every fixed-step integrator of the comparison: each of rb_sim_ros's methods, then
    MuJoCo's three."""
    return ([Ours(name) for name in METHODS]
            + [MuJoCo('Euler'), MuJoCo('implicitfast'), MuJoCo('RK4')])


def errors(states, ref) -> dict:
    """Orientation angle (rad) |log(R R_ref^T)| and |omega - omega_ref| (rad/s, world) at the
    final sample and the largest over all samples."""
    angle = [so3.angle_between(r, rr) for (r, _), (rr, _) in zip(states, ref)]
    omega = [float(np.linalg.norm(w - wr)) for (_, w), (_, wr) in zip(states, ref)]
    return {'angle_final': angle[-1], 'angle_max': max(angle), 'omega_final': omega[-1],
            'omega_max': max(omega)}
