"""The sensor's offsets at run time: re-zero on request, slow tracking at rest (Eq. 7's o).

A JR3's offsets drift with temperature over minutes (``sensor_models``: a warm-up
of some tenths of a newton, then a random walk). With the load's φ̂ known, the
contact wrench c = f − o − V·φ̂ (Eq. 13) is zero at rest in free space up to the
noise, so there c + o = f − V·φ̂ measures the offsets. Two ways to use it:

* Re-zero (on request): over ``rezero_window`` s, o ← mean(c + o). Refused, and
  the offsets kept, if during the window the slave moves, the wrench looks like
  contact (|c| beyond ``rezero_force``/``rezero_torque``: larger than any drift),
  or a sample is faulted.
* Tracking (optional, on by default): at rest and out of contact (|c| within
  ``controller.contact``, ``ContactThresholdParams``), o moves toward c + o with time constant
  ``time_constant``, by at most ``max_force_rate``/``max_torque_rate`` per second
  (so a light contact held still leaks into o at that rate at most).

"At rest": every slave joint slower than ``rest_joint_speed`` (the encoders'
velocity, independent of the wrench). Wrenches [f; τ] on the load at S, in S
(N, N·m). The state is a flat vector (``STATE_SIZE``) so that a LeafSystem can
keep it as discrete state; ``offsets_update_into`` is the one update, which ``OffsetTracker`` declares.
"""

import numpy as np

from heft.systems.controller.contact_threshold import ContactThresholdParams
from heft.systems.compiled import compiled, float_array
from heft.systems.load_dynamics import beyond
from heft.systems.controller.offset_tracking_params import OffsetTrackingParams
from heft.systems.tick_system import TickSystem

# Layout of the state: offsets, the re-zero window's sum of (c + o)·dt and its length (s),
# the re-zero status, tracking on (1) or off (0), the last re-zero request counter seen.
OFFSETS, WINDOW_SUM, WINDOW_TIME, STATUS, TRACKING, REQUESTS = slice(0, 6), slice(6, 12), 12, 13, 14, 15
STATE_SIZE = 16

IDLE, COLLECTING, DONE, REFUSED_MOVING, REFUSED_CONTACT, REFUSED_FAULT = range(6)
STATUS_TEXT = {
    IDLE: "no re-zero requested",
    COLLECTING: "re-zeroing: hold the slave still and out of contact",
    DONE: "re-zeroed: offsets measured at rest",
    REFUSED_MOVING: "re-zero refused: the slave moved; hold it still (clutch released) and ask again",
    REFUSED_CONTACT: "re-zero refused: the wrench looks like contact; free the tool and ask again",
    REFUSED_FAULT: "re-zero refused: a sensor sample was faulted; check the sensor and ask again",
}


def initial_state(offsets, params: OffsetTrackingParams) -> np.ndarray:
    """The state at start: ``offsets`` (6; N, N·m), no re-zero, tracking as ``params`` says."""
    state = np.zeros(STATE_SIZE)
    state[OFFSETS] = offsets
    state[TRACKING] = 1.0 if params.tracking else 0.0
    return state


@compiled("void(float64[:])")
def restart_rezero_window(state) -> None:
    """Empties the re-zero window (a re-zero under way starts averaging afresh)."""
    for i in range(6):
        state[6 + i] = 0.0  # WINDOW_SUM
    state[WINDOW_TIME] = 0.0


def offsets_update(state: np.ndarray, contact, fault: bool, slave_velocity, dt: float, params: OffsetTrackingParams,
                   thresholds: ContactThresholdParams, requests: float) -> None:
    """One tick, in place: ``contact`` c (6) of this tick computed with the state's offsets,
    ``fault`` (c not computed), ``slave_velocity`` q̇_S (n, rad/s), ``dt`` (s), ``thresholds`` of
    contact (``controller.contact``), ``requests`` the re-zero request counter (a re-zero starts
    whenever it exceeds the last one seen). ``offsets_update_into`` with the settings as numbers."""
    offsets_update_into(state, float_array(contact), fault, float_array(slave_velocity), dt, *kernel_settings(params),
                        float(thresholds.force), float(thresholds.torque), float(requests))


KERNEL_SETTINGS = ("rest_joint_speed", "rezero_window", "rezero_force", "rezero_torque", "time_constant",
                   "max_force_rate", "max_torque_rate")
"""The fields of ``OffsetTrackingParams`` that ``offsets_update_into`` takes, in its order."""


def kernel_settings(params: OffsetTrackingParams) -> tuple[float, ...]:
    """``params`` as ``offsets_update_into`` takes them (``KERNEL_SETTINGS``)."""
    return tuple(float(getattr(params, name)) for name in KERNEL_SETTINGS)


@compiled("void(float64[:], float64[:], boolean, float64[:], float64, float64, float64, float64, float64, float64, "
          "float64, float64, float64, float64, float64)")
