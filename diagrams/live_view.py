"""A run's rows, as they come, on ``analysis.topics``' topics: served live over the Foxglove
WebSocket protocol (``LiveView``, foxglove-sdk, ``ws://localhost:8765``) or written to an MCAP
file (``McapRecorder``), by a process of their own.

The loop's side of either is a hand-off into shared memory: ``publish(t, arrays)`` copies the
declared arrays into a ring of preallocated rows and moves a counter; no encoding, no lock, no
system call, so it never waits for the viewer. A rare message (``event``) is one datagram, sent without
waiting, to a socket the worker reads: the loop's process runs no thread of the view's. ``LiveView`` takes at
most ``rate`` rows a second (on the loop's clock ``t``), ``McapRecorder`` every row (the scene at
``SCENE_RATE``). The worker process (niced, off a real-time loop's CPU) reads the ring, adds the scene's poses
(``diagrams.scene_poses``), encodes the messages of the topics somebody takes (a client subscribed; the file
takes all) and serves or writes them. The recorder's worker
first spools each row to a temporary file, so that an encoding slower than the loop loses nothing
(it catches up after ``close``); rows a worker falls more than its ring (``RING_SECONDS``) behind on are lost,
counted.

    view = LiveView(port=8765)                      # or McapRecorder("run.mcap")
    view.open({"wrench_measured": 6, "slave_q": 6, ...})  # once: starts the worker, waits for it
    view.publish(t, arrays)                         # each tick: key → array of the declared width
    view.event("/faults", payload, t)               # rare messages (EVENT_TOPICS; row topics named at open)
    view.close()                                    # {"rows": …, "dropped": …, "messages": …, "events_dropped": …}
"""

from __future__ import annotations

import math
import multiprocessing
import os
import pickle
import queue
import shutil
import socket
import tempfile
import time
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from heft.diagrams.master_params import DEFAULT_MASTER

if TYPE_CHECKING:
    from heft.diagrams.plants import Robot

DEFAULT_PORT = 8765
"""The live view's TCP port (Foxglove's default), on localhost."""
STAND_IN_PORT = DEFAULT_PORT + 1
"""`heft stand-in`'s live view's port by default: beside a controller's view on the same machine."""
DEFAULT_RATE = 100.0
"""Rows a second the live view serves (Hz, on the loop's clock)."""
RING_ROWS = 4096
"""Rows of the recorder's shared ring: 2 s at 2 kHz for its worker to catch up in."""
RING_SECONDS = 2.0
"""A rate-limited tap's ring holds this long of its rows (s at its rate; at most ``RING_ROWS``)."""
WORKER_NICENESS = 10
"""The worker's nice value: below the loop's priority (``_leave_the_loop``)."""
POLL = 0.005
"""s between the worker's looks at the ring."""
SCENE_RATE = DEFAULT_RATE
"""Scene messages a second at most (Hz, the loop's clock; the recorder's other topics take every row):
a drawing, and the dearest message to make."""
CLOSE_TIMEOUT = 30.0
"""s the live view's worker may take to stop before it is ended."""
LINGER = 0.5
"""s the server stays up after the last row, for its messages to reach the clients."""
START_TIMEOUT = 120.0
"""s the worker may take to start (imports, the scene's plants, the server's socket)."""
EVENT_MAX = 1 << 16
"""The largest event (bytes, pickled). The worker's socket holds ``net.unix.max_dgram_qlen`` of them unread (10 by
default: a second of the 10 Hz station status); beyond, they are dropped and counted."""
_HEADER = 3  # [rows written, stop, the messages' time origin (ns, int64 bits)]


