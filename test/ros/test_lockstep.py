# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Lockstep's bookkeeping (ros/lockstep.py), without ROS: which answers are taken, refused and
applied when; the protocol as the node lives it is in test_lockstep_node.py."""

from rb_sim_ros.ros.lockstep import HOLD, Lockstep

MS = 1_000_000  # ns


def test_the_run_steps_on_only_when_every_input_answered_the_state_it_awaits():
    ls = Lockstep(['a', 'b'])
    ls.join(['a', 'b'])
    assert not ls.ready.is_set()
    assert ls.offer('a', 0, 'wa0') is not None  # no state published yet: refused
    ls.expect(0)
    assert ls.offer('b', 0, 'wb0') is None
    assert not ls.ready.is_set() and ls.missing() == ['a']
    assert ls.offer('a', 0, 'wa0') is None
    assert ls.ready.is_set() and ls.missing() == []
    # Applied in the order of the bodies, whatever the order they came in.
    assert ls.take() == [('a', 'wa0'), ('b', 'wb0')]
    ls.expect(10 * MS)
    assert not ls.ready.is_set()
    # The answer taken, sent again (the node re-sends a state, the helper its answer):
    # ignored and counted, not refused.
    assert ls.offer('a', 0, 'wa0') is None and ls.counters.repeated == 1
    assert 'stamp 0.005000000 s' in ls.offer('a', 5 * MS, 'never asked')
    assert 'stamp 0.020000000 s' in ls.offer('a', 20 * MS, 'early')
    assert ls.counters.refused == 3 and not ls.ready.is_set()
    assert ls.offer('a', 10 * MS, HOLD) is None and ls.offer('b', 10 * MS, 'wb1') is None
    assert ls.take() == [('a', HOLD), ('b', 'wb1')]


def test_answers_take_effect_delay_periods_later():
    ls = Lockstep(['a'], delay=2)
    ls.join(['a'])
    applied = []
    for k in range(6):
        ls.expect(k * 10 * MS)
        ls.offer('a', k * 10 * MS, f'w{k}')
        assert ls.ready.is_set()
        applied.append(ls.take())
    assert applied == [[], [], [('a', 'w0')], [('a', 'w1')], [('a', 'w2')], [('a', 'w3')]]


def test_undeclared_inputs_join_before_step_0_or_by_answering_later():
    ls = Lockstep(None)
    ls.expect(0)
    assert not ls.ready.is_set()  # no controller yet: step 0 waits
    assert ls.offer('a', 5 * MS, 'w') is not None  # answering no state: not an input
    ls.join(['a'])  # (a publisher seen)
    assert not ls.ready.is_set()
    assert ls.offer('b', 0, 'w') is None  # answering before it was seen: in all the same
    assert ls.offer('a', 0, 'w') is None and ls.ready.is_set()
    ls.take()
    ls.expect(10 * MS)
    # A controller that comes once the run is under way is in from its first answer...
    assert ls.offer('c', 10 * MS, 'wc') is None
    assert ls.inputs() == ['a', 'b', 'c'] and ls.missing() == ['a', 'b']
    assert any("'c' joined" in n for n in ls.notes)
    # ... and one answering another state is not.
    assert ls.offer('d', 0, 'wd') is not None and 'd' not in ls.inputs()


def test_a_declared_run_leaves_other_bodies_open_and_takes_a_returning_input_back():
    ls = Lockstep(['a'])
    ls.join(['a'])
    ls.expect(0)
    assert ls.offer('other', 0, 'w') == 'open'  # an ordinary input, queued by the node
    ls.offer('a', 0, 'w')
    ls.take()
    ls.expect(10 * MS)
    assert ls.leave('a') and ls.ready.is_set()  # gone: the run goes on without it
    ls.take()
    ls.expect(20 * MS)
    assert ls.ready.is_set()
    assert ls.offer('a', 20 * MS, 'back') is None and ls.inputs() == ['a']
    assert ls.take() == [('a', 'back')]


def test_a_timeout_steps_on_without_the_missing_answer_once():
    ls = Lockstep(['a', 'b'])
    ls.join(['a', 'b'])
    ls.expect(0)
    ls.offer('a', 0, 'wa')
    assert ls.time_out() == ['b'] and ls.ready.is_set()
    assert ls.take() == [('a', 'wa')] and ls.counters.timeouts == 1
    ls.expect(10 * MS)  # the next state waits for both again
    assert ls.missing() == ['a', 'b'] and not ls.ready.is_set()


def test_with_no_controller_at_all_a_timeout_starts_the_run_open_loop():
    ls = Lockstep(None)
    ls.expect(0)
    assert not ls.ready.is_set()
    assert ls.time_out() == [] and ls.ready.is_set() and ls.take() == []
    ls.expect(10 * MS)
    assert ls.ready.is_set()  # no input: nothing to wait for


def test_step_0_waits_for_the_inputs_to_be_looked_for_even_if_one_answered():
    """Undeclared: a controller that answers before the node looked for publishers does not
    start the run alone; the look (join) may find another one, which is then waited for."""
    ls = Lockstep(None)
    ls.expect(0)
    assert ls.offer('a', 0, 'wa') is None and not ls.ready.is_set()
    ls.join(['a', 'b'])
    assert not ls.ready.is_set() and ls.missing() == ['b']
    assert ls.offer('b', 0, 'wb') is None and ls.ready.is_set()
    assert ls.take() == [('a', 'wa'), ('b', 'wb')]


def test_a_second_different_answer_to_one_state_is_refused_and_the_first_stands():
    ls = Lockstep(['a'])
    ls.join(['a'])
    ls.expect(0)
    assert ls.offer('a', 0, 'first') is None
    assert 'second answer' in ls.offer('a', 0, 'second')
    assert ls.offer('a', 0, 'first') is None  # the same again: a repeat
    assert ls.counters.refused == 1 and ls.counters.repeated == 1
    assert ls.take() == [('a', 'first')]


def test_an_answer_after_its_timeout_is_refused_until_the_next_state():
    ls = Lockstep(['a', 'b'])
    ls.join(['a', 'b'])
    ls.expect(0)
    ls.offer('a', 0, 'wa')
    assert ls.time_out() == ['b']
    assert 'after lockstep_timeout' in ls.offer('b', 0, 'late')
    assert ls.take() == [('a', 'wa')]  # whether it came before the take or not
    ls.expect(10 * MS)
    assert ls.offer('b', 10 * MS, 'wb') is None and ls.missing() == ['a']


def test_take_is_once_a_stamp():
    ls = Lockstep(['a'], delay=1)
    ls.join(['a'])
    ls.expect(0)
    ls.offer('a', 0, 'w0')
    assert ls.take() == []
    assert ls.take() == [] and ls.counters.periods == 1  # nothing queued twice
    ls.expect(10 * MS)
    ls.offer('a', 10 * MS, 'w1')
    assert ls.take() == [('a', 'w0')]
    ls.expect(20 * MS)
    ls.offer('a', 20 * MS, 'w2')
    assert ls.take() == [('a', 'w1')]


def test_a_deleted_body_leaves_the_delay_pipeline_and_a_departed_controller_does_not():
    ls = Lockstep(['a', 'b'], delay=2)
    ls.join(['a', 'b'])
    for k in range(2):
        ls.expect(k * 10 * MS)
        ls.offer('a', k * 10 * MS, f'a{k}')
        ls.offer('b', k * 10 * MS, f'b{k}')
        assert ls.take() == []
    ls.leave('a', deleted=True)  # its queued answers have no body to act on
    ls.leave('b')  # its controller stopped: what it answered still takes effect
    ls.expect(20 * MS)
    assert ls.ready.is_set()
    assert ls.take() == [('b', 'b0')]
    ls.expect(30 * MS)
    assert ls.take() == [('b', 'b1')]


def test_unheard_inputs_are_those_never_heard_and_rearm_restarts_the_wait():
    ls = Lockstep(['a', 'b'])
    ls.join(['a', 'b'])
    ls.expect(0)
    ls.sent()
    assert ls.unheard() == ['a', 'b']
    ls.offer('a', 0, 'w')
    assert ls.unheard() == ['b']
    ls.offer('b', 0, 'w')
    ls.take()
    ls.expect(10 * MS)
    assert ls.unheard() == [] and ls.missing() == ['a', 'b']  # heard once: not re-sent
    ls._waiting_since -= 5.0  # (five seconds of waiting, without sleeping)
    assert ls.waited() >= 5.0
    ls.rearm()
    assert ls.waited() < 1.0
    assert 'waiting' in ls.describe() and 'a, b' in ls.describe()


def test_a_declared_input_deleted_before_step_0_is_not_waited_for():
    ls = Lockstep(['a', 'b'])
    ls.join(['a', 'b'])
    ls.expect(0)
    ls.offer('a', 0, 'w')
    assert ls.leave('b', deleted=True)
    ls.join(ls.declared)  # what every poll before step 0 does
    assert ls.ready.is_set() and ls.inputs() == ['a']
