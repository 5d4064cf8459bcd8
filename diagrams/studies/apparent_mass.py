"""The apparent mass the operator feels, measured in closed-loop free-space runs.

Scaling the non-contact wrench by σ makes the load feel like a mass σ·m (Kubus & Wahl,
Sec. V), which at the master handle is k_f·s·σ·m (`analysis.apparent_mass.hand_mass`).
Each run here moves the handle fast along one axis in free space (a scenario's operator
motion) with the controller given the load's TRUE parameters, so what is measured is
the loop, not the identification, and fits the force the master renders against:

* hand: the handle's own acceleration (forward kinematics of the master's encoder
  angles, smoothed and differentiated in `analysis.apparent_mass`): what the operator
  feels, the slave's tracking lag included;
* slave: the sensor's true acceleration mapped back to the master (rotated into B and
  divided by s): the force chain from accelerometer to handle alone.

The σ = 0 run's fit (the device's own baseline: rendered force not explained by the
load) is subtracted from each. With the gripper/object split (Eq. 14) σ = 1 keeps the
gripper and η the share of the gripped object.
"""

from __future__ import annotations

import json
import tempfile
from pathlib import Path

from heft.analysis.plotting import plt
import numpy as np
from pydrake.math import RollPitchYaw, RotationMatrix

from heft.analysis.apparent_mass import estimate_apparent_mass, fit_apparent_mass, hand_mass
from heft.diagrams.scenario import Scenario, layered, overrides_text
from heft.diagrams.plants import MakeArmPlant, MakeMasterPlant, Robot, slave_arm
from heft.diagrams.running.sim_identification import identify_in_simulation
from heft.diagrams.running.simulation import run_teleop, true_load, with_sigma
from heft.diagrams.load_estimate import LoadEstimate
from heft.systems.identification.excitation import ExcitationSettings
from heft.systems.controller.master_kinematics import BASE_FRAME, STYLUS_FRAME

SETTLE_TIME = 0.25
"""Time (s) after the operator starts moving that the fits leave out (the start transient)."""


def stylus_positions(master_q, master: str) -> np.ndarray:
    """p_BE (N, 3; m): the stylus origin in the base of the bundled ``master`` at the joint angles (N, 6; rad)."""
    plant = MakeMasterPlant(master)
    context = plant.CreateDefaultContext()
    B, E = plant.GetFrameByName(BASE_FRAME), plant.GetFrameByName(STYLUS_FRAME)
    positions = []
    for q in np.asarray(master_q, dtype=float):
        plant.SetPositions(context, q)
        positions.append(plant.CalcRelativeTransform(context, B, E).translation())
    return np.array(positions)


def sensor_rotations(robot: Robot, slave_q) -> np.ndarray:
    """R_RS (N, 3, 3): the sensor frame's orientation in the slave base at the joint angles (N, n; rad)."""
    plant, S = MakeArmPlant(robot)
    context = plant.CreateDefaultContext()
    R = plant.world_frame()  # the arm's base, welded at W
    rotations = []
    for q in np.asarray(slave_q, dtype=float):
        plant.SetPositions(context, q)
        rotations.append(plant.CalcRelativeTransform(context, R, S).rotation().matrix())
    return np.array(rotations)


def motion_axis(scenario: Scenario) -> np.ndarray:
    """The unit axis (in B) of the operator's translational motion."""
    amplitude = np.asarray(scenario.operator.amplitude, dtype=float)
    norm = float(np.linalg.norm(amplitude))
    if norm == 0.0:
        raise ValueError("the scenario's operator.amplitude is zero: the handle must move for a mass to show")
    return amplitude / norm