def offsets_update_into(state, contact, fault, slave_velocity, dt, rest_joint_speed, rezero_window, rezero_force,
                        rezero_torque, time_constant, max_force_rate, max_torque_rate, contact_force, contact_torque,
                        requests) -> None:
    """``offsets_update`` with ``OffsetTrackingParams`` (``kernel_settings``) and the contact thresholds
    (N, N·m) as numbers."""
    if requests > state[REQUESTS]:
        state[REQUESTS] = requests
        state[STATUS] = COLLECTING
        restart_rezero_window(state)
    at_rest = True
    for i in range(slave_velocity.shape[0]):
        if not abs(slave_velocity[i]) < rest_joint_speed:
            at_rest = False
    if state[STATUS] == COLLECTING:
        if fault:
            state[STATUS] = REFUSED_FAULT
        elif not at_rest:
            state[STATUS] = REFUSED_MOVING
        elif beyond(contact, rezero_force, rezero_torque):
            state[STATUS] = REFUSED_CONTACT
        else:
            for i in range(6):  # WINDOW_SUM, OFFSETS
                state[6 + i] += (contact[i] + state[i]) * dt
            state[WINDOW_TIME] += dt
            if state[WINDOW_TIME] >= rezero_window:
                for i in range(6):
                    state[i] = state[6 + i] / state[WINDOW_TIME]
                state[STATUS] = DONE
        return
    if state[TRACKING] > 0.5 and not fault and at_rest and not beyond(contact, contact_force, contact_torque):
        gain = dt / time_constant
        for i in range(6):
            step = (max_force_rate if i < 3 else max_torque_rate) * dt
            state[i] += min(max(gain * contact[i], -step), step)


ESTIMATE_SIZE = 17
"""A new estimate as the blocks take it: [request counter, φ (10), offsets (6; N, N·m)]."""


@compiled("void(float64[:], float64[:], float64[:], float64[:], float64[:], float64[:], float64[:], float64[:], "
          "float64[:])")
def offset_tracker_update(state, estimates_seen, contact, fault, slave_velocity, rezero, tracking, estimate,
                          settings):
    """``offsets_update_into`` on the block's arrays: ``fault`` (1, > 0.5 faulted), ``rezero`` (1, the request
    counter), ``tracking`` (1, > 0.5 on), ``estimate`` (``ESTIMATE_SIZE``: a new estimate's offsets replace the
    state's when its counter passes ``estimates_seen`` (1), a re-zero under way restarting its window),
    ``settings`` [dt (s), ``kernel_settings``…, contact force (N), contact torque (N·m)]."""
    if estimate[0] > estimates_seen[0]:
        estimates_seen[0] = estimate[0]
        for i in range(6):
            state[i] = estimate[11 + i]
        restart_rezero_window(state)
    state[TRACKING] = 1.0 if tracking[0] > 0.5 else 0.0
    offsets_update_into(state, contact, fault[0] > 0.5, slave_velocity, settings[0], settings[1], settings[2],
                        settings[3], settings[4], settings[5], settings[6], settings[7], settings[8], settings[9],
                        rezero[0])


class OffsetTracker(TickSystem):
    """The offsets Ô for force scaling, re-zeroed on request and tracked at rest
    (module docstring), updated every ``period`` s.

    Inputs: ``wrench_contact`` (6, c from force scaling), ``fault`` (1, force scaling's),
    ``slave_velocity`` (``num_joints``, rad/s), ``rezero`` (1, optional: a request counter; each
    increase starts one re-zero), ``tracking`` (1, optional: > 0.5 tracks; unconnected,
    ``params.tracking``), ``estimate`` (``ESTIMATE_SIZE``, optional: a new tool's, whose offsets
    replace the tracked ones). Outputs (state): ``offsets`` (6; N, N·m), ``rezero_status`` (1, a code
    of ``STATUS_TEXT``) and ``rezero`` (the state: ``OFFSETS`` … ``REQUESTS``). The update reads c of
    the same tick, computed with the offsets in effect. The block keeps its state when the controller
    restarts (``kept_on_restart``).
    """

    kept_on_restart = True

    def __init__(self, offsets, params: OffsetTrackingParams, thresholds: ContactThresholdParams, period: float,
                 num_joints: int = 6):
        params.validate()
        thresholds.validate()
        super().__init__(period)
        self.settings = np.array((period, *kernel_settings(params), thresholds.force, thresholds.torque), dtype=float)
        self.DeclareTickInput("wrench_contact", 6)
        self.DeclareTickInput("fault", 1)
        self.DeclareTickInput("slave_velocity", num_joints)
        self.DeclareTickInput("rezero", 1, [0.0])
        self.DeclareTickInput("tracking", 1, [1.0 if params.tracking else 0.0])
        self.DeclareTickInput("estimate", ESTIMATE_SIZE, np.zeros(ESTIMATE_SIZE))
        self.DeclareTickState("state", initial_state(offsets, params))
        self.DeclareTickState("estimates_seen", [0.0])
        self.DeclareTickOutput("offsets", "x:state", OFFSETS.start, OFFSETS.stop)
        self.DeclareTickOutput("rezero_status", "x:state", STATUS, STATUS + 1)
        self.DeclareTickOutput("rezero", "x:state")
        self.DeclareTickUpdate(offset_tracker_update, "next:state", "next:estimates_seen", "in:wrench_contact",
                               "in:fault", "in:slave_velocity", "in:rezero", "in:tracking", "in:estimate",
                               self.settings)
