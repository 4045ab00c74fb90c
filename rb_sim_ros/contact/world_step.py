# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""The collision world's step as one compiled call: n steps of integrate, detect, solve, write.

``world_steps(record, n)`` (a kernel for each family of methods, ``world_steps_two``,
``_k``, ``_split``; ``entry_point`` gives the one of a world's bodies) takes a world's
arrays as one record (``WorldRecord``, made once by ``collision_world.CollisionWorld``; read
on entry as ``w``, a named tuple ``World``) through ``n`` steps of the order written in
``collision_world``'s module docstring:

1. the awake bodies take one step of the step kernel (``step_kernel.body_step``), the ones
   without colliders too;
2. the colliders are placed, and paired: sweep and prune on their AABBs (sleepers pair like
   static colliders; an awake body that reaches a sleeper wakes it, and its whole pile, in this
   step: they take the step they missed and the pairs are found again), and the planes. A
   step that finds every body asleep leaves ``S_QUIET``: the steps after it, while every body
   still sleeps, leave what it left without a pass (nothing has moved; ``_found_none``);
3. the narrow phase of every pair (``narrow_kernels.collide_pairs_of``, with the contact
   tests the entry is compiled for: ``entry``, ``tests_for``);
4. the solve (``solver_kernels.solve_arrays``), warm-started from the impulses of the same
   features at the step before (a sorted array of keys), with the shapes' materials;
5. the checks of the solve (a non-finite result, or kinetic energy gained), the write-back
   (``world_kernels.write_contacts``), and sleeping.

It returns early, after the step in which it happened, when something needs Python: a body
that could not be integrated or whose contacts failed a check, or more colliders in one place
than the broad phase's bounds (``CROWDED``: that step's contacts are not solved) (``w.status``:
the kind, the step, the body; ``w.flagged`` the bodies named). Every other outcome a step can
have is handled here, so Python runs once per call, not once per body, pair or contact. The
warm-start arrays and the last step's contacts change size; they are left in the record
(``OUTPUTS``), not returned.