def fit_run(scenario: Scenario, log: dict, smoothing: float = 0.01) -> dict:
    """Hand and slave fits (`analysis.apparent_mass.ApparentMassFit` as dicts) of one run's
    log along the operator's motion axis, leaving out the start transient."""
    u = motion_axis(scenario)
    t = np.asarray(log["t"])
    window = (scenario.operator.start_time + SETTLE_TIME, t[-1])
    force = np.asarray(log["master_force"])[:, :3] @ u
    hand = estimate_apparent_mass(t, force, stylus_positions(log["master_q"], scenario.master) @ u, smoothing, window)
    R_BR = RotationMatrix(RollPitchYaw(scenario.controller.motion.R_RB)).inverse().matrix()
    R_BS = np.einsum("ij,njk->nik", R_BR, sensor_rotations(slave_arm(scenario), log["slave_q"]))
    a_B = np.einsum("nij,nj->ni", R_BS, np.asarray(log["accel_true"])[:, :3])
    keep = (t >= window[0]) & (t <= window[1])
    slave = fit_apparent_mass(force[keep], (a_B @ u)[keep] / scenario.controller.motion.translation_scale)
    return {"hand": hand.as_dict(), "slave": slave.as_dict(),
            "peak_force_N": float(np.abs(np.asarray(log["master_force"])[:, :3]).max())}


def _run(scenario: Scenario, load: LoadEstimate, sigma: float, smoothing: float) -> dict:
    return fit_run(scenario, run_teleop(with_sigma(scenario, sigma), load, quiet=True), smoothing)


def _subtract(fits: dict, baseline: dict) -> dict:
    """The fits' masses less the baseline's, per estimate (hand, slave)."""
    return {key: fits[key]["mass_kg"] - baseline[key]["mass_kg"] for key in ("hand", "slave")}


def _identified(scenario: Scenario, folder: Path, name: str) -> LoadEstimate:
    """The load as ``heft identify`` finds it in simulation (a quick excitation)."""
    return identify_in_simulation(scenario, folder / name, ExcitationSettings.quick())


def apparent_mass_study(scenario: Scenario, sigmas=(0.0, 0.5, 1.0, 1.5, 2.0), etas=(0.0, 1.0),
                        amplitude_scale: float = 0.4, smoothing: float = 0.01, progress=None) -> dict:
    """Runs ``scenario`` (noise as it says; free space required) once per σ with its own load,
    and once per η with a gripper holding an object (σ = 1, plus a σ = 0 baseline). The
    controller uses identified parameters, as in the lab: the load, the gripper alone (Eq. 14's
    φ_gr) and gripper with object, each from a quick simulated identification; the expected
    masses are the true ones.

    ``amplitude_scale`` shrinks the operator's motion so that the largest σ's force stays
    below the device's force limit (a clamped force hides the mass); the default suits fig6
    up to σ = 2. Returns a JSON-ready dict: per run the fits, the baseline-subtracted
    masses and the expected k_f·s·σ·m (k_f·s·(m_gripper + η·m_object) for the split)."""
    if scenario.environment.kind != "none":
        raise ValueError(f"the apparent mass is measured in free space: use a scenario with environment "
                         f"kind 'none' (got {scenario.environment.kind!r})")
    if not amplitude_scale > 0:
        raise ValueError(f"amplitude_scale must be > 0; got {amplitude_scale}")
    sigmas = sorted({float(s) for s in sigmas} | {0.0})
    scenario = layered(scenario, overrides_text(
        {"operator.amplitude": [amplitude_scale * a for a in scenario.operator.amplitude]}))
    k_f, s = scenario.controller.feedback.force_scale, scenario.controller.motion.translation_scale
    step = progress or (lambda label: None)

    with tempfile.TemporaryDirectory() as work:
        folder = Path(work)
        step("identifying the load")
        identified = _identified(scenario, folder, "load")
        load, _ = true_load(scenario)
        fits = {}
        for sigma in sigmas:
            step(f"σ = {sigma:g}")
            fits[sigma] = _run(scenario, identified, sigma, smoothing)
        split_rows, masses = _split_runs(scenario, etas, k_f, s, smoothing, step, folder) if etas else ([], {})
    sigma_rows = [{"sigma": sigma, "expected_kg": hand_mass(sigma, load.phi[0], k_f, s),
                   "measured_kg": _subtract(fits[sigma], fits[0.0]), "fits": fits[sigma]} for sigma in sigmas]
    return {"scenario": scenario.experiment, "force_scale": k_f, "motion_scale": s,
            "load_mass_kg": float(load.phi[0]), "load_mass_identified_kg": float(identified.phi[0]),
            "amplitude": list(scenario.operator.amplitude), "max_force_N": scenario.controller.feedback.max_force,
            "sigma_runs": sigma_rows, "split_runs": split_rows, **masses}


