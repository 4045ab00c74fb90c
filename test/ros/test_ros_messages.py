# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Wrench messages from outside: any float in any field is accepted exactly when it is safe."""

from fractions import Fraction
import math

from geometry_msgs.msg import Wrench as WrenchMsg
from hypothesis import given, settings, strategies as st
import numpy as np
import pytest

from rb_sim_ros.core.rigid_body import Frame
from rb_sim_ros.ros import ros_messages

FLOATS = st.one_of(st.floats(allow_nan=True, allow_infinity=True),
                   st.sampled_from([1.4e154, -1.5e154, 1e200, 1.7976931348623157e308, 5e-324]))


def _msg(f, t):
    m = WrenchMsg()
    m.force.x, m.force.y, m.force.z = f
    m.torque.x, m.torque.y, m.torque.z = t
    return m


def _exact_norm_at_most(vec, limit) -> bool:
    """|vec| <= limit in exact rational arithmetic (the oracle)."""
    return sum(Fraction(c) ** 2 for c in vec) <= Fraction(limit) ** 2


@settings(max_examples=500, deadline=None)
@given(st.tuples(FLOATS, FLOATS, FLOATS), st.tuples(FLOATS, FLOATS, FLOATS),
       st.sampled_from([1.0, 100.0, 1e6, 1e300]))
def test_accepted_exactly_when_finite_and_within_max_wrench(f, t, max_wrench):
    finite = all(math.isfinite(c) for c in f + t)
    try:
        w = ros_messages.wrench_from_msg(_msg(f, t), Frame.WORLD, max_wrench)
    except ValueError as e:
        assert 'wrench' in str(e)
        accepted = False
    else:
        accepted = True
        assert tuple(w.force) == f and tuple(w.torque) == t
    if not finite:
        assert not accepted
        return
    # hypot is correctly rounded to within an ulp: decide only where the exact answer is clear.
    margin = 1 + 1e-15
    if _exact_norm_at_most(f, max_wrench / margin) and _exact_norm_at_most(t, max_wrench / margin):
        assert accepted
    elif not (_exact_norm_at_most(f, max_wrench * margin)
              and _exact_norm_at_most(t, max_wrench * margin)):
        assert not accepted


def test_a_huge_finite_component_is_refused_not_an_overflow():
    with pytest.raises(ValueError, match='exceeds max_wrench'):
        ros_messages.wrench_from_msg(_msg((1.4e154, 0.0, 0.0), (0.0, 0.0, 0.0)), Frame.WORLD,
                                     1e6)
    with pytest.raises(ValueError, match='torque norm'):
        ros_messages.check_wrench((0.0, 0.0, 0.0), (1e308, 1e308, 0.0), 1e300)


def test_wrench_at_a_point_adds_r_cross_f():
    """Against numpy's cross product: torque + r x F, body frame; the message and the result
    are checked against max_wrench."""
    msg = WrenchMsg()
    msg.force.x, msg.force.y, msg.force.z = 1.0, -2.0, 0.5
    msg.torque.x, msg.torque.y, msg.torque.z = 0.1, 0.0, -0.3
    r = (0.2, 0.7, -0.4)
    w = ros_messages.wrench_at_point(msg, r, 100.0)
    assert w.frame is Frame.BODY
    assert np.allclose(w.torque, np.array([0.1, 0.0, -0.3]) + np.cross(r, [1.0, -2.0, 0.5]),
                       rtol=0, atol=1e-15)
    assert w.force.tolist() == [1.0, -2.0, 0.5]
    with pytest.raises(ValueError, match='torque norm'):
        # fine as sent, too big at the centre of mass
        ros_messages.wrench_at_point(msg, (0.0, 1e3, 0.0), 100.0)
