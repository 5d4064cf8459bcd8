"""The load estimate the controller uses, and its file: ``estimate.yaml``, written by
``heft identify`` (simulated or on hardware) and read by ``heft simulate``, ``heft teleop``
and ``heft load``, through the one writer and the one validating reader here."""

import dataclasses
from pathlib import Path

import numpy as np
import yaml

from heft.systems.accelerometer_calibration import AccelerometerCalibration
from heft.systems.load_dynamics import InertialParameters, checked_load, inertia_entries


@dataclasses.dataclass
class LoadEstimate:
    """The load model the controller uses: φ̂ (Eq. 6) and offsets [f_o; τ_o] (N, N·m)."""
    phi: np.ndarray
    offsets: np.ndarray


def estimate_record(result, method: str, signals: str, samples: int) -> dict:
    """The estimate.yaml content for one method's result."""
    phi, offsets = np.asarray(result.phi, dtype=float), np.asarray(result.offsets, dtype=float)
    std = np.sqrt(np.clip(np.diag(np.asarray(result.covariance, dtype=float)), 0, None))
    record = {"method": method, "signals": signals, "samples": int(samples),
              "phi": phi.tolist(), "offsets": offsets.tolist(),
              "std_offsets": std[:6].tolist(), "std_phi": std[6:].tolist(),
              "identifiable": [bool(x) for x in np.asarray(result.identifiable)]}
    if phi[0] > 0:
        body = InertialParameters.from_phi(phi)
        record.update(mass=float(body.mass), com=body.com.tolist(),
                      inertia_com=inertia_entries(body.inertia_com).tolist(),
                      physical_violations=body.violations())
    return record


def write_load_estimate(path, record: dict, verdict: dict) -> None:
    """Writes an ``estimate_record`` to ``path`` (YAML) with its fit's verdict
    (``analysis.fit_verdict``): whether it was ok, its causes, and whether a fit that was not
    ok was accepted (``heft identify --accept-fit``)."""
    fit = {"ok": verdict["ok"], "accepted": not verdict["ok"], "causes": verdict["causes"]}
    Path(path).write_text(yaml.safe_dump({**record, "fit": fit}, sort_keys=False))


def read_load_estimate(path, wrench_full_scale=None) -> LoadEstimate:
    """φ̂ and offsets from an estimate.yaml written by ``heft identify``, checked by
    ``checked_load`` (against the sensor's range ``wrench_full_scale``, N, N·m, if given)."""
    path = Path(path)
    try:
        data = yaml.safe_load(path.read_text())
        phi, offsets = np.asarray(data["phi"], dtype=float), np.asarray(data["offsets"], dtype=float)
    except (OSError, yaml.YAMLError, KeyError, TypeError, ValueError) as error:
        raise ValueError(f"cannot read a load estimate from {path}: {error}; "
                         "write one with `heft identify --scenario FILE --out DIR`") from None
    try:
        phi, offsets = checked_load(phi, offsets, wrench_full_scale)
    except ValueError as error:
        raise ValueError(f"{path}: {error}") from None
    return LoadEstimate(phi=phi, offsets=offsets)


def read_accelerometer_calibration(path) -> AccelerometerCalibration | None:
    """The accelerometer's calibration an estimate.yaml carries (its optional ``accelerometer`` section:
    R_SA, bias, scale, unit; ``accelerometer_calibration``), or None if it has none."""
    path = Path(path)
    try:
        section = (yaml.safe_load(path.read_text()) or {}).get("accelerometer")
        return None if section is None else AccelerometerCalibration(
            np.asarray(section["R_SA"], dtype=float), np.asarray(section["bias"], dtype=float),
            float(section.get("scale", 1.0)), section.get("unit", "m/s^2"))
    except (OSError, yaml.YAMLError, KeyError, TypeError, ValueError, AttributeError) as error:
        raise ValueError(f"{path}: cannot read the accelerometer's calibration: {error}") from None
