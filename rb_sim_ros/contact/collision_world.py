# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Bodies that collide: moving bodies (rows of one BodyStore), static colliders and planes.
The world is handed them (``CollisionWorld(steppers, colliders, contact)``):

    store = BodyStore(1, 1e-3, multistep.EQ27)
    ball = Stepper(RigidBody(1.0, np.full(3, 4e-3)), 1e-3, State((0.0, 0.0, 1.0)),
                   gravity=(0.0, 0.0, -9.81), store=store)
    world = CollisionWorld({'ball': ball},
                           ColliderSet([Owner('ball', (Sphere(0.1),), row=ball.row)],
                                       planes=(Plane((0.0, 0.0, 1.0), 0.0),)),
                           ContactSettings(restitution=0.5, friction=0.5))
    world.step(1000)
    world.state('ball').position, world.last_stats.contacts

(``sim.bodies.collision_world`` builds the same from ``BodySpec`` values.)

Each step, in this order (all deterministic: stable sorts, contacts in pair order, no
iteration over sets or dicts, no randomness), and ``step(n)`` takes n of them in one compiled
call (``world_step.world_steps_two``, or its twin for the bodies' method; Python runs between
calls, to apply wrenches and teleports, and to name what failed):

1. every moving body that is awake takes one step of the step kernel (Proof 3, its wrench,
   gravity and damping), exactly as without collisions;
2. broad phase (``world_kernels.sweep_and_prune`` on the colliders' world AABBs, each widened
   by its body's speculative margin; every collider against every plane by its support
   distance);
3. narrow phase (``narrow_kernels.collide_pairs_of``, every candidate pair; the step is
   compiled with the contact tests of the pairs of shapes that can meet, ``pair_tests``);
4. impulses and position correction (``solver_kernels.solve_arrays``, warm-started from the
   impulses of the same contact features at the step before);
5. every body whose velocity or pose changed is written back (``world_kernels.write_contacts``):
   its multistep history restarts there, as at a change of wrench, so the next step does not
   extrapolate accelerations across the impulse. Bodies not touched keep their history (but
   for those that fall asleep: they are set to rest).

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
colliders on moving bodies is not made (ValueError): its Steppers step alone. Wrenches are
held as usual: ``world.steppers[name].set_wrench(...)``.

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
from typing import Mapping

import numpy as np

