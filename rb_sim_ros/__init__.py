# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""rb_sim_ros: a deterministic rigid-body simulator; its core and contact layers import numpy
and numba only, no ROS."""

from rb_sim_ros.core.multistep import EQ27, METHODS, Multistep
from rb_sim_ros.core.rigid_body import Frame, RigidBody, State, Wrench, ZERO_WRENCH
from rb_sim_ros.core.stepper import IntegrationError, Stepper

__version__ = '0.1.0'

__all__ = ['EQ27', 'Frame', 'IntegrationError', 'METHODS', 'Multistep', 'RigidBody', 'State',
           'Stepper', 'Wrench', 'ZERO_WRENCH', '__version__']
