# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""campaign: a Monte Carlo of a controller in closed loop, each run recorded and replayable.

    campaign --controller examples/attitude_controller.py --seeds 1000 --stop-after 10
             --param inertia=[0.1,0.2,0.3] --controller-param target_rpy=[0.3,-0.2,1.2]
             --controller-param inertia=[0.1,0.2,0.3]
             --vary 'inertia.0=normal(0.1, 0.01)' --vary 'imu_gyro_bias.2=normal(0, 0.002)'
             --vary initial_angular_velocity.2=-0.5:0.5:3 --vary lockstep_delay=[0,1,2]
             --vary controller.natural_frequency=[1.5,2.0] --out campaign/
             [--scene scene.yaml] [--body NAME] [--metric module:function]
             [--workers 2 | --ray local|auto|ADDRESS]
    campaign --rerun campaign/campaign.json RUN [--out DIR]   # one run again, alone
    campaign --plot campaign/                                   # the pictures of a campaign
    campaign --verify campaign/run_*.mcap                       # replay --verify each

Each run is the simulator in lockstep with the controller called in-process
(offline/closed_loop: the run the node makes with the controller as a ROS node, bit for bit),
to ``--stop-after`` sim seconds, recorded to ``run_NNNNNN.mcap``. A controller is a Python file
(or module) with ``make_law(parameters)``; ``--controller-param NAME=VALUE`` sets its
parameters, ``--param NAME=VALUE`` the simulator's (node parameters: ``inertia``, ``mass``,
``initial_angular_velocity``, ``imu_gyro_noise``, ``imu_gyro_bias``, ``lockstep_delay``, ...).

``--vary KEY=SPEC`` disperses: KEY is ``controller.NAME[.i]`` (a controller parameter, or its
i-th component), ``NAME[.i]`` for a node parameter, else a path into ``--scene``'s file as
``sweep`` takes it (``bodies.<name>.mass``, ...). SPEC is a list ``[a, b]``, a range
``a:b:n`` or a seeded draw ``uniform(a, b)``, ``normal(mu, sigma)`` (as ``sweep``); a
parameter that takes whole numbers (``lockstep_delay``) takes a value only if it is whole.
Runs are the grid of the lists and ranges times ``--seeds``; each run's seed is its IMU seed,
and its draws come from its own stream (run, seed, key): a run depends only on its number,
never on the engine, the worker count or the order runs finish in.

Each run's drawn values are in its recording (the node parameters and the scene as the
simulator took them, in the run's definition; the run's number, seed, drawn values and
controller parameters in a metadata record ``rb_sim_ros_campaign``, which runs over DDS, the
node's own recordings, do not have) and in its row of ``summary.csv``, beside its metrics
(offline/metrics: settling time, overshoot, peak time, peak and RMS torque, initial and final
attitude error towards the controller's ``target_rpy``; ``contact_s``, in-process: the publish
periods whose last step had a contact anywhere in the scene, in seconds; ``--metric`` adds a
user's), ``refused`` (answers the simulator took as no change: the law raised, or its wrench
was refused) and the first one's ``refusal``, its file, its error if it failed, what it cost,
and ``rerun``: the command that makes that run again alone. ``campaign.json`` holds the
campaign itself. ``--param stop_after`` and ``--param imu_seed`` are refused: they are the
campaign's (``--stop-after``, and each run's seed).