Plain + - * / sqrt sin cos on float64, no BLAS: compiled and interpreted give the same bits.
"""

from __future__ import annotations

from collections import namedtuple
import math
import os

from numba.core import types
from numba.experimental import structref
import numpy as np

from rb_sim_ros.contact import broad_phase as bp, narrow_kernels as nk, solver_kernels as sk
from rb_sim_ros.contact import world_kernels as wk
from rb_sim_ros.core import jit, step_kernel as K
from rb_sim_ros.core.jit import borrowed, compile_for, generated_kernel, inline_kernel
from rb_sim_ros.core.jit import keep_alive, kernel

# Warm-start keys pack (collider a, collider b, feature) into one int64; features are < 2^12.
FEATURE_BITS = 12

# -- w.config: the world's constants -----------------------------------------------------------
C_DT, C_G, C_SPECULATIVE, C_SLEEP_STEPS, C_SLEEP_SPEED, C_WARM_START = 0, 1, 2, 3, 4, 5
C_MIN_TURN, C_GAIN_TOLERANCE, C_MATERIALS = 6, 7, 8
CONFIG_WIDTH = 9

# -- w.status (int64): what happened, set by world_steps ---------------------------------------
# (The step count is not here: it is the run's clock, ``run_clock`` of CONTROL.)
S_UNCHECKED, S_KIND, S_ERROR_STEP, S_ROW, S_FLAGGED, S_STEPS_DONE = 0, 1, 2, 3, 4, 5
# 1 once a contact pass has run (it stays): the record holds the last step's contacts
S_COLLIDED = 6
# 1 if a moving body may now turn faster than its method's energy bound (warn_sq):
# Python then looks (``BodyStore.check_turns``), else it need not
S_TURNED = 7
# 1 after a step whose contact pass found every body with colliders asleep (so no pair): its
# colliders are placed where the bodies still are, and the next such step leaves what it left
# without running (a sleeping world costs nothing). Any other step clears it; a new world
# starts at 0, so its first step places its colliders.
S_QUIET = 8
STATUS_WIDTH = 9
# What world_steps returns when Python must look at the status (a failure, a turn to check);
# 0 when all n steps were taken and there is nothing to say
LOOK = 1
OK, INTEGRATION, SOLVE_NON_FINITE, SOLVE_ENERGY, WRITE_NON_FINITE = 0, 1, 2, 3, 4
CROWDED = 5  # past broad_phase.MAX_PAIRS or MAX_SWEEP, or MAX_CONTACTS: no contacts solved
# The most contacts a step solves: the solver's rows take 416 bytes a contact (220 MB here);
# the broad phase's MAX_PAIRS pairs could make 9 each. A dense pile of 20,000 balls makes
# about 140,000.
MAX_CONTACTS = 1 << 19
# w.energy (11): [0:2] the kinetic energies (J) before and after a solve that gained, or [0:9]
# the x, v, omega a failed write would have given; [9:11] the kinetic energy of the bodies in
# contact before and after the last solve (0 without contacts).
SOLVE_BEFORE, SOLVE_AFTER = 9, 10
# A gain of the contact solve below the kinetic energy of its bodies moving at this speed (m/s)
# is rounding, not a gain: bodies at rest carry velocities near 1e-19 m/s, whose energies a
# relative tolerance cannot bound (a box at rest once stopped a run, "gaining"
# 1.04265e-37 J -> 1.04265e-37 J).
GAIN_FLOOR_SPEED = 1e-9
ENERGY_WIDTH = 11

# -- w.stats (int64): [0:8] the last step's, [8:16] the totals --------------------------------
CANDIDATE_PAIRS, PLANE_PAIRS, CONTACTS, ACTIVE, TOUCHED, V_ITER, P_ITER, COLOURS = range(8)
SLEEPING = 16
# the last step's pairs swept, contacts not solved because their pair's paths missed, and
# solves (more than one when the swept test brought contacts back)
SWEPT, MISSED, SOLVES = 17, 18, 19
STATS_WIDTH = 20
# The most solves a step makes while the swept test brings back contacts the solve turned
# towards each other (docs/collisions.md, "Continuous collision"); the last one solves every
# contact found, as a step without the test does.
SWEEP_ROUNDS = 4

# The typed containers a world's step is handed, each a group of arrays that live and change
# together: the moving bodies' store (``core.stepper.BodyStore``: the step kernel's rows and
# each row's clock), what is fixed for the world's life (its ``ColliderSet`` and the rows of
# its bodies), what the step moves (the colliders placed in the world and a buffer per body,
# the last slot the static world's) and its control (solver settings, world constants,
# status, statistics, flagged bodies, energies, and the run's clock: its step count, one
# int64 that the run owns and hands to its world, which moves it as it steps).
STORE = ('state', 'spare', 'params', 'coefficients', 'work', 'kstatus', 'taken', 'bad', 'clock',
         'warn_sq')
COLLIDERS = (
    # moving bodies with colliders: their store rows, Q of a non-principal body frame, reach
    # (m), 1 / m; the store rows of every moving body, ascending, and of each row its index
    # among the moving bodies with colliders (-1 without: it never sleeps); the speed (m/s)
    # above which a body's speculative contacts are swept (inf: never), and how far a turn can
    # move its colliders' surfaces (m; a ball at its centre of mass: 0)
    'rows', 'q', 'has_q', 'reach', 'inverse_mass', 'step_rows', 'body_of_row', 'sweep_speed',
    'turn_reach',
    # colliders (C) then planes (P): kinds, geoms, materials; the data of variable size that
    # kinds read at offsets in their geoms (a hull's vertices and faces)
    'kinds', 'geoms', 'restitution', 'friction', 'pool',
    # colliders only: moving body (or nb: static), owner, static, the moving ones, offsets
    'cbody', 'cowner', 'cstatic', 'dyn', 'local_pos', 'local_rot',
    # planes
    'plane_normals', 'plane_points')
MOVED = (
    # colliders then planes placed in the world, the colliders' bounds
    'centres', 'rotations', 'lower', 'upper',
    # per body buffers (the last slot: the static world)
    'x', 'rot', 'v', 'w', 'margin', 'asleep', 'slow_steps')
CONTROL = ('settings', 'config', 'status', 'stats', 'flagged', 'energy', 'run_clock')
GROUPS = (('store', STORE), ('colliders', COLLIDERS), ('moved', MOVED), ('control', CONTROL))

# What the kernels read: every array of the groups, by name (made once, on entry).
World = namedtuple('World', STORE + COLLIDERS + MOVED + CONTROL)


# What a call leaves for Python, in the record (never returned: numba makes a Python object of
# each array it returns, about 0.7 us apiece, more than a resting body's step): the warm-start
# arrays (sorted keys, normal and tangent impulses), and the contacts of the last step that
# ran a contact pass (``S_COLLIDED``).
OUTPUTS = ('warm_keys', 'warm_normal', 'warm_tangent', 'point', 'normal', 'depth', 'impulse',
           'collider_a', 'collider_b')
FIELDS = World._fields + OUTPUTS


def empty_outputs() -> tuple:
    """OUTPUTS of a world that has not stepped: no warm start, no contacts."""
    f1, f3, i1 = np.zeros(0), np.zeros((0, 3)), np.zeros(0, dtype=np.int64)
    return i1, f1, f3.copy(), f3.copy(), f3.copy(), f1.copy(), f1.copy(), i1.copy(), i1.copy()


# The record a compiled world_steps takes, one argument (crossing from Python costs one
# pointer, where a tuple of 45 arrays cost 4 us): a WorldRecord of the four groups and the
# outputs, each a numba StructRef typed by its arrays, made by ``make_record``; the
# interpreted tier takes a ``WorldHost`` of the same groups (plain objects). Kernels read
# either by attribute, the same arithmetic on the same arrays.
class _Arrays(types.StructRef):
    def preprocess_fields(self, fields):
        return tuple((name, types.unliteral(t)) for name, t in fields)


@structref.register
class StoreRecordType(_Arrays):
    pass


@structref.register
class CollidersRecordType(_Arrays):
    pass


@structref.register
class MovedRecordType(_Arrays):
    pass


@structref.register
class ControlRecordType(_Arrays):
    pass


@structref.register
class OutputsRecordType(_Arrays):
    pass


@structref.register
class WorldRecordType(_Arrays):
    pass


class StoreRecord(structref.StructRefProxy):
    """The STORE group, compiled."""


class CollidersRecord(structref.StructRefProxy):
    """The COLLIDERS group, compiled."""


class MovedRecord(structref.StructRefProxy):
    """The MOVED group, compiled."""


class ControlRecord(structref.StructRefProxy):
    """The CONTROL group, compiled."""


class OutputsRecord(structref.StructRefProxy):
    """The OUTPUTS, compiled."""


class WorldRecord(structref.StructRefProxy):
    """A world's groups and outputs as one compiled record (read them in kernels, not from
    Python)."""


structref.define_proxy(StoreRecord, StoreRecordType, list(STORE))
structref.define_proxy(CollidersRecord, CollidersRecordType, list(COLLIDERS))
structref.define_proxy(MovedRecord, MovedRecordType, list(MOVED))
structref.define_proxy(ControlRecord, ControlRecordType, list(CONTROL))
structref.define_proxy(OutputsRecord, OutputsRecordType, list(OUTPUTS))
structref.define_proxy(WorldRecord, WorldRecordType,
                       [name for name, _ in GROUPS] + ['outputs'])


class _Group:
    """One group of arrays as a plain object (the interpreted tier's record)."""

    def __init__(self, names, values) -> None:
        for name, value in zip(names, values, strict=True):
            setattr(self, name, value)


class WorldHost:
    """A world's groups and outputs as plain objects, for the interpreted tier: made from the
    same values as ``make_record`` (FIELDS, in order)."""

    __slots__ = tuple(name for name, _ in GROUPS) + ('outputs',)

    def __init__(self, *values) -> None:
        values = list(values)
        if len(values) != len(FIELDS):
            raise ValueError(f'a world has {len(FIELDS)} arrays, got {len(values)}')
        at = 0
        for name, names in GROUPS + (('outputs', OUTPUTS),):
            setattr(self, name, _Group(names, values[at:at + len(names)]))
            at += len(names)


def _record_sources() -> tuple[str, str]:
    args = ', '.join(FIELDS)
    groups = ', '.join(f'{cls}({", ".join(names)})' for cls, names in (
        ('StoreRecord', STORE), ('CollidersRecord', COLLIDERS), ('MovedRecord', MOVED),
        ('ControlRecord', CONTROL), ('OutputsRecord', OUTPUTS)))
    make = (f'def make_record({args}):\n'
            '    """A WorldRecord of these arrays (FIELDS, in order), in its groups."""\n'
            f'    return WorldRecord({groups})\n')
    outputs = ', '.join(f'w.outputs.{name}' for name in OUTPUTS)
    read = ('def record_outputs(w):\n'
            '    """OUTPUTS of a record (or host), in order."""\n'
            f'    return ({outputs})\n')
    return make, read


_MAKE_SOURCE, _READ_SOURCE = _record_sources()
make_record = generated_kernel(globals(), 'make_record', _MAKE_SOURCE, inline=False)
record_outputs = generated_kernel(globals(), 'record_outputs', _READ_SOURCE, inline=False)


def _world_source() -> str:
    fields = ', '.join(f'borrowed(w.{group}.{name})' for group, names in GROUPS
                       for name in names)
    return ('def world_of(w):\n'
            '    """The World (a named tuple) of a record\'s arrays, read once, on entry, and\n'
            '    borrowed (jit.borrowed): the record owns them for the whole call, and no\n'
            '    reference count of them is taken as the step passes them round."""\n'
            f'    return World({fields})\n')


world_of = generated_kernel(globals(), 'world_of', _world_source())


def _world_steps_of(family, tests, name):
    """``world_steps`` (below) compiled for the bodies' ``family`` (``step_kernel.family``)
    and the contact tests of the set ``tests`` (``narrow_kernels.PAIR_BIT``), constants in it
    (from Python they could not be: numba would enter its compiler at every call, 15 ms);
    ``name``, its name and the name of its cache entry."""

    def world_steps(record, n):
        """``n`` steps of the world (see the module doc) of ``record`` (a WorldRecord, or a
        WorldHost in the interpreted tier). Leaves its OUTPUTS there: the warm-start arrays
        and, when a contact pass ran in this call (then w.status[S_COLLIDED] = 1), its last
        step's contacts (point, normal, depth, normal_impulse, collider_a, collider_b)."""
        f = family
        w = world_of(record)
        out = record.outputs
        warm_keys, warm_normal, warm_tangent = out.warm_keys, out.warm_normal, out.warm_tangent
        # the last contacts, as they are until a contact pass runs (kept only if one does)
        point, normal, depth = out.point, out.normal, out.depth
        impulse, ca, cbb = out.impulse, out.collider_a, out.collider_b
        w.status[S_KIND] = OK
        w.status[S_STEPS_DONE] = 0
        collided = False  # a contact pass ran in this call
        # The arrays of a contact pass that stay in it, carved from three made for the call
        # (grown as a pass needs) and borrowed (jit.borrowed): three allocations a call where
        # a pass made twenty-five, and no reference count of them taken as the stages pass
        # them round. Those the call leaves in its outputs (the contacts, impulses) are its
        # own. Kept alive to the end of the call (jit.keep_alive). They start empty, as empty
        # views of the record's arrays of their types, which cost no allocation.
        own_f, own_i, own_b = w.energy[:0], w.rows[:0], w.asleep[:0]
        static = np.empty(w.cbody.shape[0], dtype=np.bool_)
        fast = np.empty(w.rows.shape[0] + 1, dtype=np.bool_)
        awake = np.empty(w.dyn.shape[0], dtype=np.int64)
        while w.status[S_STEPS_DONE] < n:
            # The first step (or the first after a teleport) collides before it integrates: the
            # contacts of the starting state, so that a speculative contact already holds for
            # this step's integration. A pass that fails leaves it due: the next call checks
            # again. (One call site of each stage: they are compiled inline.)
            integrated = w.status[S_UNCHECKED] == 0
            if integrated:
                row = _integrate(f, w.step_rows, w.body_of_row, w.asleep, w.state, w.spare,
                                 w.params, w.coefficients, w.kstatus, w.taken, w.bad, w.work,
                                 w.clock)
                w.run_clock[0] += 1
                w.status[S_STEPS_DONE] += 1
                if row >= 0:
                    w.status[S_KIND], w.status[S_ROW] = INTEGRATION, row
                    w.status[S_ERROR_STEP] = w.run_clock[0] - 1
                    break
            # 2. - 5. on the bodies' current states (``integrated``: the awake bodies have taken
            # this step's integration).
            nb = w.rows.shape[0]
            nc = w.cbody.shape[0]
            step = w.run_clock[0] - 1 if integrated else w.run_clock[0]
            if integrated and w.status[S_QUIET] != 0 and _all_asleep(w.asleep, nb):
                # The step before ran a pass with every body asleep (S_QUIET), and they still
                # are: no body has moved since, so that pass would find what it found (no pair:
                # sleepers pair like static colliders, and none is awake) and leave what it
                # left (its placed colliders, and the warm starts, all of sleepers).
                # (its contacts, all kept ones of sleepers, stay as they are)
                _found_none(w.status, w.stats, w.energy, w.slow_steps, w.asleep, nb, 0, 0, True)
                collided = True
                continue
            w.status[S_QUIET] = 0
            crowded = False
            # the last pass's contacts: those between sleepers are kept (below)
            was_point, was_normal, was_depth = point, normal, depth
            was_impulse, was_ca, was_cbb = impulse, ca, cbb
            while True:
                # x, R, v, omega and margins of the bodies; colliders placed (step 2's start).
                wk.read_bodies(w.state, w.rows, w.q, w.has_q, w.x, w.rot, w.v, w.w)
                wk.speculative_margins(w.v, w.w, w.reach, nb, float(w.config[C_DT]),
                                       float(w.config[C_G]), w.config[C_SPECULATIVE] != 0.0,
                                       w.margin)
                wk.place_colliders(w.dyn, w.cbody, w.x, w.rot, w.local_pos, w.local_rot,
                                   w.kinds, w.geoms, w.pool, w.margin, w.centres, w.rotations,
                                   w.lower, w.upper)
                any_asleep = False
                for c in range(nc):
                    static[c] = w.cstatic[c] or w.asleep[w.cbody[c]]
                for k in range(nb):
                    any_asleep = any_asleep or w.asleep[k]
                pairs = bp.sweep_and_prune(w.lower, w.upper, w.cowner, static, int(-1))
                crowded = pairs.shape[0] == 1 and pairs[0, 0] == bp.OVERFLOW
                if crowded or not any_asleep or pairs.shape[0] == 0:
                    break
                woken = np.zeros(nb + 1, dtype=np.bool_)
                found = False
                for k in range(pairs.shape[0]):
                    a, b = w.cbody[pairs[k, 0]], w.cbody[pairs[k, 1]]
                    if w.asleep[a] and not w.asleep[b] and a < nb:
                        woken[a], found = True, True
                    if w.asleep[b] and not w.asleep[a] and b < nb:
                        woken[b], found = True, True
                if not found:
                    break
                clock = w.run_clock[0] - (1 if integrated else 0)
                for k in range(nb):
                    if woken[k]:
                        w.asleep[k] = False
                        w.slow_steps[k] = 0
                        w.clock[w.rows[k]] = clock  # its clock stood still while asleep
                if integrated:
                    # Asleep when (1) ran: take that step now, so that they meet the solve as an
                    # awake body would, with this step's gravity and wrench, and read again. If one
                    # fails, the others still take it; the step stops there.
                    failed = -1
                    for k in range(nb):
                        if woken[k] and _advance_row(f, w.state, w.spare, w.params, w.coefficients,
                                                     w.kstatus, w.taken, w.bad, w.work, w.clock,
                                                     w.rows[k]) and failed < 0:
                            failed = w.rows[k]
                    if failed >= 0:
                        w.status[S_KIND], w.status[S_ROW] = INTEGRATION, failed
                        w.status[S_ERROR_STEP] = w.clock[failed]
                        break
            if crowded and w.status[S_KIND] == OK:  # more pairs than the bounds: refused, and
                # due again (the next call checks before it integrates: nothing moves on unsolved)
                w.status[S_KIND], w.status[S_ERROR_STEP] = CROWDED, step
                w.status[S_UNCHECKED] = 1
                w.stats[CONTACTS] = 0  # none: the narrow phase did not run
            # The last pass's contacts between sleepers (or a sleeper and the static world): no
            # pass finds them while they sleep (they pair like static colliders), and nothing
            # of them has moved, so they are kept for reads and markers, after this pass's own
            # (and alone when the step stops here).
            keep = _kept(nb, w.cbody, w.asleep, was_ca, was_cbb, any_asleep)
            if w.status[S_KIND] != OK:  # crowded, or a woken body failed: the step stops here
                point, normal, depth, impulse, ca, cbb = _with_kept(
                    point[:0], normal[:0], depth[:0], impulse[:0], ca[:0], cbb[:0], keep,
                    was_point, was_normal, was_depth, was_impulse, was_ca, was_cbb)
                collided = True
                break
            # Planes: the awake moving colliders only.
            count = 0
            for k in range(w.dyn.shape[0]):
                if not w.asleep[w.cbody[w.dyn[k]]]:
                    awake[count] = w.dyn[k]
                    count += 1
            planes = w.plane_normals.shape[0]
            if planes:
                plane_pairs = bp.plane_candidates(awake[:count], w.cbody, w.rotations,
                                                  w.kinds, w.geoms, w.pool, w.centres,
                                                  w.plane_normals, w.plane_points, w.margin)
            else:
                plane_pairs = np.zeros((0, 2), dtype=np.int64)
            # 3. The narrow phase of every candidate: collider pairs, then (collider, plane).
            p1, p2 = pairs.shape[0], plane_pairs.shape[0]
            if p1 + p2 == 0:
                # No candidate (bodies in flight, or all asleep): what the pass below leaves
                # with no contact, without making its arrays: none found, none solved, the warm
                # starts of sleepers only.
                point, normal, depth = point[:0], normal[:0], depth[:0]
                impulse, ca, cbb = impulse[:0], ca[:0], cbb[:0]
                if any_asleep:
                    warm_keys, warm_normal, warm_tangent = _store_warm(
                        nb, w.cbody, planes, w.asleep, ca, depth, normal, warm_keys,
                        warm_normal, warm_tangent)
                else:
                    warm_keys = warm_keys[:0]
                    warm_normal, warm_tangent = warm_normal[:0], warm_tangent[:0]
                point, normal, depth, impulse, ca, cbb = _with_kept(
                    point, normal, depth, impulse, ca, cbb, keep, was_point, was_normal,
                    was_depth, was_impulse, was_ca, was_cbb)
                _found_none(w.status, w.stats, w.energy, w.slow_steps, w.asleep, nb, 0, 0,
                            any_asleep and _all_asleep(w.asleep, nb))
                collided = True
                continue
            p = p1 + p2
            rows = p * nk.MAX_CONTACTS_PER_PAIR
            nn = nb + 1
            if own_f.shape[0] < p + 21 * nn + 10 * rows:
                own_f = np.empty(2 * (p + 21 * nn + 10 * rows))
            if own_i.shape[0] < 2 * p + 5 * rows + nb:
                own_i = np.empty(2 * (2 * p + 5 * rows + nb), dtype=np.int64)
            if own_b.shape[0] < nn + nb:
                own_b = np.empty(2 * (nn + nb), dtype=np.bool_)
            fs, ints, flags = borrowed(own_f), borrowed(own_i), borrowed(own_b)
            pair_a, pair_b = ints[:p], ints[p:2 * p]
            at = 2 * p
            feature, source = ints[at:at + rows], ints[at + rows:at + 2 * rows]
            at += 2 * rows
            body_a, body_b = ints[at:at + rows], ints[at + rows:at + 2 * rows]
            keys = ints[at + 2 * rows:at + 3 * rows]
            write = ints[at + 3 * rows:at + 3 * rows + nb]
            margins = fs[:p]
            inv_inertia = fs[p:p + 9 * nn].reshape((nn, 9))
            v1 = fs[p + 9 * nn:p + 12 * nn].reshape((nn, 3))
            w1 = fs[p + 12 * nn:p + 15 * nn].reshape((nn, 3))
            disp = fs[p + 15 * nn:p + 18 * nn].reshape((nn, 3))
            turn = fs[p + 18 * nn:p + 21 * nn].reshape((nn, 3))
            at = p + 21 * nn
            warm_n, e, mu = fs[at:at + rows], fs[at + rows:at + 2 * rows], fs[
                at + 2 * rows:at + 3 * rows]
            p_impulse = fs[at + 3 * rows:at + 4 * rows]
            warm_t = fs[at + 4 * rows:at + 7 * rows].reshape((rows, 3))
            tangent = fs[at + 7 * rows:at + 10 * rows].reshape((rows, 3))
            touched, bad = flags[:nn], flags[nn:nn + nb]
            for k in range(p1):
                pair_a[k], pair_b[k] = pairs[k, 0], pairs[k, 1]
                margins[k] = w.margin[w.cbody[pairs[k, 0]]] + w.margin[w.cbody[pairs[k, 1]]]
            for k in range(p2):
                pair_a[p1 + k], pair_b[p1 + k] = plane_pairs[k, 0], nc + plane_pairs[k, 1]
                margins[p1 + k] = w.margin[w.cbody[plane_pairs[k, 0]]]
            point, normal = np.empty((rows, 3)), np.empty((rows, 3))
            depth = np.empty(rows)
            # (their owners outlive the call: borrowed, a pair's test counts no reference)
            m = nk.collide_pairs_of(tests, pair_a, pair_b, w.kinds, w.geoms, w.pool, w.centres,
                                    w.rotations, margins, borrowed(point), borrowed(normal),
                                    borrowed(depth), feature, source)
            point, normal, depth = point[:m], normal[:m], depth[:m]
            stats = w.stats
            for k in range(8):
                stats[k] = 0
            stats[SWEPT] = stats[MISSED] = stats[SOLVES] = 0
            stats[CANDIDATE_PAIRS], stats[PLANE_PAIRS], stats[CONTACTS] = p1, p2, m
            if m > MAX_CONTACTS:  # more than the solve's bound: refused, and due again
                w.status[S_KIND], w.status[S_ERROR_STEP] = CROWDED, step
                w.status[S_UNCHECKED] = 1
                point, normal, depth, impulse, ca, cbb = _with_kept(
                    point[:0], normal[:0], depth[:0], was_impulse[:0], was_ca[:0], was_cbb[:0],
                    keep, was_point, was_normal, was_depth, was_impulse, was_ca, was_cbb)
                collided = True
                break
            ca = np.empty(m, dtype=np.int64)
            cbb = np.empty(m, dtype=np.int64)
            body_a, body_b, keys = body_a[:m], body_b[:m], keys[:m]
            total = max(nc + planes, 1)
            for k in range(m):
                ca[k], cbb[k] = pair_a[source[k]], pair_b[source[k]]
                body_a[k] = w.cbody[ca[k]]
                body_b[k] = w.cbody[cbb[k]] if cbb[k] < nc else nb
                keys[k] = (ca[k] * total + cbb[k]) * (1 << FEATURE_BITS) + (
                    feature[k] % (1 << FEATURE_BITS))
            impulse = np.zeros(m)
            w.energy[SOLVE_BEFORE] = w.energy[SOLVE_AFTER] = 0.0
            if m == 0:
                warm_keys, warm_normal, warm_tangent = _store_warm(
                    nb, w.cbody, w.plane_normals.shape[0], w.asleep, keys, impulse,
                    np.zeros((0, 3)), warm_keys, warm_normal, warm_tangent)
                _found_none(w.status, w.stats, w.energy, w.slow_steps, w.asleep, nb, p1, p2,
                            False)
                point, normal, depth, impulse, ca, cbb = _with_kept(
                    point, normal, depth, impulse, ca, cbb, keep, was_point, was_normal,
                    was_depth, was_impulse, was_ca, was_cbb)
                collided = True
                continue
            # 4. The solve: the bodies (the last slot static), warm start, materials.
            inv_inertia[:] = 0.0
            for k in range(nb):
                _inverse_inertia_world(w.rows, w.params, w.state, k, inv_inertia)
            warm_n, warm_t = warm_n[:m], warm_t[:m]
            warm_n[:] = 0.0
            warm_t[:] = 0.0
            use_warm = w.config[C_WARM_START] != 0.0 and warm_keys.shape[0] > 0
            if use_warm:
                _match(keys, warm_keys, warm_normal, warm_tangent, warm_n, warm_t)
            e, mu = e[:m], mu[:m]
            for k in range(m):
                if w.config[C_MATERIALS] != 0.0:
                    fa, fb = float(w.friction[ca[k]]), float(w.friction[cbb[k]])
                    mean = math.sqrt(fa * fb)
                    e[k] = max(float(w.restitution[ca[k]]), float(w.restitution[cbb[k]]))
                    mu[k] = min(mean, max(fa, fb))
                else:
                    e[k], mu[k] = w.settings[sk.RESTITUTION], w.settings[sk.FRICTION]
            tangent, p_impulse = tangent[:m], p_impulse[:m]
            source = source[:m]
            # The swept test (docs/collisions.md, "Continuous collision"): the pairs of fast
            # bodies whose contacts are all gaps, one closing within the step at the bodies'
            # velocities, are advanced along their straight-line paths through the step; those
            # that miss are not solved (no ghost stop). After a solve,
            # the missed pairs of bodies it changed are swept again at their new velocities,
            # and solved with the rest if they now meet (SWEEP_ROUNDS solves at most).
            live = m
            swept = solves = 0
            pair_state = w.rows[:0]
            tau, gap0 = w.energy[:0], w.energy[:0]
            if w.config[C_SPECULATIVE] != 0.0 and wk.fast_bodies(w.v, w.w, w.turn_reach,
                                                                 w.sweep_speed, w.asleep, nb,
                                                                 fast):
                pair_state = np.empty(p, dtype=np.int64)
                tau, gap0 = np.zeros(p), np.empty(p)
                swept = wk.sweep_candidates(point, normal, depth, source, w.cbody, pair_a,
                                            pair_b, nc, nb, w.x, w.v, w.w, fast,
                                            float(w.config[C_DT]), pair_state, gap0)
            pending = swept
            vel, ang = w.v, w.w
            rounds = 0
            while True:
                if pending:
                    pending = wk.sweep_start(normal, depth, source, pair_state, tau, gap0,
                                             pair_a, pair_b, w.cbody, nc, nb, vel, ang,
                                             w.turn_reach, float(w.config[C_G]),
                                             float(w.config[C_DT]),
                                             w.kinds, w.geoms, w.pool, w.centres, w.rotations)
                if pending:
                    _sweep(tests, pending, pair_state, tau, gap0, pair_a, pair_b, w.cbody, nc,
                           nb, w.x, vel, ang, w.turn_reach, float(w.config[C_G]),
                           float(w.config[C_DT]), w.centres, w.rotations, w.kinds, w.geoms,
                           w.pool)
                if swept:
                    order = np.empty(m, dtype=np.int64)
                    was = live
                    live = wk.live_first(pair_state, source, order)
                    if rounds > 0 and live == was:
                        break  # none came back: the last solve stands
                    if live < m:
                        point, normal, depth = point[order], normal[order], depth[order]
                        ca, cbb, keys = ca[order], cbb[order], keys[order]
                        body_a, body_b, source = body_a[order], body_b[order], source[order]
                        warm_n, warm_t = warm_n[order], warm_t[order]
                        e, mu = e[order], mu[order]
                solves += 1
                colours, v_iter, p_iter = sk.solve_arrays(
                    body_a[:live], body_b[:live], point[:live], normal[:live], depth[:live], w.x,
                    w.v, w.w, w.inverse_mass, inv_inertia, w.settings, warm_n[:live],
                    warm_t[:live], use_warm, e[:live], mu[:live], v1, w1, disp, turn,
                    impulse[:live], tangent[:live], p_impulse[:live], touched)
                if live == m:
                    break
                impulse[live:] = 0.0
                tangent[live:] = 0.0
                p_impulse[live:] = 0.0
                pending = wk.sweep_again(pair_state, tau, pair_a, pair_b, w.cbody, nc, nb, v1,
                                         w1, w.v, w.w)
                if pending == 0:
                    break
                rounds += 1
                vel, ang = v1, w1
                if rounds == SWEEP_ROUNDS - 1:  # the last solve: every contact
                    pair_state[:] = wk.SOLVED
                    pending = 0
            stats = w.stats
            stats[SWEPT], stats[MISSED], stats[SOLVES] = swept, m - live, solves
            # 5. Checks, warm start kept, write-back, sleeping.
            spared = _check_solve(w.status, w.flagged, w.energy, float(w.config[C_GAIN_TOLERANCE]),
                                  w.rows, w.state, w.params, w.inverse_mass, w.v, w.w, nb,
                                  body_a[:live], body_b[:live], v1, w1, disp, turn, step)
            if w.config[C_WARM_START] != 0.0:
                warm_keys, warm_normal, warm_tangent = _store_warm(
                    nb, w.cbody, w.plane_normals.shape[0], w.asleep, keys, impulse, tangent,
                    warm_keys, warm_normal, warm_tangent)
            count = 0
            n_touched = 0
            for k in range(nb):
                if touched[k]:
                    n_touched += 1
                    if not spared[k]:
                        write[count] = k
                        count += 1
            bad = bad[:count]
            bad[:] = False
            wk.write_contacts(w.state, w.params, w.rows, w.q, w.has_q, write[:count], w.x, w.rot,
                              v1, w1, disp, turn, float(w.config[C_MIN_TURN]), bad)
            for k in range(count):
                if bad[k] and w.status[S_KIND] == OK:
                    w.status[S_KIND], w.status[S_ERROR_STEP] = WRITE_NON_FINITE, step
                    w.status[S_ROW] = write[k]
                    w.flagged[0] = write[k]
                    w.status[S_FLAGGED] = 1
                    for c in range(3):  # what it would have been, for the message
                        w.energy[c] = w.x[write[k], c] + disp[write[k], c]
                        w.energy[3 + c] = v1[write[k], c]
                        w.energy[6 + c] = w1[write[k], c]
            if w.config[C_SLEEP_STEPS] > 0.0 and integrated:
                _fall_asleep(w.config, w.reach, w.asleep, w.slow_steps, w.cbody, w.rows, w.state,
                             w.params, nb, body_a, body_b, impulse, v1, w1, pairs)
            active = 0
            for k in range(m):
                if impulse[k] > 0.0:
                    active += 1
            stats[ACTIVE], stats[TOUCHED] = active, n_touched
            stats[COLOURS], stats[V_ITER], stats[P_ITER] = colours, v_iter, p_iter
            _finish_stats(w.asleep, w.stats, nb)
            point, normal, depth, impulse, ca, cbb = _with_kept(
                point, normal, depth, impulse, ca, cbb, keep, was_point, was_normal, was_depth,
                was_impulse, was_ca, was_cbb)
            collided = True
            if w.status[S_KIND] != OK:
                break
            w.status[S_UNCHECKED] = 0
        keep_alive(own_f, own_i, own_b)
        w.status[S_TURNED] = _turned(w.step_rows, w.state, w.warn_sq)
        out.warm_keys = warm_keys
        out.warm_normal, out.warm_tangent = warm_normal, warm_tangent
        if collided:
            w.status[S_COLLIDED] = 1
            out.point, out.normal, out.depth = point, normal, depth
            out.impulse, out.collider_a, out.collider_b = impulse, ca, cbb
        return LOOK if w.status[S_KIND] != OK or w.status[S_TURNED] != 0 else 0

    world_steps.__name__ = world_steps.__qualname__ = name
    return kernel(world_steps)


# The entries from Python, one a family and set of contact tests (see ``_world_steps_of``;
# step_kernel's ``ADVANCE_BODIES`` likewise), made the first time one is asked for
# (``entry``). Each is its own kernel with its own cache entry: a wrapper passing its family
# to one kernel would have LLVM optimise and emit the whole step twice (about 6 s of a first
# start). Those with every contact test, what ``precompile`` compiles for ``colcon build``:
world_steps_two = _world_steps_of(K.FAMILY_TWO, nk.PAIRS_ALL, 'world_steps_two')
world_steps_k = _world_steps_of(K.FAMILY_K, nk.PAIRS_ALL, 'world_steps_k')
world_steps_split = _world_steps_of(K.FAMILY_SPLIT, nk.PAIRS_ALL, 'world_steps_split')


# -- compiling world_steps in two processes ---------------------------------------------------
# The kernels world_steps calls that take longest to compile (about half of its whole compile,
# each with the kernels it calls), in two groups of about the same time: ``sim/precompile.py``
# compiles each group in its own process, side by side, before world_steps, which then loads
# them from the cache. The types below must be those world_steps passes them
# (test_compile_parts.py checks that it then compiles none of them again). The groups share
# no kernel (narrow_kernels and broad_phase call none of step_kernel, rotation_kernels or
# solver_kernels): two processes must never compile one kernel at once (``precompile``).
LEAF_GROUPS = ('narrow', 'solve')


def compile_leaves(arrays, family, tests, group: str) -> None:
    """Compile (or load) ``group``'s kernels (``LEAF_GROUPS``) for the types world_steps calls
    them with, for a world of ``arrays`` whose bodies take ``family``'s step, with the contact
    tests ``tests``."""
    w = World(*arrays)
    f1, f2 = np.zeros(0), np.zeros((0, 3))
    i1, b1 = np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.bool_)
    if group == 'narrow':
        compile_for(nk.pairs_kernel(tests), i1, i1, w.kinds, w.geoms, w.pool, w.centres,
                    w.rotations, f1, f2, f2, f1, i1, i1)
        compile_for(bp.stable_order, f1)  # sweep_and_prune's, _check_solve's
        compile_for(bp.stable_order, i1)  # _store_warm's
        compile_for(bp.sorted_copy, i1)  # sweep_and_prune's
    elif group == 'solve':
        compile_for(sk.solve_arrays, i1, i1, f2, f2, f1, w.x, w.v, w.w, w.inverse_mass,
                    np.zeros((0, 9)), w.settings, f1, f2, True, f1, f1, f2, f2, f2, f2, f1, f2,
                    f1, b1)
        # body_step's case for the family (step_kernel._two_step ...) calls this
        step = {K.FAMILY_TWO: K.advance_body_2, K.FAMILY_K: K.advance_body_k,
                K.FAMILY_SPLIT: K.advance_body_split}[family]
        compile_for(step, w.state, w.spare, w.params, w.coefficients, 0, 1, False, w.kstatus,
                    w.taken, w.bad, w.work)
    else:
        raise ValueError(f'no group of kernels {group!r}: one of {", ".join(LEAF_GROUPS)}')


