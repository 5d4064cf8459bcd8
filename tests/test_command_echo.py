"""``CommandEcho``: how late the arm stepped on the commands sent, from its status's echo, against
sequences written out by hand (an arm stepping every 0.5 ms, each command answering a status)."""

import numpy as np
import pytest

from heft.hardware_interface.command_echo import SENT_KEEP, CommandEcho

STEP_US = 500
JOINTS = 7
"""An iiwa's: the echo is compared joint by joint, whatever the arm."""


def _command(k: int) -> np.ndarray:
    """The command answering the status of step k (distinct for every k)."""
    return np.array([0.1, -0.2, 0.3, 0.0, 0.5, 1.0, -0.7]) + 1e-4 * k


def test_commands_taken_on_time_lag_nothing():
    echo = CommandEcho(STEP_US * 1e-6, JOINTS)
    echo.heard(0, np.zeros(JOINTS))  # before any command: not counted
    for k in range(20):
        echo.sent(_command(k), k * STEP_US)
        echo.heard((k + 1) * STEP_US, _command(k))  # step k + 1 took the answer to step k
        assert echo.lag == 0
    assert echo.summary() == {"statuses": 20, "late": 0, "unmeasured": 0, "max_lag": 0, "max_lag_at": 0.0}


def test_a_pause_shows_as_a_growing_lag():
    """The loop answers step 10, then pauses for eight steps: the arm steps on that answer meanwhile."""
    echo = CommandEcho(STEP_US * 1e-6, JOINTS)
    echo.sent(_command(0), 0)
    echo.heard(STEP_US, _command(0))  # the first status heard after a command: the clock's zero
    for k in range(1, 11):
        echo.sent(_command(k), k * STEP_US)
    lags = []
    for step in range(11, 20):
        echo.heard(step * STEP_US, _command(10))
        lags.append(echo.lag)
    assert lags == [0, 1, 2, 3, 4, 5, 6, 7, 8]
    assert (echo.late, echo.max_lag) == (8, 8) and echo.max_lag_at == pytest.approx(18 * STEP_US * 1e-6)


def test_an_echo_of_no_command_sent_is_not_measured():
    echo = CommandEcho(STEP_US * 1e-6, JOINTS)
    echo.sent(_command(0), 0)
    echo.heard(STEP_US, np.zeros(JOINTS))  # what the driver held before the first command: not counted
    assert (echo.lag, echo.statuses, echo.unmeasured) == (-1, 0, 0)
    echo.sent(_command(1), STEP_US)
    echo.heard(2 * STEP_US, _command(1))
    echo.heard(3 * STEP_US, np.full(6, np.nan))  # a driver echoing something else since
    assert (echo.lag, echo.statuses, echo.unmeasured, echo.late) == (-1, 2, 1, 0)


def test_a_restarted_driver_starts_the_echo_afresh():
    """A driver stamping from zero again: the commands sent before answered its old clock."""
    echo = CommandEcho(STEP_US * 1e-6, JOINTS)
    for k in range(10):
        echo.sent(_command(k), (1000 + k) * STEP_US)
    echo.heard(1010 * STEP_US, _command(9))
    assert echo.lag == 0
    echo.heard(STEP_US, _command(9))  # restarted: not counted, not a lag of minus a thousand steps
    assert (echo.statuses, echo.late, echo.unmeasured) == (1, 0, 0)
    echo.sent(_command(20), STEP_US)
    echo.heard(2 * STEP_US, _command(20))
    assert (echo.lag, echo.statuses) == (0, 2)


def test_the_newest_equal_command_is_the_one_echoed_and_old_ones_are_forgotten():
    echo = CommandEcho(STEP_US * 1e-6, JOINTS)
    for k in range(100):
        echo.sent(_command(k) if k < 98 else _command(97), k * STEP_US)  # the arm at rest: the same command again
    echo.heard(100 * STEP_US, _command(97))
    assert echo.lag == 0  # the answer to step 99
    echo.heard(101 * STEP_US, _command(100 - SENT_KEEP))  # the oldest kept: it answered step 36
    assert echo.lag == 101 - (100 - SENT_KEEP) - 1
    echo.heard(102 * STEP_US, _command(100 - SENT_KEEP - 1))  # one older: forgotten
    assert echo.lag == -1 and echo.unmeasured == 1