class TickTap:
    """The shared ring and its worker process (``LiveView``, ``McapRecorder``). ``sink``: ("ws",
    host, port) or ("mcap", path); ``rate`` rows/s at most (0: every row); ``robot`` and ``master`` pose the scene."""

    def __init__(self, sink: tuple, rate: float, robot: Robot, master: str):
        self._sink, self._rate, self._robot, self._master = sink, rate, robot, master
        self._rows = RING_ROWS if rate == 0 else min(RING_ROWS, math.ceil(RING_SECONDS * rate))
        self._process = self._widths = None
        self._topics, self._event_topics, self._lcm_topics = (), set(), set()
        self.events_dropped = 0
        """Events not sent: the worker's socket full (``EVENT_MAX``), or the worker gone."""

    @property
    def every_row(self) -> bool:
        """Whether it takes every row (the recorder) rather than a rate's (the live view)."""
        return self._rate == 0

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def open(self, widths: dict, t0_ns: int | None = None, topics=()) -> None:
        """Starts the worker for rows of the arrays ``widths`` (key → entries) and waits until it
        serves; messages are timed ``t0_ns`` + t (ns; default: the wall clock now). ``topics``: row
        topics (``analysis.topics.TOPICS``) that come as events (``event``: e.g. an estimate that comes
        once, after the loop), advertised from the start, so that a client has subscribed by then. Opening
        again with the same keys and topics keeps the worker (a live view's clients stay connected)."""
        from heft.analysis.run_export import foxglove_sdk
        from heft.analysis.topics import EVENT_TOPICS, TOPIC_BY_NAME

        foxglove_sdk()  # the one-line install hint, here in the loop's process
        unknown = [topic for topic in topics if topic not in TOPIC_BY_NAME]
        if unknown:
            raise ValueError(f"no row topic {', '.join(unknown)} (analysis.topics.TOPICS)")
        t0 = time.time_ns() if t0_ns is None else int(t0_ns)
        self._next = -math.inf
        if self._process is not None and self._process.is_alive() and (dict(widths), tuple(topics)) == (
                self._widths, self._topics):
            self._origin[0] = t0
            return
        self.close()
        self._widths, self._topics = dict(widths), tuple(topics)
        self._lcm_topics = {topic.name for topic in EVENT_TOPICS}
        self._event_topics = {*self._lcm_topics, *self._topics}
        columns = 1 + sum(self._widths.values())
        file = tempfile.NamedTemporaryFile(prefix="heft-view-", dir="/dev/shm" if os.path.isdir("/dev/shm") else None,
                                           delete=False)
        file.truncate(8 * (_HEADER + self._rows * columns))
        file.close()
        self._path = file.name
        memory = np.memmap(self._path, dtype=np.float64, mode="r+").view(np.ndarray)  # plain views: cheaper to set
        memory[:] = 0.0  # every page touched now, not at a tick's first write to it
        self._head, ring = memory[:_HEADER], memory[_HEADER:].reshape(self._rows, columns)
        self._origin = memory[2:3].view(np.int64)
        self._origin[0] = t0
        self._slots, start = [], 1
        spans = []
        for key, width in self._widths.items():
            spans.append((key, start, start + width))
            start += width
        self._slots = [(ring[i, :1], [(key, ring[i, a:b]) for key, a, b in spans]) for i in range(self._rows)]
        self._written = 0
        spawn = multiprocessing.get_context("spawn")
        self._events = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
        self._events.setblocking(False)
        self._event_folder = tempfile.mkdtemp(prefix="heft-view-")  # the user's alone: no other sends to it
        self._event_address = os.path.join(self._event_folder, "events")
        self.events_dropped = 0
        self._replies = replies = spawn.Queue()
        self._process = spawn.Process(target=_work, args=(self._path, self._widths, self._topics, self._rows,
                                                          self._sink, self._robot, self._master, self._rate,
                                                          self._event_address, replies),
                                      daemon=True)
        self._process.start()
        error = self._started(replies)
        if error:
            self.close()
            raise ValueError(error)

    def _started(self, replies) -> str | None:
        """None once the worker serves; else what went wrong."""
        deadline = time.monotonic() + START_TIMEOUT
        while time.monotonic() < deadline:
            try:
                return replies.get(timeout=0.2)
            except queue.Empty:
                if not self._process.is_alive():
                    return f"the view's worker exited (status {self._process.exitcode}) before it served"
        return f"the view's worker did not start in {START_TIMEOUT:g} s"

    def since_origin(self) -> float:
        """s from the messages' time origin (``open``'s ``t0_ns``) to now, by the wall clock: the loop's
        clock, for an event that comes after the loop."""
        return (time.time_ns() - int(self._origin[0])) * 1e-9

    def due(self, t: float) -> bool:
        """Whether a row at ``t`` (s) would be taken (the rate's next slot has come)."""
        return t >= self._next - 1e-9

    def publish(self, t: float, arrays) -> bool:
        """Hands the row at ``t`` (s, the loop's clock) of ``arrays`` (key → array or number, every key
        declared at ``open``) to the worker, unless the rate says wait; whether it was taken."""
        if t < self._next - 1e-9:
            return False
        if self._rate:
            self._next = self._next + 1.0 / self._rate if t < self._next + 1.0 / self._rate else t + 1.0 / self._rate
        stamp, views = self._slots[self._written % self._rows]
        stamp[0] = t
        for key, view in views:
            view[:] = arrays[key]
        self._written += 1
        self._head[0] = self._written  # after the row: the worker reads rows below the count
        return True

    def event(self, topic: str, message: dict | bytes, t: float) -> None:
        """A rare message at ``t`` (s, the loop's clock): on an event topic (``analysis.topics.EVENT_TOPICS``;
        ``message`` the LCM message's bytes, converted by the worker as ``heft export`` converts them, or a dict),
        or on a row topic named at ``open`` (``Topic.message``'s dict). Never waits, and never fails the loop:
        with the worker's socket full, or the worker gone, it is dropped and counted (``events_dropped``)."""
        if topic not in self._event_topics:
            raise ValueError(f"{topic} takes no events here: an event topic, or a row topic named by open(topics=…)")
        if isinstance(message, bytes) and topic not in self._lcm_topics:
            raise ValueError(f"{topic} is a row topic: its event is a dict (Topic.message), not an LCM message's bytes")
        try:
            self._events.sendto(pickle.dumps((topic, t, message), pickle.HIGHEST_PROTOCOL), self._event_address)
        except OSError:  # full, the worker gone, or larger than EVENT_MAX
            self.events_dropped += 1

    def close(self) -> dict:
        """Stops the worker after it has handled every row (the recorder: encoded every row it
        spooled, however long that takes); {"rows": handled, "dropped": rows lost, "messages": messages logged
        (on the topics somebody took), "events_dropped": events lost} ({} if not open; the worker's counts only if
        it gave them)."""
        if self._process is None:
            return {}
        self._events.close()  # every event sent is in the worker's socket before it is told to stop
        self._head[1] = 1.0
        self._process.join(timeout=None if self._rate == 0 else CLOSE_TIMEOUT)
        if self._process.is_alive():
            self._process.terminate()
            self._process.join()
        try:
            stats = self._replies.get(timeout=1.0)
        except queue.Empty:
            stats = {}
        self._process = self._widths = None
        self._slots, self._head = [], None
        Path(self._path).unlink(missing_ok=True)
        shutil.rmtree(self._event_folder, ignore_errors=True)
        return {**(stats if isinstance(stats, dict) else {}), "events_dropped": self.events_dropped}