# family -> the name of its entry with every contact test (the others: ``entry``).
WORLD_STEPS = {K.FAMILY_TWO: 'world_steps_two', K.FAMILY_K: 'world_steps_k',
               K.FAMILY_SPLIT: 'world_steps_split'}


def entry(family, tests) -> str:
    """The name of the module global holding ``world_steps`` for ``family`` and the contact
    tests ``tests`` (none, for a world of one body), made now if it is not there yet: a name,
    not the kernel, since ``jit.run_interpreted`` rebinds the module's globals (a world looks
    it up again, and makes its ``entry_point``, after a tier swap: ``jit.swaps``). Not
    compiled here."""
    nk.checked_tests(tests)
    name = WORLD_STEPS[family] + ('' if tests == nk.PAIRS_ALL else f'_{tests}')
    jit.made_global(globals(), name, lambda: _world_steps_of(family, tests, name))
    return name


# -- which contact tests a world's step is compiled with -------------------------------------
# A world steps with the entry of its family and a set of contact tests that holds those its
# bodies can meet (``ColliderSet.tests``): a new set is a new compile of the whole
# world step (about 30 s), so a world takes the smallest set whose kernels ``precompile`` put
# in the cache (``colcon build``: every test), and its own set only when there is none.
# RB_SIM_ROS_CONTACT_TESTS=all in the environment: every test, always (one compile for a
# process that meets many scenes, as a test suite does).
ALL_TESTS_VARIABLE = 'RB_SIM_ROS_CONTACT_TESTS'


