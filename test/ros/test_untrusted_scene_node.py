# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""The node on an untrusted scene file: one line on stderr naming the file, exit status 2."""

import pytest


@pytest.mark.parametrize('text, why', [
    ('lol: &l0 ["lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol"]\n'
     + ''.join(f'l{i}: &l{i} [{", ".join([f"*l{i - 1}"] * 9)}]\n' for i in range(1, 10))
     + 'bodies: [{name: a, mass: 1, inertia: *l9}]\n', 'l1[0]: aliases (*l0) are not allowed'),
    ('bodies: [{name: "h\u00e9llo", mass: 1, inertia: [1, 1, 1]}]',
     'name: must be a ROS name token'),
    ('bodies: [{name: a, shape: [box], size: [1, 1, 1], density: 1}]',
     "body 0 ('a'): shape: must be one of"),
])
def test_a_bad_scene_exits_2_with_one_line_naming_the_file(start_sim, tmp_path, text, why):
    scene = tmp_path / 'scene.yaml'
    scene.write_text(text, encoding='utf-8')
    sim = start_sim('-p', f'scene_file:={scene}')
    assert sim.proc.wait(120) == 2
    out = sim.output()
    assert 'Traceback' not in out, out
    lines = [line for line in out.splitlines() if str(scene) in line]
    assert len(lines) == 1 and why in lines[0], out