class LiveView(TickTap):
    """The live view on ``ws://host:port``, at most ``rate`` rows a second; ``robot`` and ``master`` pose the
    scene."""

    def __init__(self, port: int = DEFAULT_PORT, rate: float = DEFAULT_RATE, robot: Robot = "rx90",
                 host: str = "127.0.0.1", master: str = DEFAULT_MASTER):
        super().__init__(("ws", host, port), rate, robot, master)


class McapRecorder(TickTap):
    """Every row written to the MCAP file at ``path`` (overwritten), as ``heft export`` writes a log."""

    def __init__(self, path, robot: Robot = "rx90", master: str = DEFAULT_MASTER):
        super().__init__(("mcap", str(path)), 0.0, robot, master)


def simulation_monitor(view: TickTap, log, names: dict):
    """A ``Simulator`` monitor that opens ``view`` for the signals of ``log`` (``SimulationLog``; renamed by
    ``names``) and publishes them when due. It runs after each step, where the logger has just
    published: the row is the log's (but the plant's truth and ``slave_q``, which the log.npz
    pairs with the sensor sample before, ``diagrams.running.simulation``)."""
    from pydrake.systems.framework import EventStatus

    port = log.logger.get_input_port()
    parts = [(names.get(key, key), part) for key, part in log.columns.items()]
    view.open({key: part.stop - part.start for key, part in parts})

    def monitor(root_context):
        t = root_context.get_time()
        if view.due(t):
            row = port.Eval(log.logger.GetMyContextFromRoot(root_context))
            view.publish(t, {key: row[part] for key, part in parts})
        return EventStatus.Succeeded()

    return monitor


