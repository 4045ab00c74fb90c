#!/usr/bin/env python3
# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Write config/params.yaml: every parameter of the simulator node at its default, with its
description, from rb_sim_ros/ros/node_params.py (test/package/test_packaging.py checks they agree).

    .venv/bin/python tools/make_params_yaml.py
"""

from pathlib import Path
import textwrap

import yaml

from rb_sim_ros.ros import node_params

HEADER = """\
# Every parameter of the rb_sim_ros simulator node, at its default (`simulator --help` prints
# the same list). Use: --ros-args --params-file config/params.yaml, or
# ros2 launch rb_sim_ros sim.launch.py params_file:=... . Made by tools/make_params_yaml.py
# from rb_sim_ros/ros/node_params.py (test/package/test_packaging.py checks they agree).
rb_sim:
  ros__parameters:
"""


def text() -> str:
    lines = []
    for p in node_params.PARAMS:
        note = ' [read-only once running]' if p.read_only else ''
        lines += ['    # ' + line for line in textwrap.wrap(p.description + note, 91)]
        if isinstance(p.default, str):
            lines.append(f"    {p.name}: '{p.default}'")
        else:
            value = yaml.safe_dump(p.default, default_flow_style=True).strip()
            lines.append(f'    {p.name}: {value.removesuffix(chr(10) + "...")}')
    return HEADER + '\n'.join(lines) + '\n'


if __name__ == '__main__':
    out = Path(__file__).resolve().parents[1] / 'config' / 'params.yaml'
    out.write_text(text())
    print(f'wrote {out}')
