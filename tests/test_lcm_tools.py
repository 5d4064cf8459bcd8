"""Recording LCM traffic with lcm-logger, and the latency rule and the steal reading of `heft bench lcm`."""

import subprocess
import sys

import numpy as np
import pytest
from heft.diagrams.commands.bench_lcm import step_latencies
from heft.diagrams.running.lcm_recording import LOGGER_RECEIVE_BUFFER, LcmTrafficRecorder, logger_url
from heft.hardware_interface.channels import LcmChannels

RECORD_AND_PUBLISH = """
import sys, time, lcm
from heft.diagrams.running.lcm_recording import LcmTrafficRecorder
from heft.hardware_interface.channels import LcmChannels
channels = LcmChannels()  # the drivers' URL and the controller's, one port up
buses = [lcm.LCM(channels.lcm_url), lcm.LCM(channels.command_lcm_url())]
with LcmTrafficRecorder(channels, sys.argv[1]):
    for i in range(200):  # even numbers on one URL, odd ones on the other
        buses[i % 2].publish("HEFT_TEST", i.to_bytes(4, "little"))
        time.sleep(0.0005)
    time.sleep(0.2)
"""


def test_step_latency_is_the_first_command_past_half_way():
    """Commands every 0.5 ms; the torque answers each step 3.2 ms late, ramping over 2 ms."""
    receipts = np.arange(0.0, 1.0, 0.0005)
    steps = [(0.2, 1.0, 0.2), (0.5, -1.0, 0.5), (0.8, 1.0, 0.8)]  # (published, direction, due)
    level = np.zeros_like(receipts)
    for t_step, direction, _ in steps:
        ramp = np.clip((receipts - t_step - 0.0032) / 0.002, 0.0, 1.0)
        level = np.where(receipts >= t_step, (1.0 if direction > 0 else 0.0) * ramp
                         + (0.0 if direction > 0 else 1.0) * (1 - ramp), level)
    torques = np.outer(level, [0.1, -0.2, 0, 0, 0, 0.05])
    latencies = step_latencies(steps, receipts, torques)
    # Half-way is reached 1 ms into the ramp: 3.2 + 1.0 ms, rounded up to the next receipt.
    np.testing.assert_allclose(latencies, [0.0045, 0.0045, 0.0045], atol=1e-9)


def test_a_logger_asks_for_a_large_receive_buffer_unless_told_otherwise():
    size = f"recv_buf_size={LOGGER_RECEIVE_BUFFER}"
    assert logger_url("udpm://239.255.76.67:7667?ttl=0") == f"udpm://239.255.76.67:7667?ttl=0&{size}"
    assert logger_url("udpm://239.255.76.67:7667") == f"udpm://239.255.76.67:7667?{size}"
    assert logger_url("udpm://239.255.76.67:7667?recv_buf_size=65536") == "udpm://239.255.76.67:7667?recv_buf_size=65536"


def test_recorder_refuses_memq():
    with pytest.raises(ValueError, match="udpm"):
        LcmTrafficRecorder(LcmChannels(lcm_url="memq://"), "unused.lcmlog")


def test_recorder_writes_a_log_lcm_reads_back(netns, tmp_path):
    import lcm

    path = tmp_path / "traffic.lcmlog"
    subprocess.run(["ip", "netns", "exec", netns, sys.executable, "-c", RECORD_AND_PUBLISH, str(path)],
                   check=True, timeout=60)
    payloads = [int.from_bytes(event.data, "little") for event in lcm.EventLog(str(path), "r")
                if event.channel == "HEFT_TEST"]
    assert payloads == list(range(200))  # every message of both URLs, in order
    assert subprocess.run(["pgrep", "-f", str(path)], capture_output=True).returncode == 1, "logger left running"
    assert [p.name for p in tmp_path.iterdir()] == [path.name], "the loggers' parts are merged and removed"