def _leave_the_loop() -> None:
    """Gives up what the worker inherited from a real-time loop that started it: ``SCHED_FIFO``
    (normal scheduling, niced by ``WORKER_NICENESS``), and a CPU of its own (the others, if any)."""
    if os.sched_getscheduler(0) != os.SCHED_OTHER:
        os.sched_setscheduler(0, os.SCHED_OTHER, os.sched_param(0))
    os.nice(WORKER_NICENESS)
    mine, every = os.sched_getaffinity(0), set(range(os.cpu_count() or 1))
    if len(mine) == 1 and every - mine:
        os.sched_setaffinity(0, every - mine)


def _work(path, widths: dict, topics: tuple, rows: int, sink: tuple, robot: Robot, master: str, rate: float,
          event_address: str, replies) -> None:
    """The worker process: serves or writes the ring's rows and the events sent to ``event_address`` until told
    to stop."""
    _leave_the_loop()
    events = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
    events.bind(event_address)
    events.setblocking(False)
    event_buffer = bytearray(EVENT_MAX)
    try:
        from heft.analysis.lcm_messages import event_from_lcm
        from heft.analysis.run_export import foxglove_channel, foxglove_sdk
        from heft.analysis.topics import (EVENT_TOPICS, SCENE_FRAMES, SCENE_KEYS, SCENE_WRENCHES, encode, row_messages,
                                          row_topics, schema_of)

        foxglove = foxglove_sdk()
        context = foxglove.Context()
        scene = None
        if "slave_q" in widths and "master_q" in widths:
            from heft.diagrams.scene_poses import ScenePoses
            scene = ScenePoses(robot, master)
        names = row_topics([*widths, *(SCENE_KEYS if scene else ())])
        channels = {name: foxglove_channel(foxglove, context, name, schema_of(name))
                    for name in dict.fromkeys([*names, *topics, *(topic.name for topic in EVENT_TOPICS)])}
        if sink[0] == "ws":  # after the channels: a client's first advertisement lists them all
            server = foxglove.start_server(name="heft", host=sink[1], port=sink[2], context=context)

            def stop():
                time.sleep(LINGER)
                server.stop()
        else:
            from foxglove.mcap import MCAPWriteOptions
            writer = foxglove.open_mcap(sink[1], allow_overwrite=True, context=context,
                                        writer_options=MCAPWriteOptions(compression_threads=0))
            stop = writer.close
    except Exception as error:  # a port in use, a missing package: told to the loop's process
        replies.put(f"the live view could not start: {error}")
        return
    replies.put(None)
    memory = np.memmap(path, dtype=np.float64, mode="r+").view(np.ndarray)
    head, ring = memory[:_HEADER], memory[_HEADER:].reshape(rows, -1)
    origin = memory[2:3].view(np.int64)
    spans, start = {}, 1
    for key, width in widths.items():
        spans[key], start = slice(start, start + width), start + width
    plain = [name for name in names if name not in (SCENE_FRAMES, SCENE_WRENCHES)]
    next_scene = -math.inf

    def send(log_time: int, row) -> None:
        """The row's messages on the topics somebody takes (a client subscribed, the MCAP file): a view
        nobody watches encodes nothing."""
        nonlocal next_scene, logged
        t = float(row[0])
        arrays = {key: row[part] for key, part in spans.items()}
        drawn = scene is not None and t >= next_scene - 1e-9
        if drawn:  # the scene at most SCENE_RATE, on its grid (as ``publish`` takes rows: late ones do not drift it)
            step = 1.0 / SCENE_RATE
            next_scene = next_scene + step if t < next_scene + step else t + step
            drawn = channels[SCENE_FRAMES].has_sinks() or channels[SCENE_WRENCHES].has_sinks()
            if drawn:
                scene.update(arrays["slave_q"], arrays["master_q"])
                arrays.update(pose_RS=scene.pose_RS, pose_BE=scene.pose_BE)
        taken = [name for name in (names if drawn else plain) if channels[name].has_sinks()]
        for name, message in row_messages(t, arrays, taken) if taken else ():
            channels[name].log(encode(message), log_time=log_time)
            logged += 1

    # The recorder spools every row to a file first (a copy), then encodes from it as it can: a
    # loop faster than the encoding loses nothing, and the file is finished at close.
    spool = _Spool(ring.shape[1]) if rate == 0 else None
    read, sent, dropped, logged = 0, 0, 0, 0
    try:
        while True:
            stopping = head[1] != 0.0
            written, t0 = int(head[0]), int(origin[0])
            while True:
                try:
                    size = events.recv_into(event_buffer)
                except BlockingIOError:
                    break
                topic, t, message = pickle.loads(memoryview(event_buffer)[:size])
                if not channels[topic].has_sinks():
                    continue
                if isinstance(message, bytes):
                    message = event_from_lcm(topic, message)
                channels[topic].log(encode(message), log_time=t0 + round(t * 1e9))
                logged += 1
            if written - read > rows:
                dropped += written - read - rows
                read = written - rows
            for i in range(read, written):
                row = ring[i % rows].copy()
                if int(head[0]) - i >= rows:  # overwritten while copied
                    dropped += 1
                elif spool is None:
                    send(t0 + round(row[0] * 1e9), row)
                    sent += 1
                else:
                    spool.add(t0 + round(row[0] * 1e9), row)
            read = written
            deadline = time.monotonic() + POLL  # then back to the ring
            while spool is not None and spool.pending and time.monotonic() < deadline:
                for log_time, row in spool.take(8):
                    send(log_time, row)
                    sent += 1
            if stopping and int(head[0]) == read and not (spool and spool.pending):
                break
            if not (spool and spool.pending):
                time.sleep(POLL if rate == 0 else min(POLL, 0.5 / rate))
    finally:
        stop()
        events.close()
        if spool is not None:
            spool.close()
        replies.put({"rows": sent, "dropped": dropped, "messages": logged})


class _Spool:
    """Rows of ``columns`` floats with their log times (ns), appended to an unlinked temporary
    file and taken back in order."""

    def __init__(self, columns: int):
        self._record = np.dtype([("log_time", np.int64), ("row", np.float64, columns)])
        self._file = tempfile.TemporaryFile(prefix="heft-record-")
        self._added = self._taken = 0

    @property
    def pending(self) -> int:
        return self._added - self._taken

    def add(self, log_time: int, row) -> None:
        record = np.empty((), self._record)
        record["log_time"], record["row"] = log_time, row
        os.pwrite(self._file.fileno(), record.tobytes(), self._added * self._record.itemsize)
        self._added += 1

    def take(self, most: int):
        """Up to ``most`` of the rows not yet taken, as (log time, row)."""
        count = min(most, self.pending)
        data = os.pread(self._file.fileno(), count * self._record.itemsize, self._taken * self._record.itemsize)
        self._taken += count
        records = np.frombuffer(data, dtype=self._record)
        return [(int(record["log_time"]), record["row"]) for record in records]

    def close(self) -> None:
        self._file.close()
