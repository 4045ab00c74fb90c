# Copyright 2026 The rb_sim_ros Authors
# Licensed under the Apache License, Version 2.0
"""Real processes over DDS for the node tests: an installed simulator and a probe node.

Every test run gets its own ROS_DOMAIN_ID and LOCALHOST discovery, so parallel runs never hear
each other: the id is reserved by an exclusive lock on a file in the temporary directory, held
until the process ends (the kernel releases it even after SIGKILL), so two concurrent runs on one
machine never share one. Waiting is on conditions (spin until a message arrives), never on
sleeps.
"""

from __future__ import annotations

import fcntl
import hashlib
import os
from pathlib import Path
import shutil
import signal
import subprocess
import sys
import sysconfig
import tempfile
import time

import rclpy
from rclpy.executors import SingleThreadedExecutor

from rb_sim_ros.core import jit
from rb_sim_ros.ros import ros_domains

ROOT = Path(__file__).resolve().parents[2]


def install(prefix: Path) -> Path:
    """Install the package into ``prefix`` as colcon's ament_python build does (which
    compiles the kernels into the installed tree's own cache, whatever NUMBA_CACHE_DIR says).
    The tree's cache is first seeded with the kernels this process's NUMBA_CACHE_DIR holds:
    both are keyed by the same source text (``core/jit.py``), so the install's compile loads
    those instead of compiling them a second time (and still marks the parts itself)."""
    build = prefix.parent / 'build'
    build.mkdir(parents=True, exist_ok=True)
    seed = jit.cache_directories()[0] if os.environ.get('NUMBA_CACHE_DIR') else None
    if seed is not None and seed.is_dir():
        tree_cache = site_packages(prefix) / 'rb_sim_ros' / '__pycache__' / 'numba'
        tree_cache.mkdir(parents=True, exist_ok=True)
        for f in seed.iterdir():
            if f.suffix in ('.nbi', '.nbc'):
                shutil.copy2(f, tree_cache / f.name)
    subprocess.run([sys.executable, 'setup.py', '-q', 'egg_info', '--egg-base', str(build),
                    'build', '--build-base', str(build), 'install', '--prefix', str(prefix),
                    '--record', str(build / 'install.log'),
                    '--single-version-externally-managed'],
                   cwd=ROOT, check=True, capture_output=True,
                   env={k: v for k, v in os.environ.items()
                        if k not in ('NUMBA_CACHE_DIR', 'NUMBA_DISABLE_JIT')})
    return prefix


# What setup.py installs: a change to any of these is a new install.
INSTALLED_SOURCES = ('rb_sim_ros', 'setup.py', 'setup.cfg', 'package.xml', 'resource', 'scenes',
                     'launch', 'config', 'rviz', 'foxglove', 'examples', 'LICENSE')


def install_key() -> str:
    """A hash of every file setup.py installs (names and bytes), this interpreter and numba:
    an install made from the same key is the same install."""
    import numba
    digest = hashlib.sha256(f'{sys.executable} {numba.__version__}'.encode())
    for name in INSTALLED_SOURCES:
        top = ROOT / name
        files = [top] if top.is_file() else sorted(
            f for f in top.rglob('*') if f.is_file() and '__pycache__' not in f.parts)
        for f in files:
            digest.update(str(f.relative_to(ROOT)).encode() + b'\0' + f.read_bytes())
    return digest.hexdigest()[:20]


def shared_install(base: Path | None = None) -> Path:
    """``install`` of these sources, made once and shared: by the workers of a parallel run
    and by later runs while the sources are unchanged (a focused run pays no install). Under
    ``base`` (default: RB_SIM_ROS_TEST_INSTALLS or the temporary directory), keyed by
    ``install_key``; the first process to need it installs it while the others wait on a lock."""
    base = Path(base or os.environ.get('RB_SIM_ROS_TEST_INSTALLS')
                or Path(tempfile.gettempdir()) / f'rb_sim_ros_test_installs-{os.getuid()}')
    base.mkdir(parents=True, exist_ok=True)
    key = install_key()
    where, done = base / key, base / f'{key}.done'
    with open(base / f'{key}.lock', 'a') as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if not done.is_file():
            shutil.rmtree(where, ignore_errors=True)  # a half install, interrupted
            install(where / 'install')
            done.write_text('installed\n')
    return where / 'install'


def site_packages(prefix: Path) -> Path:
    rel = Path(sysconfig.get_path('purelib')).relative_to(sys.prefix)
    return prefix / rel


DOMAIN_IDS = ros_domains.DOMAIN_IDS
domain_lock_path = ros_domains.lock_path
reserve_domain_id = ros_domains.reserve


