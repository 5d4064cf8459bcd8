"""Shared fixtures."""

import contextlib
import logging
import os
import shutil
import subprocess
import uuid

import pytest

from heft.diagrams.commands import console


def _ip(*args, check=True):
    return subprocess.run(["ip", *args], capture_output=True, text=True, timeout=10, check=check)


@contextlib.contextmanager
def network_namespace():
    """A fresh network namespace with `lo` up and multicast routed to it, deleted on leaving; skips the
    test if one cannot be made."""
    if shutil.which("ip") is None:
        pytest.skip("needs the `ip` tool (iproute2) to create a network namespace")
    if os.geteuid() != 0:
        pytest.skip("needs root to create a network namespace (`ip netns add`)")
    name = f"heft_test_{uuid.uuid4().hex[:8]}"
    created = _ip("netns", "add", name, check=False)
    if created.returncode != 0:
        pytest.skip(f"cannot create a network namespace: {created.stderr.strip()}")
    try:
        _ip("netns", "exec", name, "ip", "link", "set", "lo", "up")
        _ip("netns", "exec", name, "ip", "route", "add", "224.0.0.0/4", "dev", "lo")
        yield name
    finally:
        _ip("netns", "del", name, check=False)


@pytest.fixture
def netns():
    """``network_namespace`` for one test."""
    with network_namespace() as name:
        yield name


@pytest.fixture(scope="module")
def module_netns():
    """``network_namespace`` shared by the tests of one module."""
    with network_namespace() as name:
        yield name


class FakeClock:
    """A monotonic clock (s) that only the test, the sleeps of the code under test and, by ``per_read``
    s, each reading advance."""

    def __init__(self, per_read: float = 0.0):
        self.t, self.per_read, self.reads = 100.0, per_read, 0

    def __call__(self) -> float:
        self.t += self.per_read
        self.reads += 1
        return self.t

    def sleep(self, seconds: float) -> None:
        assert seconds >= 0
        self.t += seconds


@pytest.fixture
def fake_clock():
    return FakeClock()


@pytest.fixture(autouse=True)
def heft_logger_at_info():
    """Each test ends with the ``heft`` logger back at INFO once something configured it: a command run
    in-process with ``-q`` left it at WARNING, which silenced a later test's command that calls ``run``
    directly (``console.logger`` configures only a logger nobody has)."""
    yield
    if logging.getLogger(console.ROOT).handlers:
        console.configure()


@pytest.fixture(autouse=True)
def process_keeps_its_cpus():
    """Each test ends with every thread of the test process back on the CPUs it started on: a command run
    in-process (`heft stand-in`, `heft driver`) leaves the real-time loop's CPU in its own process, which
    then ran the rest of the suite on one CPU and skipped the tests that need two."""
    cpus = os.sched_getaffinity(0)
    yield
    if os.sched_getaffinity(0) != cpus:
        for task in os.listdir("/proc/self/task"):
            with contextlib.suppress(OSError):  # a thread that ended meanwhile
                os.sched_setaffinity(int(task), cpus)
