"""A robot controller's setpoint conditioning: joint commands arriving at the
controller rate pass a critically damped second-order filter before the joint
servo, which then gets a smooth [q; q̇] instead of steps (quantised master
motion would otherwise hit the stiff servo as velocity spikes)."""

import numpy as np
from pydrake.systems.framework import EventStatus, LeafSystem
from scipy.linalg import expm

from heft.systems.compiled import compiled


def critically_damped_dynamics(bandwidth_hz: float) -> tuple[np.ndarray, np.ndarray]:
    """The filter of one joint, q̈ = ω²(u − q) − 2ωq̇ with ω = 2π·bandwidth (rad/s), as
    d/dt [q; q̇] = F·[q; q̇] + G·u: (F (2, 2), G (2,))."""
    w = 2 * np.pi * bandwidth_hz
    return np.array([[0.0, 1.0], [-w * w, -2 * w]]), np.array([0.0, w * w])


def critically_damped_step_matrices(bandwidth_hz: float, period: float):
    """Exact zero-order-hold discretisation (A_d, B_d) of ``critically_damped_dynamics`` for one
    joint, state [q; q̇]."""
    F, G = critically_damped_dynamics(bandwidth_hz)
    continuous = np.zeros((3, 3))
    continuous[:2, :2], continuous[:2, 2] = F, G
    step = expm(continuous * period)
    return step[:2, :2], step[:2, 2]


@compiled("void(float64[:, :], float64[:], float64[:, :], float64[:])")
def setpoint_step(A, B, state, u) -> None:
    """One step of the filter ``critically_damped_step_matrices`` gives, in place on every joint:
    [q; q̇] ← A·[q; q̇] + B·u with ``state`` (2, n) and the setpoint ``u`` (n,)."""
    for k in range(u.shape[0]):
        q, qd = state[0, k], state[1, k]
        state[0, k] = A[0, 0] * q + A[0, 1] * qd + B[0] * u[k]
        state[1, k] = A[1, 0] * q + A[1, 1] * qd + B[1] * u[k]


class SetpointFilter(LeafSystem):
    """Input ``position`` (n, rad) → output ``state`` [q_f; q̇_f] (2n), updated every ``period`` s.

    Critically damped with the given bandwidth (Hz): unity static gain, no overshoot.
    Starts at rest at the first input (initialization event); until then (e.g. while other
    systems' initialization events read it) at rest at ``initial_position``. Output is
    state: no feedthrough.
    """

    def __init__(self, initial_position, bandwidth_hz: float, period: float):
        super().__init__()
        if not (bandwidth_hz > 0 and period > 0):
            raise ValueError(f"bandwidth_hz and period must be > 0; got {bandwidth_hz}, {period}")
        A, B = critically_damped_step_matrices(bandwidth_hz, period)
        # The same 2×2 filter on every joint, applied to the (2, n) array [q_f; q̇_f].
        self._A, self._B = A, B
        initial_position = np.asarray(initial_position, dtype=float)
        size = self._size = initial_position.size
        self._input = self.DeclareVectorInputPort("position", size)
        self._state = self.DeclareDiscreteState(np.concatenate((initial_position, np.zeros(size))))
        self.DeclareInitializationDiscreteUpdateEvent(self._start)
        self.DeclarePeriodicDiscreteUpdateEvent(period, 0.0, self._update)
        self.DeclareStateOutputPort("state", self._state)

    def _start(self, context, discrete_state):
        discrete_state.set_value(self._state, np.concatenate((self._input.Eval(context), np.zeros(self._size))))
        return EventStatus.Succeeded()

    def _update(self, context, discrete_state):
        # discrete_state holds the current state: stepped in place.
        setpoint_step(self._A, self._B, discrete_state.get_mutable_value(self._state).reshape(2, self._size),
                      self._input.Eval(context))
