# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Where the benchmarks' figures go, their sanity checks, and which text quotes them.

Every benchmark writes its figures to ``docs/bench/<name>.json`` (with the command that made
them, the date and the machine); docs/benchmarks.md gathers them (its hand-written sections,
after the ones bench/report.py writes), docs/collisions.md and docs/sweeps.md quote some beside
their measurements, and README.md quotes none (it says in words what the simulator is and
links to docs/benchmarks.md). ``quotes`` below says where each figure is quoted, as the exact
text it is formatted to. ``python -m bench.figures`` (and test/package/test_bench_quick.py) checks
that every quoted text is where it should be, so a stale figure fails the suite.

Rules for derived figures: a ratio is the quotient of the two JSON values named, rounded to
the digits shown; ms and us are the JSON's seconds times 1e3 and 1e6, rounded likewise.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
import platform
import sys
import time

ROOT = Path(__file__).resolve().parents[1]
DOCS_BENCH = ROOT / 'docs' / 'bench'


def command(argv=None) -> str:
    """The command line that ran this benchmark, as a user would type it from the repository
    root: ``python -m bench.<name> ...`` for a module of bench/ (run with -m, argv[0] is the
    module's file), else ``python <script> ...``."""
    argv = sys.argv if argv is None else argv
    script = Path(argv[0])
    try:
        script = script.resolve().relative_to(ROOT)
    except ValueError:
        pass
    if script.parent == Path('bench') and script.suffix == '.py':
        return ' '.join(['python', '-m', f'bench.{script.stem}', *argv[1:]])
    return ' '.join(['python', str(script), *argv[1:]])


def machine() -> dict:
    import numpy as np
    out = {'python': platform.python_version(), 'numpy': np.__version__,
           'cpu': platform.processor() or platform.machine()}
    try:
        import mujoco
        out['mujoco'] = mujoco.__version__
    except ImportError:
        pass
    return out


