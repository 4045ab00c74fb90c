# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
# pypi-only: mcap ray
"""A Monte Carlo of a controller (offline/campaign): each kind of dispersion reaches the
physics, as the closed loop's theory says (not only the run's parameters: Basilisk's
dispersions were once written and never applied, AVSLab/basilisk#1164); the campaign is the
same on any engine and worker count, a run that fails fails alone, any run is made again alone
from its row; the metrics against closed-form second-order responses.

The loop: examples/attitude_controller.py (tau = -K_p e_v - K_d w with K_p = 2 I0 wn^2,
K_d = 2 zeta wn I0 for the nominal inertia I0), a small step about z from rest. About one
principal axis of true inertia I it is theta'' + 2 zeta_e wn_e theta' + wn_e^2 theta = 0 with
wn_e = wn sqrt(I0 / I), zeta_e = zeta sqrt(I0 / I) (small angles: e_v = theta / 2)."""

import csv
import json
import math
from pathlib import Path
import subprocess
import sys

import numpy as np
import pytest

from rb_sim_ros.offline import campaign, metrics, replay, sweep
from rb_sim_ros.recording.reader import RecordingReader
from rb_sim_ros.ros import node_recorder

ROOT = Path(__file__).resolve().parents[2]
CONTROLLER = str(ROOT / 'examples' / 'attitude_controller.py')
I0, STEP = 0.1, 0.05  # nominal moment (kg m^2), the step about z (rad)


class Serial:
    """An engine in this process, one task after the other (the physics tests need no
    processes)."""
    workers = 1

    def map(self, fn, shared, tasks):
        for i, task in enumerate(tasks):
            yield i, fn(shared, *task)

    def abort(self):
        pass

    def close(self):
        pass


def _spec(vary, controller=None, params=None, seeds=1, stop_after=6.0, **more):
    spec = {'controller': CONTROLLER,
            'controller_params': {'target_rpy': [0.0, 0.0, STEP], 'inertia': [I0] * 3,
                                  'natural_frequency': 2.0, 'damping_ratio': 0.5,
                                  **(controller or {})},
            'params': {'inertia': [I0] * 3, **(params or {})},
            'vary': [list(v) for v in vary], 'seeds': seeds, 'stop_after': stop_after,
            'scene': '', 'body': '', 'metrics': []}
    spec.update(more)
    return spec


def _rows(out):
    with open(Path(out) / 'summary.csv') as f:
        return list(csv.DictReader(f))


def _second_order(zeta, wn):
    """Overshoot and peak time of the closed form."""
    wd = wn * math.sqrt(1 - zeta * zeta)
    return math.exp(-math.pi * zeta / math.sqrt(1 - zeta * zeta)), math.pi / wd


def test_a_dispersed_inertia_changes_the_response_as_the_theory_says(tmp_path):
    rows = campaign.campaign(_spec([('inertia.2', '[0.05, 0.1, 0.2]')]), str(tmp_path),
                             Serial(), progress=False)
    assert [r.get('error') for r in rows] == ['', '', '']
    for row in _rows(tmp_path):
        ratio = I0 / float(row['inertia.2'])
        overshoot, peak = _second_order(0.5 * math.sqrt(ratio), 2.0 * math.sqrt(ratio))
        # (the controller holds each torque a period, 10 ms: a lag of 5 ms against 0.2 s)
        assert float(row['overshoot']) == pytest.approx(overshoot, rel=0.05, abs=0.003)
        assert float(row['peak_s']) == pytest.approx(peak, abs=0.02)
    # and the recording holds the inertia the physics had, and the run's drawn values
    rec = RecordingReader(str(tmp_path / 'run_000002.mcap'))
    config = json.loads(rec.metadata[node_recorder.METADATA]['config'])
    assert config['bodies'][0]['inertia'] == [0.1, 0.1, 0.2]
    assert json.loads(rec.metadata[node_recorder.PROVENANCE]['values']) == {'inertia.2': 0.2}


def test_dispersed_gains_change_the_response_as_their_theory_says(tmp_path):
    campaign.campaign(_spec([('controller.natural_frequency', '[1.0, 3.0]'),
                             ('controller.damping_ratio', '[0.3, 0.6]')]), str(tmp_path),
                      Serial(), progress=False)
    rows = _rows(tmp_path)
    assert len(rows) == 4
    for row in rows:
        overshoot, peak = _second_order(float(row['controller.damping_ratio']),
                                        float(row['controller.natural_frequency']))
        assert float(row['overshoot']) == pytest.approx(overshoot, rel=0.05, abs=0.003)
        assert float(row['peak_s']) == pytest.approx(peak, abs=0.02)