A run records what its metrics read: each body's odom and the inputs (``record_outputs`` and
``publish_tf`` default to ``[odom]`` and false here, RECORDED); ``--param
record_outputs=[odom,imu]`` keeps more, ``--param publish_tf=true`` /tf. A recording of fewer
outputs is the same run (replay regenerates every output and compares those recorded),
written faster.
"""

from __future__ import annotations

import argparse
import copy
import json
import math
import os
import re
import shlex
import sys
import time
from typing import Any

import numpy as np

from rb_sim_ros.core.stepper import IntegrationError
from rb_sim_ros.offline import campaign_plots, closed_loop, dds_loop, metrics, sweep
from rb_sim_ros.ros import node_params, node_recorder, ros_arguments
from rb_sim_ros.ros.node_config import config_from
from rb_sim_ros.sim import safe_yaml
from rb_sim_ros.sim.scene import read_scene_data, scene_from_data

# What a campaign's run records unless its --param says otherwise: odom (the metrics') and the
# inputs, the least a run needs to be verified and measured.
RECORDED = {'record_outputs': ['odom'], 'publish_tf': False}
TAIL = ('steps', 'contact_s', 'refused', 'refusal', 'file', 'error', 'wall_s', 'cpu_s', 'rerun')
# The laws of the controllers a worker loaded: a controller file is read once a worker.
_MODULES: dict[str, Any] = {}


# -- what a run is ---------------------------------------------------------------------------
def _where(key: str) -> tuple[str, str, int | None]:
    """('controller' | 'param' | 'scene', name or scene key, component index or None)."""
    parts = key.split('.')
    if parts[0] == 'controller':
        if len(parts) not in (2, 3) or not parts[1]:
            raise ValueError(f'--vary {key}: controller.NAME or controller.NAME.INDEX')
        return 'controller', parts[1], _index(key, parts[2:])
    if parts[0] in node_params.BY_NAME:
        if len(parts) > 2:
            raise ValueError(f'--vary {key}: a node parameter is NAME or NAME.INDEX')
        return 'param', parts[0], _index(key, parts[1:])
    return 'scene', key, None


def _index(key: str, rest: list) -> int | None:
    if not rest:
        return None
    if not re.fullmatch(r'[0-9]{1,3}', rest[0]):
        raise ValueError(f'--vary {key}: the component must be an index (0, 1, 2, ...)')
    return int(rest[0])


def _put(values: dict, name: str, index: int | None, value, key: str, defaults: dict):
    """Set ``values[name]`` (or its ``index``-th component) to ``value``, a whole number where
    the default is one; returns the value set."""
    default = defaults.get(name)
    if index is None:
        values[name] = _typed(value, default, key)
        return values[name]
    held: Any = values.get(name, default)
    if isinstance(held, (str, bytes)) or not hasattr(held, '__len__') or index >= len(held):
        raise ValueError(f'--vary {key}: {name} has no component {index}')
    current = list(held)
    current[index] = _typed(value, current[index], key)
    values[name] = current
    return current[index]


def _typed(value, like, key: str):
    if isinstance(like, int) and not isinstance(like, bool) and isinstance(value, float):
        if not value.is_integer():
            raise ValueError(f'--vary {key}: takes whole numbers, got {value!r}')
        return int(value)
    return value


def normalised(values: dict, defaults: dict) -> dict:
    """``values`` with an integer where the default is a float (or a list of floats) made a
    float: what a ROS parameter of that type takes, so that both ways of running (in-process,
    and the nodes given a parameters file) get, and record, the same values."""
    out = dict(values)
    for name, value in values.items():
        default = defaults.get(name)
        if isinstance(default, float) and _whole(value):
            out[name] = float(value)
        elif isinstance(default, (list, tuple)) and default and \
                all(isinstance(c, float) for c in default) and isinstance(value, (list, tuple)):
            out[name] = [float(c) if _whole(c) else c for c in value]
    return out


def _whole(v) -> bool:
    return isinstance(v, int) and not isinstance(v, bool)


def apply_values(context: dict, values: dict, seed: int) -> tuple[dict, dict, Any]:
    """(node parameters, controller parameters, scene data or None) of a run; ``values`` are
    made what was set (a whole number for a parameter that takes one)."""
    params = dict(context['params'], imu_seed=seed)
    controller = copy.deepcopy(context['controller_params'])
    data = copy.deepcopy(context['scene']) if context['scene'] is not None else None
    node_defaults = {p.name: p.default for p in node_params.PARAMS}
    for key, value in values.items():
        kind, name, index = _where(key)
        if kind == 'controller':
            values[key] = _put(controller, name, index, value, key,
                               context['controller_defaults'])
        elif kind == 'param':
            values[key] = _put(params, name, index, value, key, node_defaults)
        elif data is None:
            raise ValueError(f"--vary {key}: '{key.split('.')[0]}' is neither a node parameter "
                             'nor controller.NAME, and there is no --scene to put it in')
        else:
            sweep.set_key(data, key, value)
    return (normalised(params, node_defaults),
            normalised(controller, context['controller_defaults']), data)


def controller_defaults(where: str) -> dict:
    """The controller's parameters and defaults (its PARAMETERS table, if it has one)."""
    module = _module(where)
    table = getattr(module, 'PARAMETERS', ())
    try:
        return {str(row[0]): row[1] for row in table}
    except (TypeError, IndexError, KeyError):
        raise ValueError(f'controller {where}: its PARAMETERS is not a table of (name, '
                         'default, description) rows') from None


