"""The client side of the Foxglove WebSocket protocol, ``foxglove.websocket.v1``, written here on
websocket-client, for the live view's tests. foxglove-sdk serves that protocol under its new name
``foxglove.sdk.v1`` only (the same messages), so the client offers both names, as Foxglove and
Lichtblick do. It subscribes to every channel the server advertises. Light to import (no Drake), so
that a test can run it as a process of its own (``foxglove_listen.py``)."""

import json
import socket
import struct
import threading
import time

import websocket

SUBPROTOCOLS = ["foxglove.websocket.v1", "foxglove.sdk.v1"]
"""The protocol's two names: the specification's, and the one foxglove-sdk answers to."""
MESSAGE_DATA = 0x01


class FoxgloveClient:
    """The client side of foxglove.websocket.v1: the advertised channels, and every message of each
    channel it subscribed to as (channel topic, log time (ns), decoded JSON). While it receives it keeps
    the payloads as they came (``raw``: cheap, so that a busy machine's client falls behind less), and
    decodes them when ``messages`` is read."""

    def __init__(self, url: str, timeout: float, server_alive=lambda: True):
        deadline = time.monotonic() + timeout
        while True:
            try:
                self.socket = websocket.create_connection(url, subprotocols=SUBPROTOCOLS, timeout=5)
                break
            except (ConnectionRefusedError, websocket.WebSocketException, OSError):
                if time.monotonic() > deadline or not server_alive():
                    raise
                time.sleep(0.2)
        assert self.socket.getsubprotocol() in SUBPROTOCOLS
        self.socket.settimeout(0.2)
        self.channels, self.subscribed, self.raw, self._messages = {}, {}, [], []

    @property
    def messages(self) -> list:
        """(topic, log time (ns), message) of every message received so far."""
        for topic, log_time, payload in self.raw[len(self._messages):]:
            self._messages.append((topic, log_time, json.loads(payload)))
        return self._messages

    def receive(self, until: float) -> bool:
        """Handles what the server sends until ``until`` (monotonic s) or it closes; whether it is still open."""
        while time.monotonic() < until:
            try:
                opcode, data = self.socket.recv_data()
            except websocket.WebSocketTimeoutException:
                continue
            except (websocket.WebSocketConnectionClosedException, ConnectionError):
                return False
            if opcode == websocket.ABNF.OPCODE_CLOSE:
                return False
            if opcode == websocket.ABNF.OPCODE_TEXT:
                self._control(json.loads(data))
            elif opcode == websocket.ABNF.OPCODE_BINARY and data[0] == MESSAGE_DATA:
                subscription, log_time = struct.unpack_from("<IQ", data, 1)
                self.raw.append((self.subscribed[subscription], log_time, data[13:]))
        return True

    def _control(self, message: dict) -> None:
        if message["op"] == "advertise":
            new = []
            for channel in message["channels"]:
                if channel["id"] in self.channels:  # advertised again: already subscribed
                    continue
                self.channels[channel["id"]] = channel
                subscription = len(self.subscribed) + 1
                self.subscribed[subscription] = channel["topic"]
                new.append({"id": subscription, "channelId": channel["id"]})
            if new:
                self.socket.send(json.dumps({"op": "subscribe", "subscriptions": new}))


def wait_for_channels(client: FoxgloveClient, listening: threading.Thread, timeout: float = 30.0) -> None:
    """Until the server has advertised its channels and the client subscribed (a failure, not a hang, if never)."""
    deadline = time.monotonic() + timeout
    while not client.channels:
        assert listening.is_alive() and time.monotonic() < deadline, "the live view advertised no channel"
        time.sleep(0.01)


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]
