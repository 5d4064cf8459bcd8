"""The load estimate the controller uses, and its file: ``estimate.yaml``, written by
``heft identify`` (simulated, on hardware or from a recording) and read by ``heft simulate``,
``heft teleop`` and ``heft load``, through the one writer and the one validating reader here.

Its schema: ``phi``, ``offsets`` (what the controller uses), their standard deviations, which
entries the data identified, the fit's verdict (``fit``) and, where the data calibrated the
accelerometer (static poses with its readings), ``accelerometer``: {R_SA, bias, scale, unit} as
``systems.accelerometer_calibration`` defines them."""

import dataclasses
from pathlib import Path

import numpy as np
import yaml

from heft.systems.accelerometer_calibration import AccelerometerCalibration
from heft.systems.load_dynamics import InertialParameters, checked_load, inertia_entries


@dataclasses.dataclass
class LoadEstimate:
    """The load model the controller uses: φ̂ (Eq. 6) and offsets [f_o; τ_o] (N, N·m); the
    accelerometer's calibration when the estimate carries one; ``residual_rms`` (6,) the wrench residual
    per axis its fit left (N, N·m) when it was fitted to samples (not averaged static poses)."""
    phi: np.ndarray
    offsets: np.ndarray
    accelerometer: AccelerometerCalibration | None = None
    residual_rms: np.ndarray | None = None


def estimate_record(result, method: str, signals: str, samples: int) -> dict:
    """The estimate.yaml content for one method's result."""
    phi, offsets = np.asarray(result.phi, dtype=float), np.asarray(result.offsets, dtype=float)
    std = np.sqrt(np.clip(np.diag(np.asarray(result.covariance, dtype=float)), 0, None))
    record = {"method": method, "signals": signals, "samples": int(samples),
              "phi": phi.tolist(), "offsets": offsets.tolist(),
              "std_offsets": std[:6].tolist(), "std_phi": std[6:].tolist(),
              "identifiable": [bool(x) for x in np.asarray(result.identifiable)]}
    if signals != "static poses":  # an averaged pose's residual is not a sample's
        record["residual_rms"] = np.asarray(result.residual_rms, dtype=float).tolist()
    if phi[0] > 0:
        body = InertialParameters.from_phi(phi)
        record.update(mass=float(body.mass), com=body.com.tolist(),
                      inertia_com=inertia_entries(body.inertia_com).tolist(),
                      physical_violations=body.violations())
    return record


def write_load_estimate(path, record: dict, verdict: dict,
                        accelerometer: AccelerometerCalibration | None = None) -> None:
    """Writes an ``estimate_record`` to ``path`` (YAML) with its fit's verdict
    (``analysis.fit_verdict``): whether it was ok, its causes, and whether a fit that was not
    ok was accepted (``heft identify --accept-fit``); and the accelerometer's calibration if given."""
    fit = {"ok": verdict["ok"], "accepted": not verdict["ok"], "causes": verdict["causes"]}
    extra = {} if accelerometer is None else {"accelerometer": accelerometer.as_dict()}
    Path(path).write_text(yaml.safe_dump({**record, "fit": fit, **extra}, sort_keys=False))


def read_load_estimate(path, wrench_full_scale=None) -> LoadEstimate:
    """φ̂, offsets and the accelerometer's calibration (if any) from an estimate.yaml written by
    ``heft identify``, checked by ``checked_load`` (against the sensor's range ``wrench_full_scale``,
    N, N·m, if given) and ``AccelerometerCalibration``."""
    path = Path(path)
    try:
        data = yaml.safe_load(path.read_text())
        phi, offsets = np.asarray(data["phi"], dtype=float), np.asarray(data["offsets"], dtype=float)
        calibration = data.get("accelerometer")
        residual = None if data.get("residual_rms") is None else np.asarray(data["residual_rms"], dtype=float)
    except (OSError, yaml.YAMLError, KeyError, TypeError, ValueError, AttributeError) as error:
        raise ValueError(f"cannot read a load estimate from {path}: {error}; "
                         "write one with `heft identify --scenario FILE --out DIR`") from None
    try:
        phi, offsets = checked_load(phi, offsets, wrench_full_scale)
        if calibration is not None:
            if not isinstance(calibration, dict) or set(calibration) != {"R_SA", "bias", "scale", "unit"}:
                raise ValueError(f"accelerometer must hold R_SA, bias, scale and unit; got {calibration!r}")
            calibration = AccelerometerCalibration(**calibration)
    except (ValueError, TypeError) as error:
        raise ValueError(f"{path}: {error}") from None
    if residual is not None and (residual.shape != (6,) or not np.isfinite(residual).all() or (residual < 0).any()):
        raise ValueError(f"{path}: residual_rms needs 6 finite numbers >= 0 (N, N·m); got {residual.tolist()}")
    return LoadEstimate(phi=phi, offsets=offsets, accelerometer=calibration, residual_rms=residual)


def read_accelerometer_calibration(path) -> AccelerometerCalibration | None:
    """The accelerometer's calibration an estimate.yaml carries (``read_load_estimate``), or None."""
    return read_load_estimate(path).accelerometer
