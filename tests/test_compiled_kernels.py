"""The compiled per-tick kernels equal the plain Python they are written in (``HEFT_PURE_PYTHON=1``,
the fallback where numba is missing), run in a process of its own on the same inputs."""

import os
import subprocess
import sys

import numpy as np

from heft.systems import compiled

_KERNELS = r"""
import sys
import numpy as np
from heft.diagrams.plants import MakeArmPlant
from heft.systems import compiled
from heft.systems.load_dynamics import GRAVITY_W, regressor_into
from heft.systems.sensor_models import ForceTorqueSensorParams, HeldLowpass, SixAxisMeasurement, lowpass_coefficients
from heft.systems.serial_chain import SerialChain
from heft.systems.setpoint_filter import critically_damped_step_matrices, setpoint_step

rng = np.random.default_rng(11)
plant, S = MakeArmPlant("rx90")
chain = SerialChain(plant, plant.world_frame(), S, GRAVITY_W)
out = {"pure_python": np.array(compiled.PURE_PYTHON), "motion": [], "J": [], "V": []}
for _ in range(10):
    q, qd, qdd = rng.uniform(-2, 2, (3, 6))
    chain.update(q, qd, qdd)
    out["motion"].append(chain.motion.copy())
    out["J"].append(chain.J.copy())
    V = np.empty((6, 10))
    regressor_into(*rng.normal(0, 5, (4, 3)), V)
    out["V"].append(V)
params = ForceTorqueSensorParams()
out["measured"], out["saturated"] = SixAxisMeasurement(params, 0, 1 / 8000).measure(
    rng.normal(0, 1, (64, 6)) * np.array(params.full_scale))
held, state = HeldLowpass(lowpass_coefficients(500.0, 1 / 8000), 4), rng.normal(0, 1, (2, 6))
out["held"] = np.concatenate([held(state, value) for value in rng.normal(0, 50, (20, 6))])
A, B = critically_damped_step_matrices(10.0, 5e-4)
x = np.zeros((2, 6))
for u in rng.uniform(-1, 1, (50, 6)):
    setpoint_step(A, B, x, u)
out["setpoint"] = x
np.savez(sys.argv[1], **{name: np.asarray(value) for name, value in out.items()})
"""


def run_kernels(path, pure_python: bool) -> dict:
    env = dict(os.environ, HEFT_PURE_PYTHON="1" if pure_python else "0")
    subprocess.run([sys.executable, "-c", _KERNELS, str(path)], env=env, check=True, timeout=300)
    with np.load(path) as data:
        return dict(data)


def test_the_plain_python_kernels_equal_the_compiled_ones(tmp_path):
    assert not compiled.PURE_PYTHON, "numba is a dependency: the test suite runs the compiled kernels"
    fallback = run_kernels(tmp_path / "python.npz", pure_python=True)
    machine_code = run_kernels(tmp_path / "compiled.npz", pure_python=False)
    assert fallback.pop("pure_python") and not machine_code.pop("pure_python")
    assert fallback.keys() == machine_code.keys()
    for name, expected in fallback.items():
        assert np.abs(expected).max() > 0, name
        np.testing.assert_allclose(machine_code[name], expected, rtol=1e-13, atol=1e-13, err_msg=name)
