"""A smooth motion of a load on a free wrist sensor with every quantity from Drake: R_WS from roll-pitch-yaw
angles, ω and α through Drake's RollPitchYaw rate maps, the wrench from the plant's weld reaction
(``LoadOnSensorPlant``). The independent reference for recordings (tests/test_recording*.py)."""

from __future__ import annotations

import dataclasses

import numpy as np
from pydrake.math import RollPitchYaw

from heft.diagrams.plants import load_phi
from heft.diagrams.scenario import Scenario
from heft.diagrams.stations.load_on_sensor import LoadOnSensorPlant
from heft.systems.load_dynamics import InertialParameters

PAPER_TOOL = InertialParameters.from_phi(load_phi(Scenario().load))
"""The paper's tool (3.13 kg) as the bundled scenarios model it (diagrams/models/tool.urdf)."""


def _angular_acceleration(angles: RollPitchYaw, rpy_dt, rpy_ddt) -> np.ndarray:
    """α in the parent frame for the rpy angles' rates: Drake maps α → rpy_ddt (affine in α), inverted."""
    bias = angles.CalcRpyDDtFromRpyDtAndAngularAccelInParent(rpy_dt, np.zeros(3))
    M = np.column_stack([angles.CalcRpyDDtFromRpyDtAndAngularAccelInParent(rpy_dt, e) - bias for e in np.eye(3)])
    return np.linalg.solve(M, rpy_ddt - bias)


@dataclasses.dataclass
class SmoothMotion:
    """rpy(t) = A·sin(2πft + φ) (rad) and p_WS(t) = B·sin(2πgt + ψ) (m), per axis."""
    rpy_amplitude: tuple = (0.6, 0.5, 0.8)
    rpy_frequency: tuple = (0.7, 1.1, 0.9)
    rpy_phase: tuple = (0.3, 1.0, 2.0)
    p_amplitude: tuple = (0.15, 0.1, 0.2)
    p_frequency: tuple = (1.3, 0.8, 1.6)
    p_phase: tuple = (0.0, 0.5, 1.5)

    @staticmethod
    def _sines(t, amplitude, frequency, phase):
        w = 2 * np.pi * np.asarray(frequency)
        arg = np.outer(t, w) + np.asarray(phase)
        A = np.asarray(amplitude)
        return A * np.sin(arg), A * w * np.cos(arg), -A * w * w * np.sin(arg)

    def truth(self, t, load: InertialParameters = PAPER_TOOL):
        """At the times t (N,): dict of R_WS (N, 3, 3), the wrench the sensor exerts on the load (N, 6),
        and S's a, α, ω, g in S (N, 3 each), all from Drake."""
        rpy, rpy_dt, rpy_ddt = self._sines(t, self.rpy_amplitude, self.rpy_frequency, self.rpy_phase)
        p, v, a = self._sines(t, self.p_amplitude, self.p_frequency, self.p_phase)
        plant = LoadOnSensorPlant(load)
        out = {key: np.empty((len(t), n)) for key, n in (("wrench", 6), ("a", 3), ("alpha", 3), ("omega", 3),
                                                          ("g", 3))}
        out["R_WS"] = np.empty((len(t), 3, 3))
        for k in range(len(t)):
            angles = RollPitchYaw(rpy[k])
            R = angles.ToRotationMatrix()
            omega_W = angles.CalcAngularVelocityInParentFromRpyDt(rpy_dt[k])
            alpha_W = _angular_acceleration(angles, rpy_dt[k], rpy_ddt[k])
            q = np.concatenate((R.ToQuaternion().wxyz(), p[k]))
            state_v = np.concatenate((omega_W, v[k]))
            vdot = np.concatenate((alpha_W, a[k]))
            out["wrench"][k] = plant.reaction_wrench(q, state_v, vdot)
            out["a"][k], out["alpha"][k], out["omega"][k], out["g"][k] = plant.motion_in_S(q, state_v, vdot)
            out["R_WS"][k] = R.matrix()
        return out
