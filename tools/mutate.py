#!/usr/bin/env python3
# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Mutation check: each mutant below is a small edit of the source that must make the named
tests fail. A mutant the tests survive is a behaviour nothing pins (issue 12).

    .venv/bin/python tools/mutate.py                 # all mutants, in a throw-away copy
    .venv/bin/python tools/mutate.py --each          # every named test must fail on its own
    .venv/bin/python tools/mutate.py -k speculative  # the mutants whose name has this text

Never touches the repository's files: it copies the repository (``git archive HEAD``, then the
working-tree versions of the test files the mutants name, so that new tests can be checked
before they are committed; ``--worktree`` copies the whole working tree instead) into
``--workdir`` (default: a new temporary directory, removed at the end) and mutates there.
Each mutant is applied as exact search/replace edits (an edit whose search text is not found
exactly once is an error, not a pass), the tests run there (``python -m pytest -q -x``, with
the copy first on the path and no bytecode written, so nothing stale is imported), and the
file is restored in ``finally``, Ctrl-C included. First the named tests run on the
unmutated copy: they must pass, or a kill would mean nothing.

Prints a table (mutant, file, expected tests, killed); exit status 0 if every mutant is
killed, 1 if one survives or an edit does not apply, 2 if the baseline fails.
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path
import shutil
import subprocess
import sys
import tempfile
import time

ROOT = Path(__file__).resolve().parents[1]

CONTACTS = 'test/contact/test_mutants_contacts.py::'
STEPPER = 'test/core/test_mutants_stepper.py::'
COLLISIONS = 'test/contact/test_collisions.py::'
CONVERGENCE = 'test/core/test_convergence.py::'
HIGH_ORDER = 'test/core/test_high_order.py::'
NODE = 'test/ros/test_node.py::'
HARDENING = 'test/ros/test_node_hardening.py::'
MOTION = 'test/sim/test_motion_sensing.py::'
TF_IMU = 'test/ros/test_tf_imu_node.py::'
SIM_API = 'test/ros/test_sim_interfaces.py::'
SPAWN = 'test/sim/test_spawn_delete.py::'

# Eq. (14) of the report as printed: R_{n+1} = (exp([w + (4 b - b_prev)/6 dt] dt)
# - ([b][w] + [w][b]) dt^3 / 12) R_n, i.e. no (b x w) term in the rotation vector and the
# symmetric matrix b w^T + w b^T - 2 (b . w) I subtracted (rc = cross[0] dt^3).
_EQ14 = """\
    e00, e01, e02, e10, e11, e12, e20, e21, e22 = (
        exp_so3_small(px, py, pz) if small else exp_so3(px, py, pz, tiny))
    bw14 = bx * wx + by * wy + bz * wz
    e00 -= rc * (2.0 * bx * wx - 2.0 * bw14)
    e11 -= rc * (2.0 * by * wy - 2.0 * bw14)
    e22 -= rc * (2.0 * bz * wz - 2.0 * bw14)
    e01 -= rc * (bx * wy + wx * by)
    e10 -= rc * (bx * wy + wx * by)
    e02 -= rc * (bx * wz + wx * bz)
    e20 -= rc * (bx * wz + wx * bz)
    e12 -= rc * (by * wz + wy * bz)
    e21 -= rc * (by * wz + wy * bz)
"""

