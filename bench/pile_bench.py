# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""100 boxes piling for 2 s: rb_sim_ros's CollisionWorld next to Rapier and MuJoCo, one run.

    python -m bench.pile_bench [--quick] [--repeats 3] [--json out.json]

The figure of issue 31 ("100 boxes piling for 2 s vs Rapier 0.36 on 2 threads"). The scene:
100 cubes of 0.2 m (1 kg) dropped as 5 x 5 columns of 4, 0.24 m apart across and 0.3 m up
(7 cm gaps between layers, the lowest 0.1 m above the ground plane), every other layer shifted
by 4 cm so that each box lands off the centre of the one below; each box jittered (up to 1 cm
across, 5 mm up, tilted up to 0.05 rad about a random axis; seeded; the spacing keeps any two
apart, and that is checked). Gravity 9.81 m/s^2, dt = 1 ms, friction 0.5, no bounce
(restitution 0 everywhere). The layers land on each other and the columns lean and settle
into a pile 0.8 m high, at rest by about 1.2 s (of 2 s, 2000 steps) in every engine. The
trajectories part (the scene is chaotic), so each engine solves its own pile. (A looser drop,
0.3 m apart with half-pitch shifts and tilts to 0.2 rad, keeps boxes tumbling off the pile
until about 2 s, so that whether all rest at the end depends on the seed and the engine.)
``--quick``: 3 layers of 3 x 3 for 1 s.

The engines, each built from the same poses (not timed) and stepped through the whole run:

* rb_sim_ros: ``collision_world(bodies, dt, gravity, friction=0.5, restitution=0,
  planes=(Plane(),), sleep_time=0)`` (like for like: every contact solved every step), with its
  default solver (10 velocity and 4 position iterations at most); again with its default
  sleeping (``sleep_time=0.5``). Its contact step runs on one thread.
* Rapier: the ``rapier3d`` Python bindings (PyPI; Rapier 0.36, f32) through ``PhysicsWorld``:
  ``integration_parameters.dt = 1e-3``, everything else its defaults (``num_solver_iterations``
  4 substeps of ``num_internal_pgs_iterations`` 1 and ``num_internal_stabilization_iterations``
  1, soft contacts, allowed linear error 5 mm, CCD off), a half-space for the ground, cuboid
  colliders of mass 1 kg; ``set_num_threads(2)`` (the bindings' own pool of 2 workers, the
  setting they expose; the build is ``parallel``), bodies with ``can_sleep(False)`` (like for
  like); then with its default sleeping, and on 1 thread for reference.
* MuJoCo: free-joint boxes on a plane, its defaults (Newton, at most 100 iterations, soft
  contacts, pyramidal cones; friction "0.5 0 0"), not sleeping (its default); then with
  ``mjENBL_SLEEP``.

