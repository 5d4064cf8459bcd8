"""Which incoming stamps to accept: newer ones, and those of a restarted driver.

UDP may deliver a message late or twice; a receiver keeps only messages whose
stamp advances. A driver that restarts, though, stamps from its own zero again:
a message stamped far *before* the last accepted one cannot be a late packet
(the network reorders by milliseconds) and is taken as the first message of a
new session, so the station recovers instead of ignoring the driver forever.
"""

RESTART_JUMP = 0.5
"""A stamp this much (s) before the last accepted one marks a restarted driver."""


def restarted(stamp: float, last: float) -> bool:
    """True if ``stamp`` (s) is so much older than ``last`` (s) that its driver restarted."""
    return stamp < last - RESTART_JUMP


def stamp_accepted(stamp: float, last: float) -> bool:
    """True if a message stamped ``stamp`` (s) follows one stamped ``last`` (s): it is newer,
    or its driver restarted."""
    return stamp > last or restarted(stamp, last)