# name, file, [(search, replace), ...], tests that must fail, what the edit breaks.
MUTANTS = [
    # -- issue 12: survived the whole suite before test_mutants_*.py ---------------------
    ('touched-needs-impulse', 'rb_sim_ros/contact/solver_kernels.py',
     [('if u[i, c] != u0[i, c] or q[i, c] != 0.0:', 'if u[i, c] != u0[i, c]:')],
     [CONTACTS + 'test_a_ball_inside_the_ground_with_no_impulse_is_pushed_out'],
     'position corrections dropped for bodies that get no impulse'),
    ('bounce-without-closing', 'rb_sim_ros/contact/solver_kernels.py',
     [(' and vn0 < floor', '')],
     [CONTACTS + 'test_a_ball_skimming_the_ground_flies_until_it_reaches_it'],
     'a speculative contact the body cannot close in the step bounces it'),
    ('speculative-half-gap', 'rb_sim_ros/contact/solver_kernels.py',
     [('closing = gap / dt if gap < 0.0 else 0.0',
       'closing = 0.5 * gap / dt if gap < 0.0 else 0.0')],
     [CONTACTS + 'test_a_slow_ball_closes_its_gap_in_one_step_and_stops_on_the_ground'],
     'a speculative contact closes half its gap in a step'),
    ('plastic-impact-stops-short', 'rb_sim_ros/contact/solver_kernels.py',
     [(' and e > 0.0', '')],
     [CONTACTS + 'test_a_fast_ball_without_restitution_stops_on_the_ground_not_short_of_it'],
     'a fast body with e = 0 stops where its speculative contact began'),
    ('late-ticks-uncounted', 'rb_sim_ros/ros/diagnostics.py',
     [('        self.late_ticks += late\n', '        pass\n')],
     [NODE + 'test_diagnostics_count_an_induced_stall'],
     '/diagnostics never counts a late tick'),
    ('p99-is-p50', 'rb_sim_ros/ros/diagnostics.py',
     [("'tick_lateness_p99_ms': pct(0.99)", "'tick_lateness_p99_ms': pct(0.5)")],
     [NODE + 'test_diagnostics_count_an_induced_stall'],
     'the p99 lateness is the median'),
    ('timeout-below-a-step-disables', 'rb_sim_ros/ros/node_config.py',
     [('max(1, math.ceil(timeout / config.dt - 1e-9))',
       'math.ceil(timeout / config.dt - 1e-9)')],
     [HARDENING + 'test_a_timeout_shorter_than_a_step_still_times_out'],
     'a command_timeout shorter than a step never times out'),
    ('no-orthonormalisation', 'rb_sim_ros/core/step_kernel.py',
     [('        if countdown <= 0 and not frozen_rotation:\n'
       '            q00, q01, q02, q10, q11, q12, q20, q21, q22 = orthonormalize(\n'
       '                q00, q01, q02, q10, q11, q12, q20, q21, q22)\n',
       '        if countdown <= 0 and not frozen_rotation:\n            pass\n')],
     [STEPPER + 'test_a_rotation_written_off_so3_is_pulled_back_within_orthonormalize_every_'
      'steps'],
     'R never pulled back to SO(3)'),
    ('orthonormalisation-lost-after-a-spell', 'rb_sim_ros/core/step_kernel.py',
     [('        if countdown <= 0 and not frozen_rotation:',
       '        if countdown == 0 and not frozen_rotation:')],
     [STEPPER + 'test_orthonormalisation_goes_on_after_a_spell_without_turning'],
     'a countdown that ran out while the body did not turn never orthonormalises again'),
    ('start-up-no-extrapolation', 'rb_sim_ros/core/step_kernel.py',
     [('        apx, apy, apz = 2.0 * ax - a10, 2.0 * ay - a11, 2.0 * az - a12\n'
       '        bpx, bpy, bpz = 2.0 * bx - b10, 2.0 * by - b11, 2.0 * bz - b12\n',
       '        apx, apy, apz, bpx, bpy, bpz = ax, ay, az, bx, by, bz\n')],
     [STEPPER + 'test_first_step_from_rest_with_gravity_and_damping_has_local_order_3_and_4',
      STEPPER + 'test_first_step_of_a_damped_spinning_body_has_local_order_3_and_4'],
     'start-up takes a_{-1} = a_0 (an Euler first step)'),
    ('history-without-velocity', 'rb_sim_ros/core/step_kernel.py',
     [('float(s[i, VP]), float(s[i, VP + 1]), float(s[i, VP + 2]), bool(False))',
       '0.0, 0.0, 0.0, bool(False))')],
     [STEPPER + 'test_damped_translation_under_force_changes_is_second_order_against_the_'
      'closed_form',
      STEPPER + 'test_damped_asymmetric_body_under_wrench_changes_is_second_order_against_dop853'],
     'history re-evaluated on a wrench change without linear damping'),
    # -- caught before ---------------------------------------------------------------------
    ('eq14-rotation', 'rb_sim_ros/core/step_kernel.py',
     [('    px = wx * dt + rn * bx + rp * bpx + rc * (by * wz - bz * wy)\n'
       '    py = wy * dt + rn * by + rp * bpy + rc * (bz * wx - bx * wz)\n'
       '    pz = wz * dt + rn * bz + rp * bpz + rc * (bx * wy - by * wx)\n',
       '    px = wx * dt + rn * bx + rp * bpx\n'
       '    py = wy * dt + rn * by + rp * bpy\n'
       '    pz = wz * dt + rn * bz + rp * bpz\n'),
      ('    e00, e01, e02, e10, e11, e12, e20, e21, e22 = (\n'
       '        exp_so3_small(px, py, pz) if small else exp_so3(px, py, pz, tiny))\n',
       _EQ14)],
     [CONVERGENCE + 'test_local_orders_from_exact_history'],
     'eq. (14) as printed instead of the last line of eq. (27)'),
    ('cross-term-sign', 'rb_sim_ros/core/multistep.py',
     [("    cross=(1.0 / 12.0, 0.0),\n    description='Adams",
       "    cross=(-1.0 / 12.0, 0.0),\n    description='Adams")],
     [CONVERGENCE + 'test_local_orders_from_exact_history'],
     '(omega x beta) instead of (beta x omega) in eq. (27)'),
    ('stale-history', 'rb_sim_ros/core/stepper.py',
     [('                state[self._row, K.HISTORY] = K.HISTORY_STALE\n',
       '                pass\n')],
     [CONVERGENCE + 'test_global_order_two_with_a_wrench_change_every_few_steps'],
     'history of the old wrench kept across a change (NOTES.md 2)'),
    ('jacobian-sign', 'rb_sim_ros/contact/solver_kernels.py',
     [('            gax = -(ray * dz - raz * dy)\n            gay = -(raz * dx - rax * dz)\n'
       '            gaz = -(rax * dy - ray * dx)\n',
       '            gax = ray * dz - raz * dy\n            gay = raz * dx - rax * dz\n'
       '            gaz = rax * dy - ray * dx\n')],
     [COLLISIONS + 'test_frictionless_impact_conserves_momenta_and_obeys_restitution'],
     'the angular Jacobian of body a with the wrong sign'),
    ('no-warm-start', 'rb_sim_ros/contact/world_step.py',
     [('        use_warm = w.config[C_WARM_START] != 0.0 and warm_keys.shape[0] > 0\n',
       '        use_warm = bool(False)\n')],
     [COLLISIONS + 'test_box_stack_of_three_stands_for_10_s',
      COLLISIONS + 'test_resting_box_stays_still_for_10_s'],
     'the impulses of the step before not carried over (resting boxes drift)'),
    ('friction-ignores-mu', 'rb_sim_ros/contact/solver_kernels.py',
     [('                limit = float(rows[s, MU]) * ln\n', '                limit = ln\n')],
     [COLLISIONS + 'test_impact_on_a_static_body_and_coulomb_friction',
      COLLISIONS + 'test_sliding_box_stops_where_coulomb_says'],
     'the Coulomb disc of radius lambda_n, not mu lambda_n'),
    ('no-slop', 'rb_sim_ros/contact/solver_kernels.py',
     [('p_target[s] = fraction * (float(depth[int(order[s])]) - slop)',
       'p_target[s] = fraction * float(depth[int(order[s])])')],
     [CONTACTS + 'test_a_ball_inside_the_ground_with_no_impulse_is_pushed_out',
      COLLISIONS + 'test_box_stack_of_three_stands_for_10_s'],
     'penetration corrected to 0, not to the slop'),
    # -- issue 13: the compiled contact pipeline ------------------------------------------
    ('energy-guard-off', 'rb_sim_ros/contact/solver_kernels.py',
     [('if _energy(u, inverse_mass, inertia, which) > e0 * (1.0 + ENERGY_TOLERANCE):',
       'if False:')],
     [COLLISIONS + 'test_compiled_and_interpreted_solver_give_the_same_bits',
      'test/contact/test_untrusted_physics_contacts.py::'
      'test_a_contact_solve_never_creates_kinetic_energy'],
     'a solve that gains kinetic energy is not blended with the plastic one'),
    ('warm-start-pushes-a-along-n', 'rb_sim_ros/contact/solver_kernels.py',
     [('u[a, c] += ((l0 * (-ma * float(rows[s, NORMAL + D + c]))',
       'u[a, c] += ((l0 * (ma * float(rows[s, NORMAL + D + c]))')],
     [COLLISIONS + 'test_many_contacts_keep_momentum'],
     'the warm-started normal impulse pushes body a the wrong way (momentum not kept)'),
    ('rolling-couple-one-sided', 'rb_sim_ros/contact/solver_kernels.py',
     [('                b3 = b3 - (l1 * pb1x + l2 * pb2x)\n'
       '                b4 = b4 - (l1 * pb1y + l2 * pb2y)\n'
       '                b5 = b5 - (l1 * pb1z + l2 * pb2z)\n',
       '                b3 = b3 + (l1 * pb1x + l2 * pb2x)\n'
       '                b4 = b4 + (l1 * pb1y + l2 * pb2y)\n'
       '                b5 = b5 + (l1 * pb1z + l2 * pb2z)\n')],
     [COLLISIONS + 'test_many_contacts_keep_momentum',
      'test/contact/test_rolling_resistance.py::test_many_contacts_in_one_solve_keep_momentum'],
     'the rolling couple turns both bodies the same way (angular momentum not kept)'),
    ('pairs-b-rotation-from-a', 'rb_sim_ros/contact/narrow_kernels.py',
     [('            rot_a[q], rot_b[q] = rotations[i, q], rotations[j, q]\n',
       '            rot_a[q], rot_b[q] = rotations[i, q], rotations[i, q]\n')],
     ['test/contact/test_narrow_phase.py::test_collide_pairs_agrees_with_collide_pair_by_pair'],
     'collide_pairs gives collider B the rotation of collider A'),
    ('sphere-batch-keeps-every-pair', 'rb_sim_ros/contact/narrow_kernels.py',
     [('        keep[k] = found > 0\n', '        keep[k] = True\n')],
     ['test/contact/test_narrow_phase.py::test_batches_equal_collide_to_the_bit'],
     'the sphere batches report pairs that do not touch as kept'),
    ('world-skips-plane-margin', 'rb_sim_ros/contact/broad_phase.py',
     [('            if height - support <= float(margin[body[c]]):',
       '            if height - support <= 0.0:')],
     ['test/contact/test_narrow_phase.py::test_plane_candidates_use_the_support_distance'],
     'a collider within its speculative margin of a plane is not a candidate'),
    # -- issue 14: the higher-order methods and the flows ----------------------------------
    ('lie3-without-beta-derivative', 'rb_sim_ros/core/multistep.py',
     [('    cross=(7.0 / 48.0, -4.0 / 48.0, 1.0 / 48.0),',
       '    cross=(1.0 / 12.0, 0.0, 0.0),')],
     [HIGH_ORDER + 'test_local_orders_from_exact_history'],
     "lie3's rotation vector without the (dt^4/24) beta' x omega term"),
    ('lie-history-re-evaluated', 'rb_sim_ros/core/step_kernel.py',
     [('    # (docs/integrators.md).\n    if float(src[i, HISTORY]) != HISTORY_VALID:',
       '    # (docs/integrators.md).\n    if float(src[i, HISTORY]) == HISTORY_NONE:')],
     [HIGH_ORDER + 'test_global_order_with_a_wrench_change_every_eighth_of_a_second'],
     'lie3/lie4 keep their history across a wrench change instead of starting again'),
    ('flow-full-first-kick', 'rb_sim_ros/core/step_kernel.py',
     [('_kick(p, i, 0.5 * h, nv0, nv1, nv2, q00, q01, q02,\n'
       '                                                 q10, q11, q12, q20, q21, q22, nw0, '
       'nw1, nw2)\n            nx0',
       '_kick(p, i, h, nv0, nv1, nv2, q00, q01, q02,\n'
       '                                                 q10, q11, q12, q20, q21, q22, nw0, '
       'nw1, nw2)\n            nx0')],
     [HIGH_ORDER + 'test_splitting_orders_with_wrench_changes'],
     'a whole kick before the free flow, not half of one (Strang broken)'),
    ('flow-precession-sign', 'rb_sim_ros/core/free_flow.py',
     [('    phi1 = phi + g / (ip * lam) * (big1 - big0)',
       '    phi1 = phi - g / (ip * lam) * (big1 - big0)')],
     [HIGH_ORDER + 'test_free_flow_is_the_torque_free_motion_for_any_step'],
     'the precession about L turned the wrong way'),
    # -- issue 15: acceleration and IMU ----------------------------------------------------
    ('specific-force-plus-g', 'rb_sim_ros/sim/imu.py',
     [('    return tuple(a - g for a, g in zip(linear_acceleration, gravity))',
       '    return tuple(a + g for a, g in zip(linear_acceleration, gravity))')],
     [MOTION + 'test_a_box_at_rest_on_the_ground_accelerates_nowhere_and_its_imu_reads_plus_g'],
     'the accelerometer reads a + g (-g at rest, 2 g in free fall)'),
    ('contact-acceleration-not-over-dt', 'rb_sim_ros/contact/collision_world.py',
     [('        inv = 1.0 / self.dt\n', '        inv = 1.0\n')],
     [MOTION + 'test_a_box_at_rest_on_the_ground_accelerates_nowhere_and_its_imu_reads_plus_g'],
     "the contacts' velocity change taken as an acceleration without dividing by dt"),
    ('teleport-is-an-acceleration', 'rb_sim_ros/contact/collision_world.py',
     [('        self._v[i], self._w[i] = state.linear_velocity, state.angular_velocity\n', '')],
     [MOTION + 'test_a_teleport_is_not_an_acceleration'],
     'the velocity before the last contact pass kept across a teleport'),
    ('bias-walk-without-sqrt', 'rb_sim_ros/sim/imu.py',
     [('        root = math.sqrt((time_ns - self._last_ns) * 1e-9)',
       '        root = ((time_ns - self._last_ns) * 1e-9)')],
     [MOTION + 'test_the_bias_walks_as_sigma_sqrt_t'],
     'the bias walks as sigma t, not sigma sqrt(t)'),
    ('imu-in-world-frame', 'rb_sim_ros/ros/ros_messages.py',
     [('        force = rotate(r, specific_force(linear_acceleration, gravity), transpose=True)',
       '        force = specific_force(linear_acceleration, gravity)')],
     [TF_IMU + 'test_imu_and_accel_read_newton_and_euler_and_no_tf_when_asked'],
     "the IMU's specific force left in the world frame"),
    ('noise-drawn-only-when-filled', 'rb_sim_ros/offline/replay.py',
     [('            offsets[body] = sensors[body].sample(sim.time_ns)\n',
       "            offsets[body] = sensors[body].sample(sim.time_ns) if kind == 'imu' "
       'else None\n')],
     [TF_IMU + 'test_a_recording_with_imu_noise_tf_and_contacts_replays_bit_for_bit'],
     'replay draws the noise only for imu outputs: its stream no longer follows the node'),
    # -- issue 16: simulation_interfaces ---------------------------------------------------
    ('relative-pose-not-turned', 'rb_sim_ros/ros/sim_interfaces.py',
     [('            rx = ros_messages.rotate(r, x)\n', '            rx = x\n')],
     [SIM_API + 'test_the_standard_api_drives_the_simulator'],
     "a pose relative to a body's frame taken with the world's axes"),
    ('default-reset-scope-accepted', 'rb_sim_ros/ros/sim_interfaces.py',
     [('        if scope == ResetSimulation.Request.SCOPE_DEFAULT or \\\n'
       '                scope & ResetSimulation.Request.SCOPE_TIME:',
       '        if scope & ResetSimulation.Request.SCOPE_TIME:')],
     [SIM_API + 'test_the_standard_api_drives_the_simulator'],
     'SCOPE_DEFAULT (which includes sim time) answered as if time were reset'),
    ('step-simulation-whole-periods', 'rb_sim_ros/ros/sim_interfaces.py',
     [('            chunk = min(steps - done, node.config.steps_per_publish)',
       '            chunk = node.config.steps_per_publish')],
     [SIM_API + 'test_the_standard_api_drives_the_simulator'],
     'step_simulation rounds the steps asked up to whole publish periods'),
    ('spawn-history-restarts', 'rb_sim_ros/core/stepper.py',
     [('        store.state[row] = other._store.state[other._row]\n',
       '        store.state[row] = other._store.state[other._row]\n'
       '        store.state[row, K.HISTORY] = K.HISTORY_NONE\n')],
     [SPAWN + 'test_the_bodies_that_stay_go_on_bit_for_bit'],
     'a rebuilt world forgets the integrator history of the bodies it keeps'),
    ('delete-leaves-sleepers-asleep', 'rb_sim_ros/contact/collision_world.py',
     [('        if len(touched):\n            self._wake(touched, step_count)\n', '')],
     [SPAWN + 'test_deleting_the_ground_drops_what_rested_on_it'],
     'a box asleep on a deleted ground stays in the air'),
    ('warm-starts-dropped-on-rebuild', 'rb_sim_ros/contact/collision_world.py',
     [('        if len(old_keys):\n            self._carry_warm_starts(',
       '        if False:\n            self._carry_warm_starts(')],
     [SPAWN + 'test_a_body_resting_in_contact_goes_on_bit_for_bit_when_another_is_deleted'],
     'warm starts dropped when the world is rebuilt around other bodies'),
    ('spawned-frame-as-single-body', 'rb_sim_ros/offline/replay.py',
     [('                    outs[event.body] = outputs_of(event.body, True)',
       '                    outs[event.body] = outputs_of(event.body)')],
     ['test/offline/test_untrusted_recording.py::test_a_run_with_a_spawn_and_a_delete_verifies'],
     "replay stamps a spawned body beside the single body with the single body's frame"),
    ('tf-static-stamped-zero', 'rb_sim_ros/ros/simulator_node.py',
     [('            ros_messages.fill_tf(self._tf_static, t_ns, self._tf_static_poses)',
       '            ros_messages.fill_tf(self._tf_static, 0, self._tf_static_poses)')],
     [SIM_API + 'test_spawned_and_deleted_bodies_move_publish_and_replay'],
     '/tf_static sent again after a spawn keeps stamp 0, while replay stamps it when sent'),
    ('plane-normalised-twice', 'rb_sim_ros/contact/shapes/plane.py',
     [('        if abs(squared - 1.0) > UNIT_TOLERANCE:', '        if True:')],
     [SPAWN + 'test_a_tilted_plane_is_the_same_bits_after_a_round_trip'],
     "a plane's normal normalised again when a recording's config is read back"),
    ('plot-first-lifetime', 'rb_sim_ros/pictures/plots.py',
     [("        which = np.maximum(np.searchsorted(starts, a[:, 0], side='left') - 1, 0)",
       '        which = np.zeros(len(a), dtype=int)')],
     ['test/pictures/test_plots_render.py::'
      'test_a_name_spawned_again_is_plotted_and_drawn_as_the_body_it_names_then'],
     'a body spawned again under a name is plotted with the mass of the first'),
    # -- issue 18: sweeps ------------------------------------------------------------------
    ('sweep-profile-held-for-ever', 'rb_sim_ros/offline/sweep.py',
     [('    if profile:  # as send_wrench:', '    if False:  # as send_wrench:')],
     ['test/offline/test_sweep.py::test_the_wrench_schedule_is_what_send_wrench_sends'],
     "the profile's last row held to the end of the run, not ended by a zero"),
    ('sweep-grid-order', 'rb_sim_ros/offline/sweep.py',
     [('        for key, grid in zip(reversed(self.keys), reversed(self.grids)):',
       '        for key, grid in zip(self.keys, self.grids):')],
     ['test/offline/test_sweep.py::test_specs_lists_ranges_and_distributions'],
     'runs numbered with the first list varying fastest, not the last'),
]


