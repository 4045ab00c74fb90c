# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""docs/benchmarks.md from the summary that bench/run.py collects (no measuring here)."""

from __future__ import annotations

import math
from pathlib import Path

from bench import step_cost, work_precision as wp


def _e(x) -> str:
    """A float in short scientific notation; '-' for None, 'inf'/'nan' spelt out."""
    if x is None:
        return '-'
    if isinstance(x, float) and not math.isfinite(x):
        return str(x)
    return f'{x:.1e}'


def _order(x) -> str:
    return '-' if x is None else f'{x:.2f}'


def image(scene_key: str) -> str:
    return f'img/work_precision_{scene_key}.png'


def header(s: dict) -> list[str]:
    m = s['machine']
    mode = (' **Quick mode: short scenes, small sweeps, few repeats; not the published '
            'figures.**' if s['quick'] else '')
    return [
        '# Benchmarks: run time against error, and numerical stress', '',
        f'Measured {s["date"]} on {m["cpu"]} ({m["cores"]} cores), {m["os"]}; Python '
        f'{m["python"]}, numpy {m["numpy"]}, scipy {m["scipy"]}, MuJoCo {m["mujoco"]}. '
        f'The whole run took {s["seconds"]:.0f} s.{mode}', '',
        'Regenerate everything on this page (tables, and the figures in `docs/img/`) with',
        '', '    ./tools/bench.sh                       # full, under 10 minutes on 2 cores',
        '    ./tools/bench.sh --quick --out /tmp/b  # a few seconds; what the tests run', '',
        '`tools/bench.sh` sets up `.venv` with `requirements-bench.txt` and runs '
        '`python -m bench.run`, which also writes these figures to `docs/bench/run.json`. The '
        'cost of one step alone: `python -m bench.step_cost`. The other benchmarks (skips, the '
        'batch path, collisions, sleeping, the node) each write `docs/bench/<name>.json` with '
        'the command that ran them; this page (from "Accuracy and speed" on), '
        'docs/collisions.md and docs/sweeps.md quote only those files, and `python -m '
        'bench.figures` checks that they do.', '',
        'Order of work: the references are checked against each other, then every '
        'integrator’s error is checked to fall at its order, and only then is anything '
        'timed. A method off its order by more than '
        f'{wp.ORDER_TOLERANCE} stops the run (exit status 1).', '']


def cost(s: dict) -> list[str]:
    rows = s['step_cost']
    ours, flows = step_cost.ours_and_flows(rows)
    met = max(ours) <= step_cost.GOAL_US
    return ['## Cost of one step', '',
            f'`stepper.step({s["step_cost_steps"]})`, minimum of {s["repeats"]} runs, divided by '
            'the steps (dt = 1 ms). Each case was first checked against DOP853 after 1 s. '
            'MuJoCo: `mj_step(model, data, nstep)` on one free body, for scale (C against '
            'Python compiled by numba).', '', step_cost.table(rows), '',
            f'Issue 2’s goal, <= {step_cost.GOAL_US:g} us per step of the multistep method: '
            f'**{"met" if met else "not met"}** ({min(ours):.2f}-{max(ours):.2f} us).'
            + (f' The flows, an exact free flow each (flow2) or three (flow4), cost '
               f'{min(flows):.2f}-{max(flows):.2f} us a step.' if flows else ''), '']


def references_table(s: dict) -> list[str]:
    lines = ['## References', '',
             'Every scene starts from a general orientation R0 (rotation vector (0.3, -0.5, '
             '0.8) rad), so that a frame or quaternion-order mix-up cannot hide. Its '
             'reference is checked against an independent second solution before use:', '',
             '| scene | reference | checked against | max angle (rad) | '
             'max omega (rel.) | max drift of L (rel.) |',
             '| --- | --- | --- | ---: | ---: | ---: |']
    names = {'elliptic': 'omega: Jacobi elliptic functions; R: DOP853 rtol 1e-13',
             'top': 'closed form exp(t[L]/I_t) R0 exp(t lambda [e3])',
             'dop853': 'DOP853 rtol 1e-13 per 0.1 s segment, world-frame R'}
    for name, scene in s['work_precision'].items():
        c = scene['reference_check']
        lines.append(f'| {name} | {names[scene["scene"]["reference"]]} | {c["against"]} | '
                     f'{_e(c["angle"])} | {_e(c["omega"])} | {_e(c.get("momentum"))} |')
    return lines + ['']


