# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""send_wrench's command line: bad arguments and profiles are one line and exit 2, before ROS
starts; a good run's final zero wrench arrives and is reported as such."""

import contextlib
from fractions import Fraction
import io
import signal

from geometry_msgs.msg import Wrench, WrenchStamped
from hypothesis import given, settings, strategies as st
import pytest

from rb_sim_ros.ros import send_wrench
from rb_sim_ros.ros.body_ports import APPLIED_QOS


def _main(*args):
    """(exit status, stderr) of send_wrench with ``args``; it must stop before starting ROS."""
    err = io.StringIO()
    with contextlib.redirect_stderr(err), pytest.raises(SystemExit) as info:
        raise SystemExit(send_wrench.main(['send_wrench', *args]))
    return info.value.code, err.getvalue()


def _assert_refused(args, *words):
    code, err = _main(*args)
    assert code == 2, err
    assert err.startswith('send_wrench: ') and err.count('\n') == 1, err
    assert 'Traceback' not in err
    for w in words:
        assert w in err, err


@pytest.mark.parametrize('args, words', [
    (('--rate', '1e-300'), ('--rate',)),
    (('--rate', 'nan'), ('--rate',)),
    (('--rate', '-1'), ('--rate',)),
    (('--duration', 'nan'), ('--duration',)),
    (('--duration', 'inf'), ('--duration',)),
    (('--duration', '-1'), ('--duration',)),
    (('--wait', 'nan'), ('--wait',)),
    (('--wait', 'inf'), ('--wait',)),
    (('--force', '1.4e154', '0', '0'), ('force norm 1.4e+154 exceeds --max-wrench 1e+06',)),
    (('--torque', '0', '1e308', '1e308'), ('torque norm 1.41421e+308 exceeds',)),
    (('--force', 'nan', '0', '0'), ('non-finite',)),
    (('--torque', '0', 'inf', '0'), ('non-finite',)),
    (('--force', '2', '0', '0', '--max-wrench', '1'), ('force norm 2 exceeds',)),
    (('--max-wrench', 'nan'), ('--max-wrench',)),
    (('--max-wrench', '0'), ('--max-wrench',)),
    (('--rate', 'fast'), ('--rate',)),
])
def test_bad_arguments_are_one_line_and_exit_2(args, words):
    _assert_refused(args, *words)


HEADER = 't,fx,fy,fz,tx,ty,tz,frame\n'


@pytest.mark.parametrize('content, words', [
    (HEADER + '0,1,0,0,0,0,0,' + 'w' * 200_000 + '\n', (':2: not a CSV profile', 'field')),
    (HEADER + '0,1e200,1e200,0,0,0,0,world\n', (':2: force norm',)),
    (HEADER + '0,1,0,0,0,0,0,world\n1,0,0,0,0,2e6,0,world\n', (':3: torque norm',)),
    (HEADER + '0,1,0,0,0,0,nan,world\n', (':2: non-finite',)),
    (HEADER + 'nan,1,0,0,0,0,0,world\n', (':2: non-finite',)),
    (HEADER + '1e300,1,0,0,0,0,0,world\n', (':2: t must be',)),
    (HEADER + '0,1,0,0,0,0,0,sideways\n', (":2: frame must be world or body, got 'sideways'",)),
    (HEADER + '0,1,0,0\0,0,0,0,world\n', (':2: not a number',)),
    ('t,fx\n0,1\n', ('missing columns',)),
    (HEADER, ('no rows',)),
])
def test_bad_profiles_are_one_line_and_exit_2(tmp_path, content, words):
    f = tmp_path / 'profile.csv'
    f.write_text(content)
    _assert_refused(('--csv', str(f)), str(f), *words)


def test_unreadable_profiles_are_one_line_and_exit_2(tmp_path):
    binary = tmp_path / 'binary.csv'
    binary.write_bytes(HEADER.encode() + b'0,1,0,0,0,0,0,\xff\xfe\n')
    _assert_refused(('--csv', str(binary)), str(binary), 'not a text file')
    _assert_refused(('--csv', str(tmp_path / 'missing.csv')), 'missing.csv: cannot read')
    _assert_refused(('--csv', str(tmp_path)), 'cannot read')


FINITE = st.floats(allow_nan=False, allow_infinity=False)