def _module(where: str):
    if where not in _MODULES:
        _MODULES[where] = closed_loop.controller_module(where)
    return _MODULES[where]


def run_campaign_one(context: dict, run: int, seed: int, values: dict, out_path: str) -> dict:
    """One run (sweep.run_task's ``run_one``): its row."""
    t0, c0 = time.perf_counter(), time.process_time()
    row: dict[str, Any] = {'run': run, 'seed': seed,
                           **{k: sweep._cell(v) for k, v in values.items()}}
    try:
        values = dict(values)
        params, controller, data = apply_values(context, values, seed)
        row.update({k: sweep._cell(v) for k, v in values.items()})
        scene = scene_from_data(data, context['scene_path']) if data is not None else None
        if context.get('dds'):  # the scene's file, unless a key of it was dispersed
            varied = any(_where(key)[0] == 'scene' for key in values)
            _over_dds(context, params, controller, data if varied else None, scene, out_path,
                      row)
        else:
            _in_process(context, run, seed, values, params, controller, scene, out_path, row)
        for where in context['metrics'] if not row.get('error') else ():
            info = {'run': run, 'seed': seed, 'values': values,
                    'body': context['body'] or _first_body(scene),
                    'target_rpy': controller.get('target_rpy')}
            found = metrics.user_metric(where)(out_path, info)
            row.update({k: repr(float(v)) for k, v in found.items()})
    except (ValueError, IntegrationError) as e:
        row['error'] = str(e).splitlines()[0][:500]
    row['rerun'] = f"campaign --rerun {shlex.quote(context['spec_path'])} {run}"
    row['wall_s'] = f'{time.perf_counter() - t0:.6f}'
    row['cpu_s'] = f'{time.process_time() - c0:.6f}'
    return row


def _in_process(context, run, seed, values, params, controller, scene, out_path, row) -> None:
    law = closed_loop.make_law(_module(context['controller']), context['controller'],
                               controller)
    body = context['body'] or _first_body(scene)
    provenance = {'campaign': context['spec_path'], 'run': str(run), 'seed': str(seed),
                  'values': json.dumps(values, sort_keys=True),
                  'controller': context['controller'],
                  'controller_parameters': json.dumps(controller, sort_keys=True)}
    loop = closed_loop.ClosedLoop(
        closed_loop.node_values(params), {body: law}, out_path, scene, trace=True,
        metadata={node_recorder.PROVENANCE: provenance})
    result = loop.run_to_end()
    config = loop.config
    row['steps'] = result.steps
    row['contact_s'] = repr(loop.contact_periods * config.dt * config.steps_per_publish)
    row['refused'], row['refusal'] = result.refused, result.refusal
    row.update(_metrics(next(b for b in loop.bodies if b.name == body), controller))
    row['error'] = result.error


def _over_dds(context, params, controller, data, scene, out_path, row) -> None:
    """The run with the simulator and the controller as ROS nodes (dds_loop): its metrics
    read back from the node's recording (contact_s is not known: the node does not record
    contacts)."""
    values = closed_loop.node_values(params)  # checked here: a bad value is the row's error
    config = config_from(values, scene)
    body = context['body'] or _first_body(scene)
    error = dds_loop.run(params, context['controller'], controller, out_path, data,
                         namespace=body if scene is not None else '')
    if error:
        row['error'] = error
        return
    row['steps'] = math.ceil(values['stop_after'] / config.dt - 1e-9)
    target = controller.get('target_rpy')
    if target is not None:
        found = metrics.attitude(out_path, body if scene is not None else '',
                                 metrics.quaternion_from_rpy(*target))
        row.update({k: repr(v) for k, v in found.items()})
    row['error'] = ''


def _first_body(scene) -> str:
    """The body a campaign controls by default: the single body, or a scene's first moving
    one."""
    if scene is None:
        return 'body'
    return next(b.name for b in scene.bodies if not b.static)