def _at(points, **match):
    for p in points:
        if all(abs(p.get(k, math.nan) - v) <= 1e-12 * v for k, v in match.items()):
            return p
    return None


def work_precision(s: dict) -> list[str]:
    lines = ['## Work-precision', '',
             'Error: the orientation angle |log(R R_ref^T)| (rad) and |omega - omega_ref| '
             '(rad/s, world frame), at the final time and the largest over samples every '
             '0.05 s. Time: wall seconds per simulated second, the minimum of '
             f'{s["repeats"]} runs (no sampling while timed). Fixed steps dt = 0.1 s / n, '
             'n in ' + ', '.join(str(n) for n in s['steps_n']) + '; DOP853 at rtol '
             + ', '.join(f'{r:g}' for r in s['rtols']) + ' (atol = rtol / 1000). The order is '
             'the slope of log(final error) against log(dt) over the finest (up to '
             f'{wp.FIT_POINTS}) steps whose error lies between {wp.FLOOR:g} and '
             f'{wp.ASYMPTOTIC:g}. In the plots a ring marks dt = 1 ms; points that diverged or '
             'lost more than 1 rad are left out.', '']
    targets = (1e-3, 1e-6, 1e-9)
    for name, scene in s['work_precision'].items():
        info = scene['scene']
        lines += [f'### {name}', '',
                  f'{info["t_end"]:g} s, principal moments '
                  + ', '.join(f'{x:.3g}' for x in info['moments'])
                  + f' kg m^2, |omega0| = {info["omega0"]:.3g} rad/s.', '',
                  f'![{name}]({image(info["key"])})', '',
                  '| method | order R | order omega | setting | R error final / max (rad) | '
                  'omega error final / max (rad/s) | s per sim s | cheapest to '
                  + ' / '.join(f'{t:g}' for t in targets) + ' rad (s per sim s) |',
                  '| --- | ---: | ---: | --- | ---: | ---: | ---: | ---: |']
        for method, data in scene['methods'].items():
            if data['expected_order'] is None:
                p, setting = _at(data['points'], rtol=1e-8), 'rtol 1e-8'
            else:
                p, setting = _at(data['points'], dt=1e-3), 'dt 1 ms'
            if p is None:
                p = data['points'][-1]
                setting = f'rtol {p["rtol"]:g}' if 'rtol' in p else f'dt {p["dt"]:g} s'
            if 'diverged' in p:
                errs, secs = 'diverged', '-'
                omega = '-'
            else:
                errs = f'{_e(p["angle_final"])} / {_e(p["angle_max"])}'
                omega = f'{_e(p["omega_final"])} / {_e(p["omega_max"])}'
                secs = _e(p.get('seconds_per_sim_second'))
            cheap = ' / '.join(_e(wp.cheapest(data['points'], t)) for t in targets)
            lines.append(f'| {method} | {_order(data.get("order_angle"))} | '
                         f'{_order(data.get("order_omega"))} | {setting} | {errs} | {omega} | '
                         f'{secs} | {cheap} |')
        lines.append('')
    return lines