Timed: the whole 2 s run, best of ``--repeats`` (wall clock, and the process's CPU time beside
it: the cores busy, Rapier's workers counted whether working or waiting), as users run them: a
Python loop of one step a call (``world.step()``, ``world.step(1)``, ``mj_step``), and for the
engines that take n steps in one call the whole run in one call (``world.step(2000)``,
``mj_step(m, d, 2000)``; Rapier's bindings have none). Reported: ms per step and ours / Rapier
(2 threads) in the same run.

Checks first, on a run of each engine apart from the timed ones (exit 1 if one fails): every
box finite, inside the scene (within 3 m of the axis), none fallen through the ground (no
corner 5 cm below it), every box at rest at the end (the fastest point of any box, |v| +
|w| sqrt(3) a / 2, below 2 cm/s), nothing overlapping at the start. Measured on every engine the
same way, from the poses: the largest penetration into the ground (the lowest corner below
z = 0) and between boxes (the separating-axis overlap of the two cubes, exact for boxes) at the
end and the largest over the run (sampled every 10 ms), the pile's height (the highest
corner), and, as each engine reports it, its deepest contact of the last step (Rapier's, the
distance of a manifold point, can exceed the pair's overlap). Sanity checks of
the figures (finite, positive, within orders of magnitude; no timing budgets) make the exit
status. Writes docs/bench/pile_bench.json (or ``--json``; ``--quick`` writes none unless asked).
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path
import sys
import time

import mujoco
import numpy as np
import rapier3d

from bench import figures
from rb_sim_ros.contact.collision_shapes import Box, Plane
from rb_sim_ros.contact.settings import ContactSettings
from rb_sim_ros.core import so3
from rb_sim_ros.sim.bodies import collision_world
from rb_sim_ros.sim.simulation import BodySpec

DT = 1e-3
G = 9.81
SIZE = 0.2
HALF = SIZE / 2
MASS = 1.0
FRICTION = 0.5
PITCH = 0.24            # m between columns
LAYER = 0.3             # m between layers
SHIFT = 0.04            # m, every other layer (in x and y)
TILT = 0.05             # rad, the largest
SEED = 31
REST_SPEED = 0.02       # m/s, the fastest point of a box at rest
SAMPLE = 10             # steps between the samples of penetration in the checked runs


def layout(side: int, layers: int, seed: int = SEED) -> tuple[np.ndarray, np.ndarray]:
    """Centres (n, 3) and rotation vectors (n, 3) of side x side columns of ``layers`` boxes."""
    rng = np.random.default_rng(seed)
    pos, rotvec = [], []
    for k in range(layers):
        shift = SHIFT * (k % 2)
        for i in range(side):
            for j in range(side):
                pos.append(((i - (side - 1) / 2) * PITCH + shift + rng.uniform(-0.01, 0.01),
                            (j - (side - 1) / 2) * PITCH + shift + rng.uniform(-0.01, 0.01),
                            HALF + 0.1 + k * LAYER + rng.uniform(-0.005, 0.005)))
                axis = rng.normal(size=3)
                rotvec.append(axis / np.linalg.norm(axis) * rng.uniform(0.0, TILT))
    return np.array(pos), np.array(rotvec)


# -- what is measured on the poses, the same for every engine ---------------------------------
def ground_penetration(pos: np.ndarray, rot: np.ndarray) -> float:
    """Depth (m) of the lowest corner of any box below z = 0 (<= 0: none touches)."""
    lowest = pos[:, 2] - HALF * np.abs(rot[:, 2, :]).sum(axis=1)
    return float(-lowest.min())


def box_penetration(pos: np.ndarray, rot: np.ndarray) -> float:
    """The deepest overlap (m) of two boxes: the least overlap over the 15 separating axes of
    each pair (the penetration depth of two convex polyhedra); 0 if none overlaps."""
    i, j = np.triu_indices(len(pos), 1)
    near = np.linalg.norm(pos[j] - pos[i], axis=1) < 2 * HALF * math.sqrt(3)
    i, j = i[near], j[near]
    if not len(i):
        return 0.0
    a, b = rot[i], rot[j]                         # columns: the boxes' axes in the world
    cross = np.cross(a.transpose(0, 2, 1)[:, :, None, :], b.transpose(0, 2, 1)[:, None, :, :])
    axes = np.concatenate([a.transpose(0, 2, 1), b.transpose(0, 2, 1),
                           cross.reshape(-1, 9, 3)], axis=1)          # (m, 15, 3)
    length = np.linalg.norm(axes, axis=2)
    valid = length > 1e-9                         # parallel edges give no axis
    axes = axes / np.where(valid, length, 1.0)[:, :, None]
    ra = HALF * np.abs(np.einsum('mkc,mca->mka', axes, a)).sum(axis=2)
    rb = HALF * np.abs(np.einsum('mkc,mca->mka', axes, b)).sum(axis=2)
    gap = np.abs(np.einsum('mkc,mc->mk', axes, pos[j] - pos[i]))
    overlap = np.where(valid, ra + rb - gap, np.inf).min(axis=1)
    return float(max(0.0, overlap.max()))


def outcome(pos, rot, v, w) -> dict:
    point_speed = np.linalg.norm(v, axis=1) + np.linalg.norm(w, axis=1) * HALF * math.sqrt(3)
    top = pos[:, 2] + HALF * np.abs(rot[:, 2, :]).sum(axis=1)
    return {'finite': bool(np.isfinite(pos).all() and np.isfinite(rot).all()
                           and np.isfinite(v).all() and np.isfinite(w).all()),
            'ground_penetration': ground_penetration(pos, rot),
            'box_penetration': box_penetration(pos, rot),
            'fastest_point_speed': float(point_speed.max()),
            'pile_height': float(top.max()),
            'lowest_centre': float(pos[:, 2].min()),
            'farthest_from_axis': float(np.linalg.norm(pos[:, :2], axis=1).max())}


# -- the engines: each a (step one, step n, poses, deepest own contact) ------------------------
class Ours:
    def __init__(self, pos, rotvec, sleeping: bool = False) -> None:
        inertia = (MASS * SIZE * SIZE / 6.0,) * 3
        bodies = [BodySpec(f'b{n}', MASS, inertia, initial_position=tuple(p),
                           initial_orientation_xyzw=tuple(
                               so3.quaternion_xyzw_from_matrix(so3.exp(r))),
                           colliders=(Box((SIZE,) * 3),))
                  for n, (p, r) in enumerate(zip(pos, rotvec))]
        self.names = [b.name for b in bodies]
        self.world = collision_world(
            bodies, DT, (0.0, 0.0, -G), planes=(Plane(),),
            contact=ContactSettings(restitution=0.0, friction=FRICTION,
                                    sleep_time=ContactSettings.sleep_time if sleeping else 0.0))
        self.step = self.world.step           # step(n): n steps in one call

    def poses(self):
        states = [self.world.state(n) for n in self.names]
        return (np.array([s.position for s in states]), np.array([s.rotation for s in states]),
                np.array([s.linear_velocity for s in states]),
                np.array([s.angular_velocity for s in states]))

    def deepest(self) -> dict:
        """Its last step's contacts (depth > 0: overlapping), ground and box-box apart."""
        ground = [c.depth for c in self.world.last_contacts() if '' in (c.a, c.b)]
        boxes = [c.depth for c in self.world.last_contacts() if '' not in (c.a, c.b)]
        return {'ground': max(ground, default=0.0), 'boxes': max(boxes, default=0.0),
                'contacts': len(ground) + len(boxes)}


class Rapier:
    def __init__(self, pos, rotvec, threads: int = 2, sleep: bool = False) -> None:
        w = rapier3d.PhysicsWorld(gravity=(0.0, 0.0, -G))
        w.integration_parameters.dt = DT
        w.set_num_threads(threads)
        self.ground = w.add_collider(
            rapier3d.Collider.halfspace((0.0, 0.0, 1.0)).friction(FRICTION).restitution(0.0))
        self.handles = [
            w.add_body(rapier3d.RigidBody.dynamic().translation(tuple(p)).rotation(tuple(r))
                       .can_sleep(sleep),
                       [rapier3d.Collider.cuboid(HALF, HALF, HALF).mass(MASS)
                        .friction(FRICTION).restitution(0.0)])
            for p, r in zip(pos, rotvec)]
        self.world = w
        self.step = w.step                    # one step a call: the bindings have no n

    def poses(self):
        bodies = [self.world.rigid_bodies[h] for h in self.handles]
        return (np.array([b.translation.to_ndarray() for b in bodies], dtype=float),
                np.array([b.rotation.to_matrix() for b in bodies], dtype=float).reshape(-1, 3, 3),
                np.array([b.linvel.to_ndarray() for b in bodies], dtype=float),
                np.array([b.angvel.to_ndarray() for b in bodies], dtype=float))

    def deepest(self) -> dict:
        ground, boxes, count = [0.0], [0.0], 0
        for pair in self.world.narrow_phase.contact_pairs():
            depths = [-p.dist for m in pair.manifolds for p in m.points]
            count += len(depths)
            (ground if self.ground in (pair.collider1, pair.collider2) else boxes).extend(depths)
        return {'ground': max(ground), 'boxes': max(boxes), 'contacts': count}


class MuJoCo:
    def __init__(self, pos, rotvec, sleep: bool = False) -> None:
        boxes = []
        for p, r in zip(pos, rotvec):
            q = so3.quaternion_xyzw_from_matrix(so3.exp(r))
            boxes.append(f'<body pos="{p[0]:.17g} {p[1]:.17g} {p[2]:.17g}" quat="{q[3]:.17g} '
                         f'{q[0]:.17g} {q[1]:.17g} {q[2]:.17g}"><freejoint/><geom type="box" '
                         f'size="{HALF} {HALF} {HALF}" mass="{MASS}" '
                         f'friction="{FRICTION} 0 0"/></body>')
        xml = (f'<mujoco><option timestep="{DT}" gravity="0 0 {-G}"/><worldbody><geom '
               f'type="plane" size="50 50 0.1" friction="{FRICTION} 0 0"/>{"".join(boxes)}'
               '</worldbody></mujoco>')
        self.model = mujoco.MjModel.from_xml_string(xml)
        if sleep:
            self.model.opt.enableflags |= mujoco.mjtEnableBit.mjENBL_SLEEP
        self.data = mujoco.MjData(self.model)
        mujoco.mj_forward(self.model, self.data)

    def step(self, n: int = 1) -> None:
        mujoco.mj_step(self.model, self.data, n)

    def poses(self):
        d = self.data
        q = d.qpos.reshape(-1, 7)   # (xmat is from before the step's integration: not used)
        return (q[:, :3].copy(), np.array([so3.matrix_from_quaternion_xyzw((*x[4:], x[3]))
                                           for x in q]),
                d.qvel.reshape(-1, 6)[:, :3].copy(),
                # free joint: angular velocity in the body frame; its norm is what counts
                d.qvel.reshape(-1, 6)[:, 3:].copy())

    def deepest(self) -> dict:
        c = self.data.contact[:self.data.ncon]
        ground = c.geom1 == 0
        return {'ground': float(max(0.0, -c.dist[ground].min(initial=0.0))),
                'boxes': float(max(0.0, -c.dist[~ground].min(initial=0.0))),
                'contacts': int(self.data.ncon)}


ENGINES = {
    'rb_sim_ros': lambda pos, rv: Ours(pos, rv),
    'rb_sim_ros, sleeping': lambda pos, rv: Ours(pos, rv, sleeping=True),
    'Rapier, 2 threads': lambda pos, rv: Rapier(pos, rv, 2),
    'Rapier, 2 threads, sleeping': lambda pos, rv: Rapier(pos, rv, 2, sleep=True),
    'Rapier, 1 thread': lambda pos, rv: Rapier(pos, rv, 1),
    'MuJoCo Newton': lambda pos, rv: MuJoCo(pos, rv),
    'MuJoCo Newton, sleeping': lambda pos, rv: MuJoCo(pos, rv, sleep=True),
}
# (row, engine, steps a call: 1 or the whole run)
TIMED = [('rb_sim_ros, step(1)', 'rb_sim_ros', 1), ('rb_sim_ros, step(n)', 'rb_sim_ros', None),
         ('rb_sim_ros sleeping, step(1)', 'rb_sim_ros, sleeping', 1),
         ('Rapier 2 threads, step()', 'Rapier, 2 threads', 1),
         ('Rapier 2 threads sleeping, step()', 'Rapier, 2 threads, sleeping', 1),
         ('Rapier 1 thread, step()', 'Rapier, 1 thread', 1),
         ('MuJoCo Newton, mj_step', 'MuJoCo Newton', 1),
         ('MuJoCo Newton, mj_step(n)', 'MuJoCo Newton', None),
         ('MuJoCo Newton sleeping, mj_step', 'MuJoCo Newton, sleeping', 1)]


def checked_run(engine, steps: int) -> dict:
    """The run, with the penetrations sampled every SAMPLE steps, and its outcome."""
    worst_ground = worst_boxes = -math.inf
    for k in range(steps):
        engine.step()
        if (k + 1) % SAMPLE == 0:
            pos, rot = engine.poses()[:2]
            worst_ground = max(worst_ground, ground_penetration(pos, rot))
            worst_boxes = max(worst_boxes, box_penetration(pos, rot))
    out = outcome(*engine.poses())
    out.update(max_ground_penetration=worst_ground, max_box_penetration=worst_boxes,
               own_deepest=engine.deepest())
    return out


def problems_of(name: str, o: dict) -> list[str]:
    p = []
    if not o['finite']:
        p.append(f'{name}: a box is not finite')
        return p
    if o['farthest_from_axis'] > 3.0:
        p.append(f'{name}: a box left the scene ({o["farthest_from_axis"]:.2f} m off the axis)')
    if o['ground_penetration'] > 0.05 or o['lowest_centre'] < 0.0:
        p.append(f'{name}: a box fell through the ground (corner '
                 f'{o["ground_penetration"] * 1e3:.1f} mm below it)')
    if o['fastest_point_speed'] > REST_SPEED:
        p.append(f'{name}: not at rest at the end (a point moves at '
                 f'{o["fastest_point_speed"] * 1e3:.1f} mm/s)')
    return p


def timed(make, steps: int, per_call: int | None) -> tuple[float, float]:
    """(wall, CPU) seconds of the run, the engine built beforehand."""
    engine = make()
    step = engine.step
    t, c = time.perf_counter(), time.process_time()
    if per_call is None:
        step(steps)
    else:
        for _ in range(steps):
            step()
    return time.perf_counter() - t, time.process_time() - c


def main() -> int:
    parser = argparse.ArgumentParser(
        prog='python -m bench.pile_bench', description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--quick', action='store_true',
                        help='27 boxes (3 layers of 3 x 3) for 1 s, 1 repeat')
    parser.add_argument('--repeats', type=int, help='timed runs of each engine (default 3)')
    parser.add_argument('--json', type=Path, help='write the figures here (default: '
                        'docs/bench/pile_bench.json; --quick: none)')
    opts = parser.parse_args()
    side, layers, seconds = (3, 3, 1.0) if opts.quick else (5, 4, 2.0)
    repeats = opts.repeats or (1 if opts.quick else 3)
    steps = round(seconds / DT)
    pos, rotvec = layout(side, layers)
    n = len(pos)
    features = rapier3d.build_features()
    print(f'{n} boxes of {SIZE} m, {layers} layers of {side} x {side}, dt = {DT} s, '
          f'{seconds} s ({steps} steps); rapier3d {rapier3d.__version__} '
          f'({features.profile}, parallel={features.parallel}), MuJoCo {mujoco.__version__}')
    rot0 = np.array([so3.exp(r) for r in rotvec])
    problems = []
    if box_penetration(pos, rot0) > 0.0 or ground_penetration(pos, rot0) > 0.0:
        problems.append('the boxes overlap at the start')

    outcomes = {}
    for name, make in ENGINES.items():
        t = time.perf_counter()
        outcomes[name] = checked_run(make(pos, rotvec), steps)
        print(f'  checked {name} ({time.perf_counter() - t:.1f} s; the first: its kernels '
              'compiled or loaded)', file=sys.stderr)
        problems += problems_of(name, outcomes[name])
    if problems:
        print('checks failed: ' + '; '.join(problems), file=sys.stderr)
        return 1

    wall = {row: [] for row, _, _ in TIMED}
    cpu = {row: [] for row, _, _ in TIMED}
    for _ in range(repeats):                  # the engines interleaved: the same noise
        for row, name, per_call in TIMED:
            w, c = timed(lambda: ENGINES[name](pos, rotvec), steps, per_call)
            wall[row].append(w)
            cpu[row].append(c)
    rows = {}
    for row, name, per_call in TIMED:
        best = int(np.argmin(wall[row]))
        rows[row] = {'engine': name, 'steps_a_call': per_call or steps,
                     'seconds_per_step': wall[row][best] / steps,
                     'run_seconds': wall[row], 'cpu_over_wall': cpu[row][best] / wall[row][best]}
    rapier = rows['Rapier 2 threads, step()']['seconds_per_step']
    ratios = {row: r['seconds_per_step'] / rapier for row, r in rows.items()}
    like = {'rb_sim_ros / Rapier 2 threads, step(1), neither sleeping':
            ratios['rb_sim_ros, step(1)'],
            'rb_sim_ros step(n) / Rapier 2 threads, neither sleeping':
            ratios['rb_sim_ros, step(n)'],
            'rb_sim_ros / Rapier 2 threads, both sleeping':
            rows['rb_sim_ros sleeping, step(1)']['seconds_per_step']
            / rows['Rapier 2 threads sleeping, step()']['seconds_per_step'],
            'rb_sim_ros / Rapier 1 thread, step(1), neither sleeping':
            rows['rb_sim_ros, step(1)']['seconds_per_step']
            / rows['Rapier 1 thread, step()']['seconds_per_step'],
            'rb_sim_ros / MuJoCo Newton, one step a call, neither sleeping':
            rows['rb_sim_ros, step(1)']['seconds_per_step']
            / rows['MuJoCo Newton, mj_step']['seconds_per_step']}

    print(f'\nms per step over the whole {seconds} s run (best of {repeats}), one step a call '
          'unless n;\nCPU / wall: cores busy on average; ratio: the time over Rapier on 2 '
          'threads, not sleeping')
    print('| run | ms per step | CPU / wall | / Rapier 2 threads |\n| --- | ---: | ---: | ---: |')
    for row, r in rows.items():
        print(f'| {row} | {r["seconds_per_step"] * 1e3:.3f} | {r["cpu_over_wall"]:.2f} | '
              f'{ratios[row]:.2f}x |')
    busy = rows['Rapier 2 threads, step()']['cpu_over_wall']
    if busy < 1.3:
        print(f'note: Rapier on 2 threads kept {busy:.2f} cores busy, so its second thread found '
              'no free core\n(another process?): its ratio is then about that of one thread')
    print('\nlike for like, ours over theirs:')
    for k, v in like.items():
        print(f'  {k}: {v:.2f}x')
    print('\noutcome at the end (the checked runs); penetrations in mm, from the poses '
          '(max: sampled every 10 ms), and as the engine reports its last contacts')
    print('| engine | ground | ground max | box-box | box-box max | own: ground / box-box '
          '| pile height (m) | fastest point (mm/s) |')
    print('| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |')
    for name, o in outcomes.items():
        own = o['own_deepest']
        print(f'| {name} | {o["ground_penetration"] * 1e3:.3f} | '
              f'{o["max_ground_penetration"] * 1e3:.3f} | {o["box_penetration"] * 1e3:.3f} | '
              f'{o["max_box_penetration"] * 1e3:.3f} | {own["ground"] * 1e3:.3f} / '
              f'{own["boxes"] * 1e3:.3f} | {o["pile_height"]:.3f} | '
              f'{o["fastest_point_speed"] * 1e3:.2f} |')

    sane = figures.Sanity()
    for row, r in rows.items():
        sane.within(f'{row}: s per step', r['seconds_per_step'], 1e-7, 1.0)
        sane.within(f'{row}: CPU / wall', r['cpu_over_wall'], 0.05, 64.0)
        sane.within(f'{row}: / Rapier', ratios[row], 1e-3, 1e3)
    for name, o in outcomes.items():
        sane.within(f'{name}: pile height (m)', o['pile_height'], SIZE * 0.9,
                    HALF + 0.1 + layers * LAYER + SIZE)
        sane.within(f'{name}: largest ground penetration (m)', o['max_ground_penetration'],
                    -SIZE, 0.05)
    path = opts.json or (None if opts.quick else figures.DOCS_BENCH / 'pile_bench.json')
    if path:
        figures.write(path, {
            'quick': opts.quick, 'repeats': repeats, 'dt': DT, 'boxes': n, 'seconds': seconds,
            'steps': steps, 'seed': SEED,
            'rapier3d': {'version': rapier3d.__version__, 'profile': features.profile,
                         'parallel': features.parallel, 'threads': 2,
                         'num_solver_iterations': rapier3d.IntegrationParameters
                         .default_params().num_solver_iterations},
            'rows': rows, 'ratios_to_rapier_2_threads': ratios, 'like_for_like': like,
            'outcomes': outcomes})
    return sane.report()


if __name__ == '__main__':
    sys.exit(main())