def _metrics(body, controller: dict) -> dict:
    """The attitude metrics of the traced body towards the controller's target_rpy (none
    without one): the recording's values, as metrics.attitude reads them back."""
    target = controller.get('target_rpy')
    if target is None or not body.times:
        return {}
    q = metrics.quaternion_from_rpy(*target)
    found = metrics.response(
        np.array(body.times), metrics.error_vectors(np.array(body.orientations), q),
        np.array(body.wrench_times), np.array(body.torques, dtype=float).reshape(-1, 3))
    return {k: repr(v) for k, v in found.items()}


# -- the campaign ----------------------------------------------------------------------------
def _spec_context(spec: dict, spec_path: str) -> dict:
    """The context the workers get, from a campaign's spec (campaign.json): checked, and its
    first run's values put in, so that a bad key or value is one line before any worker."""
    seeds, stop = spec['seeds'], spec['stop_after']
    if not 1 <= seeds <= sweep.MAX_RUNS:
        raise ValueError(f'seeds must be from 1 to {sweep.MAX_RUNS}, got {seeds}')
    if not (isinstance(stop, (int, float)) and 0 < stop <= 1e9):  # (no float() of 10**400)
        raise ValueError(f'stop_after must be from 0 to 1e9 s, got {stop}')
    for name in ('stop_after', 'imu_seed'):
        if name in spec['params']:
            raise ValueError(f"{name} is the campaign's: "
                             + ('--stop-after' if name == 'stop_after' else
                                "each run's seed is its imu_seed (--seeds)"))
    if spec.get('controller', '').endswith('.py'):  # (over DDS it runs from elsewhere)
        spec = dict(spec, controller=os.path.abspath(spec['controller']))
    varies = [(key, sweep.parse_spec(key, text)) for key, text in spec['vary']]
    for key, _ in varies:
        _where(key)
    scene_path = os.path.abspath(spec['scene']) if spec.get('scene') else ''
    data = read_scene_data(scene_path) if scene_path else None
    if data is None and spec.get('body') not in ('', 'body', None):
        raise ValueError(f"--body {spec['body']}: without --scene the body is 'body'")
    params = dict(spec['params'], stop_after=float(spec['stop_after']))
    if 'odom' not in node_params.record_outputs(params.get('record_outputs', 'odom')):
        raise ValueError(f"record_outputs {params['record_outputs']!r}: a campaign records odom "
                         '(its metrics read it)')
    if scene_path:
        params['scene_file'] = scene_path
    context = {'plan': sweep.Plan(varies, int(spec['seeds'])), 'params': params,
               'controller': spec['controller'],
               'controller_params': dict(spec['controller_params']),
               'controller_defaults': controller_defaults(spec['controller']),
               'scene': data, 'scene_path': scene_path, 'body': spec.get('body') or '',
               'metrics': list(spec.get('metrics', ())), 'spec_path': spec_path,
               'dds': bool(spec.get('dds')),
               'run_one': run_campaign_one}
    for where in context['metrics']:
        metrics.user_metric(where)
    run, seed, values = context['plan'].run(0)
    params, controller, data = apply_values(context, values, seed)
    closed_loop.node_values(params)
    closed_loop.make_law(_module(spec['controller']), spec['controller'], controller)
    if data is not None:
        scene = scene_from_data(data, scene_path)
        body = context['body']
        if body and not any(b.name == body and not b.static for b in scene.bodies):
            raise ValueError(f'--body {body}: no moving body of that name in the scene')
    return context


def campaign(spec: dict, out_dir: str, engine=None, progress: bool = True) -> list:
    """Run a campaign (``spec``: what campaign.json holds); its rows, sorted by run."""
    os.makedirs(out_dir, exist_ok=True)
    spec_path = os.path.join(out_dir, 'campaign.json')
    # (written into campaign.json: a campaign made before these defaults reruns as it ran)
    spec = dict(spec, params={**RECORDED, **spec['params']})
    context = _spec_context(spec, spec_path)
    sweep._write_atomically(spec_path, json.dumps(spec, indent=1, sort_keys=True).encode())
    return sweep.drive(context, [k for k, _ in spec['vary']], out_dir, engine, progress,
                       'campaign', TAIL)