def _git(*args, **kwargs):
    return subprocess.run(['git', '-C', str(ROOT), *args], check=True, **kwargs)


def copy_repo(dest: Path, worktree: bool, extra: list[str]) -> None:
    """HEAD (or the whole working tree) into ``dest``, then the working-tree files ``extra``."""
    dest.mkdir(parents=True, exist_ok=True)
    if any(dest.iterdir()):
        raise SystemExit(f'mutate: --workdir {dest} is not empty')
    if worktree:
        listed = _git('ls-files', '-z', '--cached', '--others', '--exclude-standard',
                      capture_output=True).stdout.decode().split('\0')
        extra = [p for p in listed if p] + extra
    else:
        archive = _git('archive', '--format=tar', 'HEAD', capture_output=True).stdout
        subprocess.run(['tar', '-x', '-C', str(dest)], input=archive, check=True)
    for rel in extra:
        src = ROOT / rel
        if src.is_file():
            (dest / rel).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(src, dest / rel)


def _env(workdir: Path) -> dict:
    env = dict(os.environ)
    env['PYTHONPATH'] = str(workdir) + os.pathsep + env.get('PYTHONPATH', '')
    env['PYTHONDONTWRITEBYTECODE'] = '1'     # no stale .pyc of a mutated file, ever
    return env


