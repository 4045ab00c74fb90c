# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""The set-up scripts a newcomer runs first: they say what they do and where the log is, and two
of them started at once do not install into one venv at the same time."""

import os
from pathlib import Path
import re
import subprocess

ROOT = Path(__file__).resolve().parents[2]


def _fake_venv(tmp_path: Path, python_body: str) -> Path:
    venv = tmp_path / 'venv'
    (venv / 'bin').mkdir(parents=True)
    python = venv / 'bin' / 'python'
    python.write_text('#!/bin/sh\n' + python_body + '\n')
    python.chmod(0o755)
    return venv


def _source(script: str, venv: Path, **env) -> subprocess.CompletedProcess:
    code = f'set -euo pipefail; root={ROOT}; venv={venv}; . {ROOT}/tools/{script}'
    return subprocess.run(['bash', '-c', code], capture_output=True, text=True, timeout=120,
                          env={**os.environ, 'RB_SIM_VENV': str(venv), **env})


def test_the_message_build_names_its_log_and_each_step_and_a_failure_is_one_warning(tmp_path):
    """A build that fails at its first step (here: a python that cannot install anything) still
    said, before it started, what it builds and where its log is, then which step it was in,
    and ends in one warning naming the log; it leaves no stamp, so the next start tries again."""
    venv = _fake_venv(tmp_path, 'echo "pip: no network" >&2; exit 1')
    done = _source('build_msgs.sh', venv)
    assert done.returncode == 0, done.stderr
    log = venv / '.rb_sim_ros-msgs.log'
    lines = done.stderr.splitlines()
    assert str(log) in lines[0] and 'tools/msgs' in lines[0], lines
    assert any('installing the rosidl generator wheels' in line for line in lines), lines
    assert 'WARNING' in lines[-1] and str(log) in lines[-1], lines
    assert 'pip: no network' in log.read_text()  # the step's own output went to the log
    assert 'pip: no network' not in done.stderr
    assert not (venv / '.rb_sim_ros-msgs.stamp').exists()


def _msgs_stamp(venv: Path) -> None:
    want = subprocess.run(
        ['bash', '-c', 'cat requirements-msgs.txt $(find tools/msgs -type f | sort) '
         '| sha256sum | cut -c1-16'], cwd=ROOT, capture_output=True, text=True, check=True)
    (venv / '.rb_sim_ros-msgs.stamp').write_text(want.stdout)


def test_a_current_stamp_means_no_build_and_no_output(tmp_path):
    venv = _fake_venv(tmp_path, 'exit 1')
    first = _source('build_msgs.sh', venv)
    assert first.stderr  # it tried (and failed: no stamp)
    _msgs_stamp(venv)
    again = _source('build_msgs.sh', venv)
    assert again.returncode == 0 and again.stderr == ''


def test_venv_sh_installs_under_a_lock(tmp_path):
    """The pip step of tools/venv.sh runs holding the venv's lock file: a second set-up command
    waits, then finds the stamp the first wrote and installs nothing."""
    calls = tmp_path / 'calls'
    venv = _fake_venv(
        tmp_path, f'echo "$$ start" >> {calls}; sleep 1; echo "$$ end" >> {calls}; exit 0')
    _msgs_stamp(venv)  # the message build is not under test
    code = f'. {ROOT}/tools/venv.sh requirements.txt'
    env = {**os.environ, 'RB_SIM_VENV': str(venv)}
    procs = [subprocess.Popen(['bash', '-c', code], env=env, stdout=subprocess.DEVNULL,
                              stderr=subprocess.DEVNULL) for _ in range(2)]
    for p in procs:
        p.wait(timeout=120)
    events = calls.read_text().split('\n')[:-1]
    # Two pip calls (requirements, then the package), by one process, never interleaved.
    assert len(events) == 4, events
    pids = [e.split()[0] for e in events]
    assert len(set(pids)) <= 2 and [e.split()[1] for e in events] == ['start', 'end'] * 2


def _requirements(name: str) -> set:
    out = set()
    for line in (ROOT / name).read_text().splitlines():
        line = line.split('#')[0].strip()
        if line.startswith('-r '):
            out |= _requirements(line[3:].strip())
        elif line:
            out.add(line)
    return out


def test_the_attitude_demo_installs_what_it_runs_and_not_the_test_peers():
    """The demo runs the node, the controller, replay --verify and --plot: the runtime and the
    picture packages; MuJoCo, Drake, Ray and pytest are the suite's, minutes of download."""
    script = (ROOT / 'examples' / 'attitude_demo.sh').read_text()
    [req] = re.findall(r'tools/venv\.sh"? (requirements[-\w]*\.txt)', script)
    wanted = _requirements(req)
    assert _requirements('requirements.txt') <= wanted and 'matplotlib' in wanted
    assert not wanted & {'mujoco', 'drake', 'ray', 'pytest', 'pybullet'}, wanted