@settings(max_examples=300, deadline=None)
@given(values=st.lists(FINITE, min_size=6, max_size=6),
       max_wrench=st.floats(min_value=1e-300, max_value=1e300))
def test_the_wrench_check_agrees_with_exact_norms(values, max_wrench):
    """Accepted iff both norms are at most max_wrench, by exact rational arithmetic (away from
    the boundary by a relative 1e-12: hypot is correctly rounded to within an ulp)."""
    limit = Fraction(max_wrench) ** 2
    squares = [sum(Fraction(c) ** 2 for c in values[i:i + 3]) for i in (0, 3)]
    try:
        send_wrench.check_wrench(tuple(values), max_wrench, 'here')
        accepted = True
    except ValueError as e:
        assert str(e).startswith('here: ') and '\n' not in str(e)
        accepted = False
    if all(s <= limit * (1 - Fraction(1, 10 ** 12)) for s in squares):
        assert accepted
    elif any(s >= limit * (1 + Fraction(1, 10 ** 12)) for s in squares):
        assert not accepted


def test_huge_finite_components_do_not_overflow_the_check():
    send_wrench.check_wrench((1.4e154, 1.4e154, 0.0, 0.0, 0.0, 1e300), 1e301, 'ok')
    with pytest.raises(ValueError, match='force norm 1.4e\\+154'):
        send_wrench.check_wrench((1.4e154, 0.0, 0.0, 0.0, 0.0, 0.0), 1e6, 'x')
    with pytest.raises(ValueError, match='torque norm 1.41421e\\+308'):
        send_wrench.check_wrench((0.0, 0.0, 0.0, 1e308, 1e308, 0.0), 1e300, 'x')


def test_the_final_zero_arrives_without_a_warning(start_sim, probe):
    start_sim('-p', 'command_timeout:=0.0')
    applied = probe.collect(WrenchStamped, 'applied_wrench', APPLIED_QOS)
    sender = start_sim(exe='send_wrench', args=('--force', '0', '0', '3', '--duration', '0.2'))
    probe.wait_for(lambda: sender.proc.poll() is not None, timeout=60,
                   what='send_wrench to finish')
    assert sender.proc.returncode == 0, sender.output()
    assert 'not acknowledged' not in sender.output()
    probe.wait_for(lambda: applied and applied[-1].wrench == Wrench(), what='the final zero')
    assert [a.wrench.force.z for a in applied] == [3.0, 0.0]


def test_a_profile_mixing_framed_and_unframed_rows_ends_with_zero(start_sim, probe, tmp_path):
    # Each row goes on its own topic (wrench_stamped with a frame, wrench without); with
    # command_timeout:=0 nothing but send_wrench's final zero can unforce the body.
    start_sim('-p', 'command_timeout:=0.0')
    applied = probe.collect(WrenchStamped, 'applied_wrench', APPLIED_QOS)
    profile = tmp_path / 'mixed.csv'
    profile.write_text('t,fx,fy,fz,tx,ty,tz,frame\n'
                       '0,0,0,1,0,0,0,world\n'
                       '0.3,0,0,2,0,0,0,\n')
    sender = start_sim(exe='send_wrench', args=('--csv', str(profile), '--duration', '0.3'))
    probe.wait_for(lambda: sender.proc.poll() is not None, timeout=60,
                   what='send_wrench to finish')
    assert sender.proc.returncode == 0, sender.output()
    assert 'Traceback' not in sender.output()
    probe.wait_for(lambda: applied and applied[-1].wrench == Wrench(), what='the final zero')
    forces = [a.wrench.force.z for a in applied]
    assert 1.0 in forces and 2.0 in forces and forces[-1] == 0.0, forces


def test_sigterm_still_sends_the_final_zero(start_sim, probe):
    start_sim('-p', 'command_timeout:=0.0')
    applied = probe.collect(WrenchStamped, 'applied_wrench', APPLIED_QOS)
    sender = start_sim(exe='send_wrench', args=('--force', '0', '0', '4', '--duration', '1e6'))
    probe.wait_for(lambda: any(a.wrench.force.z == 4.0 for a in applied), timeout=60,
                   what='the wrench to be applied')
    assert sender.stop(signal.SIGTERM, timeout=30) == 0, sender.output()
    probe.wait_for(lambda: applied[-1].wrench == Wrench(), what='the final zero')
    assert 'Traceback' not in sender.output()