def ros_env(prefix: Path) -> dict:
    """The environment of a node run from the install at ``prefix``: with the kernels that
    install compiled (no NUMBA_CACHE_DIR of this process), on a private domain."""
    env = {k: v for k, v in os.environ.items() if k != 'NUMBA_CACHE_DIR'}
    env['ROS_DOMAIN_ID'] = str(reserve_domain_id())
    env['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
    env['AMENT_PREFIX_PATH'] = os.pathsep.join([str(prefix), sys.prefix])
    env['PYTHONPATH'] = os.pathsep.join(filter(None, [str(site_packages(prefix)),
                                                      env.get('PYTHONPATH', '')]))
    env['PYTHONUNBUFFERED'] = '1'
    return env


class SimProcess:
    """The installed ``simulator`` executable as a subprocess."""

    def __init__(self, prefix: Path, env: dict, args=(), log_dir: Path | None = None,
                 exe: str = 'simulator') -> None:
        self.log = (log_dir or prefix) / f'{exe}-{time.monotonic_ns()}.log'
        self._log_file = open(self.log, 'w')
        self.proc = subprocess.Popen([str(prefix / 'lib' / 'rb_sim_ros' / exe), *args],
                                     env=env, stdout=self._log_file, stderr=subprocess.STDOUT)

    def stop(self, sig=signal.SIGINT, timeout=10.0) -> int:
        if self.proc.poll() is None:
            self.proc.send_signal(sig)
            try:
                self.proc.wait(timeout)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        self._log_file.close()
        return self.proc.returncode

    def output(self) -> str:
        if not self._log_file.closed:
            self._log_file.flush()
        return self.log.read_text()


class Probe:
    """A node in the test process, on the test's own domain."""

    def __init__(self, env: dict, name: str = 'probe') -> None:
        self.context = rclpy.Context()
        rclpy.init(context=self.context, domain_id=int(env['ROS_DOMAIN_ID']))
        self.node = rclpy.create_node(name, context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self._clients: dict = {}

    def collect(self, msg_type, topic: str, qos=10) -> list:
        """Subscribe; the returned list fills with every message received."""
        got: list = []
        self.node.create_subscription(msg_type, topic, got.append, qos)
        return got

    # Generous: a node's start on a machine whose cores other jobs keep busy takes minutes.
    def wait_for(self, predicate, timeout: float = 300.0, what: str = 'condition') -> None:
        end = time.monotonic() + timeout
        while not predicate():
            if time.monotonic() > end:
                raise TimeoutError(f'timed out after {timeout} s waiting for {what}')
            self.executor.spin_once(timeout_sec=0.02)

    # A read (a Get... service) unanswered this long is asked again: DDS can report a
    # service ready before the server has matched this client's reply reader, and a reply
    # sent then is lost (seen on a loaded machine). A call that changes state is resent only
    # when its caller says a second one does no harm (``resend=True``, e.g. one more step of
    # a loop that steps until something is seen). A client is made once for each service and
    # kept: once a reply has come the match is made and no later call can lose one. A new
    # client waits SETTLE_NEW_CLIENT once ready before its first call, for the server to match
    # its reply reader: the server waits only briefly for that match, and under load a reply
    # was lost so ('failed to send response (timeout)' in the node's log).
    RESEND_READS_AFTER = 20.0
    SETTLE_NEW_CLIENT = 1.0

    def call(self, srv_type, name: str, request, timeout: float = 300.0,
             resend: bool | None = None):
        key = (srv_type, name)
        client = self._clients.get(key)
        new = client is None
        if new:
            client = self._clients[key] = self.node.create_client(srv_type, name)
        self.wait_for(client.service_is_ready, timeout, f'service {name}')
        if new:
            self.settle()
        end = time.monotonic() + timeout
        future = client.call_async(request)
        if srv_type.__name__.startswith('Get') if resend is None else resend:
            while True:
                left = end - time.monotonic()
                try:
                    self.wait_for(future.done, min(self.RESEND_READS_AFTER, max(left, 0.0)),
                                  f'response of {name}')
                    break
                except TimeoutError:
                    if left <= self.RESEND_READS_AFTER:
                        raise TimeoutError(f'timed out after {timeout} s waiting for the '
                                           f'response of {name}') from None
                    client.remove_pending_request(future)
                    future = client.call_async(request)
        self.wait_for(future.done, max(end - time.monotonic(), 0.0), f'response of {name}')
        return future.result()

    def settle(self) -> None:
        """Spin SETTLE_NEW_CLIENT: for the other side to match what this side has just
        seen (a service's reply reader, an action's feedback subscription)."""
        settled = time.monotonic() + self.SETTLE_NEW_CLIENT
        while time.monotonic() < settled:
            self.executor.spin_once(timeout_sec=0.02)

    def publisher(self, msg_type, topic: str, subscribers: int = 1):
        """A publisher, returned once ``subscribers`` subscriptions have matched it."""
        pub = self.node.create_publisher(msg_type, topic, 10)
        self.wait_for(lambda: pub.get_subscription_count() >= subscribers,
                      what=f'a subscriber on {topic}')
        return pub

    def close(self) -> None:
        self.executor.shutdown()
        self.node.destroy_node()
        rclpy.try_shutdown(context=self.context)


def stamp_ns(stamp) -> int:
    return stamp.sec * 1_000_000_000 + stamp.nanosec