def contact_part(family, tests) -> str:
    """The name of the kernel part (``sim/precompile.py``) of a world of ``family`` with the
    contact tests ``tests``: 'contact-two-step' with every test, else with the pairs named,
    'contact-two-step:sphere-sphere+sphere-plane' (':none' for none)."""
    name = f'contact-{K.FAMILY_NAMES[family]}'
    if tests == nk.PAIRS_ALL:
        return name
    return name + ':' + ('+'.join(nk.pair_names(tests)) or 'none')


def part_tests(part: str) -> tuple[int, int]:
    """(family, tests) of a contact part's name (``contact_part``); ValueError for another."""
    head, colon, pairs = part.partition(':')
    family = next((f for f, n in K.FAMILY_NAMES.items() if head == f'contact-{n}'), None)
    if family is None or (colon and not pairs):
        raise ValueError(f'no contact part {part!r}')
    if not colon:
        return family, nk.PAIRS_ALL
    return family, 0 if pairs == 'none' else nk.pairs_named(pairs.split('+'))


def tests_for(family, needed: int) -> int:
    """The contact tests a world of ``family`` whose bodies need ``needed`` steps with: the
    smallest set holding them whose part is precompiled (``jit.precompiled``), else
    ``needed`` itself (every test with RB_SIM_ROS_CONTACT_TESTS=all)."""
    if os.environ.get(ALL_TESTS_VARIABLE, '').strip().lower() == 'all':
        return nk.PAIRS_ALL
    every = contact_part(family, nk.PAIRS_ALL)
    best = nk.PAIRS_ALL if jit.precompiled([every]) else None
    for part in jit.marked_parts(every + ':'):
        try:
            f, tests = part_tests(part)
        except ValueError:
            continue  # not one of ours
        if f == family and tests & needed == needed and (
                best is None or (bin(tests).count('1'), tests) < (bin(best).count('1'), best)):
            best = tests
    return needed if best is None else best