def test_a_gyro_bias_leaves_the_attitude_error_the_bias_makes(tmp_path):
    """The controller reads the IMU: tau = -K_p e_v - K_d (w + b) is zero at rest for
    e_v = -K_d b / K_p, an angle of 2 zeta b / wn."""
    campaign.campaign(_spec([('imu_gyro_bias.2', '[-0.02, 0.01]')],
                            controller={'source': 'imu'}, stop_after=12.0),
                      str(tmp_path), Serial(), progress=False)
    for row in _rows(tmp_path):
        b = float(row['imu_gyro_bias.2'])
        assert float(row['final_error_rad']) == pytest.approx(2 * 0.5 * abs(b) / 2.0,
                                                              rel=0.01)


def test_dispersed_noise_delay_twist_and_torque_limit_reach_the_run(tmp_path):
    campaign.campaign(_spec([('imu_gyro_noise', '[0.0, 0.05]'),
                             ('lockstep_delay', '0:2:2'),
                             ('initial_angular_velocity.2', 'uniform(-0.3, 0.3)'),
                             ('controller.max_torque', '[0.001, 10.0]')],
                            stop_after=4.0, params={'record_outputs': ['odom', 'imu']}),
                      str(tmp_path), Serial(), progress=False)
    rows = _rows(tmp_path)
    assert len(rows) == 8 and not any(r['error'] for r in rows)
    for row in rows:
        path = tmp_path / row['file']
        rec = RecordingReader(str(path))
        odom = [m.message for m in rec.messages(topics=['/odom'])]
        imu = [m.message for m in rec.messages(topics=['/imu'])]
        wrench = [m for m in rec.messages(topics=['/rb_sim/input/body/wrench'])]
        # the twist: the first state's (the body at rest in attitude: body = world frame)
        assert odom[0].twist.twist.angular.z == float(row['initial_angular_velocity.2'])
        # the delay: the first answer takes effect d periods (10 steps each) after step 0
        assert wrench[0].sequence == 10 * int(row['lockstep_delay'])
        # the noise: the IMU's gyro less the true rate has the dispersed deviation
        diff = np.array([[i.angular_velocity.x - o.twist.twist.angular.x,
                          i.angular_velocity.y - o.twist.twist.angular.y]
                         for i, o in zip(imu, odom)])
        sigma = float(row['imu_gyro_noise'])
        assert diff.std() == pytest.approx(sigma, rel=0.1, abs=1e-15)
        # the limit: each torque component is clipped to it, and the small one binds
        limit = float(row['controller.max_torque'])
        torques = np.array([[m.message.wrench.torque.z] for m in wrench])
        assert np.abs(torques).max() <= limit
        if limit < 0.01:
            assert np.abs(torques).max() == limit
    assert len({r['lockstep_delay'] for r in rows}) == 2


FORCE_LAW = """
PARAMETERS = (('force', 1.0, 'N along x'),)


def make_law(parameters):
    force = parameters.get('force', 1.0)

    def law(state):
        return (force, 0.0, 0.0), (0.0, 0.0, 0.0)
    return law
"""
SPEED_METRIC = """
from rb_sim_ros.recording.reader import RecordingReader


def final_speed(path, info):
    odom = list(RecordingReader(path).messages(topics=['/odom']))[-1].message
    return {'final_vx': odom.twist.twist.linear.x}
"""


def test_a_dispersed_mass_a_users_controller_and_a_users_metric(tmp_path, monkeypatch):
    """A constant force F on a dispersed mass m: v = F t / m at the end (from the user's
    metric, read from the recording)."""
    (tmp_path / 'force_law.py').write_text(FORCE_LAW)
    (tmp_path / 'speed_metric.py').write_text(SPEED_METRIC)
    monkeypatch.syspath_prepend(str(tmp_path))
    spec = _spec([('mass', '[0.5, 2.0]'), ('controller.force', '[1.0, 3.0]')],
                 stop_after=1.0, metrics=['speed_metric:final_speed'])
    spec.update(controller=str(tmp_path / 'force_law.py'), controller_params={})
    campaign.campaign(spec, str(tmp_path / 'out'), Serial(), progress=False)
    rows = _rows(tmp_path / 'out')
    assert len(rows) == 4
    for row in rows:
        v = float(row['controller.force']) * 1.0 / float(row['mass'])
        assert float(row['final_vx']) == pytest.approx(v, rel=1e-12)
        assert 'overshoot' not in row or row['overshoot'] == ''  # (no target_rpy)