def dzhanibekov(d: dict) -> list[str]:
    lines = ['### Dzhanibekov flip', '',
             f'A body with moments {tuple(d["moments"])} kg m^2 spun at omega_body = '
             f'{tuple(d["omega0_body"])} rad/s, near its middle axis, flips twice per period '
             'of its body-frame motion. Period measured from the sign changes of omega_2 '
             '(interpolated between steps), against the elliptic oracle 4 K(k) / rate = '
             f'**{d["expected_period_s"]:.6f} s**. Close to the separatrix the period depends '
             'logarithmically on the distance to it, so it is a sharp test of how well the '
             'invariants are kept.', '',
             '| method | dt (ms) | periods | measured period (s) | relative error | '
             'first / last period (s) |', '| --- | ---: | ---: | ---: | ---: | ---: |']
    for r in d['rows']:
        if 'period_s' in r:
            lines.append(f'| {r["method"]} | {r["dt"] * 1e3:g} | {r["periods"]} | '
                         f'{r["period_s"]:.6f} | {r["relative_error"]:+.1e} | '
                         f'{r["first_period_s"]:.4f} / {r["last_period_s"]:.4f} |')
        else:
            why = 'diverged' if 'diverged' in r else 'no flip seen'
            lines.append(f'| {r["method"]} | {r["dt"] * 1e3:g} | - | {why} | - | - |')
    return lines + ['']


def extreme(rows: list[dict]) -> list[str]:
    methods = []
    for row in rows:
        methods += [m for m in row['results'] if m not in methods]
    head = '| case (moments kg m^2, abs(omega0) rad/s) | ' + ' | '.join(methods) + ' |'
    rule = '| --- |' + ' ---: |' * len(methods)
    lines = ['### Extreme inertia', '',
             f'Torque-free, dt = 1 ms, {rows[0]["t_end"]:g} s, against DOP853 (rtol 1e-13). '
             'The triangle inequality (I1 + I2 >= I3) bounds every coefficient of Euler’s '
             'equations by 1, so a thin rod is not stiff in itself: what stresses an '
             'integrator is the fast spin about the small axis it invites. The last two rows '
             'are the body of mujoco#3553 (0.12 kg, moments 1.7231e-4, 6.58e-6, 1.7243e-4); '
             '"nested inertia" puts it on a welded child of a massless free body, the form '
             'that issue reported unstable under implicitfast.', '',
             'Worst orientation error over the run (rad):', '', head, rule]

    def label(row):
        return (f'{row["case"]} ({", ".join(f"{x:.6g}" for x in row["moments"])}; '
                f'{row["omega0"]:.3g})')

    def cell(r, key):
        return 'diverged' if 'diverged' in r else _e(r[key])
    for row in rows:
        lines.append(f'| {label(row)} | ' + ' | '.join(
            cell(row['results'][m], 'angle_max') if m in row['results'] else ''
            for m in methods) + ' |')
    lines += ['', 'Largest relative drift of the kinetic energy over the run:', '', head, rule]
    for row in rows:
        lines.append(f'| {label(row)} | ' + ' | '.join(
            cell(row['results'][m], 'energy_drift') if m in row['results'] else ''
            for m in methods) + ' |')
    return lines + ['']


def fast_spin(f: dict) -> list[str]:
    methods = list(f['rows'][0]['results'])
    lines = ['### Fast spin', '',
             'Body (1, 2, 3) kg m^2 tumbling near its major axis, |omega0| = 1 rad/s, '
             'dt = omega*dt. Cell: worst orientation error over the first 10 revolutions '
             '(rad, against DOP853 rtol 1e-13) and relative energy drift over '
             f'{f["revolutions"]} revolutions; **div** = diverged (non-finite, MuJoCo reset, '
             f'or the energy changed by more than {100 * 1.0:g}%).', '',
             '![fast spin](img/fast_spin.png)', '',
             '| omega dt | ' + ' | '.join(methods) + ' |', '| ---: |' + ' ---: |' * len(methods)]
    for row in f['rows']:
        cells = []
        for m in methods:
            r = row['results'][m]
            if r['status'] == 'diverged':
                why = (f' (step {r["step"]})' if r.get('step') is not None
                       else f' (energy x{1 + r["energy_drift"]:.2g})' if 'energy_drift' in r
                       else '')
                cells.append(f'**div**{why}')
            else:
                cells.append(f'{_e(r["angle_max"])}, {_e(r["energy_drift"])}')
        lines.append(f'| {row["omega_dt"]:g} | ' + ' | '.join(cells) + ' |')
    lines += ['', 'Where each method stops (accurate: worst error <= 1e-2 rad over 10 '
              'revolutions at this and every smaller omega*dt):', '']
    for m, lim in f['limits'].items():
        first = f['rows'][0]['omega_dt']
        acc = (f'accurate up to omega*dt = {lim["accurate_up_to"]:g}' if lim['accurate_up_to']
               else f'not accurate even at omega*dt = {first:g}')
        div = (f'diverges from omega*dt = {lim["first_diverged"]:g}' if lim['first_diverged']
               else f'stays bounded up to {lim["tested_up_to"]:g} (the largest tried)')
        lines.append(f'- {m}: {acc}; {div}.')
    return lines + ['']