def write(path, data: dict) -> Path:
    """``data`` with the command, date and machine, as JSON at ``path``."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    out = {'command': command(), 'date': time.strftime('%Y-%m-%d'), 'machine': machine(),
           **data}
    path.write_text(json.dumps(out, indent=1, default=_plain) + '\n')
    return path


def _plain(x):
    if hasattr(x, 'item'):
        return x.item()
    if hasattr(x, 'tolist'):
        return x.tolist()
    return str(x)


class Sanity:
    """Collects what is implausible about a benchmark's figures (not timing budgets: a
    figure must be finite, positive and within orders of magnitude of what it measures)."""

    def __init__(self) -> None:
        self.problems: list[str] = []

    def within(self, name: str, value, low: float, high: float) -> None:
        if value is None or not isinstance(value, (int, float)) or not math.isfinite(value) \
                or not low <= value <= high:
            self.problems.append(f'{name} = {value!r}, expected within [{low:g}, {high:g}]')

    def true(self, name: str, ok: bool) -> None:
        if not ok:
            self.problems.append(name)

    def report(self) -> int:
        """Exit status: 0, or 1 after printing the problems."""
        if self.problems:
            print('sanity checks failed:\n  ' + '\n  '.join(self.problems), file=sys.stderr)
            return 1
        return 0


# -- what the documents quote -----------------------------------------------------------------
def load(name: str, folder: Path = DOCS_BENCH) -> dict:
    return json.loads((folder / f'{name}.json').read_text())


def _ms(seconds: float, digits: int = 1) -> str:
    return f'{seconds * 1e3:.{digits}f}'


def _ms_auto(seconds: float) -> str:
    """ms with 1 decimal from 5 ms up, 3 below (0.425, not 0.4)."""
    return _ms(seconds, 1 if seconds >= 5e-3 else 3)


def _row(rows, **match):
    return next(r for r in rows if all(r.get(k) == v for k, v in match.items()))


def quotes(folder: Path = DOCS_BENCH) -> list[tuple[str, str, str]]:
    """(document, anchor, text): ``text`` must occur in the document in the line that
    contains ``anchor`` (with the indented lines that continue it), or, for an anchor starting
    with '#', in that section (spaces and line breaks counted as one space)."""
    q: list[tuple[str, str, str]] = []
    figs, coll = 'docs/benchmarks.md', 'docs/collisions.md'

    step = load('step_cost', folder)
    cost = {(r['method'], r['body'], r['call']): r['us_per_step'] for r in step['rows']}
    full = 'full inertia, body-frame wrench'
    one, ten, amort = (cost[('rb_sim_ros eq27', full, c)]
                       for c in ('step(1)', 'step(10)', 'amortised'))
    step_text = f'{one:.2f} / {ten:.2f} / {amort:.2f} us'
    q.append((figs, 'cost of one step', step_text))
    q.append((figs, '**Fast**', f'{amort * 1e3:.0f} ns'))
    rk4 = cost[('MuJoCo RK4', 'full inertia, world-frame wrench (mj_step, nstep)', 'amortised')]
    q.append((figs, '**Fast**', f"about {100 * amort / rk4:.0f}% of MuJoCo's RK4 step"))
    diag = 'diagonal inertia, torque-free'
    ours_one = [cost[('rb_sim_ros eq27', b, 'step(1)')] for b in (diag, full)]
    rk4_one = [cost[('MuJoCo RK4', f'{b} (mj_step)', 'step(1)')]
               for b in (diag, 'full inertia, world-frame wrench')]
    q.append((figs, 'one free body at one step a call',
              f'{ours_one[0]:.2f} / {ours_one[1]:.2f} us ({rk4_one[0]:.2f} / {rk4_one[1]:.2f} '
              f'us): {ours_one[0] / rk4_one[0]:.2f}x / {ours_one[1] / rk4_one[1]:.2f}x'))

    skip = load('skip_bench', folder)
    general = _row(skip['rows'], key='general')
    projectile = _row(skip['rows'], key='projectile')
    parked = _row(skip['rows'], key='parked')
    q.append((figs, 'a projectile', f'{projectile["specialised_us"]:.2f} us '
              f'({general["specialised_us"] / projectile["specialised_us"]:.1f}x) / '
              f'{parked["specialised_us"]:.2f}'))

    node = load('node_timing', folder)
    rates = {r['publish_rate_hz']: r for r in node['rates']}
    r1k, r100 = rates[1000.0], rates[100.0]
    q.append((figs, 'node at 1 kHz: late ticks',
              f'{100 * r1k["late_tick_fraction"]:.2f}%, {r1k["tick_lateness_p99_ms"]:.1f} ms, '
              f'{100 * r1k["cpu_per_core"]:.0f}% of a core'))
    q.append((figs, 'wrench-to-pose latency',
              f'{r100["latency_p50_ms"]:.1f} / {r100["latency_p99_ms"]:.1f} ms (1 kHz: '
              f'{r1k["latency_p50_ms"]:.1f} / {r1k["latency_p99_ms"]:.1f} ms)'))
    fast = {(f['body'], f['pose_subscriber']): f['real_time_factor'] for f in node['fastest']}
    moving = 'spinning, full tensor'
    q.append((figs, 'fastest real-time factor',
              f'{fast[(moving, False)]:.0f}x / {fast[(moving, True)]:.0f}x '
              f'(at rest: {fast[("at rest", False)]:.0f}x)'))
    q.append((figs, '**Fast**', f'{fast[(moving, False)]:.0f}x real time'))
    q.append((figs, '**Fast**', f'{100 * r1k["late_tick_fraction"]:.2f}% late ticks'))
    scene = node['scene']['sim_over_wall']
    sw = {e['engine']: e for e in load('sweep_bench', folder)['engines']}
    one, two = sw['local, 1 worker'], sw['local, 2 workers']
    ray = sw['ray (local), 2 CPUs']
    scaling = two['runs_per_s'] / one['runs_per_s']
    sweep_text = (f'1 worker {one["runs_per_s"]:.2f} runs/s, 2 workers '
                  f'{two["runs_per_s"]:.2f} runs/s ({scaling:.2f}x), '
                  f'Ray with 2 CPUs {ray["runs_per_s"]:.2f} runs/s')
    cpu = one['cpu_s_per_run']
    sweeps = ('docs/sweeps.md', '#On a Ray cluster')
    q.append((*sweeps, sweep_text))
    q.append((*sweeps, f'{cpu * 1e3:.0f} ms of one core'))
    q.append((*sweeps, f'{cpu * 1e6 / 3600:.0f} core-hours'))

    q.extend(campaign_quotes(folder))

    sleeping = '#Sleeping'
    q.append((coll, sleeping, f'{scene[0]:.2f} sim seconds per wall second in the first'))
    q.append((coll, sleeping, f'then {min(scene[-3:]):.1f} to {max(scene[-3:]):.1f} in the last '
              'three seconds'))
    q.append((coll, '#Benchmark: 1000 spheres', f'{scene[0]:.2f} sim seconds per wall'))
    off = node['scene_sleeping_off']['sim_over_wall']
    q.append((figs, 'collision demo through the node', f'{min(off):.0f}x / {scene[0]:.0f}x'))
    q.append((coll, '#Sleeping', f'{min(off):.0f} to {max(off):.0f} with sleeping off'))

    col = load('collision_bench', folder)
    ours, mj = col['rb_sim_ros'], col['mujoco']
    like = mj['PGS, 10 iterations']
    ratio_like = ours['seconds_per_step'] / like['seconds_per_step']
    ratio_cg = ours['seconds_per_step'] / mj['CG, 10 iterations']['seconds_per_step']
    ratio_default = ours['seconds_per_step'] / mj['Newton (default)']['seconds_per_step']
    q.append((figs, '1000 spheres settled',
              f'{_ms(ours["seconds_per_step"])} ({_ms(like["seconds_per_step"])} / '
              f'{_ms(mj["CG, 10 iterations"]["seconds_per_step"])} / '
              f'{_ms(mj["Newton (default)"]["seconds_per_step"], 0)})'))
    q.append((figs, '#Collisions', f'{_ms(ours["seconds_per_step"])} ms a step'))
    q.append((figs, '#Collisions', f'{ratio_like:.1f}x MuJoCo'))
    q.append((figs, '#Collisions', f'{ratio_cg:.1f}x its CG'))
    q.append((figs, '**Fast**', f'{ratio_cg:.1f}x its'))
    q.append((figs, '#Collisions', f'takes {1 / ratio_default:.0f} times as long as ours'))
    bench = '#Benchmark: 1000 spheres'
    for anchor, r, cap in [('| rb_sim_ros CollisionWorld', ours, 10)] + [
            (f'| MuJoCo {name} |', r, r['max_iterations']) for name, r in mj.items()]:
        q.append((coll, anchor, f'| {_ms(r["seconds_per_step"])} | {r["forced_contacts"]:.0f} '
                  f'| {r["forced_contacts"] / r["seconds_per_step"]:,.0f} | '
                  f'{r["iterations"]:.1f} ({cap}) |'))
    q.append((coll, '| rb_sim_ros CollisionWorld', f'PGS; {ours["contacts"]:.0f} contacts'))
    q.append((coll, bench, f'{ratio_like:.1f}x the time of MuJoCo'))
    q.append((coll, bench, f'{ratio_cg:.1f}x that of its CG'))
    q.append((coll, bench, f'{1 / ratio_default:.0f} times as long as ours'))
    total = sum(ours['phases'].values())
    for phase, sec in ours['phases'].items():
        q.append((coll, f'| {phase} ', f'| {_ms(sec)} | {sec / total:.0%} |'))
    free = col['no_colliders']
    q.append((coll, bench, f'{_ms(free["world"], 3)} ms per step against '
              f'{_ms(free["steppers"], 3)} ms'))
    q.append((coll, '#Order of a step',
              f'{_ms(free["world"], 3)} against {_ms(free["steppers"], 3)} ms'))

    rest = load('resting_bench', folder)
    awake, asleep, mj_awake, mj_asleep = (rest[k] for k in ('awake', 'asleep', 'mujoco',
                                                            'mujoco_sleeping'))
    q.append((figs, '200 boxes at rest',
              f'{_ms_auto(awake["seconds_per_step"])} / {_ms(asleep["seconds_per_step"], 3)} '
              f'({_ms(mj_awake["seconds_per_step"], 3)} / '
              f'{_ms(mj_asleep["seconds_per_step"], 3)})'))
    for anchor, r in (('| rb_sim_ros, sleeping off |', awake),
                      ('| rb_sim_ros, sleeping (default) |', asleep),
                      ('| MuJoCo mj_step (Newton, sleeping off) |', mj_awake),
                      ('| MuJoCo mj_step (Newton, sleeping) |', mj_asleep)):
        digits = 1 if r['seconds_per_step'] > 5e-3 else 3
        drop = (f'{_ms_auto(r["drop_seconds_per_step"])} |' if 'drop_seconds_per_step' in r
                else '- |')
        q.append((coll, anchor, f'| {_ms(r["seconds_per_step"], digits)} | {r["contacts"]} | '
                  f'{r["drift"] * 1e3:.2f} | {drop}'))
    q.append((coll, '#Sleeping', f'{awake["seconds_per_step"] / asleep["seconds_per_step"]:.0f}x '
              'cheaper'))
    q.append((coll, '#Sleeping',
              f'{awake["seconds_per_step"] / mj_awake["seconds_per_step"]:.1f}x MuJoCo'))
    q.append((coll, '#Sleeping',
              f'{asleep["seconds_per_step"] / mj_asleep["seconds_per_step"]:.2f}x it with both'))
    q.append((coll, '#Sleeping', f'wakes {asleep["awake_after_drop"]} of '
              f'{2 * rest["side"] ** 2 + 1} bodies'))
    demo = rest['demo_scene']
    q.append((coll, '#Sleeping', f'costs {_ms_auto(demo["moving_seconds_per_step"])} ms per step '
              'in its first'))
    q.append((coll, '#Sleeping', f'{demo["asleep_seconds_per_step"] * 1e6:.2f} us from 4 to 5 s'))
    q.append((coll, bench, f'costs {_ms_auto(demo["moving_seconds_per_step"])} ms per step'))
    q.append((figs, '#Collisions', f'from {_ms_auto(demo["moving_seconds_per_step"])} ms'))
    q.append((figs, '#Collisions', f'to {demo["asleep_seconds_per_step"] * 1e6:.2f} us'))

    cases = load('collision_cases', folder)
    for test, cell in cases['cells'].items():
        q.append((coll, f'`{test}', f'| {cell} |'))
    wall = cases['thin_wall']
    q.append((coll, '#Speculative contacts',
              f'up to {wall["speculative_held_up_to"] / 1e3:,.0f} km/s at dt = 1 ms'))
    q.append((coll, '#Speculative contacts',
              f'{wall["phases"]} phases): every phase held at {wall["discrete_held_up_to"]} m/s, '
              f'some tunnelled at {wall["discrete_first_failure"]} m/s'))
    q.append((figs, '#Collisions',
              f'held to {wall["speculative_held_up_to"] / 1e3:,.0f} km/s'))

    batch = load('batch_bench', folder)
    rows = {r['n']: r for r in batch['rows']}
    big = rows[100_000]
    q.append((figs, 'batch path, ns per body-step',
              f'{big["batch_free_one_thread_ns"]:.1f} / {big["batch_free_ns"]:.1f} / '
              f'{big["batch_free_one_step_per_call_ns"]:.0f} '
              f'({big["mujoco_euler_ns"]:.0f} / {big["mujoco_euler_all_cores_ns"]:.0f}; '
              f'{big["mujoco_rk4_ns"]:.0f})'))
    q.append((figs, 'memory per body',
              f'{big["memory_per_body"]["batch_arrays_B"] / 1e3:.1f} kB / '
              f'{big["memory_per_body"]["mujoco_model_plus_data_B"] / 1e3:.1f} kB'))
    life = load('node_lifecycle', folder)
    big_start = max(life['startup'], key=lambda r: r['bodies'])
    q.append((figs, '**Large scenes**', f'A {big_start["bodies"]:,}-body scene publishes its '
              f'first `poses` {big_start["first_poses_s"]:.1f} s after the process starts, with '
              f'{big_start["peak_memory_mb"]:.0f} MB'))
    q.append((figs, '**Stopping**', f'{life["stop_clean"]} of {life["stop_runs"]} '
              f'runs at `real_time_factor:=0` within {max(life["stop_exit_s"]):.2f} s'))
    first = life['first_start_s']
    tier = first['cold_background']
    warm_ready = first['warm_runs']['ready_s']
    installed_ready = first['installed_runs']['ready_s']
    table = (f'{tier["first_poses_s"]:.1f} s ({tier["compiled_s"]:.0f} s) / '
             f'{first["cold"]:.0f} s / {first["warm"]:.1f} s ({warm_ready:.1f} s) / '
             f'{first["installed"]:.1f} s ({first["install_s"]:.0f} s)')
    q.append((figs, 'node start on the collision demo', table))
    cache, tiers = '**A cache**', '**Two tiers on a first start**'
    q.append((figs, cache, f'the install took {first["install_s"]:.0f} s'))
    q.append((figs, cache, f'after it was stepping after {installed_ready:.1f} s'))
    q.append((figs, cache, f'first poses of a step after {first["installed"]:.1f} s, '
              'the rest being DDS discovery'))
    q.append((figs, cache, f'(the node stepping after {warm_ready:.1f} s, '
              f'{first["warm"]:.1f} s to a subscriber'))
    q.append((figs, tiers, f'after {tier["first_poses_s"]:.1f} s and ran at '
              f'{tier["interpreted_early_sim_over_wall"]:.2f}x real time'))
    q.append((figs, tiers, f'done after {tier["compiled_s"]:.0f} s'))
    q.append((figs, tiers, f'step instead: {first["cold"]:.0f} s to those poses'))
    q.append((coll, '#What is left', f'(first poses after {tier["first_poses_s"]:.1f} s)'))
    q.append((coll, '#What is left',
              f'runs the demo at {tier["interpreted_early_sim_over_wall"]:.2f}x'))

    contact = load('contact_step_bench', folder)['seconds_per_step']
    names = ('sliding box', 'bouncing ball', 'rolling ball', 'tipping cube')
    ours = ' / '.join(f'{contact[n]["rb_sim_ros, 10"] * 1e6:.1f}' for n in names)
    theirs = ' / '.join(f'{contact[n]["MuJoCo Newton, 10"] * 1e6:.1f}' for n in names)
    q.append((figs, 'one body in contact', f'{ours} us ({theirs} us)'))
    ratios = {c: [contact[n][f'rb_sim_ros, {c}'] / contact[n][f'MuJoCo Newton, {c}']
                  for n in names] for c in ('1', '10')}
    means = [contact[n]['rb_sim_ros, 1, mean'] / contact[n]['MuJoCo Newton, 1, mean']
             for n in names]
    q.append((figs, 'one body in contact at one step a call',
              ' / '.join(f'{r:.2f}x' for r in ratios['1']) + '; mean over the run '
              + ' / '.join(f'{r:.2f}x' for r in means)))
    q.append((figs, '#Collisions', f'{min(ratios["10"]):.1f}x to {max(ratios["10"]):.1f}x'))
    q.append((figs, '#Collisions', f'{min(ratios["1"]):.1f}x to {max(ratios["1"]):.1f}x'))
    spread = max(contact[n]['rb_sim_ros, 1, mean'] / contact[n]['rb_sim_ros, 1'] for n in names)
    q.append((figs, '#Collisions', f'within {math.ceil(100 * (spread - 1)):.0f}% of their'))
    q.append((figs, '**Fast**', f'costs {ratios["10"][0]:.1f}x'))
    q.append((figs, '**Fast**', f'({ratios["1"][0]:.1f}x at one step a call'))

    cyl = load('cylinder_bench', folder)['seconds_per_step']
    cyl_ratios = {c: [r[f'rb_sim_ros, {c}'] / r[f'MuJoCo Newton, {c}'] for r in cyl.values()]
                  for c in ('1', '10')}
    q.append((figs, '#Collisions', f'{min(cyl_ratios["10"]):.1f}x to '
              f'{max(cyl_ratios["10"]):.1f}x'))
    q.append((figs, '#Collisions', f'{min(cyl_ratios["1"]):.1f}x to '
              f'{max(cyl_ratios["1"]):.1f}x'))

    hull = load('hull_bench', folder)['seconds_per_step']
    hull_ratio = {(name, c): r[f'rb_sim_ros, {c}'] / r[f'MuJoCo Newton, {c}']
                  for name, r in hull.items() for c in ('1', '10')}
    on_plane = [hull_ratio[(n, c)] for n in ('tipping post', 'pebble on the ground')
                for c in ('10', '1')]
    q.append((figs, '#Collisions', f"{on_plane[0]:.1f}x and {on_plane[2]:.1f}x MuJoCo's step "
              f'at ten steps a call ({on_plane[1]:.1f}x and {on_plane[3]:.1f}x at one)'))
    q.append((figs, '#Collisions', f'a hull on a hull {hull_ratio[("hull on a hull", "10")]:.1f}x '
              f'({hull_ratio[("hull on a hull", "1")]:.1f}x)'))
    q.append((figs, '#Collisions', f'{hull_ratio[("pebble on terrain", "10")]:.1f}x MuJoCo on '
              f'its height field ({hull_ratio[("pebble on terrain", "1")]:.1f}x)'))

    hull_pile = load('hull_pile_bench', folder)
    per_step = hull_pile['seconds_per_step']
    ms = (per_step['rb_sim_ros'] * 1e3, per_step['MuJoCo Newton'] * 1e3,
          per_step['rb_sim_ros, terrain bin'] * 1e3)
    q.append((figs, '#Collisions', f"{ms[0]:.3f} ms a step against MuJoCo's "
              f'{ms[1]:.3f}, {ms[0] / ms[1]:.2f}x'))
    deep = hull_pile['deepest_penetration']
    q.append((figs, '#Collisions', f'{ms[2]:.3f} ms, {ms[2] / ms[1]:.2f}x MuJoCo '
              f"on its box walls; deepest penetration {deep['rb_sim_ros, terrain bin'] * 1e3:.2f} "
              f"mm, {deep['rb_sim_ros'] * 1e3:.2f} in the box bin, MuJoCo's "
              f"{deep['MuJoCo Newton'] * 1e3:.2f}"))

    pile = load('pile_bench', folder)
    rows, out = pile['rows'], pile['outcomes']
    ms = [rows[k]['seconds_per_step'] * 1e3 for k in (
        'rb_sim_ros, step(1)', 'Rapier 2 threads, step()', 'Rapier 1 thread, step()',
        'MuJoCo Newton, mj_step')]
    q.append((figs, '100 boxes piling for 2 s',
              ' / '.join(f'{m:.3f}' for m in ms) + f' ms: {ms[0] / ms[1]:.2f}x / '
              f'{ms[0] / ms[2]:.2f}x / {ms[0] / ms[3]:.2f}x; '
              f'{out["rb_sim_ros"]["box_penetration"] * 1e3:.2f} / '
              f'{out["Rapier, 2 threads"]["box_penetration"] * 1e3:.1f} mm'))

    many = '#Many bodies at once'
    q.append((figs, many, f'{big["batch_free_one_thread_ns"]:.1f} ns per body-step'
              f' on one core'))
    one = big['mujoco_euler_ns'] / big['batch_free_one_thread_ns']
    q.append((figs, many, f'{one:.1f}x less than MuJoCo'))
    q.append((figs, many, f'{big["batch_free_ns"]:.1f} ns on both'))
    q.append((figs, many,
              f'{big["mujoco_euler_all_cores_ns"] / big["batch_free_ns"]:.1f}x less than'))
    q.append((figs, many, f'{big["batch_free_one_step_per_call_ns"]:.0f} ns'))

    compiled = {r['case']: r for r in load('compile_cost', folder)['rows']}
    steppers = [compiled[f'stepper {m}'] for m in ('eq27', 'lie4', 'flow4')]
    total = load('compile_cost', folder)['package_kernels']
    q.append((figs, 'first use on an empty kernel cache',
              ' / '.join(f'{r["seconds"]:.1f}' for r in steppers) + ' s ('
              + ' / '.join(str(r['kernels_compiled']) for r in steppers) + f' of {total}); '
              f'{compiled["node default scene"]["seconds"]:.0f} / '
              f'{compiled["node collision demo"]["seconds"]:.0f} / '
              f'{compiled["node balls on the ground"]["seconds"]:.0f} s; '
              f'{compiled["all parts"]["seconds"]:.0f} s'))
    demo = f'{compiled["node collision demo"]["seconds"]:.0f} s'
    q.append((coll, '#What is left', f'compiles its kernels in {demo}'))
    q.append((figs, tiers, f'the child now takes {demo} for the demo'))
    balls = compiled['node balls on the ground']
    demo_row = compiled['node collision demo']
    q.append((figs, "**Compiled for the scene's shapes**",
              f'Their first start took {balls["seconds"]:.0f} s and '
              f'{balls["cpu_seconds"]:.0f} CPU seconds ({balls["kernels_compiled"]} kernels), '
              f'the collision demo\'s {demo_row["seconds"]:.0f} s and '
              f'{demo_row["cpu_seconds"]:.0f} CPU seconds ({demo_row["kernels_compiled"]} '
              'kernels'))
    spawned = list(compiled['node balls, a crate spawned']['parts'].values())[-1]
    q.append((figs, "**Compiled for the scene's shapes**",
              f'a crate spawned among the balls: {spawned:.0f} s more'))
    lock = load('lockstep_bench', folder)
    lockstep = '#Closed loops and lockstep'
    one, two = lock['one_controller'], lock['two_controllers']
    rec, op = lock['one_recorded'], lock['open_loop']
    q.append((figs, lockstep, 'one body and its controller make '
              f"{one['periods_per_s']:,.0f} round trips a second "
              f"({1e6 / one['periods_per_s'] / 1e3:.2f} ms each: a 100 Hz controller at "
              f"{one['periods_per_s'] / 100:.0f}x real time)"))
    q.append((figs, lockstep, f"{rec['periods_per_s']:,.0f} when recorded; two bodies with "
              f"a controller each {two['periods_per_s']:,.0f}."))
    q.append((figs, lockstep, f"open loop steps {op['periods_per_s']:,.0f} periods a second, "
              f"so lockstep costs {op['periods_per_s'] / one['periods_per_s']:.0f}x"))
    q.append((figs, lockstep, f"makes {lock['rclpy_ping_pong_per_s']:,.0f} round trips a "
              'second in the'))
    q.append((figs, lockstep, f"({1e6 / lock['rclpy_ping_pong_per_s']:.0f} us each; "
              f"{lock['rclpy_ping_pong_executors_per_s']:,.0f} spun by executors)"))
    q.append((figs, lockstep, f"Of a lockstep round trip of {1e6 / one['periods_per_s']:.0f} "
              f"us, the node's"))
    q.append((figs, lockstep, f"own work is {one['own_work_us']:.0f} us"))
    rest = 1e6 / one['periods_per_s'] - one['own_work_us']
    q.append((figs, lockstep, f'the other {rest:.0f} us, the controller and DDS'))
    ex = lock['one_controller_executed']
    q.append((figs, lockstep, f"({ex['periods_per_s']:,.0f} round trips a second through its "
              f"executor instead: {one['periods_per_s'] / ex['periods_per_s']:.2f}x)"))
    q.append((figs, lockstep, 'are identical in every field'
              if all(lock['identical'].values()) else 'are not all identical'))

    cradles = load('cradle_bench', folder)['cradles']
    for balls in ('3', '5'):
        for engine in ('rb_sim_ros', 'MuJoCo, elastic (solref -1e6 -1e-6)'):
            r = cradles[balls][engine]
            q.append((coll, '#Impacts: chains of touching bodies',
                      f'({", ".join(f"{x:.3f}" for x in r["velocities"])})'))
    for engine in ('PyBullet', 'Drake (point contact, no dissipation)'):
        r = cradles['3'][engine]
        q.append((coll, '#Impacts: chains of touching bodies',
                  f'({", ".join(f"{x:.3f}" for x in r["velocities"])})'))
    drake = cradles['3']['Drake (point contact, no dissipation)']
    q.append((coll, '#Impacts: chains of touching bodies',
              f'losing {-100 * drake["energy_change"]:.0f}% of the energy'))
    elastic = cradles['5']['MuJoCo, elastic (solref -1e6 -1e-6)']
    q.append((coll, '#Impacts: chains of touching bodies',
              f'gaining {100 * elastic["energy_change"]:.0f}% of the energy'))

    ccd = load('ccd_bench', folder)
    for key, text in ccd_cells(ccd).items():
        q.append((coll, '#Continuous collision: the swept test', text))
    tun, gh, cost = ccd['tunnelling'], ccd['ghosts'], ccd['cost']
    for anchor, text in (
            ('1 cm wall held in all', f"held in all {tun['cases']} orientations drawn"),
            ('1 cm wall held in all', f"the discrete method let {tun['passed']['discrete']} "
             'through'),
            ('fast skimming runs', f"no ghost stop in {gh['cases']} fast skimming runs"),
            ('fast skimming runs', f"({gh['stopped_without']} without the swept test)"),
            ('fast skimming runs', f"x{cost['heap']['ratio']:.3f}"),
            ("the collision demo's.", f"x{cost['demo']['ratio']:.3f}")):
        q.append((figs, anchor, text))
    return q


def ccd_cells(ccd: dict) -> dict[str, str]:
    """The cells of docs/collisions.md's table of bench/ccd_bench.py, by what they say."""
    tun, gh = ccd['tunnelling'], ccd['ghosts']
    cells = {
        'plates': f"{tun['passed']['default']} of {tun['cases']}",
        'plates_discrete': f"{tun['passed']['discrete']} of {tun['cases']} (discrete method)",
        'ghosts': f"{gh['stopped_with_sweep']} of {gh['cases']}",
        'ghosts_without': f"{gh['stopped_without']} of {gh['cases']} (speculative contacts "
                          'alone)'}
    for name, digits in (('heap', 2), ('demo', 4)):
        c = ccd['cost'][name]
        cells[name] = (f"{c['seconds_per_step_with'] * 1e3:.{digits}f} (x{c['ratio']:.3f}; "
                       f"{c['pairs_swept']:,} pairs swept, {c['contacts_missed']} contacts "
                       'missed)')
        cells[name + '_without'] = f"{c['seconds_per_step_without'] * 1e3:.{digits}f}"
    return cells