def tests_keeping(family, needed: int, current: int | None) -> int:
    """The contact tests a world of ``family`` whose bodies need ``needed`` steps with when
    it goes on from a world of the run compiled with ``current`` (None: none): ``current``
    if it holds them (its step is compiled or loaded already), else ``tests_for`` them and
    ``current``'s together (shapes that come and go then need no other)."""
    if current is None:
        return tests_for(family, needed)
    if needed & ~current == 0:
        return current
    return tests_for(family, needed | current)


def entry_point(name, record):
    """``world_steps`` from Python: what to call as ``f(record, n)``, for the entry named
    ``name`` (``entry``) on ``record`` (a WorldRecord compiled, a WorldHost interpreted), with
    any int ``n`` (typed int64), in the tier of now: the compiled entry itself
    (``jit.entry_point``: numba's dispatch costs more than a small world's step), compiled or
    loaded now."""
    return jit.entry_point(globals()[name], record, 0)


# The stages take the arrays they use, never ``w``, and steps 2 - 5 are written out in
# ``world_steps`` (a call of more than 29 arguments cannot be inlined): numba increfs every
# array of a named tuple argument on entry and decrefs it on exit, and with a call in between
# LLVM cannot drop the pairs. For the 48 arrays of ``w`` that cost about 0.45 us an
# invocation, once a step for each stage and once a body for each integration: more than a
# resting body's whole step (bench/contact_step_bench.py, bench/resting_bench.py).