def long_run(lr: dict) -> list[str]:
    lines = [f'### Long run: {lr["steps"]:.0e} steps', '',
             f'Torque-free tumble of the body (1, 2, 3) kg m^2 at dt = {lr["dt"] * 1e3:g} ms '
             f'({lr["steps"] * lr["dt"]:g} s simulated), every method. The orthonormality '
             'error max(|R^T R - I|, |det R - 1|) is of the R that rb_sim_ros integrates, read '
             'raw at 120 log-spaced times (the multistep methods re-orthonormalize every 1024 '
             'steps; the flows evaluate R afresh each step from the kept polhode; MuJoCo '
             'renormalizes its quaternion every step).', '',
             '![long run](img/long_run.png)', '',
             '| method | energy drift at the end | momentum drift at the end | max '
             'orthonormality error of R | note |', '| --- | ---: | ---: | ---: | --- |']
    for name, d in lr['methods'].items():
        e = d['energy_drift'][-1] if d['energy_drift'] else None
        m = d['momentum_drift'][-1] if d['momentum_drift'] else None
        note = f'diverged: {d["diverged"]}' if d['diverged'] else ''
        lines.append(f'| {name} | {_e(e) if e is None else f"{e:+.1e}"} | {_e(m)} | '
                     f'{_e(d["max_orthonormality_error"])} | {note} |')
    return lines + ['']


def blow_up(rows: list[dict]) -> list[str]:
    lines = ['### Blow-up', '',
             'Body (1, 2, 3) kg m^2 at omega*dt = 1.5 (dt = 1 s), far past every method’s '
             'limit, `stepper.step(1000)`: the stepper must raise `IntegrationError` naming '
             'the step, never hand back a non-finite state. "Checked" means a second stepper '
             'stepping one step at a time first fails at the same step, and the stepper is left '
             'at the last finite state.', '',
             '| method | raised | step named | step_count after | state finite after | '
             'checked | message |', '| --- | --- | ---: | ---: | --- | --- | --- |']
    for r in rows:
        if r['raised']:
            lines.append(f'| {r["method"]} | yes | {r["step"]} | {r["step_count_after"]} | '
                         f'{r["state_finite"]} | {r["consistent"]} | '
                         f'{r["message"][:70]}... |')
        elif r.get('exact_flow'):
            lines.append(f'| {r["method"]} | no (exact flow: no limit) | - | - | {r["finite"]} '
                         f'| - | energy drift {r["energy_drift"]:+.1e} in 1000 steps |')
        else:
            lines.append(f'| {r["method"]} | **no** | - | - | {r["finite"]} | - | - |')
    return lines + ['']


def _x(v: float) -> str:
    return f'{v:.0f}' if v >= 10 else f'{v:.1f}'


def _ratio_range(values) -> str:
    values = sorted(values)
    lo, hi = values[0], values[-1]
    return f'{_x(lo)}x' if hi < 1.2 * lo else f'{_x(lo)}-{_x(hi)}x'


def _range(values) -> str:
    values = sorted(values)
    return _e(values[0]) if values[0] == values[-1] else f'{_e(values[0])}-{_e(values[-1])}'


