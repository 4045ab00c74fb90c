# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""The standard simulator API, simulation_interfaces (ROS 2 Jazzy, release 1.5), on the node.

Services (relative to the node's namespace): get_simulator_features, get_entities,
get_entity_state, get_entities_states, set_entity_state, get_simulation_state,
set_simulation_state, step_simulation, reset_simulation, spawn_entity, spawn_entities (1.5:
with a release before it, not served), delete_entity, get_spawnables; the action
simulate_steps. What is supported is what get_simulator_features
says, truthfully: no tags or bounds, no named poses, no worlds, no reset of sim time (time is
step * dt, and recordings rely on it growing).

spawn_entity takes a body as a scene-file body entry in ``resource_string`` (YAML or JSON, as
``scene.body_entry`` reads it: ``{mass: 1, inertia: [0.1, 0.1, 0.1], colliders: [...]}``), or
the name of one of the scene's ``templates`` in ``uri`` (get_spawnables lists them). The name
is the request's, else the entry's, else the template's; ``allow_renaming`` appends _2, _3, ...
to a name in use. ``initial_pose`` places it (in ``world_frame`` or another body's frame, at
the step it appears); left at its default (identity, no frame) the entry's own pose holds.
Its velocities are the entry's (world frame). The body gets the topics of a scene body
(``<name>/pose``, ``<name>/wrench``, ...). reset_simulation with SCOPE_SPAWNED deletes what was
spawned; SCOPE_STATE puts a spawned body back where it appeared. spawn_entities spawns many
bodies, each as spawn_entity would, all at the same step or none: if one is refused, the
result is ENTITIES_SPAWN_FAILED and each request's own result says why it, or another, was
refused (one refused at the step itself, after others were applied, takes them back: each
such spawn is then deleted at the same step, and both are in the recording).

Entities are the scene's bodies (the single body: its name 'body'); category STATIC_OBJECT for
a static body, DYNAMIC_OBJECT for the others. States are ground truth in ``world_frame``:
pose, twist (linear velocity of the centre of mass, angular velocity, both in the world frame)
and acceleration (``Simulation.accelerations``). set_entity_state takes a reference frame: empty
or ``world_frame`` ('world'), or the frame of another body, whose state at the step the change
takes effect carries the given pose and twist into the world (v = v_F + w_F x (R_F p) + R_F v',
w = w_F + R_F w'); the acceleration is ignored, as the standard allows.

Every change goes through the node's inputs, so it is recorded at the step it took effect and
replays bit for bit; a refused request changes nothing and says why in ``result``.
"""

from __future__ import annotations

from dataclasses import replace
import math
import re
import time

from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.task import Future
from simulation_interfaces.action import SimulateSteps
from simulation_interfaces.msg import (EntityCategory, EntityState, Result, SimulationState,
                                       SimulatorFeatures)
from simulation_interfaces.msg import Spawnable
from simulation_interfaces.srv import (DeleteEntity, GetEntities, GetEntitiesStates,
                                       GetEntityState, GetSimulationState,
                                       GetSimulatorFeatures, GetSpawnables, ResetSimulation,
                                       SetEntityState, SetSimulationState, SpawnEntity,
                                       StepSimulation)
try:  # simulation_interfaces 1.5 (Jazzy's since 2026-04); not in an older install
    from simulation_interfaces.msg import SpawnResult
    from simulation_interfaces.srv import SpawnEntities
except ImportError:  # then spawn_entities is not served, nor listed as a feature
    SpawnEntities = SpawnResult = None
try:  # a requirement (python3-regex); without it, a filter is a plain substring
    import regex
except ImportError:  # pragma: no cover - an install without it
    regex = None

from rb_sim_ros.ros import ros_messages
from rb_sim_ros.sim import scene
from rb_sim_ros.sim.simulation import Delete, SetPose, SetTwist, Spawn

# The most steps one simulate_steps goal may ask for (1e9 s at 1 ms), and one step_simulation
# call, which holds the executor until it is done (a few seconds for one body).
MAX_STEPS = 10 ** 12
MAX_SERVICE_STEPS = 10 ** 6
FEATURES = (SimulatorFeatures.ENTITY_CATEGORIES, SimulatorFeatures.ENTITY_STATE_GETTING,
            SimulatorFeatures.ENTITY_STATE_SETTING, SimulatorFeatures.SIMULATION_RESET,
            SimulatorFeatures.SIMULATION_RESET_STATE, SimulatorFeatures.SIMULATION_STATE_GETTING,
            SimulatorFeatures.SIMULATION_STATE_SETTING, SimulatorFeatures.SIMULATION_STATE_PAUSE,
            SimulatorFeatures.STEP_SIMULATION_SINGLE, SimulatorFeatures.STEP_SIMULATION_MULTIPLE,
            SimulatorFeatures.STEP_SIMULATION_ACTION, SimulatorFeatures.SPAWNING,
            SimulatorFeatures.DELETING, SimulatorFeatures.SPAWNING_RESOURCE_STRING,
            SimulatorFeatures.SPAWNABLES, SimulatorFeatures.SIMULATION_RESET_SPAWNED) + \
    ((SimulatorFeatures.SPAWNING_ENTITIES,) if SpawnEntities is not None else ())
# The most bodies one spawn_entities may ask for.
MAX_SPAWN_REQUESTS = 1000
# What a spawn's resource_string may be: a scene-file body entry, or a model of one body.
SPAWN_FORMATS = ('yaml', 'urdf', 'mjcf')
# The services and the action: (name, type, the method serving it, what). Created from this
# table, and ``simulator --help`` lists them from it.
SERVICES = (
    ('get_simulator_features', GetSimulatorFeatures, '_features', 'what is supported'),
    ('get_entities', GetEntities, '_entities', 'the bodies, by name pattern and category'),
    ('get_entities_states', GetEntitiesStates, '_entities_states', 'their states'),
    ('get_entity_state', GetEntityState, '_get_state', 'pose, twist, acceleration (world)'),
    ('set_entity_state', SetEntityState, '_set_state', 'pose and twist, in a frame'),
    ('get_simulation_state', GetSimulationState, '_get_sim_state', 'playing, paused, stopped'),
    ('set_simulation_state', SetSimulationState, '_set_sim_state', 'play, pause or stop'),
    ('step_simulation', StepSimulation, '_step', 'steps, while paused'),
    ('reset_simulation', ResetSimulation, '_reset', 'SCOPE_STATE, SCOPE_SPAWNED'),
    ('spawn_entity', SpawnEntity, '_spawn', 'a body entry (YAML) or a template'),
) + ((('spawn_entities', SpawnEntities, '_spawn_all', 'many, at one step, all or none'),)
     if SpawnEntities is not None else ()) + (
    ('delete_entity', DeleteEntity, '_delete', 'a body'),
    ('get_spawnables', GetSpawnables, '_spawnables', "the scene's templates"),
)
ACTIONS = (('simulate_steps', SimulateSteps, '_simulate', 'steps with feedback, cancellable'),)


def _pose_problem(pose) -> str:
    """Why an initial_pose (PoseStamped) cannot place anything, or '' (its frame aside)."""
    p, o = pose.pose.position, pose.pose.orientation
    x, q = (p.x, p.y, p.z), (o.x, o.y, o.z, o.w)
    if not all(math.isfinite(c) for c in x + q) or not any(q):
        return f'initial_pose must be finite with a non-zero quaternion, got {x}, {q}'
    return ''


def _result(code: int = Result.RESULT_OK, message: str = '') -> Result:
    return Result(result=code, error_message=message)


class EntityStateInput:
    """A set_entity_state, carried into the world frame at the step it takes effect (that
    needs the reference body's state then)."""

    def __init__(self, body: str, frame_body: str | None, position, orientation, linear,
                 angular) -> None:
        self.body, self.frame_body = body, frame_body
        self.position, self.orientation = position, orientation
        self.linear, self.angular = linear, angular

    def events(self, sim) -> tuple:
        """(SetPose, SetTwist) in the world frame, from the reference body's state now."""
        x, q, v, w = self.position, self.orientation, self.linear, self.angular
        if self.frame_body is not None:
            fx, fq, fv, fw = sim.pose_twist(self.frame_body)
            r = ros_messages.rotation_from_quaternion(fq)
            rx = ros_messages.rotate(r, x)
            x = tuple(a + b for a, b in zip(fx, rx))
            q = _quaternion_product(fq, q)
            rv, rw = ros_messages.rotate(r, v), ros_messages.rotate(r, w)
            spin = _cross(fw, rx)
            v = tuple(fv[k] + spin[k] + rv[k] for k in range(3))
            w = tuple(fw[k] + rw[k] for k in range(3))
        if not all(math.isfinite(c) for c in x + tuple(q) + v + w):
            raise ValueError(f"entity '{self.body}': the state in the world frame is not "
                             f'finite: pose {x}, {q}, twist {v}, {w}')
        return SetPose(x, q, self.body), SetTwist(v, w, self.body)


def match_names(pattern: str, names: list) -> list:
    """The names ``pattern`` (a regular expression: Python's syntax, plus the POSIX classes
    such as ``[[:alpha:]]``, as the ``regex`` package reads it) finds a match in.

    The request is untrusted, and a backtracking engine can take exponential time on some
    patterns: a pattern with no special character is a plain substring search; any other is
    matched with the ``regex`` package's time limit, MATCH_TIMEOUT_S for the whole query, so a
    query holds the executor (and the wrenches waiting behind it) that long at most.
    ValueError, saying why, for a bad, too long or too slow pattern."""
    if len(pattern) > MAX_PATTERN:
        raise ValueError(f'filter is {len(pattern)} characters long; at most {MAX_PATTERN}')
    if re.escape(pattern) == pattern:
        return [n for n in names if pattern in n]
    if regex is None:
        raise ValueError('a filter that is a regular expression needs the regex package '
                         '(pip install regex; on a ROS install: python3-regex); a plain '
                         'substring filter works without it')
    size = pattern_size(pattern)
    if size > MAX_PATTERN_SIZE:  # the compile has no time limit: (a{1000}){1000} takes 4 s
        raise ValueError(f'filter {pattern[:80]!r} is about {size:.3g} items once its counted '
                         f'repeats are spelled out; at most {MAX_PATTERN_SIZE}')
    try:
        compiled = regex.compile(pattern)
    except (regex.error, OverflowError, RecursionError, ValueError, MemoryError) as e:
        why = str(e).strip().splitlines()[0] if str(e).strip() else ''
        raise ValueError(f'filter {pattern[:80]!r} is not a regular expression: '
                         f'{type(e).__name__}: {why}') from None
    end = time.monotonic() + MATCH_TIMEOUT_S
    found = []
    try:
        for n in names:
            left = end - time.monotonic()
            if left <= 0.0:
                raise TimeoutError
            if compiled.search(n, timeout=left) is not None:
                found.append(n)
    except TimeoutError:
        raise ValueError(f'filter {pattern[:80]!r} took more than {MATCH_TIMEOUT_S * 1e3:g} ms '
                         'to match the entity names (catastrophic backtracking?): simplify '
                         'it') from None
    except (RecursionError, MemoryError, OverflowError) as e:
        raise ValueError(f'filter {pattern[:80]!r} could not be matched: '
                         f'{type(e).__name__}') from None
    return found


MAX_PATTERN = 1000
# What regex's compile spells out of nested counted repeats, the way pattern_size counts it:
# 10^4 compiles in well under 0.2 s, 10^6 in seconds, and 10^8 fits in a 30-character filter.
MAX_PATTERN_SIZE = 10_000
_COUNT = re.compile(r'\{(\d*)(?:,(\d*))?\}')
_POSIX = re.compile(r'\[:\^?[A-Za-z_]+:\]')


def pattern_size(pattern: str) -> int:
    """An upper estimate of the items of ``pattern`` once each counted repeat ``{m}``, ``{m,n}``
    of an item or a group is written out (``(ab){3}`` is 6); at least the length of a pattern
    without them. Character classes (with POSIX classes and escapes in them) are one item; a
    scan that misreads a construct only ever counts more, not less."""
    stack = [0]  # the size of each open group, the outermost first
    last = 0  # the size of the item a quantifier would repeat
    i, n = 0, len(pattern)
    while i < n:
        c = pattern[i]
        if c == '\\':
            i += 2
            last = 1
        elif c == '[':
            j = i + 1
            if j < n and pattern[j] == '^':
                j += 1
            if j < n and pattern[j] == ']':
                j += 1
            while j < n and pattern[j] != ']':
                m = _POSIX.match(pattern, j)
                j = m.end() if m else j + (2 if pattern[j] == '\\' else 1)
            i = j + 1
            last = 1
        elif c == '(':
            stack.append(0)
            i += 1
            last = 0
            continue
        elif c == ')' and len(stack) > 1:
            last = max(stack.pop(), 1)
            i += 1
        else:
            m = _COUNT.match(pattern, i) if c == '{' else None
            if m:
                count = max([int(g) for g in m.groups() if g] or [1])
                stack[-1] += last * (count - 1)
                last *= count
                i = m.end()
                continue
            i += 1
            last = 1
        stack[-1] += last
    return sum(stack)


# The time one filtered query may take, all names together: short, since it holds the
# executor that also takes the wrench commands.
MATCH_TIMEOUT_S = 0.05


def _cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def _quaternion_product(a, b):
    """a * b of quaternions x, y, z, w (the rotation b, then a)."""
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (aw * bx + ax * bw + ay * bz - az * by, aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw, aw * bw - ax * bx - ay * by - az * bz)


class SimulationInterfaces:
    """The services and the action on ``node`` (a SimulatorNode)."""

    def __init__(self, node) -> None:
        self.node = node
        self._stopped_at = None  # the step of a stop (reset and paused), while it holds
        self._epoch = 0  # counts changes of the simulation state: a stepping call stops then
        self.stepping = False  # a step_simulation or simulate_steps is under way
        self._turns = ReentrantCallbackGroup()  # _executor_turn's timers: never held up
        n = node
        for name, srv_type, method, _ in SERVICES:
            n.create_service(srv_type, name, getattr(self, method))
        ((name, action_type, method, _),) = ACTIONS
        self._action = ActionServer(n, action_type, name, getattr(self, method),
                                    goal_callback=self._goal,
                                    cancel_callback=lambda _: CancelResponse.ACCEPT)

    # -- entities --------------------------------------------------------------------------
    def _names(self):
        return [b.name for b in self.node.config.bodies]

    def _category(self, name: str) -> int:
        static = not self.node.sim.is_moving(name)
        return EntityCategory.CATEGORY_STATIC_OBJECT if static else \
            EntityCategory.CATEGORY_DYNAMIC_OBJECT

    def _features(self, request, response):
        f = response.features
        f.features = list(FEATURES)
        f.spawn_formats = list(SPAWN_FORMATS)
        f.custom_info = ('rb_sim_ros: entities are the bodies; reset keeps sim time '
                         '(SCOPE_STATE, SCOPE_SPAWNED); states in world_frame; spawn a scene-file '
                         'body entry (resource_string, YAML), a URDF or MJCF model of one body '
                         '(resource_string, XML) or a scene template (uri)')
        return response

    def _filtered(self, filters):
        """(Result, names) of the entities passing ``filters``."""
        if filters.tags.tags:
            return _result(Result.RESULT_FEATURE_UNSUPPORTED, 'entity tags are not supported'), []
        if filters.bounds.type != 0 or filters.bounds.points:
            return _result(Result.RESULT_FEATURE_UNSUPPORTED,
                           'bounds filters are not supported'), []
        wanted = {c.category for c in filters.categories}
        names = [n for n in self._names() if not wanted or self._category(n) in wanted]
        if filters.filter:
            try:
                names = match_names(filters.filter, names)
            except ValueError as e:
                return _result(Result.RESULT_OPERATION_FAILED, str(e)), []
        return _result(), names

    def _entities(self, request, response):
        response.result, response.entities = self._filtered(request.filters)
        return response

    def _entity_state(self, name: str) -> EntityState:
        node = self.node
        sim = node.sim
        state = EntityState()
        state.header.frame_id = node._v['world_frame']
        state.header.stamp = ros_messages.time_msg(sim.time_ns)
        x, q, v, w = sim.pose_twist(name)
        a, b = sim.accelerations(name)
        p, o = state.pose.position, state.pose.orientation
        p.x, p.y, p.z = x
        o.x, o.y, o.z, o.w = q
        t, acc = state.twist, state.acceleration
        t.linear.x, t.linear.y, t.linear.z = v
        t.angular.x, t.angular.y, t.angular.z = w
        acc.linear.x, acc.linear.y, acc.linear.z = a
        acc.angular.x, acc.angular.y, acc.angular.z = b
        if not all(math.isfinite(c) for vec in (x, q, v, w, a, b) for c in vec):
            raise ValueError(f"the state of '{name}' is not finite (its acceleration "
                             'overflows): not sent')
        return state

    def _get_state(self, request, response):
        if request.entity not in self._names():
            response.result = _result(Result.RESULT_NOT_FOUND,
                                      f"no entity named '{request.entity}'")
            return response
        try:
            with self.node._lock:
                response.state = self._entity_state(request.entity)
        except ValueError as e:
            response.state = EntityState()
            response.result = _result(Result.RESULT_OPERATION_FAILED, str(e))
            return response
        response.result = _result()
        return response

    def _entities_states(self, request, response):
        response.result, names = self._filtered(request.filters)
        try:
            with self.node._lock:
                states = [self._entity_state(n) for n in names]
        except ValueError as e:
            response.result = _result(Result.RESULT_OPERATION_FAILED, str(e))
            return response
        response.entities, response.states = names, states
        return response

    def _set_state(self, request, response):
        response.result = self._check_set_state(request.entity, request.state)
        return response

    def _check_set_state(self, name: str, state: EntityState) -> Result:
        node = self.node
        if name not in self._names():
            return _result(Result.RESULT_NOT_FOUND, f"no entity named '{name}'")
        if not node.sim.is_moving(name):
            return _result(Result.RESULT_OPERATION_FAILED,
                           f"entity '{name}' is static: it cannot be moved")
        frame = state.header.frame_id.lstrip('/')
        frames = {p.body_frame: p.name for p in node.ports.values()}
        if frame in ('', node._v['world_frame'], 'world'):
            frame_body = None
        elif frame in frames:
            frame_body = frames[frame]
        else:
            return _result(Result.RESULT_OPERATION_FAILED, (
                f"reference frame '{frame}' is neither '{node._v['world_frame']}' nor a body "
                f'frame ({", ".join(sorted(frames))})'))
        p, o = state.pose.position, state.pose.orientation
        position, q = (p.x, p.y, p.z), (o.x, o.y, o.z, o.w)
        t = state.twist
        linear = (t.linear.x, t.linear.y, t.linear.z)
        angular = (t.angular.x, t.angular.y, t.angular.z)
        values = position + q + linear + angular
        if not all(math.isfinite(c) for c in values) or not any(q):
            return _result(Result.RESULT_OPERATION_FAILED,
                           f'state must be finite with a non-zero quaternion, got pose '
                           f'{position}, {q}, twist {linear}, {angular}')
        event = EntityStateInput(name, frame_body, position, q, linear, angular)
        with node._lock:
            if not node._paused:  # at the next period: checked then (a refusal is logged)
                node._pending.append(event)
                return _result()
            node._guarded(node._drain)  # what was queued before it goes first
            rejected = node.diagnostics.rejected
            node._pending.append(event)
            ok = node._guarded(node._drain)  # paused: now, so the answer can say how it went
            if not ok:
                return _result(Result.RESULT_OPERATION_FAILED, node.diagnostics.error)
            if node.diagnostics.rejected != rejected:
                return _result(Result.RESULT_OPERATION_FAILED,
                               f"entity '{name}': the state in the world frame is not finite "
                               'or not valid; nothing changed')
        return _result()

    # -- simulation state ------------------------------------------------------------------
    @property
    def stopped(self) -> bool:
        """Stopped (reset and paused) and neither run nor stepped since, by any interface."""
        node = self.node
        return (self._stopped_at is not None and node._paused
                and node.sim.step_count == self._stopped_at)

    def _state(self) -> int:
        if self.stopped:
            return SimulationState.STATE_STOPPED
        return SimulationState.STATE_PAUSED if self.node._paused else \
            SimulationState.STATE_PLAYING

    def _get_sim_state(self, request, response):
        response.state.state = self._state()
        response.result = _result()
        return response

    def _set_sim_state(self, request, response):
        want, now = request.state.state, self._state()
        node = self.node
        if want == now:
            response.result = _result(SetSimulationState.Response.ALREADY_IN_TARGET_STATE,
                                      'already in that state')
            return response
        self._epoch += 1  # a stepping call under way stops at its next period
        if want == SimulationState.STATE_PLAYING:
            with node._lock:
                ok = node._guarded(node._resume)
        elif want == SimulationState.STATE_PAUSED:
            if now == SimulationState.STATE_STOPPED:
                response.result = _result(SetSimulationState.Response.INCORRECT_TRANSITION,
                                          'stopped: play to run, not pause')
                return response
            with node._lock:
                node._paused, node._error_paused = True, False
            ok = True
        elif want == SimulationState.STATE_STOPPED:
            with node._lock:
                node._paused, node._error_paused = True, False
                node._pending.extend(node.reset_events())
                ok = node._guarded(node._drain)
            self._stopped_at = node.sim.step_count if ok else None
        else:
            response.result = _result(Result.RESULT_FEATURE_UNSUPPORTED,
                                      f'state {want} is not supported (playing, paused or '
                                      'stopped)')
            return response
        response.result = _result() if ok else _result(
            SetSimulationState.Response.STATE_TRANSITION_ERROR, node.diagnostics.error)
        return response

    def _reset(self, request, response):
        scope = request.scope
        if scope == ResetSimulation.Request.SCOPE_DEFAULT or \
                scope & ResetSimulation.Request.SCOPE_TIME:
            response.result = _result(Result.RESULT_FEATURE_UNSUPPORTED, (
                'sim time is not reset (it is step * dt; recordings rely on it growing): ask '
                'for SCOPE_STATE, which puts every body back to its initial state'))
            return response
        self._epoch += 1
        if scope & ResetSimulation.Request.SCOPE_SPAWNED:
            for name in list(self.node.sim.spawned):
                why = self.node.change_bodies(Delete(name))
                if why:
                    response.result = _result(Result.RESULT_OPERATION_FAILED,
                                              f"deleting '{name}': {why}")
                    return response
        if not scope & ResetSimulation.Request.SCOPE_STATE:  # SCOPE_SPAWNED alone
            response.result = _result()
            return response
        ok = self.node.reset_all()
        response.result = _result() if ok else _result(Result.RESULT_OPERATION_FAILED,
                                                       self.node.diagnostics.error)
        return response

    # -- spawning and deleting -------------------------------------------------------------
    def _spawnables(self, request, response):
        response.spawnables = [
            Spawnable(uri=t.name, description=(
                f'{"static" if t.static else f"{t.mass:g} kg"}, '
                f'{len(t.colliders)} collider(s): template of the scene'))
            for t in self.node.templates]
        response.result = _result(Result.RESULT_OK, 'sources are not searched: the templates '
                                  'of the scene' if request.sources else '')
        return response

    def _spawn(self, request, response):
        code, message, spec = self._spawn_spec(request)
        if spec is not None:
            placed = []

            def place(s):  # under the node's lock, at the step it takes effect
                placed.append(self._placed(s, request.initial_pose))
                return placed[0]
            try:
                why = self.node.change_bodies(Spawn(spec), place)
            except ValueError as e:
                code, message, spec = SpawnEntity.Response.INVALID_POSE, str(e), None
            else:
                spec = placed[0] if placed else spec
                if why:
                    code, message = Result.RESULT_OPERATION_FAILED, why
        response.result = _result(code, message)
        response.entity_name = spec.name if spec is not None and code == Result.RESULT_OK \
            else ''
        return response

    def _spawn_all(self, request, response):
        """spawn_entities: each request as spawn_entity, all at the same step or none."""
        requests = request.spawn_requests
        failed = SpawnEntities.Response.ENTITIES_SPAWN_FAILED
        if len(requests) > MAX_SPAWN_REQUESTS:
            response.result = _result(failed, f'{len(requests)} requests: at most '
                                      f'{MAX_SPAWN_REQUESTS} a call')
            return response
        results, changes, names = [], [], set(self._names())
        for r in requests:
            one = SpawnEntity.Request(
                name=r.name, allow_renaming=r.allow_renaming, uri=r.entity_resource.uri,
                resource_string=r.entity_resource.resource_string,
                entity_namespace=r.entity_namespace, initial_pose=r.initial_pose)
            code, message, spec = self._spawn_spec(one, names, len(changes))
            if spec is not None and _pose_problem(one.initial_pose):  # (its frame: at the step)
                code, message, spec = SpawnResult.INVALID_POSE, \
                    _pose_problem(one.initial_pose), None
            results.append(SpawnResult(result=_result(code, message)))
            if spec is not None:
                names.add(spec.name)
                changes.append((Spawn(spec), self._placer(one.initial_pose)))
                results[-1].entity_name = spec.name
        bad = [k for k, r in enumerate(results) if r.result.result != Result.RESULT_OK]
        if not bad and requests:
            index, why, placing = self.node.change_all(changes)
            if index >= 0:
                bad = [index]
                results[index].result = _result(
                    SpawnResult.INVALID_POSE if placing else Result.RESULT_OPERATION_FAILED,
                    why)
        if bad:
            for k, r in enumerate(results):
                r.entity_name = ''
                if k not in bad:
                    r.result = _result(Result.RESULT_OPERATION_FAILED,
                                       f'not spawned: request {bad[0]} was refused (all or '
                                       'none)')
            response.result = _result(failed, f'{len(bad)} of {len(requests)} requests '
                                      f'refused, the first ({bad[0]}): '
                                      f'{results[bad[0]].result.error_message}')
        else:
            response.result = _result()
        response.results = results
        return response

    def _placer(self, pose):
        """The ``place`` of change_bodies: a spec at ``pose`` (at the step it spawns)."""
        return lambda spec: self._placed(spec, pose)

    def _spawn_spec(self, request, names=None, more: int = 0):
        """(code, message, the BodySpec to spawn or None); ``names``: those taken (default
        the bodies'), ``more``: bodies to be spawned with it."""
        R = SpawnEntity.Response
        node = self.node
        if request.entity_namespace:
            return R.NAMESPACE_INVALID, ("a body's topics are under its name (<name>/pose, "
                                         '...): leave entity_namespace empty'), None
        name = request.name
        if name and (len(name) > scene.MAX_NAME or not scene.NAME.match(name)):
            return R.NAME_INVALID, (f'name {name[:80]!r} must be an ASCII letter, then ASCII '
                                    'letters, digits and underscores, at most '
                                    f'{scene.MAX_NAME} (it names topics and a frame)'), None
        templates = {t.name: t for t in node.templates}
        if request.resource_string:
            try:
                spec = scene.body_entry(request.resource_string, name, default='entity')
            except ValueError as e:
                return R.RESOURCE_PARSE_ERROR, str(e), None
        elif request.uri in templates:
            spec = replace(templates[request.uri], name=name or request.uri)
        elif not request.uri:
            return R.NO_RESOURCE, ('give a body entry (YAML) in resource_string or a '
                                   'template of the scene in uri (get_spawnables)'), None
        else:
            return R.UNSUPPORTED_FORMAT, (
                f'uri {request.uri[:200]!r} is not a template of the scene (have: '
                f'{", ".join(sorted(templates)) or "none"}); files and URLs are not read: '
                'put the body entry in resource_string'), None
        names = set(self._names()) if names is None else names
        if spec.name in names:
            if not request.allow_renaming:
                return R.NAME_NOT_UNIQUE, (f"there is an entity named '{spec.name}' "
                                           '(allow_renaming picks another)'), None
            k = 2
            while f'{spec.name[:scene.MAX_NAME - 8]}_{k}' in names:
                k += 1
            spec = replace(spec, name=f'{spec.name[:scene.MAX_NAME - 8]}_{k}')
        if len(node.config.bodies) + more >= scene.MAX_BODIES:
            return Result.RESULT_OPERATION_FAILED, (f'{len(node.config.bodies)} bodies: at '
                                                    f'most {scene.MAX_BODIES}'), None
        return Result.RESULT_OK, '', spec

    def _placed(self, spec, pose):
        """``spec`` at ``initial_pose`` (a PoseStamped), unless that is left at its default.
        Called with the node's lock held (change_bodies)."""
        p, o = pose.pose.position, pose.pose.orientation
        x, q = (p.x, p.y, p.z), (o.x, o.y, o.z, o.w)
        frame = pose.header.frame_id.lstrip('/')
        if not frame and x == (0.0, 0.0, 0.0) and q == (0.0, 0.0, 0.0, 1.0):
            return spec
        if _pose_problem(pose):
            raise ValueError(_pose_problem(pose))
        node = self.node
        frames = {pt.body_frame: pt.name for pt in node.ports.values()}
        if frame not in ('', node._v['world_frame'], 'world'):
            if frame not in frames:
                raise ValueError(f"initial_pose frame '{frame[:80]}' is neither "
                                 f"'{node._v['world_frame']}' nor a body frame")
            fx, fq = node.sim.pose_twist(frames[frame])[:2]
            rx = ros_messages.rotate(ros_messages.rotation_from_quaternion(fq), x)
            x = tuple(a + b for a, b in zip(fx, rx))
            q = _quaternion_product(fq, q)
        try:
            return replace(spec, initial_position=x, initial_orientation_xyzw=q)
        except ValueError as e:
            raise ValueError(f'initial_pose: {e}') from None

    def _delete(self, request, response):
        name = request.entity
        if name not in self._names():
            response.result = _result(Result.RESULT_NOT_FOUND, f"no entity named '{name[:80]}'")
            return response
        why = self.node.change_bodies(Delete(name))
        response.result = _result(Result.RESULT_OPERATION_FAILED, why) if why else _result()
        return response

    # -- stepping --------------------------------------------------------------------------
    def _check_steps(self, steps: int, most: int = MAX_STEPS) -> Result | None:
        if self.stepping:
            return _result(Result.RESULT_OPERATION_FAILED,
                           'another step_simulation or simulate_steps is under way')
        if not self.node._paused:
            return _result(Result.RESULT_OPERATION_FAILED,
                           'not paused: set_simulation_state to paused first')
        if not 1 <= steps <= most:
            more = ' (more with the simulate_steps action)' if most < MAX_STEPS else ''
            return _result(Result.RESULT_OPERATION_FAILED,
                           f'steps must be from 1 to {most}{more}, got {steps}')
        return None

    def _chunks(self, steps: int, wait: bool = False):
        """Take ``steps`` physics steps in publish periods (the last one shorter), publishing
        after each; yields the steps done after each period, and returns the Result (a
        failure pauses the node with its reason, given here too). One at a time
        (``stepping``); a change of the simulation state or a reset stops it. In lockstep,
        before each period the answers to the last state: ``wait`` yields None while they
        are not in (the caller gives the executor a turn to take them in); without it, a
        failure then."""
        epoch = self._epoch
        self.stepping = True
        if self.node._lockstep is not None:  # lockstep_timeout counts from the call
            self.node._lockstep.rearm()
        try:
            return (yield from self._periods(steps, epoch, wait))
        finally:
            self.stepping = False

    def _periods(self, steps: int, epoch: int, wait: bool):
        node = self.node
        done = 0
        lockstep = node._lockstep
        while done < steps and not node._stop.is_set():
            if not node._paused or self._epoch != epoch:
                return _result(Result.RESULT_OPERATION_FAILED,
                               f'the simulation state changed after {done} of {steps} steps: '
                               'stopped there')
            if lockstep is not None and not lockstep.ready.is_set():
                if node._error_paused:  # a lockstep timeout that errs
                    return _result(Result.RESULT_OPERATION_FAILED, node.diagnostics.error)
                if not wait:
                    return _result(Result.RESULT_OPERATION_FAILED, (
                        f'lockstep: {lockstep.describe()}, after {done} of {steps} steps; '
                        'step_simulation holds the executor the answers come through: use '
                        'the simulate_steps action, or step'))
                with node._lock:
                    node.lockstep_poll()
                yield None
                continue
            node._wait_for_recorder()  # as the step loop: never outpace the recording
            chunk = min(steps - done, node.config.steps_per_publish)
            with node._lock:
                failures = node._failures
                node._guarded(lambda: node._period(chunk))
                node._error_paused = False
                failed = node._failures != failures
            done += chunk
            if failed:
                return _result(Result.RESULT_OPERATION_FAILED, node.diagnostics.error)
            yield done
        if done < steps:
            return _result(Result.RESULT_OPERATION_FAILED,
                           f'stopped after {done} of {steps} steps (shutting down)')
        return _result()

    def _step(self, request, response):
        """step_simulation: answered when done (as the standard has it), so at most
        MAX_SERVICE_STEPS a call: the executor serves nothing else meanwhile. Longer runs are
        for the simulate_steps action, which gives the executor a turn after each period."""
        problem = self._check_steps(request.steps, MAX_SERVICE_STEPS)
        if problem is not None:
            response.result = problem
            return response
        chunks = self._chunks(request.steps)
        while True:
            try:
                next(chunks)
            except StopIteration as end:
                response.result = end.value
                return response

    def _goal(self, goal_request):
        return GoalResponse.ACCEPT

    async def _simulate(self, goal_handle):
        """The action: a period at a time, with feedback, giving the executor a turn between
        periods (so a cancel is heard: it stops at the end of the period)."""
        steps = goal_handle.request.steps
        result = SimulateSteps.Result()
        problem = self._check_steps(steps)
        if problem is not None:
            result.result = problem
            goal_handle.abort()
            return result
        chunks = self._chunks(steps, wait=True)
        while True:
            if goal_handle.is_cancel_requested and not self.stepping:  # before it began
                result.result = _result(Result.RESULT_OK, 'cancelled before any step')
                goal_handle.canceled()
                return result
            try:
                done = next(chunks)
            except StopIteration as end:
                result.result = end.value
                break
            if done is None:  # lockstep: the executor takes the answers in meanwhile
                await self._executor_turn(0.001)
                if goal_handle.is_cancel_requested:
                    chunks.close()
                    result.result = _result(Result.RESULT_OK, 'cancelled while waiting for '
                                            "lockstep's answers")
                    goal_handle.canceled()
                    return result
                continue
            goal_handle.publish_feedback(SimulateSteps.Feedback(
                completed_steps=done, remaining_steps=steps - done))
            await self._executor_turn()
            if goal_handle.is_cancel_requested:
                chunks.close()
                result.result = _result(Result.RESULT_OK, f'cancelled after {done} steps')
                goal_handle.canceled()
                return result
        if result.result.result == Result.RESULT_OK:
            goal_handle.succeed()
        else:
            goal_handle.abort()
        return result

    def _executor_turn(self, delay: float = 0.0) -> Future:
        """A future the executor completes on its next turn (a one-shot timer): awaiting it
        lets the executor serve what waits (a cancel, other services) in between."""
        future = Future()

        def fire():
            timer.cancel()
            self.node.destroy_timer(timer)
            future.set_result(None)
        timer = self.node.create_timer(delay, fire, callback_group=self._turns)
        return future