def rerun(spec_path: str, run: int, out_dir: str) -> tuple[dict, str]:
    """Run ``run`` of the campaign of ``spec_path`` again, alone, into ``out_dir``: its row and
    its recording's path."""
    spec = read_spec(spec_path)
    context = _spec_context(spec, spec_path)
    if not 0 <= run < len(context['plan']):
        raise ValueError(f'run {run}: the campaign has runs 0 to {len(context["plan"]) - 1}')
    os.makedirs(out_dir, exist_ok=True)
    path = os.path.join(out_dir, sweep.file_name(run))
    if os.path.realpath(out_dir) == os.path.realpath(os.path.dirname(spec_path) or '.'):
        raise ValueError(f'--out {out_dir}: the directory of the campaign (its run would be '
                         'written over): choose another')
    _, seed, values = context['plan'].run(run)
    return run_campaign_one(context, run, seed, values, path), path


SPEC_TYPES: dict[str, Any] = {
    'controller': str, 'controller_params': dict, 'params': dict, 'vary': list, 'seeds': int,
    'stop_after': (int, float), 'scene': str, 'body': str, 'metrics': list}


def read_spec(path: str) -> dict:
    """A campaign.json, its fields checked (ValueError naming the first that is wrong)."""
    try:
        with open(path) as f:
            spec = json.load(f)
    except OSError as e:
        raise ValueError(f'{path}: cannot read it: {e.strerror}') from None
    except ValueError as e:
        raise ValueError(f'{path}: not a campaign (not JSON: {e})') from None
    if not isinstance(spec, dict):
        raise ValueError(f'{path}: not a campaign (a JSON object expected)')
    for name, kind in SPEC_TYPES.items():
        if not isinstance(spec.get(name), kind) or isinstance(spec.get(name), bool):
            raise ValueError(f"{path}: not a campaign ('{name}' missing or not a "
                             f'{getattr(kind, "__name__", "number")})')
    if not all(isinstance(v, list) and len(v) == 2 and all(isinstance(c, str) for c in v)
               for v in spec['vary']) or not all(isinstance(m, str) for m in spec['metrics']):
        raise ValueError(f"{path}: not a campaign ('vary' holds [KEY, SPEC] pairs, 'metrics' "
                         'names)')
    return spec


# -- command line ----------------------------------------------------------------------------
def _assignments(items: list, what: str, parser) -> dict:
    out = {}
    for item in items:
        name, sep, text = item.partition('=')
        if not sep or not name:
            parser.error(f'{what} takes NAME=VALUE, got {item!r}')
        try:
            out[name] = safe_yaml.load(text, max_depth=3, max_nodes=1000)
        except safe_yaml.YamlError as e:
            parser.error(f'{what} {name}: {e.reason}')
    return out