def campaign_text(folder: Path = DOCS_BENCH) -> str:
    """What docs/campaigns.md and docs/benchmarks.md say of bench/campaign_bench.py's run."""
    c = load('campaign_bench', folder)
    e = {x['engine']: x for x in c['engines']}
    one, two = e['in-process, 1 worker'], e['in-process, 2 workers']
    ray, dds = e['in-process, Ray (local) 2 CPUs'], e['over DDS, 2 workers']
    text = (f"in-process, 1 worker {one['runs_per_s']:.2f} runs/s, 2 workers "
            f"{two['runs_per_s']:.2f} runs/s ({two['runs_per_s'] / one['runs_per_s']:.2f}x), "
            f"Ray with 2 CPUs {ray['runs_per_s']:.2f} runs/s; over DDS, 2 workers "
            f"{dds['runs_per_s']:.2f} runs/s ({two['runs_per_s'] / dds['runs_per_s']:.0f}x "
            f"fewer). A run costs {one['cpu_s_per_run'] * 1e3:.0f} ms of one core in-process: "
            f"a million runs are {one['cpu_s_per_run'] * 1e6 / 3600:.0f} core-hours.")
    big = c.get('big')
    if big:
        text += (f" {big['runs']:,} runs on 2 workers took {big['seconds'] / 60:.1f} min "
                 f"({big['runs'] / big['seconds']:.2f} runs/s).")
    return text


