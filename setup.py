# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
import os
import subprocess
import sys

from setuptools import find_packages, setup
from setuptools.command.install import install

package_name = 'rb_sim_ros'


class InstallAndPrecompile(install):
    """install, then compile the kernels into the installed package's compilation cache
    (python -m rb_sim_ros.sim.precompile, run from the installed tree), so that the first start
    of the node loads them instead of compiling them (about 2 min on 2 cores). colcon build
    runs this; a wheel or staged install (--root) and RB_SIM_ROS_PRECOMPILE=0 skip it, and a
    failure only warns: the node then compiles at its first start."""

    def run(self):
        super().run()
        if self.root is not None or os.environ.get('RB_SIM_ROS_PRECOMPILE', '1') == '0':
            return
        print(f'rb_sim_ros: compiling the kernels in {self.install_lib}', file=sys.stderr)
        try:
            subprocess.run([sys.executable, '-m', 'rb_sim_ros.sim.precompile'],
                           cwd=self.install_lib, check=True, timeout=1800)
        except (OSError, subprocess.SubprocessError) as e:
            print(f'rb_sim_ros: warning: kernels not compiled ahead ({e}); the first start '
                  'of the node compiles them', file=sys.stderr)


setup(
    name=package_name,
    version='0.1.0',
    packages=find_packages(exclude=['test', 'test.*', 'bench', 'bench.*']),
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + package_name]),
        ('share/' + package_name, ['package.xml']),
        ('share/' + package_name + '/scenes',
         ['scenes/example.yaml', 'scenes/collisions.yaml', 'scenes/terrain.yaml']),
        ('share/' + package_name + '/launch', ['launch/sim.launch.py']),
        ('share/' + package_name + '/config', ['config/params.yaml']),
        ('share/' + package_name + '/rviz', ['rviz/rb_sim.rviz']),
        ('share/' + package_name + '/foxglove', ['foxglove/rb_sim_layout.json']),
        ('share/' + package_name + '/examples',
         ['examples/attitude_controller.py', 'examples/attitude_demo.sh']),
        ('share/doc/' + package_name, ['LICENSE', 'README.md']),
    ],
    # ROS dependencies come from package.xml (rosdep); PyPI-only ones (mcap for recording)
    # are in requirements.txt, used by the README's commands, never forced on colcon.
    install_requires=['setuptools'],
    cmdclass={'install': InstallAndPrecompile},
    zip_safe=True,
    maintainer='rb_sim_ros maintainers',
    maintainer_email='maintainers@rb-sim-ros.invalid',
    description='A fast, accurate, deterministic rigid-body simulator node.',
    license='Apache-2.0',
    tests_require=['pytest'],
    entry_points={
        'console_scripts': [
            'simulator = rb_sim_ros.ros.simulator_node:main',
            'send_wrench = rb_sim_ros.ros.send_wrench:main',
            'replay = rb_sim_ros.offline.replay:main',
            'sweep = rb_sim_ros.offline.sweep:main',
            'campaign = rb_sim_ros.offline.campaign:main',
        ],
    },
)