def findings(s: dict) -> list[str]:
    """The key figures of this run, in words (computed from the summary)."""
    out = ['## Findings', '']
    ours, flows = step_cost.ours_and_flows(s['step_cost'])
    out.append(f'- One step of rb_sim_ros’s multistep methods costs {min(ours):.2f}-'
               f'{max(ours):.2f} us amortised over step({s["step_cost_steps"]}) (goal <= '
               f'{step_cost.GOAL_US:g} us), compiled (numba)'
               + (f', of the flows {min(flows):.2f}-{max(flows):.2f} us' if flows else '')
               + '; a call per step costs more (step(1) and step(10), as the node steps: '
               '`python -m bench.step_cost`, docs/bench/step_cost.json). MuJoCo’s mj_step on '
               'one free body, for scale, is in the table below.')
    # At dt = 1 ms: eq27 against MuJoCo's first-order integrators.
    better, cost_ratio, best, cross = {}, [], {}, []
    for name, scene in s['work_precision'].items():
        m = scene['methods']
        eq27 = _at(m['rb_sim_ros eq27']['points'], dt=1e-3)
        no_cross = _at(m['rb_sim_ros eq27-no-cross']['points'], dt=1e-3)
        cross.append(no_cross['angle_final'] / eq27['angle_final'])
        for peer in ('MuJoCo Euler', 'MuJoCo implicitfast'):
            p = _at(m[peer]['points'], dt=1e-3)
            better.setdefault(peer, []).append(p['angle_final'] / eq27['angle_final'])
            cost_ratio.append(eq27['seconds_per_sim_second'] / p['seconds_per_sim_second'])
        for target in (1e-3, 1e-6):
            costs = {k: wp.cheapest(v['points'], target) for k, v in m.items()}
            costs = {k: v for k, v in costs.items() if v is not None}
            winner = min(costs, key=costs.get)
            best.setdefault(target, []).append((winner, costs[winner],
                                                costs.get('rb_sim_ros eq27')))
    out.append('- At dt = 1 ms, eq27’s orientation error is '
               + ' and '.join(f'{_ratio_range(v)} smaller than {k}’s' for k, v in better.items())
               + f' on the four work-precision scenes, for {_ratio_range(cost_ratio)} their wall '
               'time (second order against first, at the same step).')
    for target, rows in best.items():
        winners = sorted({w for w, _, _ in rows})
        ours = [c for _, _, c in rows if c is not None]
        out.append(f'- Cheapest measured way to {target:g} rad: {", ".join(winners)} '
                   f'({_range([c for _, c, _ in rows])} s per simulated second); eq27 needs '
                   + (f'{_range(ours)}' if ours else 'a finer dt than swept')
                   + (f' (not reached on {len(rows) - len(ours)} scene(s))'
                      if ours and len(ours) < len(rows) else '') + '.')
    extreme_rows = s['stress']['extreme_inertia']
    spins = [r for r in extreme_rows if 'long-axis' in r['case']]
    ratio = [r['results']['rb_sim_ros eq27-no-cross']['angle_max']
             / r['results']['rb_sim_ros eq27']['angle_max'] for r in spins
             if 'angle_max' in r['results']['rb_sim_ros eq27']]
    if ratio:
        out.append('- The (beta x omega) dt^2/12 term of eq. (27) barely matters in the '
                   f'work-precision scenes (eq27-no-cross’s error is {_ratio_range(cross)} '
                   'eq27’s at 1 ms), but on the long-axis spins of the extreme-inertia cases '
                   f'eq27-no-cross is {_ratio_range(ratio)} less accurate than eq27.')
    worst = max(r['results']['rb_sim_ros eq27'].get('angle_max', math.inf) for r in extreme_rows)
    out.append(f'- Extreme inertia (ratios to 1e4, the mujoco#3553 body): eq27 stays finite, '
               f'its worst orientation error over the runs is {_e(worst)} rad at dt = 1 ms.')
    issue = [r for r in extreme_rows if r['case'].startswith('mujoco#3553')]
    same = all(r['results'].get('MuJoCo implicitfast (nested inertia)')
               == r['results'].get('MuJoCo implicitfast') for r in issue)
    if issue:
        out.append(f'- MuJoCo {s["machine"]["mujoco"]}: implicitfast with the nested inertia of '
                   f'mujoco#3553 {"gives exactly" if same else "does not give"} the results of '
                   'the flat body' + (': the instability reported there does not occur in this '
                                      'version.' if same else '.'))
    limits = s['stress']['fast_spin']['limits']['rb_sim_ros eq27']
    if limits['accurate_up_to']:
        out.append(f'- Fast spin: eq27 keeps the orientation within 1e-2 rad over 10 revolutions '
                   f'up to omega*dt = {limits["accurate_up_to"]:g} (at dt = 1 ms, '
                   f'|omega| <= {limits["accurate_up_to"] / 1e-3:g} rad/s)'
                   + (f'; from omega*dt = {limits["first_diverged"]:g} it blows up, and the '
                      'stepper raises IntegrationError.' if limits['first_diverged'] else '.'))
    flips = {r['dt']: r for r in s['stress']['dzhanibekov']['rows']
             if r['method'] == 'rb_sim_ros eq27' and 'relative_error' in r}
    if 1e-3 in flips:
        text = (f'- Dzhanibekov flip at dt = 1 ms: eq27’s period is off by '
                f'{flips[1e-3]["relative_error"]:+.1e}')
        if 2e-3 in flips and 5e-4 in flips:
            ratio = flips[2e-3]['relative_error'] / flips[5e-4]['relative_error']
            order = math.log2(abs(ratio)) / 2
            text += f' (falling at order {order:.1f} in dt)'
        out.append(text + '.')
    lr = s['stress']['long_run']
    d = lr['methods']['rb_sim_ros eq27']
    if d['energy_drift']:
        out.append(f'- {lr["steps"]:.0e} steps torque-free: eq27 drifts '
                   f'{d["energy_drift"][-1]:+.1e} in energy and {d["momentum_drift"][-1]:.1e} '
                   f'in world angular momentum; R stays orthonormal to '
                   f'{_e(d["max_orthonormality_error"])}.')
    rows = s['stress']['blow_up']
    raised = all(r['raised'] and r['consistent'] for r in rows if not r.get('exact_flow'))
    flows = [r for r in rows if r.get('exact_flow')]
    out.append('- Blow-up: every multistep method raises IntegrationError at the first '
               'non-finite step '
               + ('(checked step by step).' if raised else '**NOT always: see below.**')
               + (' The flows run through omega*dt = 1.5 finite, energy kept to '
                  f'{_e(max(abs(r.get("energy_drift", math.inf)) for r in flows))}.'
                  if flows else ''))
    return out + ['']


