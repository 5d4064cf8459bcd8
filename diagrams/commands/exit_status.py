"""The exit statuses of every `heft` command, each for one kind of outcome (README, "Exit statuses")."""

from __future__ import annotations

OK = 0
"""The command did its job."""
CHECK_FAILED = 1
"""`heft check`: Eq. 4 disagrees with Drake's dynamics."""
USAGE = 2
"""A usage error or bad input: an unknown option, a malformed file, a value out of range (argparse's own)."""
FIT_REFUSED = 3
"""`heft identify`: the fit's verdict refused the estimate (no estimate.yaml written; ``--accept-fit``)."""
HARDWARE_FAULT = 4
"""A run on hardware stopped: no healthy hardware, or a fault mid-way (forces off, the arm held)."""
LOAD_REFUSED = 5
"""`heft load`: the running controller refused the command (its reason printed)."""
TIMEOUT = 6
"""An answer that did not come in time (`heft load --timeout`)."""

STATUSES = {OK: "ok", CHECK_FAILED: "check failed", USAGE: "usage error or bad input", FIT_REFUSED: "fit refused",
            HARDWARE_FAULT: "hardware fault", LOAD_REFUSED: "load command refused", TIMEOUT: "timeout"}
"""{status: what it means}, as ``heft --help`` lists them."""


def epilog() -> str:
    """The statuses as one line each, for a parser's epilog."""
    return "exit statuses:\n" + "\n".join(f"  {status}  {meaning}" for status, meaning in STATUSES.items())