@inline_kernel
def _sweep(tests, pending, state, tau, gap0, pair_a, pair_b, cbody, nc, nb, x, v, omega, reach,
           g, dt, centres, rotations, kinds, geoms, pool):
    """The swept test of the ``pending`` pairs that are PENDING in ``state`` (P,), at the
    bodies' velocities v, omega (world_kernels.sweep_place, sweep_advance): rounds of conservative
    advancement, each one call of the narrow phase (the contact tests ``tests``) for all the
    pairs still pending, until none is (at most SWEEP_STEPS)."""
    which = np.empty(pending, dtype=np.int64)
    kinds2 = np.empty(2 * pending, dtype=np.int64)
    geoms2 = np.empty((2 * pending, geoms.shape[1]))
    centres2, rotations2 = np.empty((2 * pending, 3)), np.empty((2 * pending, 9))
    pa2 = np.empty(pending, dtype=np.int64)
    pb2 = np.empty(pending, dtype=np.int64)
    for u in range(pending):
        pa2[u], pb2[u] = 2 * u, 2 * u + 1
    margins2 = np.empty(pending)
    count = 0
    for k in range(state.shape[0]):   # the pending pairs, listed once
        if state[k] == wk.PENDING:
            which[count] = k
            count += 1
    rows = pending * nk.MAX_CONTACTS_PER_PAIR
    point2, normal2 = np.empty((rows, 3)), np.empty((rows, 3))
    depth2 = np.empty(rows)
    feature2 = np.empty(rows, dtype=np.int64)
    source2 = np.empty(rows, dtype=np.int64)
    for step in range(wk.SWEEP_STEPS):
        count = wk.sweep_place(state, tau, gap0, pair_a, pair_b, cbody, nc, nb, x, v, omega, reach,
                               g, dt, centres, rotations, kinds, geoms, which, count, kinds2,
                               geoms2, centres2, rotations2, margins2)
        if count == 0:
            return
        found = nk.collide_pairs_of(tests, pa2[:count], pb2[:count], kinds2[:2 * count],
                                    geoms2[:2 * count], pool, centres2[:2 * count],
                                    rotations2[:2 * count], margins2[:count], point2, normal2,
                                    depth2, feature2, source2)
        wk.sweep_advance(count, which, found, source2, normal2, depth2, state, tau, gap0, pair_a,
                         pair_b, cbody, nc, nb, v, omega, reach, g, dt,
                         step == wk.SWEEP_STEPS - 1,
                         kinds2, geoms2, pool, centres2, rotations2)


