"""``--view`` and ``--view-port``: the live view (``diagrams.live_view``) on the commands that run a loop."""

from __future__ import annotations

from heft.diagrams.live_view import DEFAULT_PORT, LiveView
from heft.diagrams.master_params import DEFAULT_MASTER

VIEW_HOWTO = "open it in Foxglove or Lichtblick: Open connection → Foxglove WebSocket (docs/live_view.md)"


def add_view(parser, port: int = DEFAULT_PORT, what: str = "the run") -> None:
    parser.add_argument("--view", action="store_true",
                        help=f"serve {what} live on ws://localhost:PORT; {VIEW_HOWTO}")
    parser.add_argument("--view-port", type=int, default=port, metavar="PORT",
                        help=f"the live view's port (default {port})")


def view_from(args, robot, master: str = DEFAULT_MASTER) -> LiveView | None:
    """The ``LiveView`` the options ask for (not yet open), or None; ``robot`` (``plants.Robot``) and ``master`` pose
    its scene. A
    ValueError (one line: how to install it) without foxglove-sdk."""
    if not args.view:
        return None
    from heft.analysis.run_export import foxglove_sdk

    foxglove_sdk()
    return LiveView(args.view_port, robot=robot, master=master)