def main(args=None) -> int:
    argv = sys.argv if args is None else args
    parser = sweep._Parser(prog='campaign', description=__doc__,
                           formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('files', nargs='*', help='with --verify: the recordings')
    parser.add_argument('--controller', metavar='FILE', help='the controller: a .py file or a '
                        'module with make_law(parameters)')
    parser.add_argument('--controller-param', action='append', default=[],
                        metavar='NAME=VALUE', help='a controller parameter (YAML value)')
    parser.add_argument('--param', action='append', default=[], metavar='NAME=VALUE',
                        help='a node parameter (YAML value), e.g. inertia=[0.1,0.2,0.3]')
    parser.add_argument('--vary', action='append', default=[], metavar='KEY=SPEC')
    parser.add_argument('--seeds', type=int, default=1, help='runs per grid point')
    parser.add_argument('--stop-after', type=float, default=10.0, metavar='SECONDS',
                        help='sim seconds a run')
    parser.add_argument('--scene', metavar='YAML', help='a scene file (default: the single '
                        'body of the parameters)')
    parser.add_argument('--body', help='the controlled body (default: the first moving one)')
    parser.add_argument('--metric', action='append', default=[], metavar='MODULE:FUNCTION')
    parser.add_argument('--dds', action='store_true', help='run the controller as the ROS '
                        'node it is, over DDS in lockstep with the simulator node (two '
                        'processes a run, on a ROS domain each worker holds), instead of '
                        'in-process')
    parser.add_argument('--out', default='campaign_out', help='directory of the runs')
    parser.add_argument('--workers', type=int, default=os.cpu_count() or 1)
    parser.add_argument('--ray', metavar='ADDRESS', help="run on Ray: 'local', 'auto' or an "
                        'address')
    parser.add_argument('--rerun', nargs=2, metavar=('CAMPAIGN_JSON', 'RUN'),
                        help='run one run of a campaign again, alone, into --out')
    parser.add_argument('--plot', metavar='DIR', help="draw a campaign's pictures into DIR")
    parser.add_argument('--verify', action='store_true', help='replay --verify every file')
    opts = parser.parse_args(ros_arguments.non_ros_args(argv, 'campaign'))
    if not 1 <= opts.workers <= 4096:
        parser.error(f'--workers must be from 1 to 4096, got {opts.workers}')
    return sweep.handling_signals('campaign', lambda handle: _main(parser, opts, handle))


def _main(parser, opts, handle: bool) -> int:
    try:
        if opts.verify:
            engine = sweep._engine(opts, handle)
            try:
                results = sweep.verify_many(opts.files, engine)
            finally:
                engine.close()
            bad = [r for r in results if not r[1]]
            for path, ok, text in bad:
                print(f'MISMATCH {path}: {text}' if ok is False else f'UNREADABLE {path}: {text}')
            print(f'campaign: {len(results) - len(bad)} of {len(results)} recordings verify '
                  'bit for bit')
            return 1 if bad else 0
        if opts.plot:
            paths = campaign_plots.plot(
                opts.plot, read_spec(os.path.join(opts.plot, 'campaign.json')))
            print('\n'.join(paths))
            return 0
        if opts.rerun:
            spec_path, run = opts.rerun
            if not re.fullmatch(r'[0-9]{1,9}', run):
                parser.error(f'--rerun takes a run number, got {run!r}')
            row, path = rerun(spec_path, int(run), opts.out)
            print(f'campaign: run {run} again in {path}'
                  + (f": {row['error']}" if row.get('error') else ''))
            original = os.path.join(os.path.dirname(spec_path), sweep.file_name(int(run)))
            if os.path.exists(original):
                diff = node_recorder.same_run(original, path)
                print('the same run as ' + original if not diff else
                      f'NOT the same run as {original}: {diff}')
                return 1 if diff else 0
            return 1 if row.get('error') else 0
        if not opts.controller or opts.files:
            parser.error('--controller FILE (and no positional arguments but with --verify)')
        for item in opts.vary:
            key, sep, spec = item.partition('=')
            if not sep or not key:
                parser.error(f'--vary takes KEY=SPEC, got {item!r}')
        if not (math.isfinite(opts.stop_after) and 0 < opts.stop_after <= 1e9):
            parser.error(f'--stop-after must be from 0 to 1e9 s, got {opts.stop_after}')
        if not 1 <= opts.seeds <= sweep.MAX_RUNS:
            parser.error(f'--seeds must be from 1 to {sweep.MAX_RUNS}, got {opts.seeds}')
        spec = {'controller': os.path.abspath(opts.controller) if opts.controller.endswith(
                    '.py') else opts.controller,
                'controller_params': _assignments(opts.controller_param, '--controller-param',
                                                  parser),
                'params': _assignments(opts.param, '--param', parser),
                'vary': [list(item.partition('=')[::2]) for item in opts.vary],
                'seeds': opts.seeds, 'stop_after': opts.stop_after,
                'scene': os.path.abspath(opts.scene) if opts.scene else '',
                'body': opts.body or '', 'metrics': opts.metric, 'dds': opts.dds}
        engine = sweep._engine(opts, handle)
        try:
            rows = campaign(spec, opts.out, engine)
        finally:
            engine.close()
        failed = sum(1 for r in rows if r.get('error'))
        print(f'campaign: {len(rows)} runs in {opts.out} ({failed} failed); summary '
              f'{os.path.join(opts.out, "summary.csv")}')
        return 0
    except (ValueError, OSError) as e:
        print(f'campaign: {str(e).splitlines()[0]}', file=sys.stderr)
        return 2


if __name__ == '__main__':
    sys.exit(main())