@inline_kernel
def _turned(rows, state, warn_sq):
    """1 if one of the store rows ``rows`` turns faster than its warn_sq (|omega|^2, rad^2/s^2)
    allows, or nearly (the check in Python sums the squares its own way), else 0."""
    for k in range(rows.shape[0]):
        i = rows[k]
        wx, wy, wz = float(state[i, K.W]), float(state[i, K.W + 1]), float(state[i, K.W + 2])
        if wx * wx + wy * wy + wz * wz > float(warn_sq[i]) * (1.0 - 1e-9):
            return 1
    return 0


@inline_kernel
def _advance_row(f, state, spare, params, coefficients, kstatus, taken, bad, work, clock,
                 row):
    """One step of store row ``row``; True if it failed (then it stays at its state before;
    the reason in kstatus)."""
    one = int(1)
    K.body_step(f, state, spare, params, coefficients, row, one, bool(False), kstatus, taken,
                bad, work)
    failed = kstatus[row] != K.STATUS_OK
    if failed:
        K.body_step(f, state, spare, params, coefficients, row, one, bool(True), kstatus,
                    taken, bad, work)
    for c in range(state.shape[1]):
        state[row, c] = spare[row, c]
    clock[row] += taken[row]
    return failed


@inline_kernel
def _integrate(f, step_rows, body_of_row, asleep, state, spare, params, coefficients, kstatus,
               taken, bad, work, clock):
    """Every awake body one step, in row order; the first row that failed, or -1 (the others
    still take their step)."""
    first = -1
    for j in range(step_rows.shape[0]):
        row = step_rows[j]
        k = body_of_row[row]
        if k >= 0 and asleep[k]:
            continue
        if _advance_row(f, state, spare, params, coefficients, kstatus, taken, bad, work,
                        clock, row) and first < 0:
            first = row
    return first


@inline_kernel
def _finish_stats(asleep, stats, nb):
    """The totals, and the sleepers counted."""
    sleeping = 0
    for k in range(nb):
        if asleep[k]:
            sleeping += 1
    stats[SLEEPING] = sleeping
    for k in range(7):
        stats[8 + k] += stats[k]


@inline_kernel
def _found_none(status, stats, energy, slow_steps, asleep, nb, p1, p2, quiet):
    """The end of a step whose pass found no contact (of ``p1`` candidate pairs and ``p2``
    plane pairs): none solved, no body counted as slow (sleeping counts the steps at rest in
    contact), the totals, the check done, and ``quiet`` (every body asleep) kept for the next
    step (``S_QUIET``). Its caller empties the last contacts."""
    for k in range(8):
        stats[k] = 0
    stats[SWEPT] = stats[MISSED] = stats[SOLVES] = 0
    stats[CANDIDATE_PAIRS], stats[PLANE_PAIRS] = p1, p2
    energy[SOLVE_BEFORE] = energy[SOLVE_AFTER] = 0.0
    for k in range(nb):
        slow_steps[k] = 0
    _finish_stats(asleep, stats, nb)
    status[S_UNCHECKED] = 0
    status[S_QUIET] = 1 if quiet else 0


@inline_kernel
def _all_asleep(asleep, nb):
    """Every one of the nb bodies with colliders asleep (none: False)."""
    for k in range(nb):
        if not asleep[k]:
            return False
    return nb > 0


@inline_kernel
def _inverse_inertia_world(rows, params, state, k, out):
    """R I_body^-1 R^T of body k (row-major into out[k]), from its principal frame r (the
    state row) and inverse principal moments: r diag(j) r^T."""
    row = rows[k]
    jx = float(params[row, K.INVERSE_MOMENTS])
    jy = float(params[row, K.INVERSE_MOMENTS + 1])
    jz = float(params[row, K.INVERSE_MOMENTS + 2])
    for a in range(3):
        ra0 = float(state[row, K.R + 3 * a])
        ra1 = float(state[row, K.R + 3 * a + 1])
        ra2 = float(state[row, K.R + 3 * a + 2])
        for b in range(3):
            out[k, 3 * a + b] = (ra0 * jx * float(state[row, K.R + 3 * b])
                                 + ra1 * jy * float(state[row, K.R + 3 * b + 1])
                                 + ra2 * jz * float(state[row, K.R + 3 * b + 2]))


@inline_kernel
def _energy(rows, state, params, inverse_mass, k, vel, ang):
    """Kinetic energy (J) of body k at (vel, ang): 1/2 m v.v + 1/2 w . I w, I = r diag(I_p) r^T
    (principal moments from the params row)."""
    row = rows[k]
    vx, vy, vz = float(vel[k, 0]), float(vel[k, 1]), float(vel[k, 2])
    wx, wy, wz = float(ang[k, 0]), float(ang[k, 1]), float(ang[k, 2])
    # omega in the principal frame: r^T w
    total = (vx * vx + vy * vy + vz * vz) / float(inverse_mass[k])
    for j in range(3):
        b = (float(state[row, K.R + j]) * wx + float(state[row, K.R + 3 + j]) * wy
             + float(state[row, K.R + 6 + j]) * wz)
        total += float(params[row, K.MOMENTS + j]) * b * b
    return 0.5 * total


@inline_kernel
def _check_solve(status, flagged_bodies, energy, gain_tolerance, rows, state, params,
                 inverse_mass, v0, w0, nb, body_a, body_b, v1, w1, disp, turn, step):
    """The bodies not to write (True): those the solve gave a non-finite value, or, if it gave
    the bodies more kinetic energy (at v1, w1) than they had (at v0, w0; the last guard,
    docs/collisions.md "Energy"), the ones whose energy rose, largest gain first. The error is
    recorded in ``status`` (w.status), the bodies in ``flagged_bodies``, the energies in
    ``energy``."""
    involved = np.zeros(nb + 1, dtype=np.bool_)
    for k in range(body_a.shape[0]):
        involved[body_a[k]] = True
        involved[body_b[k]] = True
    spared = np.zeros(nb, dtype=np.bool_)
    flagged = 0
    for k in range(nb):
        if not involved[k]:
            continue
        total = 0.0
        for c in range(3):
            total += (v1[k, c] * 0.0 + w1[k, c] * 0.0 + disp[k, c] * 0.0 + turn[k, c] * 0.0)
        if total != 0.0:
            spared[k] = True
            flagged_bodies[flagged] = k
            flagged += 1
    if flagged:
        if status[S_KIND] == OK:
            status[S_KIND], status[S_ERROR_STEP] = SOLVE_NON_FINITE, step
            status[S_FLAGGED] = flagged
        return spared
    e0 = np.zeros(nb)
    e1 = np.zeros(nb)
    total0, total1, floor = 0.0, 0.0, 0.0
    for k in range(nb):
        if involved[k]:
            e0[k] = _energy(rows, state, params, inverse_mass, k, v0, w0)
            e1[k] = _energy(rows, state, params, inverse_mass, k, v1, w1)
            total0 += e0[k]
            total1 += e1[k]
            floor += 0.5 * GAIN_FLOOR_SPEED * GAIN_FLOOR_SPEED / float(inverse_mass[k])
    energy[SOLVE_BEFORE], energy[SOLVE_AFTER] = total0, total1
    if total1 <= total0 * (1.0 + gain_tolerance) + floor or not (
            total0 <= 1.7976931348623157e308):
        return spared
    gain = np.empty(nb)
    for k in range(nb):
        gain[k] = e0[k] - e1[k] if involved[k] else math.inf
    order = bp.stable_order(gain)  # the largest gain first
    for k in order:
        if involved[k] and e1[k] > e0[k]:
            spared[k] = True
            flagged_bodies[flagged] = k
            flagged += 1
    if status[S_KIND] == OK:
        status[S_KIND], status[S_ERROR_STEP] = SOLVE_ENERGY, step
        status[S_FLAGGED] = flagged
        energy[0], energy[1] = total0, total1
    return spared