TARGETS = (1e-3, 1e-6, 1e-9)


def methods_table(s: dict) -> list[str]:
    """Per method of ours, the figures of the integrators issue: per scene the cheapest way to
    each target against MuJoCo RK4's, then the Dzhanibekov period, the fast-spin limit and
    the long run's drifts."""
    out = ['## rb_sim_ros against MuJoCo RK4, method by method', '',
           'Cheapest measured wall time per simulated second to a final orientation error of '
           + ' / '.join(f'{t:g}' for t in TARGETS) + ' rad on each work-precision scene: the '
           'best of rb_sim_ros (which method) over MuJoCo RK4 (x: ratio; "-": not reached in '
           'the dt swept).', '',
           '| scene | ' + ' | '.join(f'to {t:g} rad: ours (method) / RK4' for t in TARGETS)
           + ' |', '| --- |' + ' --- |' * len(TARGETS)]
    for name, scene in s['work_precision'].items():
        m = scene['methods']
        cells = []
        for target in TARGETS:
            ours = {k: wp.cheapest(v['points'], target) for k, v in m.items()
                    if k.startswith('rb_sim_ros')}
            ours = {k: v for k, v in ours.items() if v is not None}
            rk4 = wp.cheapest(m['MuJoCo RK4']['points'], target)
            if not ours:
                cells.append(f'- / {_e(rk4)}')
                continue
            best = min(ours, key=ours.get)
            ratio = f' = {ours[best] / rk4:.2g}x' if rk4 else ' (RK4: -)'
            cells.append(f'{_e(ours[best])} ({best.split()[-1]}) / {_e(rk4)}{ratio}')
        out.append(f'| {name} | ' + ' | '.join(cells) + ' |')
    st = s['stress']
    flips = {r['method']: r for r in st['dzhanibekov']['rows'] if r['dt'] == 1e-3}
    limits = st['fast_spin']['limits']
    lr = st['long_run']
    out += ['', f'Stress, each method: the Dzhanibekov period at dt = 1 ms (relative error), '
            'the largest omega*dt still within 1e-2 rad over 10 revolutions (fast spin), and '
            f'the drifts after {lr["steps"]:.0e} torque-free steps at dt = {lr["dt"]:g} s.', '',
            '| method | Dzhanibekov period error | fast spin: accurate up to omega*dt | '
            'energy drift | world angular momentum drift |', '| --- | ---: | ---: | ---: | ---: |']
    for name in limits:
        flip = flips.get(name, {})
        period = (f'{flip["relative_error"]:+.1e}' if 'relative_error' in flip else '-')
        spin = limits[name]['accurate_up_to']
        d = lr['methods'].get(name, {})
        energy = f'{d["energy_drift"][-1]:+.1e}' if d.get('energy_drift') else '-'
        momentum = f'{d["momentum_drift"][-1]:.1e}' if d.get('momentum_drift') else '-'
        if d.get('diverged'):
            energy = momentum = 'diverged'
        out.append(f'| {name} | {period} | {spin if spin else "-"} | {energy} | {momentum} |')
    return out + ['']