PROBE_RECEIVER_CHECK = """
import time, lcm
from heft.diagrams.commands.bench_lcm import _TimestampedReceiver
url = "udpm://239.255.76.67:7667?ttl=0"
receiver = _TimestampedReceiver(url, "HEFT_MASTER_COMMAND")
bus = lcm.LCM(url)
before = time.time()
bus.publish("HEFT_OTHER", b"not this one")
bus.publish("HEFT_MASTER_COMMAND", b"payload")
time.sleep(0.05)
messages = receiver.take()
taken = time.time()
assert [payload for _, payload in messages] == [b"payload"], messages
# The kernel's time of delivery: after the publish, before the read (on a busy machine the
# loopback's delivery itself may wait for a CPU, so it is not bounded by the publish's return).
assert before <= messages[0][0] <= taken, (before, messages[0][0], taken)
print("ok")
"""


@pytest.mark.slow
def test_probe_receiver_gets_the_channel_with_the_kernels_arrival_time(netns):
    """The bench probe's command receiver, on real UDP multicast in a private namespace."""
    result = subprocess.run(["ip", "netns", "exec", netns, sys.executable, "-c", PROBE_RECEIVER_CHECK],
                            capture_output=True, text=True, timeout=60)
    assert result.returncode == 0 and "ok" in result.stdout, result.stderr


def test_the_bench_waits_for_a_line_and_leaves_the_rest_to_communicate():
    """`heft bench lcm` starts the controller once the stand-in says it publishes: the line is found
    among others written at once, what follows it reaches ``communicate``, and a process that ends
    without it is an error that shows what it wrote."""
    import subprocess
    import sys

    from heft.diagrams.commands.bench_lcm import _wait_for_line

    # The child's output may reach the pipe in pieces (unbuffered under PYTHONUNBUFFERED): what the
    # wait read and what ``communicate`` reads make up all of it, and the wait stopped before "c".
    script = "import sys, time; print('a\\nready: go\\nb', flush=True); time.sleep(0.2); print('c')"
    process = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, text=True)
    started = _wait_for_line(process, "ready:", 30.0)
    assert started.startswith("a\nready: go\n") and "c" not in started
    assert started + process.communicate(timeout=30)[0] == "a\nready: go\nb\nc\n"
    silent = subprocess.Popen([sys.executable, "-c", "print('starting'); raise SystemExit(3)"],
                              stdout=subprocess.PIPE, text=True)
    with pytest.raises(RuntimeError, match="(?s)no line beginning 'ready:'.*starting"):
        _wait_for_line(silent, "ready:", 30.0)


def test_a_bench_process_that_fails_or_hangs_is_reported_with_everything_each_wrote():
    """The controller fails at once while the probe would wait on for it: the probe is killed after its timeout,
    not waited for, and the error shows both outputs."""
    import subprocess
    import sys

    from heft.diagrams.commands.bench_lcm import _finish

    failed = subprocess.Popen([sys.executable, "-c", "print('teleop: refused'); raise SystemExit(2)"],
                              stdout=subprocess.PIPE, text=True)
    waiting = subprocess.Popen([sys.executable, "-c", "import time; print('probe: waiting', flush=True); "
                                "time.sleep(60)"], stdout=subprocess.PIPE, text=True)
    with pytest.raises(RuntimeError, match="(?s)teleop: refused.*probe: waiting.*killed: still running 1 s"):
        _finish({"teleop": (failed, 30), "probe": (waiting, 1)})
    assert waiting.returncode is not None and waiting.returncode < 0


def test_the_bench_reads_each_cpus_steal_from_proc_stat_as_the_kernel_lays_it_out():
    """proc(5): per CPU, user nice system idle iowait irq softirq steal … in clock ticks; the machine's total line
    and the other lines are not CPUs, and a kernel that counts no steal gives none."""
    import os

    from heft.diagrams.commands.bench_lcm import cpu_steal_ms

    tick_ms = 1e3 / os.sysconf("SC_CLK_TCK")
    stat = ("cpu  3310789 632564 605096 3366585 26987 0 37678 7288 0 0\n"
            "cpu0 1472708 294739 359697 1817569 7385 0 20521 4042 0 0\n"
            "cpu1 1838080 337824 245399 1549016 19602 0 17156 3246 0 0\n"
            "intr 9139233 0 9 0 0 0 0 0\n"
            "ctxt 512883211\n")
    assert cpu_steal_ms(stat) == {"cpu0": 4042 * tick_ms, "cpu1": 3246 * tick_ms}
    assert cpu_steal_ms("cpu  1 2 3 4\ncpu0 1 2 3 4\n") == {}