from rb_sim_ros.contact import broad_phase as bp, contact_solver, narrow_kernels as nk
from rb_sim_ros.contact import world_step as ws
from rb_sim_ros.contact.colliders import ColliderSet
from rb_sim_ros.contact.settings import ContactSettings, MAX_CONTACT_MASS, MIN_CONTACT_MASS
from rb_sim_ros.core import jit, step_kernel as K
from rb_sim_ros.core.rigid_body import State
from rb_sim_ros.core.step_count import check_steps, MAX_STEPS
from rb_sim_ros.core.stepper import carry_over, IntegrationError, Stepper

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
    ``seconds`` of the step (``{'step': s}``: the stages run in one compiled call, so they are
    not timed apart; statistics only). ``CollisionWorld.totals`` sums them over the
    steps taken (but for ``colours`` and ``sleeping``, which it leaves at 0: read them in
    ``last_stats``). ``swept``: pairs of the last step whose paths the swept test followed,
    ``missed``: contacts it found their paths to miss, not solved, ``solves``: how many times
    the step solved (more than once when the test brought contacts back; docs/collisions.md,
    "Continuous collision"; last step only)."""

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
    swept: int = 0
    missed: int = 0
    solves: int = 0

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


class CollisionWorld:
    """Moving and static bodies with collision shapes, stepped with a fixed dt (s): the
    world is handed its data (as Rapier's pipeline is) and builds nothing of it.

    steppers: the moving bodies by name, rows of one ``BodyStore`` (its dt and method are
    the world's; gravity and damping are each row's): the world steps them all, those
    without colliders too. colliders: a ``colliders.ColliderSet`` of their colliders (a
    moving owner is the row of the stepper of its name; one at least), static bodies' and
    the world's planes. contact: how bodies respond when they touch, one
    ``settings.ContactSettings`` (checked when it was made): restitution and friction of
    every collider without a material of its own, the solver's iterations and tolerances
    (``bounce_threshold`` (m/s) must stay above |g| dt, or resting bodies bounce on the speed
    gravity gives them in one step), speculative contacts, warm starts, and sleeping
    (``sleep_time``, ``sleep_speed``: see Sleeping above). ``pair_tests``: contact tests (a
    set of ``narrow_kernels.PAIR_BIT``) the world's step is compiled with besides those its
    colliders can meet (``pair_tests`` the attribute: the union); None:
    ``world_step.tests_for`` chooses (a precompiled set that holds them, so that it is
    loaded rather than compiled). The bits are the same with any set. ``clock``: the run's
    step count, a one-element int64 array its owner keeps (a ``Simulation``'s, so that a run
    has one clock, whether a world steps it or not): the world moves it as it steps; None: a
    clock of its own, from 0. Every argument is validated (ValueError naming it) before
    anything is built. ``sim.bodies.collision_world`` builds one from a scene's bodies.
    """

    def __init__(self, steppers: Mapping[str, Stepper], colliders: ColliderSet,
                 contact: ContactSettings = ContactSettings(),
                 pair_tests: int | None = None, clock: np.ndarray | None = None) -> None:
        steppers = dict(steppers)
        if not steppers or not all(isinstance(k, str) and isinstance(s, Stepper)
                                   for k, s in steppers.items()):
            raise ValueError('steppers must map one or more names to Steppers')
        store = next(iter(steppers.values())).store
        if any(s.store is not store for s in steppers.values()):
            raise ValueError('steppers must be rows of one BodyStore')
        if len({s.row for s in steppers.values()}) != len(steppers):
            raise ValueError('steppers must be distinct rows (one stepper named twice would '
                             'step twice)')
        if not isinstance(colliders, ColliderSet):
            raise ValueError(f'colliders must be a ColliderSet, got {colliders!r}')
        if not colliders.moving:
            raise ValueError('colliders: no moving body has one (a run without colliders '
                             'on moving bodies has no collision world)')
        for o in colliders.owners:
            s = steppers.get(o.name)
            if o.moving and (s is None or s.row != o.row):
                raise ValueError(f"colliders: owner '{o.name}' (row {o.row}) is not the row "
                                 'of a stepper of that name')
            if not o.moving and s is not None:
                raise ValueError(f"colliders: static owner '{o.name}' has a stepper")
            if o.moving:  # what the contact solve can take (settings: MIN/MAX_CONTACT_MASS)
                values = [s.body.mass] + s.body.principal_moments.tolist()
                if not all(MIN_CONTACT_MASS <= v <= MAX_CONTACT_MASS for v in values):
                    raise ValueError(
                        f"colliders: owner '{o.name}': mass and principal moments must lie in "
                        f'[{MIN_CONTACT_MASS:g}, {MAX_CONTACT_MASS:g}] for the contact solve, '
                        f'got {values}')
        if not isinstance(contact, ContactSettings):
            raise ValueError(f'contact must be a ContactSettings, got {contact!r}')
        if pair_tests is not None:
            nk.checked_tests(pair_tests, 'pair_tests')
        if clock is None:
            clock = np.zeros(1, dtype=np.int64)
        elif not (isinstance(clock, np.ndarray) and clock.dtype == np.int64
                  and clock.shape == (1,) and clock.flags.c_contiguous
                  and clock.flags.writeable):
            raise ValueError(f'clock must be a writable int64 array of one element, got '
                             f'{clock!r}')
        # The run's step count: its owner's (a Simulation's), moved by this world's steps.
        self.clock = clock
        self.contact = contact  # checked when it was made (it is frozen)
        self.colliders = colliders
        self.store = store
        self.dt = store.dt
        self.settings = contact.solver_settings(self.dt)
        self.speculative, self.warm_start = contact.speculative, contact.warm_start
        self.continuous_speed = contact.continuous_speed
        sleep_time = contact.sleep_time
        # Steps a supported body must stay slow before it sleeps (0: never).
        # (at most 2^52: the kernel reads it back from a float; that is 1.4 million years at
        # dt = 10 us, never)
        steps = sleep_time / self.settings.dt - 1e-9
        self._sleep_steps = (min(math.ceil(steps), 2 ** 52) if steps < 2.0 ** 52 else 2 ** 52
                             ) if sleep_time else 0
        self._sleep_speed = float(contact.sleep_speed)
        self.steppers = steppers
        self.static = {o.name: o.pose for o in colliders.owners if o.pose is not None}
        self._all_steppers = tuple(steppers.values())
        # What world_steps reads and leaves: whether the contacts of the state are due, what
        # happened (_unchecked and _collided read it)
        self._status = np.zeros(ws.STATUS_WIDTH, dtype=np.int64)
        self._unsynced, self._unsynced_seconds, self._call_seconds = False, 0.0, 0.0
        self._last_stats = StepStats()
        self._totals = StepStats()
        # What world_steps leaves (world_step.OUTPUTS: warm starts, the last contacts): here,
        # or newer in the record the kernels take (``_record``: (interpreted?, the store's
        # state and spare it was made with, the record)), until ``_pull`` brings them here.
        self._outputs = ws.empty_outputs()
        self._record = None
        # What _call calls, while the store's state and spare, the contact tests and the tier
        # (jit.swaps) stay those it was made with: (those four, the record, ws.entry_point)
        self._run: tuple = (None, None, -1, -1, None, None)
        self._unchecked = True
        self._build()
        # The contact tests its colliders can meet, and those its step is compiled with.
        self.pairs_needed = needed = colliders.tests()
        self._entry = (-1, '')  # (tests, the name of world_steps' entry for them)
        if pair_tests is not None:
            self.pair_tests = pair_tests | needed
        else:
            self.pair_tests = ws.tests_for(K.family(store.coefficients), needed)

    # -- set-up --------------------------------------------------------------------------------
    def _build(self) -> None:
        """The arrays world_steps reads and writes: the colliders' (copies of those it
        moves), the moving bodies' and the settings'."""
        cs = self.colliders
        self._moving_steppers = [self.steppers[o.name] for o in cs.moving]
        nb = len(cs.moving)
        self._inverse_mass = np.array([1.0 / s.body.mass for s in self._moving_steppers]
                                      + [0.0])
        self._cbody, self._cowner = cs.body, cs.owner
        self._cstatic, self._cdyn = cs.static, cs.dynamic
        self._local_pos, self._local_rot9 = cs.local_position, cs.local_rotation9
        self._kinds, self._geoms, self._pool, self._reach = cs.kinds, cs.geoms, cs.pool, cs.reach
        # the speed above which a body's speculative contacts are swept (inf: never)
        self._sweep_speed = np.where(cs.continuous, self.continuous_speed, math.inf)
        self._turn_reach = cs.turn_reach
        self._plane_normals, self._plane_points = cs.plane_normals, cs.plane_points
        # What the kernels write: the colliders' world placement and bounds (a static one's
        # as the set placed it), the planes' after them.
        self._all_centres, self._all_rotations = cs.centres.copy(), cs.rotations9.copy()
        self._lower, self._upper = cs.lower.copy(), cs.upper.copy()
        # The moving bodies with colliders as rows of their steppers' store.
        store = self.store
        self._rows = rows = cs.rows
        self._q, self._has_q = store.frames[rows], store.has_frame[rows]
        self._x = np.zeros((nb + 1, 3))
        self._rot = np.zeros((nb, 9))
        self._v = np.zeros((nb + 1, 3))
        self._w = np.zeros((nb + 1, 3))
        self._margin = np.zeros(nb + 1)
        st = self.settings
        # Materials of the colliders, then of the planes (the world's where a shape has none);
        # when no shape has one the solver uses the settings' as before.
        self._restitution, self._friction, materials = cs.materials(st.restitution,
                                                                    st.friction)
        self._asleep = np.zeros(nb + 1, dtype=bool)   # the last slot: static colliders
        self._slow_steps = np.zeros(nb, dtype=np.int64)
        self._step_rows = np.array(sorted(s.row for s in self._all_steppers), dtype=np.int64)
        self._body_of_row = np.full(len(store), -1, dtype=np.int64)
        self._body_of_row[rows] = np.arange(nb)
        self._settings_array = contact_solver.settings_array(st)
        # |g| of the fastest-falling row (they share one in a scene): the speculative margin
        g = max(math.sqrt(sum(c * c for c in store.params[r, K.GRAVITY:K.GRAVITY + 3].tolist()))
                for r in self._step_rows.tolist())
        self._config = np.zeros(ws.CONFIG_WIDTH)
        self._config[[ws.C_DT, ws.C_G, ws.C_SPECULATIVE, ws.C_SLEEP_STEPS, ws.C_SLEEP_SPEED,
                      ws.C_WARM_START, ws.C_MIN_TURN, ws.C_GAIN_TOLERANCE, ws.C_MATERIALS]] = (
            self.dt, g, float(self.speculative), float(self._sleep_steps), self._sleep_speed,
            float(self.warm_start), MIN_TURN, GAIN_TOLERANCE, float(materials))
        self._stats = np.zeros(ws.STATS_WIDTH, dtype=np.int64)
        self._counted = np.zeros(ws.P_ITER + 1, dtype=np.int64)
        self._flagged = np.zeros(nb, dtype=np.int64)
        self._energy = np.zeros(ws.ENERGY_WIDTH)
        self._wrench_seen = [s.wrench for s in self._moving_steppers]
        self._wrench_changes_seen = -1  # (look at the first step)
        self._index = {o.name: i for i, o in enumerate(cs.moving)}
        self._by_row = {s.row: s for s in self._all_steppers}

    # -- read ----------------------------------------------------------------------------------
    @property
    def step_count(self) -> int:
        """Steps taken: the run's clock (``clock``), which this world moves as it steps."""
        return self._step_count

    # The run's clock and the contacts' state live in arrays the kernel keeps (it reads
    # them there and moves them on), so that a call neither writes nor reads them.
    @property
    def _step_count(self) -> int:
        return int(self.clock[0])

    @_step_count.setter
    def _step_count(self, value: int) -> None:
        self.clock[0] = value

    @property
    def _unchecked(self) -> bool:
        """The contacts of the state are due before the next integration (the first step,
        a teleport, a refused pass)."""
        return bool(self._status[ws.S_UNCHECKED])

    @_unchecked.setter
    def _unchecked(self, value: bool) -> None:
        self._status[ws.S_UNCHECKED] = int(value)

    @property
    def _collided(self) -> bool:
        """A contact pass ran: last_contacts has something to say."""
        return bool(self._status[ws.S_COLLIDED])

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

    def contact_accelerations(self, name: str):
        """What the last step's contacts did to body ``name``'s velocities, over dt: (linear
        m/s^2, angular rad/s^2), world frame; None while it sleeps (held at rest: its whole
        acceleration is zero). Zero for a body without colliders, and after a teleport until
        the next step."""
        if name not in self.steppers:
            raise ValueError(f"no moving body named '{name}'")
        i = self._index.get(name)
        if i is None:
            return (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
        if self._asleep[i]:
            return None
        _, _, v, w = self.steppers[name]._row_components()
        inv = 1.0 / self.dt
        dv, dw = self._v[i].tolist(), self._w[i].tolist()
        return (tuple((v[c] - dv[c]) * inv for c in range(3)),
                tuple((w[c] - dw[c]) * inv for c in range(3)))

    def last_contacts(self) -> list[WorldContact]:
        """The contacts of the last step (speculative ones too), in solver order, then those of
        sleepers (between two, or one and the static world), kept as their last pass found them
        while they sleep (no pass finds them then; nothing of them moves). Not while
        another thread steps the world (the step replaces the arrays read here; the node reads
        them after its step, in the same thread)."""
        if not self._collided:
            return []
        point, normal, depth, impulse, ca, cbb = self._current_outputs()[3:]
        owners = self.colliders.owner_of
        names = [o.name for o in self.colliders.owners] + ['']
        return [WorldContact(names[owners[a]], names[owners[b]], point[k].copy(),
                             normal[k].copy(), float(depth[k]), float(impulse[k]))
                for k, (a, b) in enumerate(zip(ca.tolist(), cbb.tolist()))]

    # -- step ----------------------------------------------------------------------------------
    def step(self, n: int = 1) -> None:
        """Advance ``n`` >= 0 steps. If a body's state becomes non-finite the others still
        advance that step and its IntegrationError is raised after it."""
        if type(n) is not int or not 0 <= n <= MAX_STEPS:  # (the common case, quickly)
            check_steps(n)
        if n == 0:
            return
        if self._sleep_steps and self.store.wrench_changes != self._wrench_changes_seen:
            # A changed wrench starts a body's slow count again, and wakes a sleeper before
            # it would miss the step. (Wrenches change only between calls; the store counts
            # them, so a call with none looks at no body.)
            self._wrench_changes_seen = self.store.wrench_changes
            seen = self._wrench_seen
            changed = [i for i, s in enumerate(self._moving_steppers) if s.wrench is not seen[i]]
            if changed:
                for i in changed:
                    seen[i] = self._moving_steppers[i].wrench
                changed = np.array(changed, dtype=np.int64)
                self._slow_steps[changed] = 0
                self._wake(changed, self._step_count)
        # The path of every call, kept short: a small world's step costs less than numba's
        # dispatch did (_call), or a Python method call.
        t0 = time.perf_counter()
        look = self._call(n)
        seconds = time.perf_counter() - t0
        # The call's wall time; last_stats and totals are made from the kernel's statistics
        # when read (_sync), not after every call.
        self._unsynced_seconds += seconds
        self._unsynced = True
        if not look:  # all n steps taken, nothing to say
            self._call_seconds = seconds / n
            return
        status = self._status.tolist()  # one read of them all (an item read costs as much)
        self._call_seconds = seconds / max(status[ws.S_STEPS_DONE], 1)
        if status[ws.S_KIND] != ws.OK:
            raise self._error()
        if status[ws.S_TURNED]:  # a TurnWarning, as the bodies' own steps give (every body
            # the kernel steps: those without colliders too)
            self.store.check_turns(self._step_rows)

    @property
    def last_solve_energy(self) -> tuple[float, float]:
        """Kinetic energy (J) of the bodies in contact before and after the last step's
        contact solve (0, 0 without contacts): the solve never adds energy
        (docs/collisions.md, "Energy")."""
        return float(self._energy[ws.SOLVE_BEFORE]), float(self._energy[ws.SOLVE_AFTER])

    def warm_up(self) -> None:
        """Compile (or load from the cache) every kernel a step of this world runs, without
        taking a step: ``world_steps`` for 0 steps, and what of its store's kernels it
        calls."""
        self.store.warm_up(stepping=False)
        self._call(0)

    def compile_leaves(self, group: str) -> None:
        """Compile (or load) one group of the kernels ``world_steps`` calls
        (``world_step.compile_leaves``), for another process to compile the rest beside it."""
        ws.compile_leaves(self._world(), K.family(self.store.coefficients), self.pair_tests,
                          group)

    def _call(self, n: int) -> int:
        """``world_steps`` for n steps from the world's clock and arrays as they are now: 1
        if Python must look at its status (``world_step.LOOK``), else 0."""
        run, store, swaps = self._run, self.store, jit.swaps
        if (run[0] is not store.state or run[1] is not store.spare
                or run[2] != self.pair_tests or run[3] != swaps):
            # (what _record_now checks, and the tests: the record, or the entry, changed)
            if self._entry[0] != self.pair_tests:  # (a world's tests change in carry only)
                self._entry = (self.pair_tests,
                               ws.entry(K.family(self.store.coefficients), self.pair_tests))
            record = self._record_now()
            run = self._run = (store.state, store.spare, self.pair_tests, swaps, record,
                               ws.entry_point(self._entry[1], record))
        return run[5](run[4], n)

    def _record_now(self):
        """The record world_steps takes: the one made before, while the tier and the store's
        state and spare arrays (which a Stepper's own step swaps) are those it was made with;
        else a new one, with the outputs of the last (a WorldHost interpreted, a WorldRecord
        compiled)."""
        interpreted, store = jit.interpreted(), self.store
        made = self._record
        if (made is not None and made[0] == interpreted and made[1] is store.state
                and made[2] is store.spare):
            return made[3]
        self._pull()
        values = self._world() + self._outputs
        if interpreted:
            record = ws.WorldHost(*values)
        else:
            record = ws.make_record(*values)
            ws.record_outputs(record)  # compiled (or loaded) now: ``_pull`` may need it later
        self._record = (interpreted, store.state, store.spare, record)
        return record

    def _current_outputs(self) -> tuple:
        """world_step.OUTPUTS as they are now."""
        made = self._record
        if made is None:
            return self._outputs
        if made[0]:
            return tuple(getattr(made[3].outputs, name) for name in ws.OUTPUTS)
        # the compiled reader, in either tier (compiled when the record was made)
        return jit.compiled(ws.record_outputs)(made[3])

    def _pull(self) -> None:
        """Bring the outputs of the record here and drop it (the next call makes another)."""
        self._outputs = self._current_outputs()
        self._record = None
        self._run = (None, None, -1, -1, None, None)

    def _world(self) -> tuple:
        """The world's arrays for the step kernel (the store's, as they are now), in the order
        of ``world_step.World``: its groups STORE, COLLIDERS, MOVED and CONTROL."""
        st = self.store
        return (
            st.state, st.spare, st.params, st.coefficients, st.work, st.status, st.taken,
            st.bad, st.clock, st.warn_sq,
            self._rows, self._q, self._has_q, self._reach, self._inverse_mass, self._step_rows,
            self._body_of_row, self._sweep_speed, self._turn_reach, self._kinds, self._geoms,
            self._restitution,
            self._friction, self._pool,
            self._cbody, self._cowner, self._cstatic, self._cdyn, self._local_pos,
            self._local_rot9, self._plane_normals, self._plane_points,
            self._all_centres, self._all_rotations, self._lower, self._upper,
            self._x, self._rot, self._v, self._w, self._margin, self._asleep, self._slow_steps,
            self._settings_array, self._config, self._status, self._stats, self._flagged,
            self._energy, self.clock)

    @property
    def last_stats(self) -> StepStats:
        """What the last step did (StepStats)."""
        self._sync()
        return self._last_stats

    @last_stats.setter
    def last_stats(self, value: StepStats) -> None:
        self._sync()
        self._last_stats = value

    @property
    def totals(self) -> StepStats:
        """The StepStats summed over the steps taken since construction, or since a user set
        ``totals`` (to a fresh StepStats, say). The sums are brought up to date when this is
        read: read it again after stepping, rather than keeping the object."""
        self._sync()
        return self._totals

    @totals.setter
    def totals(self, value: StepStats) -> None:
        self._sync()
        self._totals = value

    def _sync(self) -> None:
        """last_stats from the kernel's statistics of the last step; into totals what the
        calls since the last sync added."""
        if not self._unsynced:
            return
        self._unsynced = False
        s = self._stats
        self._last_stats = StepStats(
            int(s[ws.CANDIDATE_PAIRS]), int(s[ws.PLANE_PAIRS]), int(s[ws.CONTACTS]),
            int(s[ws.ACTIVE]), int(s[ws.TOUCHED]), int(s[ws.SLEEPING]), int(s[ws.COLOURS]),
            int(s[ws.V_ITER]), int(s[ws.P_ITER]), {'step': self._call_seconds},
            int(s[ws.SWEPT]), int(s[ws.MISSED]), int(s[ws.SOLVES]))
        # The kernel counts since construction; the totals add what the calls added.
        counts = s[8:8 + ws.P_ITER + 1].copy()
        added = counts - self._counted
        self._counted = counts
        t = self._totals
        t.candidate_pairs += int(added[ws.CANDIDATE_PAIRS])
        t.plane_pairs += int(added[ws.PLANE_PAIRS])
        t.contacts += int(added[ws.CONTACTS])
        t.active += int(added[ws.ACTIVE])
        t.touched += int(added[ws.TOUCHED])
        t.velocity_iterations += int(added[ws.V_ITER])
        t.position_iterations += int(added[ws.P_ITER])
        t.seconds['step'] = t.seconds.get('step', 0.0) + self._unsynced_seconds
        self._unsynced_seconds = 0.0

    def _error(self) -> IntegrationError:
        """The IntegrationError of what stopped the kernel (its status), with names."""
        status = self._status
        kind, step = int(status[ws.S_KIND]), int(status[ws.S_ERROR_STEP])
        if kind == ws.INTEGRATION:
            s = self._by_row[int(status[ws.S_ROW])]
            e = s._error()
            return IntegrationError(e.step, f"body '{self._owner(s)}': {e}")
        when = f'at step {step} (t = {step * self.dt:.9g} s)'
        if kind == ws.CROWDED:
            contacts = int(self._stats[ws.CONTACTS])
            what = (f'{contacts} contacts, more than world_step.MAX_CONTACTS = '
                    f'{ws.MAX_CONTACTS}' if contacts > ws.MAX_CONTACTS else
                    f'more than {bp.MAX_PAIRS} pairs of colliders that may touch (the broad '
                    "phase's bound, broad_phase.MAX_PAIRS)")
            return IntegrationError(
                step, f'{what} {when}: too many colliders in one place; no contacts were '
                'solved in that step')
        flagged = self._flagged[:int(status[ws.S_FLAGGED])].tolist()
        if kind == ws.WRITE_NON_FINITE:
            e = self._energy
            return IntegrationError(
                step, f"body '{self._name(flagged[0])}': a contact made the state non-finite "
                f'{when}: x = {e[0:3].tolist()}, v = {e[3:6].tolist()}, omega = '
                f'{e[6:9].tolist()}; the body keeps its state before the contact')
        names = ', '.join(f"'{self._name(i)}'" for i in flagged)
        what = ('non-finite' if kind == ws.SOLVE_NON_FINITE else
                f'gain kinetic energy ({self._energy[0]:.6g} J -> {self._energy[1]:.6g} J)')
        return IntegrationError(
            step, f'the contact solve made {names} {what} {when}; they keep their states '
            'before the contacts')

    def set_state(self, name: str, state: State) -> None:
        """Teleport the moving body ``name`` to ``state`` (world frame); its history restarts,
        and the next step checks contacts before it integrates (as the first step does)."""
        if name not in self.steppers:
            raise ValueError(f"no moving body named '{name}'")
        self.steppers[name].set_state(state)
        self._unchecked = True
        i = self._index.get(name)
        if i is None:
            return
        # Its velocities before the last contact pass are now its new ones: a teleport is
        # not an acceleration (contact_accelerations).
        self._v[i], self._w[i] = state.linear_velocity, state.angular_velocity
        self._slow_steps[i] = 0
        if self._asleep.any():
            # It and every sleeper its colliders' AABBs reached where it was: what rested on
            # it must not stay in the air. Their neighbours wake at the next broad phase.
            mine = np.flatnonzero(self._cbody == i)
            lower, upper = self._lower[mine], self._upper[mine]
            near = np.all((self._lower[:, None, :] <= upper[None]) &
                          (lower[None] <= self._upper[:, None, :]), axis=2).any(axis=1)
            self._wake(np.unique(np.append(self._cbody[near], i)), self._step_count)

    def carry(self, old: 'CollisionWorld | None', steppers: dict, step_count: int,
              recheck: bool) -> None:
        """Take over the run of ``old`` (a world, or None for bodies stepped without one,
        ``steppers`` by name) at ``step_count``: the bodies of both keep their motion bit for
        bit (``Stepper.take_over``), sleep state, the velocities their accelerations are read
        against and their contacts' warm starts; a new body goes on from its stepper's state
        on this clock. ``recheck``: check contacts before the next step integrates (as after
        a teleport: a new body may touch). ``sim.bodies.rebuilt`` builds and carries."""
        carry_over(self.steppers, steppers, step_count)
        self._step_count = step_count
        # Its colliders are placed where its own bodies were, not where these are: no pass
        # may be skipped until one has placed them (world_step.S_QUIET; a new world's is 0).
        self._status[ws.S_QUIET] = 0
        if old is not None:
            self.pair_tests = ws.tests_keeping(K.family(self.store.coefficients),
                                               self.pairs_needed, old.pair_tests)
        self._unchecked = True if recheck or old is None else old._unchecked
        if old is not None:
            self.totals, self.last_stats = old.totals, old.last_stats
        was = old._index if old is not None else {}
        for name, i in self._index.items():
            j = was.get(name)
            s = self.steppers[name]
            if j is None:  # new here: its velocities now (no acceleration from before)
                _, _, self._v[i], self._w[i] = s.components()
                self._wrench_seen[i] = s.wrench
                continue
            self._v[i], self._w[i] = old._v[j], old._w[j]
            self._asleep[i], self._slow_steps[i] = old._asleep[j], old._slow_steps[j]
            self._wrench_seen[i] = old._wrench_seen[j]
        if not was:
            return
        self._asleep[-1] = old._asleep[-1]
        if self._asleep.any() and not old.warm_start and not recheck:
            # A delete, without warm starts: no record says what rested on the body: wake all.
            self._wake(np.arange(len(self._asleep)), step_count)
        old_outputs = old._current_outputs()
        position = {cid: i for i, cid in enumerate(self.colliders.ids)}
        mapping = np.array([position.get(cid, -1) for cid in old.colliders.ids],
                           dtype=np.int64)
        old_keys, old_normal, old_tangent = old_outputs[:3]
        if len(old_keys):
            self._carry_warm_starts(old, old_keys, old_normal, old_tangent, mapping,
                                    step_count)
        if old._collided:  # (after the wakes: only those still asleep keep theirs)
            self._carry_sleeping_contacts(old_outputs[3:], mapping)

    def _carry_warm_starts(self, old, old_keys, old_normal, old_tangent, mapping,
                           step_count) -> None:
        """``old``'s warm starts, here: keyed by (collider a, collider b, feature), renumbered
        by ``mapping``, the pairs of a deleted collider dropped, sorted again (in the same
        order: both numberings follow the bodies' order, which a spawn or a delete keeps)."""
        old_total = max(len(old.colliders.ids), 1)
        total = max(len(self.colliders.ids), 1)
        keys = old_keys
        pair, feature = keys >> ws.FEATURE_BITS, keys & ((1 << ws.FEATURE_BITS) - 1)
        a, b = mapping[pair // old_total], mapping[pair % old_total]
        keep = (a >= 0) & (b >= 0)
        new_keys = ((a * total + b) << ws.FEATURE_BITS) + feature
        order = np.argsort(new_keys[keep], kind='mergesort')
        self._pull()
        self._outputs = (np.ascontiguousarray(new_keys[keep][order]),
                         np.ascontiguousarray(old_normal[keep][order]),
                         np.ascontiguousarray(old_tangent[keep][order])) + self._outputs[3:]
        # A sleeper that rested on a deleted body (their contact is among the warm starts
        # kept while asleep) wakes, or it would hang in the air; its neighbours wake at the
        # next broad phase.
        gone = np.concatenate([a[~keep & (a >= 0)], b[~keep & (b >= 0)]])
        touched = np.unique(self._cbody[gone[gone < len(self._cbody)]])
        if len(touched):
            self._wake(touched, step_count)

    def _carry_sleeping_contacts(self, contacts: tuple, mapping: np.ndarray) -> None:
        """The old world's last contacts (point, normal, depth, impulse, collider a, b) between
        bodies that still sleep here (or one and the static world), renumbered by ``mapping``
        (old collider index -> new, -1: deleted): the step keeps such contacts for reads and
        markers while they sleep (world_step), and a spawn or a delete elsewhere must not
        make them vanish."""
        point, normal, depth, impulse, ca, cbb = contacts
        if not len(ca):
            return
        a, b = mapping[ca], mapping[cbb]
        nc, nb = len(self._cbody), len(self._asleep) - 1
        body = np.append(self._cbody, nb)  # (the static slot for every plane)
        owner_a, owner_b = body[np.clip(a, 0, nc)], body[np.clip(b, 0, nc)]
        static_a, static_b = owner_a == nb, owner_b == nb
        keep = ((a >= 0) & (b >= 0) & (static_a | self._asleep[owner_a])
                & (static_b | self._asleep[owner_b]) & ~(static_a & static_b))
        if not keep.any():
            return
        self._pull()
        self._outputs = self._outputs[:3] + tuple(
            np.ascontiguousarray(x[keep]) for x in (point, normal, depth, impulse, a, b))
        self._status[ws.S_COLLIDED] = 1

    @property
    def sleeping(self) -> list[str]:
        """Names of the bodies asleep: at rest in contact, not integrated or solved until an
        awake body comes near, their wrench changes or they are teleported."""
        moving = self.colliders.moving
        return [moving[i].name for i in np.flatnonzero(self._asleep[:-1]).tolist()]

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

    def _owner(self, stepper) -> str:
        """The name of the body that ``stepper`` moves."""
        return next(name for name, s in self.steppers.items() if s is stepper)

    def _name(self, i: int) -> str:
        """The name of moving body ``i`` (an index among those with colliders)."""
        return self.colliders.moving[i].name