def test_the_rows_metrics_are_the_recordings(tmp_path):
    """Measured during the run, they are what metrics.attitude reads back from the file; the
    file records odom and the inputs only (a campaign's default), and replay verifies it."""
    campaign.campaign(_spec([('controller.natural_frequency', '[2.0]')], stop_after=3.0),
                      str(tmp_path), Serial(), progress=False)
    row = _rows(tmp_path)[0]
    # (the defaults are written into campaign.json: a rerun makes the run as it was made)
    assert json.loads((tmp_path / 'campaign.json').read_text())['params']['record_outputs'] \
        == ['odom']
    recording = RecordingReader(str(tmp_path / row['file']))
    assert {t for t, info in recording.topics.items()
            if info.message_count and not t.startswith('/rb_sim/')} == {'/odom'}
    assert replay.verify(str(tmp_path / row['file'])).identical
    found = metrics.attitude(str(tmp_path / row['file']), '',
                             metrics.quaternion_from_rpy(0.0, 0.0, STEP))
    for name, value in found.items():
        assert repr(value) == row[name], name


def test_metrics_of_a_closed_form_response():
    """theta(t) of a second-order step response, sampled at 1 ms: the overshoot and peak
    time of its formula, the 2 % settling time where the sampled curve last leaves the band,
    and the torque's peak and time-weighted RMS."""
    zeta, wn, theta0 = 0.4, 3.0, 0.2
    t = np.arange(0.0, 6.0, 0.001)
    wd = wn * math.sqrt(1 - zeta ** 2)
    theta = theta0 * np.exp(-zeta * wn * t) * (
        np.cos(wd * t) + zeta * wn / wd * np.sin(wd * t))
    r = np.zeros((len(t), 3))
    r[:, 1] = theta
    torque = np.array([[0.0, 2.0, 0.0], [0.0, 0.0, -1.0]])
    found = metrics.response(t, r, np.array([0.0, 1.5]), torque)
    overshoot, peak = _second_order(zeta, wn)
    assert found['overshoot'] == pytest.approx(overshoot, rel=1e-5)
    assert found['peak_s'] == pytest.approx(peak, abs=0.001)
    last_out = t[np.flatnonzero(np.abs(theta) > 0.02 * theta0)[-1] + 1]
    assert found['settling_s'] == last_out and found['settled'] == 1
    assert found['peak_torque'] == 2.0
    span = t[-1]
    assert found['rms_torque'] == pytest.approx(math.sqrt((4.0 * 1.5 + 1.0 * (span - 1.5))
                                                          / span), rel=1e-12)
    assert found['initial_error_rad'] == theta0
    # a response that never settles says so
    assert metrics.response(t[:100], r[:100], np.zeros(0), np.zeros((0, 3)))['settled'] == 0


def _same(a, b):
    names = sorted(p.name for p in Path(a).glob('*.mcap'))
    assert names == sorted(p.name for p in Path(b).glob('*.mcap')) and names
    return all(node_recorder.same_run(str(Path(a) / n), str(Path(b) / n)) == ''
               for n in names)


def _costless(rows):
    return [{k: v for k, v in r.items() if k not in ('wall_s', 'cpu_s', 'rerun')}
            for r in rows]


ENGINE_SPEC = _spec([('inertia.0', 'normal(0.1, 0.02)'), ('lockstep_delay', '[0, 1]')],
                    params={'imu_gyro_noise': 0.01}, controller={'source': 'imu'}, seeds=3,
                    stop_after=1.0)


def test_any_worker_count_gives_the_same_campaign_and_a_failed_run_fails_alone(
        tmp_path, monkeypatch):
    """Runs with an inertia the simulator refuses (-1) are rows with their error, the others
    run; a worker killed on its first try of run 2 (as if killed) loses nothing."""
    spec = dict(ENGINE_SPEC, vary=[['inertia.0', '[0.1, -1.0]'], ['lockstep_delay', '[0, 1]']])
    one = tmp_path / 'one'
    campaign.campaign(spec, str(one), Serial(), progress=False)
    monkeypatch.setenv(sweep.DIE_ONCE_ENV, f'{tmp_path / "died"}:2')
    two = tmp_path / 'two'
    engine = sweep.LocalEngine(2)
    try:
        campaign.campaign(spec, str(two), engine, progress=False)
    finally:
        engine.close()
    assert (tmp_path / 'died').exists()
    rows = _rows(one)
    assert _costless(rows) == _costless(_rows(two)) and len(rows) == 12
    failed = [r for r in rows if r['error']]
    assert len(failed) == 6 and all(r['inertia.0'] == '-1.0' for r in failed)
    assert all('inertia' in r['error'] and not r['file'] for r in failed)
    assert _same(one, two)