def _split_runs(scenario: Scenario, etas, k_f: float, s: float, smoothing: float, step, folder: Path):
    """The η runs with a gripper holding an object: the controller's φ_gr from identifying the
    gripper alone, its φ̂ from identifying gripper and object; expected from the truth."""
    gripper = layered(scenario, overrides_text({"load.kind": "gripper_object"}))
    gripper_load, phi_gripper = true_load(gripper)
    m_gripper, m_object = float(phi_gripper[0]), float(gripper_load.phi[0] - phi_gripper[0])
    step("identifying the gripper alone, then with the object")
    # A grasp after the identification: the gripper holds nothing while it is identified.
    phi_gripper_hat = _identified(layered(gripper, overrides_text({"load.grasp_at": 1e9})), folder, "gripper").phi
    identified = _identified(gripper, folder, "gripper_object")

    def split_scenario(eta: float) -> Scenario:
        return layered(gripper, overrides_text({"controller.force.eta": eta,
                                                "controller.force.phi_gripper": phi_gripper_hat.tolist()}))

    step("gripper, σ = 0, η = 0")
    baseline = _run(split_scenario(0.0), identified, 0.0, smoothing)
    rows = []
    for eta in etas:
        step(f"gripper, σ = 1, η = {eta:g}")
        fit = _run(split_scenario(float(eta)), identified, 1.0, smoothing)
        rows.append({"eta": float(eta), "expected_kg": hand_mass(1.0, m_gripper + eta * m_object, k_f, s),
                     "measured_kg": _subtract(fit, baseline), "fits": fit})
    return rows, {"gripper_mass_kg": m_gripper, "object_mass_kg": m_object,
                  "gripper_mass_identified_kg": float(phi_gripper_hat[0]),
                  "load_with_object_identified_kg": float(identified.phi[0])}


def write_study(study: dict, out_dir) -> tuple[Path, Path]:
    """apparent_mass.png (measured m_a vs σ over the line k_f·s·σ·m; the η runs beside) and
    apparent_mass.json into ``out_dir``; returns their paths."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    rows = study["sigma_runs"]
    sigma = np.array([r["sigma"] for r in rows])
    figure, (left, right) = plt.subplots(1, 2, figsize=(10, 4), gridspec_kw={"width_ratios": [2, 1]})
    line = np.linspace(0.0, sigma.max(), 50)
    left.plot(line, study["force_scale"] * study["motion_scale"] * study["load_mass_kg"] * line, "k-", lw=1,
              label="k_f·s·σ·m")
    for key, marker in (("hand", "o"), ("slave", "x")):
        left.plot(sigma, [r["measured_kg"][key] for r in rows], marker, ls="none",
                  label=f"measured ({key} acceleration)")
    left.set_xlabel("σ")
    left.set_ylabel("apparent mass at the handle (kg)")
    left.set_title(f"{study['scenario'] or 'scenario'}: load {study['load_mass_kg']:.3g} kg")
    left.legend(fontsize=8)
    left.grid(alpha=0.3)
    split = study["split_runs"]
    if split:
        x = np.arange(len(split))
        right.bar(x - 0.2, [r["expected_kg"] for r in split], 0.4, color="0.7", label="k_f·s·(m_gr + η·m_obj)")
        right.bar(x + 0.2, [r["measured_kg"]["hand"] for r in split], 0.4, label="measured (hand)")
        right.set_xticks(x, [f"η = {r['eta']:g}" for r in split])
        right.set_title("gripper + object, σ = 1")
        right.legend(fontsize=8)
    else:
        right.axis("off")
    figure.tight_layout()
    png, document = out / "apparent_mass.png", out / "apparent_mass.json"
    figure.savefig(png, dpi=120)
    plt.close(figure)
    document.write_text(json.dumps(study, indent=2) + "\n")
    return png, document
