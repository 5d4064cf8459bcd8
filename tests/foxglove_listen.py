"""A Foxglove WebSocket client as a process of its own, for a live view inside a test's network namespace
(`ip netns exec NS python foxglove_listen.py …`): ``foxglove_client.FoxgloveClient`` subscribed to every
advertised channel until the server closes (or ``--timeout`` s), then the channels and every message
written to OUT as JSON ({"channels": [...], "messages": [[topic, log time (ns), message], ...]}).

It prints "subscribed" once the server has advertised its channels, and "seen N TOPIC" once N messages of
``--enough TOPIC N`` have come, so that the test can wait for what it needs.

    python foxglove_listen.py ws://127.0.0.1:8765 out.json --enough /wrench/contact 300
"""

import argparse
import json
import sys
import time
from pathlib import Path

from foxglove_client import FoxgloveClient


def main() -> int:
    parser = argparse.ArgumentParser()
    parser.add_argument("url")
    parser.add_argument("out", type=Path)
    parser.add_argument("--enough", nargs=2, metavar=("TOPIC", "N"), default=None)
    parser.add_argument("--timeout", type=float, default=300.0, help="s at most, connecting included")
    args = parser.parse_args()
    deadline = time.monotonic() + args.timeout
    client = FoxgloveClient(args.url, timeout=args.timeout)
    announced, open_ = set(), True
    while open_ and time.monotonic() < deadline:
        open_ = client.receive(min(deadline, time.monotonic() + 0.2))
        if client.channels and "subscribed" not in announced:
            announced.add("subscribed")
            print("subscribed", flush=True)
        if args.enough and "seen" not in announced:
            topic, count = args.enough[0], int(args.enough[1])
            if sum(message[0] == topic for message in client.raw) >= count:
                announced.add("seen")
                print(f"seen {count} {topic}", flush=True)
    args.out.write_text(json.dumps({"channels": list(client.channels.values()), "messages": client.messages}))
    print(f"closed by the server: {not open_}; {len(client.messages)} messages", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