def campaign_quotes(folder: Path = DOCS_BENCH) -> list[tuple[str, str, str]]:
    text = campaign_text(folder)
    return [('docs/campaigns.md', '#Engines, faults, scale', text),
            ('docs/benchmarks.md', '#Campaigns', text)]


def section(text: str, title: str) -> str:
    """The text of the markdown section whose heading starts with ``title`` (no '#')."""
    lines, out, inside = text.splitlines(), [], False
    for line in lines:
        if line.startswith('#'):
            inside = line.lstrip('#').strip().startswith(title)
            continue
        if inside:
            out.append(line)
    return '\n'.join(out)


def _continued(lines: list[str]) -> list[str]:
    out = []
    for line in lines:
        if not line.startswith('  ') or not line.strip():
            break
        out.append(line)
    return out


def stale(folder: Path = DOCS_BENCH, root: Path = ROOT) -> list[str]:
    """Every quote that is not where it should be, as a sentence."""
    texts: dict[str, str] = {}
    problems = []
    for doc, anchor, text in quotes(folder):
        body = texts.setdefault(doc, (root / doc).read_text())
        if anchor.startswith('#'):
            where = section(body, anchor[1:])
            if not where:
                problems.append(f'{doc}: no section {anchor!r}')
                continue
            places = [' '.join(where.split())]
        else:
            lines = body.splitlines()
            # a line, with the indented lines that continue it (a bullet's)
            places = [' '.join(' '.join([line] + _continued(lines[i + 1:])).split())
                      for i, line in enumerate(lines) if anchor in line]
            if not places:
                problems.append(f'{doc}: no line with {anchor!r} (expected {text!r})')
                continue
        if not any(text in p for p in places):
            problems.append(f'{doc}: {text!r} missing from the line with {anchor!r}')
    return problems


def main() -> int:
    problems = stale()
    for p in problems:
        print(p)
    if not problems:
        print(f'every quoted figure matches {DOCS_BENCH.relative_to(ROOT)}/*.json')
    return 1 if problems else 0


if __name__ == '__main__':
    sys.exit(main())
