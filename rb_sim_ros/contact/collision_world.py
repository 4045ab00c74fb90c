# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Bodies that collide: one Stepper per moving body, static colliders and planes, and contacts.

    world = CollisionWorld([BodySpec('ball', mass=1.0, inertia=(4e-3,) * 3,
                                     initial_position=(0.0, 0.0, 1.0),
                                     colliders=(Sphere(0.1),))],
                           dt=1e-3, gravity=(0.0, 0.0, -9.81), restitution=0.5, friction=0.5,
                           planes=(Plane((0.0, 0.0, 1.0), 0.0),))
    world.step(1000)
    world.state('ball').position, world.last_stats.contacts

Each step, in this order (all deterministic: stable sorts, contacts in pair order, no
iteration over sets or dicts, no randomness):

1. every moving body that is awake takes one step of its own ``Stepper`` (Proof 3, its
   wrench, gravity and damping), exactly as without collisions;
2. broad phase (``world_kernels.sweep_and_prune`` on the colliders' world AABBs, each widened
   by its body's speculative margin; every collider against every plane by its support
   distance);
3. narrow phase (``narrow_phase``; sphere-sphere and sphere-plane pairs as numpy batches);
4. impulses and position correction (``contact_solver.solve``, warm-started from the impulses
   of the same contact features at the step before);
5. every body whose velocity or pose changed gets ``Stepper.apply_contact``: its multistep
   history restarts there, as at a change of wrench, so the next step does not extrapolate
   accelerations across the impulse. Bodies not touched keep their history (but for those
   that fall asleep: they are set to rest).

Sleeping (``sleep_time`` > 0, default 0.5 s): a body pressed by a contact whose points all
move slower than ``sleep_speed`` for sleep_time falls asleep at exact rest, together with every
body near it (broad-phase pairs, transitively) and only if they are all ready. A sleeper is not
integrated, and pairs like a static collider, so a resting pile costs no contacts. It wakes when
an awake body's AABB reaches it (the whole pile at once, in that step, taking the integration
it missed and its resting impulses as warm start), when its wrench changes, or when it, or a
body whose AABB reached it, is teleported; on waking its Stepper's clock catches up with the
steps it slept (while asleep it stands still). A changed wrench or a teleport also restarts an
awake body's count of slow steps.

The first step, and the first after ``CollisionWorld.set_state`` (use it, not the Stepper's,
to teleport a body), runs 2-5 on the starting state before it integrates. A world without
colliders on moving bodies skips 2-5 and costs what the Steppers cost. Wrenches are held as
usual: ``world.steppers[name].set_wrench(...)``.