@pytest.mark.slow  # a Ray cluster started
def test_ray_gives_the_same_campaign(tmp_path):
    local = tmp_path / 'local'
    campaign.campaign(ENGINE_SPEC, str(local), Serial(), progress=False)
    engine = sweep.RayEngine('local', 2)
    try:
        campaign.campaign(ENGINE_SPEC, str(tmp_path / 'ray'), engine, progress=False)
    finally:
        engine.close()
    assert _costless(_rows(local)) == _costless(_rows(tmp_path / 'ray'))
    assert _same(local, tmp_path / 'ray')


def _cli(*args, cwd):
    return subprocess.run([sys.executable, '-m', 'rb_sim_ros.offline.campaign', *args],
                          capture_output=True, text=True, cwd=cwd, timeout=600)


def test_from_the_command_line_each_run_is_made_again_from_its_row_and_verifies(tmp_path):
    out = _cli('--controller', CONTROLLER, '--seeds', '2', '--stop-after', '1',
               '--param', 'imu_gyro_noise=0.01', '--controller-param', 'source=imu',
               '--controller-param', 'target_rpy=[0.0,0.0,0.3]',
               '--vary', 'initial_angular_velocity.0=normal(0, 0.1)', '--out', 'c',
               '--workers', '2', cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    rows = _rows(tmp_path / 'c')
    assert len(rows) == 2 and rows[0]['seed'] != rows[1]['seed']
    rerun = _cli(*rows[1]['rerun'].split()[1:], '--out', 'again', cwd=tmp_path)
    assert rerun.returncode == 0 and 'the same run as' in rerun.stdout, rerun.stdout
    assert node_recorder.same_run(str(tmp_path / 'c' / rows[1]['file']),
                                  str(tmp_path / 'again' / rows[1]['file'])) == ''
    assert replay.verify(str(tmp_path / 'c' / rows[0]['file'])).identical
    plots = _cli('--plot', 'c', cwd=tmp_path)
    assert plots.returncode == 0, plots.stderr
    for name in ('envelope.png', 'histograms.png', 'against_initial_angular_velocity.0.png'):
        assert (tmp_path / 'c' / name).read_bytes()[:8] == b'\x89PNG\r\n\x1a\n'


@pytest.mark.parametrize('args, said', [
    (['--vary', 'bodies.x.mass=[1]'], 'neither a node parameter nor controller.NAME'),
    (['--vary', 'lockstep_delay=[0.5]'], 'takes whole numbers'),
    (['--vary', 'inertia.7=[1]'], 'inertia has no component 7'),
    (['--controller-param', 'gain=1'], "unknown parameter 'gain'"),
    (['--param', 'dt=-1'], 'dt'),
    (['--stop-after', '0'], '--stop-after'),
])
def test_bad_arguments_are_one_line(tmp_path, args, said):
    out = _cli('--controller', CONTROLLER, '--out', 'c', *args, cwd=tmp_path)
    assert out.returncode == 2 and said in out.stderr, out.stderr
    assert len(out.stderr.strip().splitlines()) <= 2  # (argparse: usage and the line)


def test_a_controller_without_make_law_is_one_line(tmp_path):
    (tmp_path / 'plain.py').write_text('x = 1\n')
    out = _cli('--controller', str(tmp_path / 'plain.py'), cwd=tmp_path)
    assert out.returncode == 2 and 'no make_law' in out.stderr


def test_over_dds_the_controllers_node_makes_the_same_campaign_as_in_process(tmp_path):
    """--dds: per run the simulator node and examples/attitude_controller.py as a ROS node,
    in lockstep, on a domain each worker holds (two workers: two loops at once that must not
    hear each other). The rows and the recordings are the in-process campaign's."""
    spec = _spec([('initial_angular_velocity.0', 'normal(0, 0.1)'),
                  ('lockstep_delay', '[0, 1]'), ('controller.natural_frequency', '[2, 3]')],
                 params={'imu_gyro_noise': 0.01}, controller={'source': 'imu'}, seeds=1,
                 stop_after=1.0)
    campaign.campaign(spec, str(tmp_path / 'here'), Serial(), progress=False)
    engine = sweep.LocalEngine(2)
    try:
        campaign.campaign(dict(spec, dds=True), str(tmp_path / 'dds'), engine,
                          progress=False)
    finally:
        engine.close()
    here, dds = _rows(tmp_path / 'here'), _rows(tmp_path / 'dds')
    assert len(here) == 4 and not any(r['error'] for r in here + dds), dds
    unknown = ('contact_s', 'refused', 'refusal')  # (the node records neither)
    assert [{k: v for k, v in r.items() if k not in unknown} for r in _costless(here)] == \
        [{k: v for k, v in r.items() if k not in unknown} for r in _costless(dds)]
    assert _same(tmp_path / 'here', tmp_path / 'dds')


@pytest.mark.parametrize('text, said', [
    ('{', 'not JSON'), ('[]', 'a JSON object'), ('{"controller": 1}', "'controller' missing"),
    (json.dumps(dict(_spec([]), seeds=0)), 'seeds must be from 1'),
    (json.dumps(dict(_spec([]), vary=[['a']])), "'vary' holds"),
])
def test_a_campaign_file_that_is_not_one_is_one_line(tmp_path, text, said):
    (tmp_path / 'campaign.json').write_text(text)
    out = _cli('--rerun', str(tmp_path / 'campaign.json'), '0', '--out', 'x', cwd=tmp_path)
    assert out.returncode == 2 and said in out.stderr and \
        len(out.stderr.strip().splitlines()) == 1, out.stderr


def test_a_rerun_into_the_campaigns_own_directory_is_refused(tmp_path):
    campaign.campaign(_spec([], stop_after=0.1), str(tmp_path / 'c'), Serial(),
                      progress=False)
    out = _cli('--rerun', 'c/campaign.json', '0', '--out', 'c', cwd=tmp_path)
    assert out.returncode == 2 and 'written over' in out.stderr


RAISING_LAW = """
def make_law(parameters):
    def law(state):
        raise RuntimeError('sensor fault')
    return law
"""


def test_a_law_that_always_fails_shows_in_its_row(tmp_path):
    """An open-loop run is not a silent success: every answer refused, and why."""
    (tmp_path / 'raising.py').write_text(RAISING_LAW)
    spec = _spec([], stop_after=0.5)
    spec.update(controller=str(tmp_path / 'raising.py'), controller_params={})
    campaign.campaign(spec, str(tmp_path / 'out'), Serial(), progress=False)
    row = _rows(tmp_path / 'out')[0]
    assert row['error'] == '' and row['refused'] == '50'
    assert row['refusal'] == 't = 0.000000000 s: the law raised RuntimeError: sensor fault'


def test_contact_time_is_the_periods_in_contact(tmp_path):
    """A ball resting on the ground is in contact every period; one far above, never."""
    scene = tmp_path / 'ball.yaml'
    scene.write_text(
        'gravity: [0, 0, -9.81]\n'
        'bodies:\n'
        '  - {name: ball, shape: sphere, radius: 0.1, density: 1000, position: [0, 0, 0.1],\n'
        '     colliders: shape}\n'
        '  - name: ground\n'
        '    static: true\n'
        '    colliders: [{type: plane, normal: [0.0, 0.0, 1.0], offset: 0.0}]\n')
    spec = _spec([('bodies.ball.position.2', '[0.1, 100.0]')], stop_after=0.5,
                 scene=str(scene), params={})
    spec['controller_params'] = {'target_rpy': [0.0, 0.0, 0.0], 'inertia': [0.004] * 3}
    campaign.campaign(spec, str(tmp_path / 'out'), Serial(), progress=False)
    resting, falling = _rows(tmp_path / 'out')
    assert resting['error'] == falling['error'] == ''
    assert float(resting['contact_s']) == pytest.approx(0.5, abs=0.0100001)
    assert float(falling['contact_s']) == 0.0


@pytest.mark.parametrize('args, said', [
    (['--param', 'stop_after=3'], '--stop-after'),
    (['--param', 'imu_seed=3'], "each run's seed"),
    (['--body', 'ghost'], "without --scene the body is 'body'"),
    (['--metric', 'no_such_module_x:f'], '--metric no_such_module_x:f: ModuleNotFoundError'),
    (['--param', 'record_outputs=[imu]'], 'a campaign records odom'),
])
def test_more_bad_arguments_are_one_line(tmp_path, args, said):
    out = _cli('--controller', CONTROLLER, '--out', 'c', *args, cwd=tmp_path)
    assert out.returncode == 2 and said in out.stderr, out.stderr
    assert len(out.stderr.strip().splitlines()) == 1


def test_a_campaign_file_with_a_huge_stop_is_one_line(tmp_path):
    (tmp_path / 'campaign.json').write_text(json.dumps(dict(_spec([]), stop_after=10 ** 400)))
    out = _cli('--rerun', 'campaign.json', '0', '--out', 'x', cwd=tmp_path)
    assert out.returncode == 2 and 'stop_after must be' in out.stderr, out.stderr