@kernel
def _match(keys, old_keys, old_normal, old_tangent, normal, tangent):
    """Impulses of the previous step's contacts with the same keys (0 for new ones): the
    first of old_keys (sorted) not below each key (np.searchsorted's), found by galloping
    from the last one found. The keys come pair after pair in the broad phase's order, so
    the next is mostly a step or two away; a binary search over all of them mispredicted
    its way through 5% of a 100-box pile's step."""
    count = old_keys.shape[0]
    hint = 0
    for k in range(keys.shape[0]):
        key = keys[k]
        if hint < count and old_keys[hint] < key:  # the first not below key is past hint
            bound = 1
            while hint + bound < count and old_keys[hint + bound] < key:
                bound *= 2
            lo, hi = hint + bound // 2 + 1, min(hint + bound, count)
        else:  # at hint or before it
            bound = 1
            while hint - bound >= 0 and old_keys[hint - bound] >= key:
                bound *= 2
            lo, hi = max(hint - bound + 1, 0), hint - bound // 2
        while lo < hi:  # the first of [lo, hi) not below key, or hi
            mid = (lo + hi) // 2
            if old_keys[mid] < key:
                lo = mid + 1
            else:
                hi = mid
        pos = lo
        hint = pos
        if pos < count and old_keys[pos] == keys[k]:
            normal[k] = old_normal[pos]
            for c in range(3):
                tangent[k, c] = old_tangent[pos, c]


@inline_kernel
def _kept(nb, cbody, asleep, ca, cbb, any_asleep):
    """The indices of the contacts (collider pairs ca, cbb; cbb >= C a plane) between two
    sleepers or a sleeper and the static world; none when no body sleeps."""
    nc = cbody.shape[0]
    keep = np.empty(ca.shape[0] if any_asleep else 0, dtype=np.int64)
    kept = 0
    for k in range(keep.shape[0]):
        body_a = cbody[ca[k]] if ca[k] < nc else nb
        body_b = cbody[cbb[k]] if cbb[k] < nc else nb
        if ((body_a == nb or asleep[body_a]) and (body_b == nb or asleep[body_b])
                and not (body_a == nb and body_b == nb)):
            keep[kept] = k
            kept += 1
    return keep[:kept]


@inline_kernel
def _with_kept(point, normal, depth, impulse, ca, cbb, keep, was_point, was_normal, was_depth,
               was_impulse, was_ca, was_cbb):
    """A pass's contacts, then the kept ones (``keep``, indices into the was_ arrays); the
    pass's own arrays when none is kept."""
    kept = keep.shape[0]
    if kept == 0:
        return point, normal, depth, impulse, ca, cbb
    m = ca.shape[0]
    all_point, all_normal = np.empty((m + kept, 3)), np.empty((m + kept, 3))
    all_depth, all_impulse = np.empty(m + kept), np.empty(m + kept)
    all_ca, all_cbb = np.empty(m + kept, dtype=np.int64), np.empty(m + kept, dtype=np.int64)
    for k in range(m + kept):
        j = k if k < m else keep[k - m]
        mine = k < m
        for c in range(3):
            all_point[k, c] = point[j, c] if mine else was_point[j, c]
            all_normal[k, c] = normal[j, c] if mine else was_normal[j, c]
        all_depth[k] = depth[j] if mine else was_depth[j]
        all_impulse[k] = impulse[j] if mine else was_impulse[j]
        all_ca[k] = ca[j] if mine else was_ca[j]
        all_cbb[k] = cbb[j] if mine else was_cbb[j]
    return all_point, all_normal, all_depth, all_impulse, all_ca, all_cbb


@inline_kernel
def _store_warm(nb, cbody, planes, asleep, keys, normal, tangent, old_keys, old_normal,
                old_tangent):
    """This step's impulses for the next one's warm start, sorted by key, with the kept
    impulses of contacts between sleepers (or a sleeper and the static world): they are not
    found while asleep, and a pile that wakes resumes from its resting impulses, not from 0."""
    nc = cbody.shape[0]
    total = max(nc + planes, 1)
    keep = np.zeros(old_keys.shape[0], dtype=np.bool_)
    kept = 0
    any_asleep = False
    for k in range(nb):
        any_asleep = any_asleep or asleep[k]
    if any_asleep:
        for k in range(old_keys.shape[0]):
            pair = old_keys[k] >> FEATURE_BITS
            a, b = pair // total, pair % total
            body_a = cbody[a] if a < nc else nb
            body_b = cbody[b] if b < nc else nb
            if (asleep[body_a] or body_a == nb) and (asleep[body_b] or body_b == nb):
                keep[k] = True
                kept += 1
    m = keys.shape[0]
    all_keys = np.empty(m + kept, dtype=np.int64)
    all_normal = np.empty(m + kept)
    all_tangent = np.empty((m + kept, 3))
    for k in range(m):
        all_keys[k], all_normal[k] = keys[k], normal[k]
        for c in range(3):
            all_tangent[k, c] = tangent[k, c]
    j = m
    for k in range(old_keys.shape[0]):
        if keep[k]:
            all_keys[j], all_normal[j] = old_keys[k], old_normal[k]
            for c in range(3):
                all_tangent[j, c] = old_tangent[k, c]
            j += 1
    order = bp.stable_order(all_keys)
    out_keys = np.empty(m + kept, dtype=np.int64)
    out_normal = np.empty(m + kept)
    out_tangent = np.empty((m + kept, 3))
    for k in range(m + kept):
        out_keys[k], out_normal[k] = all_keys[order[k]], all_normal[order[k]]
        for c in range(3):
            out_tangent[k, c] = all_tangent[order[k], c]
    return out_keys, out_normal, out_tangent


@inline_kernel
def _fall_asleep(config, reach, asleep, slow_steps, cbody, rows, state, params, nb, body_a,
                 body_b, impulse, v1, w1, pairs):
    """Count the steps each awake body has been slow (every point of its colliders under
    sleep_speed) while pressed by a contact; bodies that have been so for sleep_time sleep, at
    exact rest, together with every body near them (the broad phase's pairs, transitively),
    and only if all of those are ready too: a body never sleeps next to an awake one."""
    supported = np.zeros(nb + 1, dtype=np.bool_)
    for k in range(body_a.shape[0]):
        if impulse[k] > 0.0:
            supported[body_a[k]] = True
            supported[body_b[k]] = True
    sleep_steps = int(config[C_SLEEP_STEPS])
    any_ready = False
    ready = np.zeros(nb, dtype=np.bool_)
    for k in range(nb):
        vx, vy, vz = float(v1[k, 0]), float(v1[k, 1]), float(v1[k, 2])
        wx, wy, wz = float(w1[k, 0]), float(w1[k, 1]), float(w1[k, 2])
        speed = math.sqrt(vx * vx + vy * vy + vz * vz) + math.sqrt(
            wx * wx + wy * wy + wz * wz) * float(reach[k])
        if supported[k] and speed < float(config[C_SLEEP_SPEED]) and not asleep[k]:
            slow_steps[k] += 1
        else:
            slow_steps[k] = 0
        ready[k] = slow_steps[k] >= sleep_steps
        any_ready = any_ready or ready[k]
    if not any_ready:
        return
    # Spread "not ready" along the pairs of moving bodies until nothing changes.
    blocked = np.zeros(nb + 1, dtype=np.bool_)
    for k in range(nb):
        blocked[k] = not ready[k]
    changed = True
    while changed:
        changed = False
        for k in range(pairs.shape[0]):
            a, b = cbody[pairs[k, 0]], cbody[pairs[k, 1]]
            if a < nb and b < nb and blocked[a] != blocked[b]:
                blocked[a] = blocked[b] = True
                changed = True
    for k in range(nb):
        if ready[k] and not blocked[k]:
            row = rows[k]
            for c in range(3):
                state[row, K.V + c] = 0.0
                state[row, K.W + c] = 0.0
            state[row, K.HISTORY] = K.HISTORY_NONE
            K.evaluate(state, params, row)
            asleep[k] = True