The speculative margin of a body is the distance it can move in a step,
(|v| + |omega| rho) dt + |g| dt^2 with rho its colliders' reach from its centre of mass: a
contact with a gap smaller than the margin is solved as one that may close the gap in this step
but not more, so nothing tunnels (docs/collisions.md). ``speculative=False`` gives the
plain discrete method, which tunnels above about (r + w/2) / dt.
"""

from __future__ import annotations

from dataclasses import dataclass, field
import math
import time
from typing import Any, Sequence

import numpy as np

from rb_sim_ros.contact import contact_solver, narrow_phase, world_kernels as wk
from rb_sim_ros.contact.bodies import BodySpec, make_steppers
from rb_sim_ros.contact.collision_shapes import combined_material, Plane, Shape
from rb_sim_ros.core.rigid_body import finite_floats, non_negative, State
from rb_sim_ros.core.stepper import IntegrationError, step_all

# Warm-start keys pack (collider a, collider b, feature) into one int64; features are < 2^12.
FEATURE_BITS = 12
# Position corrections that turn a body by less than this (rad) are not applied: they are the
# rounding noise of contacts whose lever arm is parallel to the normal (a sphere's), and
# skipping them saves an exp() per body. A real correction is ~depth / size, 1e-6 rad or more.
MIN_TURN = 1e-12
# A solve whose bodies end with more kinetic energy than this relative gain raises: the solver
# keeps the energy to contact_solver.ENERGY_TOLERANCE (1e-9), rounding is ~1e-15.
GAIN_TOLERANCE = 1e-6


@dataclass
class StepStats:
    """What the last step did: ``candidate_pairs`` from the sweep, ``plane_pairs`` near a
    plane (both tested by the narrow phase: ``pairs_tested`` is their sum), ``contacts``
    found (speculative ones included), ``active`` (normal impulse > 0), ``touched`` bodies
    (written), ``sleeping`` bodies, solver ``colours``, the iterations each pass ran, and wall
    ``seconds`` per phase (statistics only). ``CollisionWorld.totals`` sums them over the
    steps taken (but for ``colours`` and ``sleeping``, which it leaves at 0: read them in
    ``last_stats``)."""

    candidate_pairs: int = 0
    plane_pairs: int = 0
    contacts: int = 0
    active: int = 0
    touched: int = 0
    sleeping: int = 0
    colours: int = 0
    velocity_iterations: int = 0
    position_iterations: int = 0
    seconds: dict[str, float] = field(default_factory=dict)

    @property
    def pairs_tested(self) -> int:
        return self.candidate_pairs + self.plane_pairs


@dataclass(frozen=True)
class WorldContact:
    """A contact of the last step, world frame: bodies ``a``, ``b`` (names; '' for a plane of
    ``planes``), point (m), normal (from a to b), depth (m), normal impulse (N s) on b."""

    a: str
    b: str
    point: np.ndarray
    normal: np.ndarray
    depth: float
    normal_impulse: float


@dataclass
class _Collider:
    shape: Shape
    owner: int          # index of the BodySpec (or -1 for ``planes``)
    body: int           # index among the moving bodies with colliders, or -1 if static
    position: np.ndarray
    rotation: np.ndarray


class CollisionWorld:
    """Moving and static bodies with collision shapes, stepped with a fixed dt (s).

    bodies: ``simulation.BodySpec`` values; ``colliders`` holds shapes of
    ``collision_shapes`` in the body frame; a ``static`` body never moves (infinite mass).
    planes: extra static ``Plane`` values in the world frame. gravity (m/s^2, world).
    restitution e in [0, 1] and friction mu >= 0 are those of every collider that has no
    material of its own. The other keywords are ``contact_solver.SolverSettings`` fields;
    ``bounce_threshold`` (m/s) must stay above |g| dt, or resting bodies bounce on the speed
    gravity gives them in one step.
    ``sleep_time`` (s, 0: never) and ``sleep_speed`` (m/s): see Sleeping above. Every
    argument is validated (ValueError naming it) before anything is built.
    """

    def __init__(self, bodies: Sequence[BodySpec], dt: float, gravity: Any = (0.0, 0.0, 0.0),
                 restitution: float = 0.0, friction: float = 0.5,
                 planes: Sequence[Plane] = (), integrator: str = 'eq27',
                 velocity_iterations: int = 10, position_iterations: int = 4,
                 slop: float = 1e-4, position_fraction: float = 0.8,
                 bounce_threshold: float = 0.1, tolerance: float = 1e-6,
                 speculative: bool = True, warm_start: bool = True,
                 batch_threshold: int = 48, sleep_time: float = 0.5,
                 sleep_speed: float = 1e-3, rolling_resistance: float = 0.0,
                 torsional_friction: float = 0.0) -> None:
        bodies = tuple(bodies)
        if not bodies or not all(isinstance(b, BodySpec) for b in bodies):
            raise ValueError('bodies must be one or more BodySpec')
        names = [b.name for b in bodies]
        if len(set(names)) != len(names):
            raise ValueError(f'body names must be unique, got {names}')
        self._gravity = finite_floats('gravity', gravity, 3)
        self.settings = contact_solver.SolverSettings(
            restitution=restitution, friction=friction, dt=dt,
            velocity_iterations=velocity_iterations, position_iterations=position_iterations,
            slop=slop, position_fraction=position_fraction, bounce_threshold=bounce_threshold,
            tolerance=tolerance, batch_threshold=batch_threshold,
            rolling_resistance=rolling_resistance, torsional_friction=torsional_friction)
        for name, flag in (('speculative', speculative), ('warm_start', warm_start)):
            if not isinstance(flag, bool):
                raise ValueError(f'{name} must be true or false, got {flag!r}')
        self.speculative, self.warm_start = speculative, warm_start
        sleep_time = non_negative('sleep_time', sleep_time)
        # Steps a supported body must stay slow before it sleeps (0: never).
        self._sleep_steps = math.ceil(sleep_time / self.settings.dt - 1e-9) if sleep_time else 0
        self._sleep_speed = non_negative('sleep_speed', sleep_speed)
        planes = tuple(planes)
        for i, p in enumerate(planes):
            if not isinstance(p, Plane):
                raise ValueError(f'planes[{i}] must be a Plane, got {p!r}')
        self.bodies = bodies
        self.dt = self.settings.dt
        self.steppers, self.static = make_steppers(bodies, dt, integrator, self._gravity)
        self._all_steppers = tuple(self.steppers.values())
        self._step_count = 0
        self.last_stats = StepStats()
        self.totals = StepStats()
        self._last = None
        self._warm_keys = np.zeros(0, dtype=np.int64)
        self._warm_normal = np.zeros(0)
        self._warm_tangent = np.zeros((0, 3))
        self._unchecked = True
        self._build(planes)

    @classmethod
    def from_config(cls, config, **kwargs) -> 'CollisionWorld':
        """The bodies, dt, gravity and integrator of a ``sim.simulation.Config`` (read by
        attribute: this layer does not import the one above it)."""
        return cls(config.bodies, config.dt, config.gravity, integrator=config.integrator,
                   **kwargs)

    # -- set-up --------------------------------------------------------------------------------
    def _build(self, planes) -> None:
        moving: list[int] = []         # BodySpec index of each moving body with colliders
        colliders: list[_Collider] = []
        plane_normals, plane_points, plane_owner, plane_shapes = [], [], [], []
        for owner, spec in enumerate(self.bodies):
            if not spec.colliders:
                continue
            if spec.static:
                st = self.static[spec.name]
                for shape in spec.colliders:
                    centre, rot = (st.position + st.rotation @ np.array(shape.position),
                                   st.rotation @ shape.rotation)
                    if isinstance(shape, Plane):
                        plane_normals.append(rot @ np.array(shape.normal))
                        plane_points.append(centre)
                        plane_owner.append(owner)
                        plane_shapes.append(shape)
                    else:
                        colliders.append(_Collider(shape, owner, -1, centre, rot))
            else:
                index = len(moving)
                moving.append(owner)
                for shape in spec.colliders:
                    colliders.append(_Collider(shape, owner, index,
                                               np.array(shape.position, dtype=float),
                                               np.array(shape.rotation)))
        for p in planes:
            plane_normals.append(np.array(p.normal))
            plane_points.append(np.array(p.position))
            plane_owner.append(-1)
            plane_shapes.append(p)
        self._moving_specs = moving
        self._moving_steppers = [self.steppers[self.bodies[i].name] for i in moving]
        self._colliders = colliders
        self._plane_normals = np.array(plane_normals, dtype=float).reshape(-1, 3)
        self._plane_points = np.array(plane_points, dtype=float).reshape(-1, 3)
        self._plane_owner = plane_owner
        # World planes as shapes at the identity, for the narrow phase's generic pairs.
        self._plane_shapes = [Plane(tuple(n), 0.0) for n in self._plane_normals.tolist()]
        self._identity = np.eye(3)
        self.enabled = bool(moving) and (len(colliders) + len(plane_normals) > 0)
        if not self.enabled:
            return
        nb = len(moving)
        self._static_slot = nb
        inv_mass, inv_inertia = [], []
        for i in moving:
            body = self.bodies[i].body()
            inv_mass.append(1.0 / body.mass)
            inv_inertia.append(np.linalg.inv(body.inertia))
        self._inverse_mass = np.array(inv_mass + [0.0])
        self._inverse_inertia_body = np.array(inv_inertia).reshape(nb, 3, 3)
        # Per-collider arrays.
        self._kind = np.array([c.shape.kind for c in colliders])
        self._cbody = np.array([c.body if c.body >= 0 else nb for c in colliders],
                               dtype=np.int64)
        self._cowner = np.array([c.owner for c in colliders], dtype=np.int64)
        self._cstatic = self._cbody == nb
        self._cdyn = np.flatnonzero(~self._cstatic)
        self._local_pos = np.array([c.position for c in colliders]).reshape(-1, 3)
        self._local_rot = np.array([c.rotation for c in colliders]).reshape(-1, 3, 3)
        self._radius = np.array([getattr(c.shape, 'radius', 0.0) for c in colliders])
        self._half_length = np.array([c.shape.half_length if c.shape.kind == 'capsule'
                                      else 0.0 for c in colliders])
        self._half = np.array([c.shape.half_extents if c.shape.kind == 'box' else (0.0,) * 3
                               for c in colliders]).reshape(-1, 3)
        reach = np.zeros(nb)
        for c in colliders:
            if c.body >= 0:
                r = float(np.linalg.norm(c.position)) + c.shape.bounding_radius
                reach[c.body] = max(reach[c.body], r)
        self._reach = reach
        self._centres = np.array([c.position if c.body < 0 else np.zeros(3)
                                  for c in colliders]).reshape(-1, 3)
        # World rotations as 9 row-major values (the kernels' form) and as 3x3 views of them.
        self._rotations9 = np.array([c.rotation if c.body < 0 else np.eye(3)
                                     for c in colliders]).reshape(-1, 9)
        self._rotations = self._rotations9.reshape(-1, 3, 3)
        self._local_rot9 = np.ascontiguousarray(self._local_rot.reshape(-1, 9))
        self._lower = np.zeros((len(colliders), 3))
        self._upper = np.zeros((len(colliders), 3))
        for c in np.flatnonzero(self._cstatic).tolist():
            wk.extents(c, self._rotations9, self._half, self._half_length, self._radius, 0.0,
                       self._centres, self._lower, self._upper)
        # The moving bodies with colliders as rows of their steppers' store.
        self._store = self._moving_steppers[0]._store
        self._rows = np.array([s._row for s in self._moving_steppers], dtype=np.int64)
        self._q = np.array([s._q9 if s._q9 is not None else np.eye(3).reshape(9)
                            for s in self._moving_steppers]).reshape(-1, 9)
        self._has_q = np.array([s._q9 is not None for s in self._moving_steppers])
        self._x = np.zeros((nb + 1, 3))
        self._rot = np.zeros((nb, 9))
        self._v = np.zeros((nb + 1, 3))
        self._w = np.zeros((nb + 1, 3))
        self._margin = np.zeros(nb + 1)
        self._sphere = self._kind == 'sphere'
        self._collider_count = len(colliders) + len(plane_normals)
        # Materials of the colliders, then of the planes (the world's where a shape has none);
        # None when no shape has one: the solver then uses the settings' as before.
        shapes = [c.shape for c in colliders] + plane_shapes
        self._materials = None
        if any(sh.restitution is not None or sh.friction is not None for sh in shapes):
            st = self.settings
            self._materials = (
                np.array([st.restitution if sh.restitution is None else sh.restitution
                          for sh in shapes]),
                np.array([st.friction if sh.friction is None else sh.friction
                          for sh in shapes]))
        self._asleep = np.zeros(nb + 1, dtype=bool)   # the last slot: static colliders
        self._slow_steps = np.zeros(nb, dtype=np.int64)
        self._wrench_seen = [s.wrench for s in self._moving_steppers]
        self._index = {self.bodies[k].name: i for i, k in enumerate(self._moving_specs)}
        self._by_row = {s._row: s for s in self._all_steppers}
        self._restep()

    # -- read ----------------------------------------------------------------------------------
    @property
    def step_count(self) -> int:
        return self._step_count

    @property
    def time(self) -> float:
        """Simulated time (s): step_count * dt."""
        return self._step_count * self.dt

    def state(self, name: str) -> State:
        """The state (world frame) of the body called ``name``."""
        if name in self.steppers:
            return self.steppers[name].state
        if name in self.static:
            return self.static[name]
        raise ValueError(f"no body named '{name}'")

    def last_contacts(self) -> list[WorldContact]:
        """The contacts of the last step (speculative ones too), in solver order."""
        if self._last is None:
            return []
        contacts, owners, impulse = self._last
        names = [b.name for b in self.bodies] + ['']
        return [WorldContact(names[oa], names[ob], contacts.point[k].copy(),
                             contacts.normal[k].copy(), float(contacts.depth[k]),
                             float(impulse[k]))
                for k, (oa, ob) in enumerate(owners)]

    # -- step ----------------------------------------------------------------------------------
    def step(self, n: int = 1) -> None:
        """Advance ``n`` >= 0 steps. If a body's state becomes non-finite the others still
        advance that step and its IntegrationError is raised after it."""
        if not isinstance(n, int) or isinstance(n, bool) or n < 0:
            raise ValueError(f'n must be an int >= 0, got {n!r}')
        if not self.enabled:
            try:
                step_all(self._all_steppers, n)
            finally:
                self._step_count += n
            return
        for _ in range(n):
            self._step_once()

    def set_state(self, name: str, state: State) -> None:
        """Teleport the moving body ``name`` to ``state`` (world frame); its history restarts,
        and the next step checks contacts before it integrates (as the first step does)."""
        if name not in self.steppers:
            raise ValueError(f"no moving body named '{name}'")
        self.steppers[name].set_state(state)
        self._unchecked = True
        i = self._index.get(name) if self.enabled else None
        if i is None:
            return
        self._slow_steps[i] = 0
        if self._asleep.any():
            # It and every sleeper its colliders' AABBs reached where it was: what rested on
            # it must not stay in the air. Their neighbours wake at the next broad phase.
            mine = np.flatnonzero(self._cbody == i)
            lower, upper = self._lower[mine], self._upper[mine]
            near = np.all((self._lower[:, None, :] <= upper[None]) &
                          (lower[None] <= self._upper[:, None, :]), axis=2).any(axis=1)
            self._wake(np.unique(np.append(self._cbody[near], i)), self._step_count)

    @property
    def sleeping(self) -> list[str]:
        """Names of the bodies asleep: at rest in contact, not integrated or solved until an
        awake body comes near, their wrench changes or they are teleported."""
        if not self.enabled:
            return []
        return [self.bodies[self._moving_specs[i]].name
                for i in np.flatnonzero(self._asleep[:-1]).tolist()]

    def _wake(self, bodies: np.ndarray, clock: int) -> None:
        """Wake the sleepers among ``bodies`` (indices, the static slot allowed); their
        Steppers' clocks move on to ``clock`` steps (the steps they spent asleep)."""
        bodies = bodies[self._asleep[bodies]]
        if not len(bodies):
            return
        self._asleep[bodies] = False
        self._slow_steps[bodies] = 0
        for i in bodies.tolist():
            s = self._moving_steppers[i]
            s.rest(clock - s.step_count)
        self._restep()

    def _restep(self) -> None:
        """The store rows of the bodies that step: all but the sleepers."""
        asleep = set(self._rows[np.flatnonzero(self._asleep[:-1])].tolist())
        self._stepping = np.array(sorted(s._row for s in self._all_steppers
                                         if s._row not in asleep), dtype=np.int64)

    def _step_once(self) -> None:
        if self._unchecked:
            # The first step (or the first after a teleport) starts from a state no collision
            # pass has seen: check it first, so that a speculative contact already holds for
            # this step's integration.
            self._collide(time.perf_counter(), integrated=False)
            self._unchecked = False
        clock = time.perf_counter
        t0 = clock()
        if self._sleep_steps:
            # A changed wrench starts a body's slow count again, and wakes a sleeper before
            # it would miss the step.
            seen = self._wrench_seen
            changed = [i for i, s in enumerate(self._moving_steppers) if s.wrench is not seen[i]]
            if changed:
                for i in changed:
                    seen[i] = self._moving_steppers[i].wrench
                changed = np.array(changed, dtype=np.int64)
                self._slow_steps[changed] = 0
                self._wake(changed, self._step_count)
        failed = self._store.advance(self._stepping, 1)  # every awake body, one call
        self._step_count += 1
        if failed:  # the others took their step; the first that failed, in body order
            s = self._by_row[failed[0]]
            e = s._error()
            raise IntegrationError(e.step, f"body '{self._owner(s)}': {e}")
        self._collide(t0)

    def _collide(self, t0: float, integrated: bool = True) -> None:
        """Detect and resolve the contacts of the bodies' current states (a step's 2-5);
        ``integrated``: the awake bodies have taken this step's integration (1)."""
        clock = time.perf_counter
        t1 = clock()
        error = None
        nb = len(self._moving_steppers)
        dyn = self._cdyn
        cb = self._cbody[dyn]
        asleep = self._asleep
        while True:
            x, rot, v, w, margin = self._read(nb, dyn, cb)
            # Sleepers pair like static colliders (not with each other or the static ones);
            # a sleeper near an awake body wakes, and the pairs are found again with it
            # awake, so a whole resting pile wakes in the step something reaches it.
            pairs = wk.sweep_and_prune(self._lower, self._upper, self._cowner,
                                       self._cstatic | asleep[self._cbody])
            if not asleep.any() or not len(pairs):
                break
            sa, sb = asleep[self._cbody[pairs[:, 0]]], asleep[self._cbody[pairs[:, 1]]]
            woken = np.concatenate([self._cbody[pairs[sa & ~sb, 0]],
                                    self._cbody[pairs[sb & ~sa, 1]]])
            woken = np.unique(woken[woken < nb])
            if not len(woken):
                break
            self._wake(woken, self._step_count - (1 if integrated else 0))
            if integrated:
                # Asleep when (1) ran: take that step now, so that they meet the solve as an
                # awake body would, with this step's gravity and wrench, and read again.
                step_all([self._moving_steppers[i] for i in woken.tolist()], 1)
        awake = ~asleep[cb]
        plane_pairs = self._plane_candidates(dyn[awake], cb[awake], margin)
        t2 = clock()
        contacts, owners, keys, pair_ids = self._narrow(pairs, plane_pairs, margin)
        t3 = clock()
        stats = StepStats(len(pairs), len(plane_pairs), len(contacts))
        if len(contacts):
            bodies = contact_solver.Bodies(
                x, v, w, self._inverse_mass,
                np.concatenate([contact_solver.inverse_inertia_world(
                    rot, self._inverse_inertia_body), np.zeros((1, 3, 3))]))
            warm_n = warm_t = None
            if self.warm_start and len(self._warm_keys):
                warm_n, warm_t = self._match(keys)
            e = mu = None
            if self._materials is not None:
                e, mu = combined_material(self._materials[0][pair_ids[0]],
                                          self._materials[1][pair_ids[0]],
                                          self._materials[0][pair_ids[1]],
                                          self._materials[1][pair_ids[1]])
            result = contact_solver.solve(contacts, bodies, self.settings, warm_n, warm_t,
                                          e, mu)
            step = self._step_count - 1 if integrated else self._step_count
            spared, failed = self._check_solve(contacts, bodies, result, nb, step)
            error = error or failed
            if self.warm_start:
                self._store_warm(keys, result.normal_impulse, result.tangent_impulse)
            t4 = clock()
            touched = np.flatnonzero(result.touched[:nb])
            write = np.array([i for i in touched.tolist() if i not in spared], dtype=np.int64)
            bad = np.zeros(len(write), dtype=bool)
            wk.write_contacts(self._store.state, self._store.params, self._rows, self._q,
                              self._has_q, write, x, self._rot, result.velocity,
                              result.angular_velocity, result.displacement, result.rotation,
                              MIN_TURN, bad)
            if bad.any() and error is None:  # the others got theirs
                i = int(write[np.flatnonzero(bad)[0]])
                error = IntegrationError(
                    step, f"body '{self._name(i)}': a contact made the state non-finite at "
                    f'step {step} (t = {step * self.dt:.9g} s): x = '
                    f'{(x[i] + result.displacement[i]).tolist()}, v = '
                    f'{result.velocity[i].tolist()}, omega = '
                    f'{result.angular_velocity[i].tolist()}; the body keeps its state before '
                    'the contact')
            if self._sleep_steps and integrated:
                self._fall_asleep(contacts, result, nb, pairs)
            stats.active = int(np.count_nonzero(result.normal_impulse > 0.0))
            stats.touched = len(touched)
            stats.colours = result.colours
            stats.velocity_iterations = result.velocity_iterations
            stats.position_iterations = result.position_iterations
            self._last = (contacts, owners, result.normal_impulse)
        else:
            self._store_warm(np.zeros(0, dtype=np.int64), np.zeros(0), np.zeros((0, 3)))
            self._slow_steps[:] = 0
            t4 = clock()
            self._last = None
        stats.sleeping = int(np.count_nonzero(self._asleep[:nb]))
        t5 = clock()
        stats.seconds = {'integrate': t1 - t0, 'broad': t2 - t1, 'narrow': t3 - t2,
                         'solve': t4 - t3, 'write': t5 - t4}
        self.last_stats = stats
        tot = self.totals
        tot.candidate_pairs += stats.candidate_pairs
        tot.plane_pairs += stats.plane_pairs
        tot.contacts += stats.contacts
        tot.active += stats.active
        tot.touched += stats.touched
        tot.velocity_iterations += stats.velocity_iterations
        tot.position_iterations += stats.position_iterations
        for k, s in stats.seconds.items():
            tot.seconds[k] = tot.seconds.get(k, 0.0) + s
        if error is not None:
            raise error

    def _owner(self, stepper) -> str:
        """The name of the body that ``stepper`` moves."""
        return next(name for name, s in self.steppers.items() if s is stepper)

    def _name(self, i: int) -> str:
        """The name of moving body ``i`` (an index among those with colliders)."""
        return self.bodies[self._moving_specs[i]].name

    def _named(self, i: int, error: IntegrationError) -> IntegrationError:
        return IntegrationError(error.step, f"body '{self._name(i)}': {error}")

    def _check_solve(self, contacts, bodies, result, nb: int, step: int):
        """(bodies not to write, IntegrationError naming them, or None): the bodies to which
        the solve gave a non-finite value, or, if it gave the bodies more kinetic energy than
        they had (the solver keeps the energy by construction, docs/collisions.md "Energy":
        this is the last guard, so that no garbage reaches a Stepper or the node), the ones
        whose energy rose. They keep their states; the others get their contacts."""
        which = np.unique(np.concatenate([contacts.body_a, contacts.body_b]))
        which = which[which < nb]
        u0 = np.concatenate([bodies.velocity, bodies.angular_velocity], axis=1)
        u1 = np.concatenate([result.velocity, result.angular_velocity, result.displacement,
                             result.rotation], axis=1)
        bad = which[~np.all(np.isfinite(u1[which]), axis=1)]
        if len(bad):
            what = 'non-finite'
        else:
            e0 = contact_solver.kinetic_energies(bodies, u0, which)
            e1 = contact_solver.kinetic_energies(bodies, u1[:, :6], which)
            total0, total1 = float(np.sum(e0)), float(np.sum(e1))
            if total1 <= total0 * (1.0 + GAIN_TOLERANCE) or not math.isfinite(total0):
                return (), None
            order = np.argsort(e0 - e1, kind='stable')  # the largest gain first
            bad = which[order][(e1 > e0)[order]]
            what = f'gain kinetic energy ({total0:.6g} J -> {total1:.6g} J)'
        names = ', '.join(f"'{self._name(i)}'" for i in bad.tolist())
        return set(bad.tolist()), IntegrationError(
            step, f'the contact solve made {names} {what} at step {step} '
            f'(t = {step * self.dt:.9g} s); they keep their states before the contacts')

    def _read(self, nb: int, dyn: np.ndarray, cb: np.ndarray):
        """(x, R, v, omega, speculative margin) of the moving bodies with colliders (a zero
        row appended for the static slot but for R); places their colliders and AABBs."""
        x, rot, v, w, margin = self._x, self._rot, self._v, self._w, self._margin
        wk.read_bodies(self._store.state, self._rows, self._q, self._has_q, x, rot, v, w)
        g = math.sqrt(sum(c * c for c in self._gravity))
        wk.speculative_margins(v, w, self._reach, nb, self.dt, g, self.speculative, margin)
        wk.place_colliders(dyn, self._cbody, x, rot, self._local_pos, self._local_rot9,
                           self._half, self._half_length, self._radius, margin, self._centres,
                           self._rotations9, self._lower, self._upper)
        return x, rot.reshape(nb, 3, 3), v, w, margin

    def _fall_asleep(self, contacts, result, nb: int, pairs: np.ndarray) -> None:
        """Count the steps each awake body has been slow (every point of its colliders under
        sleep_speed) while pressed by a contact; bodies that have been so for sleep_time
        sleep, at exact rest, together with every body near them (the broad phase's pairs,
        transitively), and only if all of those are ready too: a body never sleeps next to
        an awake one, which would wake it at the next step."""
        active = result.normal_impulse > 0.0
        supported = np.zeros(nb + 1, dtype=bool)
        supported[contacts.body_a[active]] = True
        supported[contacts.body_b[active]] = True
        speed = (np.linalg.norm(result.velocity[:nb], axis=1)
                 + np.linalg.norm(result.angular_velocity[:nb], axis=1) * self._reach)
        slow = supported[:nb] & (speed < self._sleep_speed) & ~self._asleep[:nb]
        self._slow_steps = np.where(slow, self._slow_steps + 1, 0)
        ready = self._slow_steps >= self._sleep_steps
        if not ready.any():
            return
        # Spread "not ready" along the pairs of moving bodies until nothing changes.
        a, b = self._cbody[pairs[:, 0]], self._cbody[pairs[:, 1]]
        moving = (a < nb) & (b < nb)
        a, b = a[moving], b[moving]
        blocked = np.append(~ready, False)
        while len(a):
            spread = blocked.copy()
            spread[a] |= blocked[b]
            spread[b] |= blocked[a]
            if np.array_equal(spread, blocked):
                break
            blocked = spread
        tired = np.flatnonzero(ready & ~blocked[:nb])
        if not len(tired):
            return
        for i in tired.tolist():
            s = self._moving_steppers[i]
            x, r, _, _ = s.components()
            s.apply_contact(x, r, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
        self._asleep[tired] = True
        self._restep()

    def _plane_candidates(self, dyn, cb, margin) -> np.ndarray:
        if not len(self._plane_normals) or not len(dyn):
            return np.zeros((0, 2), dtype=np.int64)
        return wk.plane_candidates(dyn, self._cbody, self._rotations9, self._half,
                                   self._half_length, self._radius, self._centres,
                                   self._plane_normals, self._plane_points, margin)

    def _narrow(self, pairs, plane_pairs, margin):
        """Contacts of the candidate pairs: (ContactArrays, [(owner a, owner b)], keys,
        (collider a, collider b or len(colliders) + plane) of each)."""
        cbody = self._cbody
        centres, rotations = self._centres, self._rotations
        parts = []        # (a collider, b collider or plane id, body a, body b, pt, n, depth, f)
        nc = len(self._colliders)
        # Sphere-sphere as one batch.
        if len(pairs):
            ss = self._sphere[pairs[:, 0]] & self._sphere[pairs[:, 1]]
            if np.any(ss):
                i, j = pairs[ss, 0], pairs[ss, 1]
                keep, pt, nrm, depth = narrow_phase.sphere_sphere_batch(
                    centres[i], self._radius[i], centres[j], self._radius[j],
                    margin[cbody[i]] + margin[cbody[j]])
                parts.append((i[keep], j[keep], pt, nrm, depth, np.zeros(len(depth), int)))
            rest = pairs[~ss]
        else:
            rest = pairs
        for i, j in rest.tolist():
            found = narrow_phase.collide(
                self._colliders[i].shape, (centres[i], rotations[i]),
                self._colliders[j].shape, (centres[j], rotations[j]),
                float(margin[cbody[i]] + margin[cbody[j]]))
            if found:
                parts.append(_gather(i, j, found))
        if len(plane_pairs):
            sp = self._sphere[plane_pairs[:, 0]]
            if np.any(sp):
                i, p = plane_pairs[sp, 0], plane_pairs[sp, 1]
                keep, pt, nrm, depth = narrow_phase.sphere_plane_batch(
                    centres[i], self._radius[i], self._plane_points[p], self._plane_normals[p],
                    margin[cbody[i]])
                parts.append((i[keep], nc + p[keep], pt, nrm, depth,
                              np.zeros(len(depth), int)))
            for i, p in plane_pairs[~sp].tolist():
                found = narrow_phase.collide(
                    self._colliders[i].shape, (centres[i], rotations[i]),
                    self._plane_shapes[p], (self._plane_points[p], self._identity),
                    float(margin[cbody[i]]))
                if found:
                    parts.append(_gather(i, nc + p, found))
        if not parts:
            empty = contact_solver.ContactArrays(np.zeros(0, int), np.zeros(0, int),
                                                 np.zeros((0, 3)), np.zeros((0, 3)),
                                                 np.zeros(0))
            none = np.zeros(0, dtype=np.int64)
            return empty, [], none, (none, none)
        ca = np.concatenate([p[0] for p in parts]).astype(np.int64)
        cbb = np.concatenate([p[1] for p in parts]).astype(np.int64)
        body_b = self._collider_body(cbb)
        contacts = contact_solver.ContactArrays(
            cbody[ca], body_b, np.concatenate([p[2] for p in parts]).reshape(-1, 3),
            np.concatenate([p[3] for p in parts]).reshape(-1, 3),
            np.concatenate([p[4] for p in parts]).astype(float))
        feature = np.concatenate([p[5] for p in parts]).astype(np.int64)
        total = max(self._collider_count, 1)
        keys = (ca * total + cbb) * (1 << FEATURE_BITS) + (feature % (1 << FEATURE_BITS))
        owner_a = self._cowner[ca].tolist()
        owner_b = [self._cowner[c] if c < nc else self._plane_owner[c - nc]
                   for c in cbb.tolist()]
        return contacts, list(zip(owner_a, [int(o) for o in owner_b])), keys, (ca, cbb)

    def _collider_body(self, ids: np.ndarray) -> np.ndarray:
        """The body slot of each collider id of a contact (ids past the colliders are planes:
        the static slot)."""
        nc = len(self._colliders)
        return np.where(ids < nc, self._cbody[np.minimum(ids, nc - 1)], self._static_slot)

    def _store_warm(self, keys, normal, tangent) -> None:
        """Keep this step's impulses for the next one's warm start, and the kept impulses of
        contacts between sleepers (or a sleeper and the static world): they are not found
        while asleep, and a pile that wakes resumes from its resting impulses, not from 0."""
        old = self._warm_keys
        if len(old) and self._asleep.any():
            pair = old >> FEATURE_BITS
            total = max(self._collider_count, 1)
            slot = self._static_slot
            body_a = self._collider_body(pair // total)
            body_b = self._collider_body(pair % total)
            keep = ((self._asleep[body_a] | (body_a == slot))
                    & (self._asleep[body_b] | (body_b == slot)))
            keys = np.concatenate([keys, old[keep]])
            normal = np.concatenate([normal, self._warm_normal[keep]])
            tangent = np.concatenate([tangent, self._warm_tangent[keep]])
        order = np.argsort(keys, kind='stable')
        self._warm_keys = keys[order]
        self._warm_normal = normal[order]
        self._warm_tangent = tangent[order]

    def _match(self, keys: np.ndarray):
        """Impulses of the previous step's contacts with the same keys (0 for new ones)."""
        old = self._warm_keys
        pos = np.minimum(np.searchsorted(old, keys), len(old) - 1)
        hit = old[pos] == keys
        normal = np.where(hit, self._warm_normal[pos], 0.0)
        tangent = np.where(hit[:, None], self._warm_tangent[pos], 0.0)
        return normal, tangent


def _gather(i: int, j: int, found: list) -> tuple:
    count = len(found)
    return (np.full(count, i), np.full(count, j), np.array([c.point for c in found]),
            np.array([c.normal for c in found]), np.array([c.depth for c in found]),
            np.array([c.feature for c in found]))