def run_tests(python: str, workdir: Path, tests: list[str]) -> tuple[int, str]:
    cmd = [python, '-m', 'pytest', '-q', '-x', '-p', 'no:cacheprovider', *tests]
    proc = subprocess.run(cmd, cwd=workdir, env=_env(workdir), capture_output=True, text=True)
    lines = (proc.stdout + proc.stderr).strip().splitlines()
    return proc.returncode, lines[-1] if lines else ''


def mutated(text: str, edits) -> str:
    """``text`` with the edits applied; ValueError if a search text is not found exactly
    once (in the text as the edits before left it)."""
    for search, replace in edits:
        count = text.count(search)
        if count != 1:
            raise ValueError(f'search text found {count} times: {search!r}')
        text = text.replace(search, replace)
    return text


def short(test: str) -> str:
    file, _, name = test.partition('::')
    return f'{Path(file).stem}::{name}' if name else Path(file).stem


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--workdir', type=Path, help='an empty or new directory to copy the '
                        'repository into and mutate there (default: a temporary one)')
    parser.add_argument('--keep', action='store_true', help='keep the copy')
    parser.add_argument('--worktree', action='store_true', help='copy the working tree '
                        '(uncommitted edits included) rather than HEAD')
    parser.add_argument('--each', action='store_true', help='run each expected test alone: '
                        'every one must fail')
    parser.add_argument('-k', dest='match', default='', help='only mutants whose name has this')
    parser.add_argument('--python', default=sys.executable, help='the interpreter for pytest')
    args = parser.parse_args(argv)

    mutants = [m for m in MUTANTS if args.match in m[0]]
    if not mutants:
        print(f'mutate: no mutant matches {args.match!r}', file=sys.stderr)
        return 2
    tests = sorted({t for m in mutants for t in m[3]})
    workdir = args.workdir or Path(tempfile.mkdtemp(prefix='rb_sim_mutate_'))
    workdir = workdir.resolve()
    if workdir == ROOT or ROOT in workdir.parents:
        print('mutate: --workdir must be outside the repository', file=sys.stderr)
        return 2
    remove = args.workdir is None and not args.keep
    rows, status = [], 0
    try:
        copy_repo(workdir, args.worktree, sorted({t.split('::')[0] for t in tests}))
        probe = 'import rb_sim_ros; print(rb_sim_ros.__file__)'
        where = subprocess.run([args.python, '-c', probe], cwd=workdir, env=_env(workdir),
                               capture_output=True, text=True)
        if workdir not in Path(where.stdout.strip()).resolve().parents:
            print(f'mutate: rb_sim_ros imports from {where.stdout.strip() or where.stderr}, not '
                  f'from the copy {workdir}', file=sys.stderr)
            return 2
        print(f'mutate: copy in {workdir}; baseline: {len(tests)} tests', flush=True)
        code, last = run_tests(args.python, workdir, tests)
        if code != 0:
            print(f'mutate: the tests fail without any mutant ({last}); fix that first',
                  file=sys.stderr)
            return 2
        for name, rel, edits, expected, what in mutants:
            path = workdir / rel
            start = time.monotonic()
            original = path.read_text()
            try:
                text = mutated(original, edits)
            except ValueError as e:
                rows.append((name, rel, expected, f'EDIT FAILED: {e}', ''))
                status = 1
                continue
            try:
                path.write_text(text)
                groups = [[t] for t in expected] if args.each else [expected]
                results = [run_tests(args.python, workdir, g) for g in groups]
            finally:
                path.write_text(original)
            # pytest exits 1 when tests fail; 2-5 (collection error, usage...) is no kill.
            killed = all(code == 1 for code, _ in results)
            if not killed:
                status = 1
            detail = '; '.join(last for _, last in results)
            rows.append((name, rel, expected, 'yes' if killed else 'NO',
                         f'{time.monotonic() - start:.1f} s: {detail}'))
            print(f'  {name}: {"killed" if killed else "SURVIVED"} ({detail})', flush=True)
    finally:
        if remove:
            shutil.rmtree(workdir, ignore_errors=True)
    print()
    print('| mutant | file | expected to fail | killed |')
    print('| --- | --- | --- | --- |')
    for name, rel, expected, killed, _ in rows:
        print(f'| {name} | {Path(rel).name} | {"<br>".join(short(t) for t in expected)} | '
              f'{killed} |')
    survivors = [r[0] for r in rows if r[3] != 'yes']
    print(f'\n{len(rows) - len(survivors)} of {len(rows)} mutants killed'
          + (f'; not killed: {", ".join(survivors)}' if survivors else ''))
    return status


if __name__ == '__main__':
    sys.exit(main())