def render(s: dict) -> str:
    st = s['stress']
    lines = (header(s) + findings(s) + methods_table(s) + cost(s) + references_table(s)
             + work_precision(s)
             + ['## Stress', ''] + dzhanibekov(st['dzhanibekov']) + extreme(st['extreme_inertia'])
             + fast_spin(st['fast_spin']) + long_run(st['long_run']) + blow_up(st['blow_up']))
    return '\n'.join(lines)


def console(s: dict) -> str:
    """The small table run.py prints: orientation error at dt = 1 ms (DOP853: rtol 1e-8) and
    wall time per simulated second, per method and scene."""
    scenes = list(s['work_precision'])
    methods = list(s['work_precision'][scenes[0]]['methods'])
    width = max(len(m) for m in methods)
    lines = ['error (rad) / s per simulated second at dt = 1 ms (DOP853: rtol 1e-8)',
             ' ' * width + ''.join(f' | {n[:19]:19s}' for n in scenes)]
    for m in methods:
        cells = []
        for n in scenes:
            data = s['work_precision'][n]['methods'][m]
            p = (_at(data['points'], rtol=1e-8) if data['expected_order'] is None
                 else _at(data['points'], dt=1e-3))
            cells.append('-' if p is None or 'diverged' in p else
                         f'{_e(p["angle_final"])} / {_e(p.get("seconds_per_sim_second"))}')
        lines.append(f'{m:{width}s}' + ''.join(f' | {c:19s}' for c in cells))
    return step_cost.table(s['step_cost']) + '\n\n' + '\n'.join(lines)


# Where the page's written part starts: the figures of the other benchmarks, with their
# commands, kept as they are when the generated part above is written again.
WRITTEN = '\n## Accuracy and speed\n'


def write(out: Path, summary: dict) -> Path:
    """Write OUT/benchmarks.md: the generated part, then the written part of the page there
    (from ``WRITTEN`` on), if any."""
    path = Path(out) / 'benchmarks.md'
    old = path.read_text() if path.exists() else ''
    kept = old[old.index(WRITTEN):] if WRITTEN in old else ''
    path.write_text(render(summary).rstrip('\n') + '\n' + kept if kept else render(summary))
    return path
