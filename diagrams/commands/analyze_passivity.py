"""``heft analyze passivity LOG``: energy through the ports of a run, and what the
passivity controller did (`analysis.passivity_analysis`), from a simulation's ``log.npz`` or
the LCM log of ``heft teleop --hardware --record`` (`analysis.run_log`).

Master port: the wrench the network renders on the hand (``master_force``) against the
stylus twist J_M(q)·q̇ from the logged master angles and velocities, as the passivity
observer pairs them. Environment port (when the log has ``slave_q`` and
``wrench_contact_true``): the contact part of the sensor's wrench against the twist of S,
from the slave's angles differentiated in time; positive energy flows from the slave's
tool into the environment.

Sample alignment: in a simulation's log the observer's energy and damping logged at row k
come from the update that paired the stylus twist (master angles and velocities) and the wrench
logged at row k−1; on hardware from those of row k (``RunLog.observer_lag``, 1 or 0);
`paired_rows` shifts the twist and the wrench so that every row holds one update's inputs. Each row is
held for the log's ``hold`` where it has one (a hardware controller's measured ticks), else
until the next row. The report checks the pairing: the observer's energy must equal the port
energy plus what the PC dissipated (``observer_identity_gap_J``, zero up to rounding on an
undelayed run). On hardware the analysis takes the controller's longest stretch between
restarts (the observer restarts from zero) and prints what the log lacks.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from pydrake.multibody.tree import JacobianWrtVariable

from heft.analysis.passivity_analysis import (CHANNELS, passivity_controller_summary, passivity_figure,
                                              port_energy, port_power, sample_periods)
from heft.analysis.run_log import KINDS, RunLog, complete_rows, longest_start, read_run_log
from heft.diagrams.arm_params import BUNDLED_ARMS
from heft.diagrams.master_params import BUNDLED_MASTERS, DEFAULT_MASTER
from heft.diagrams.plants import MakeArmPlant, MakeMasterPlant
from heft.systems.controller.master_kinematics import BASE_FRAME, STYLUS_FRAME
from heft.systems.serial_chain import SerialChain
from heft.diagrams.commands.console import logger
from heft.diagrams.commands.options import add_out

say = logger(__name__)

REQUIRED_KEYS = ("t", "master_q", "master_v", "master_force", "passivity_energy", "passivity_damping")
ENVIRONMENT_KEYS = ("slave_q", "wrench_contact_true")


def read_log(path, kind: str | None = None) -> RunLog:
    """The run in a log.npz or a hardware LCM log (`read_run_log`): the rows with the master's
    state and, on hardware, of those the longest stretch between controller restarts; a
    ValueError names a missing file or key."""
    run = read_run_log(path, kind)
    missing = [key for key in REQUIRED_KEYS if key not in run.arrays]
    if missing:
        raise ValueError(f"{path} lacks {', '.join(missing)}: the passivity analysis needs {', '.join(REQUIRED_KEYS)}")
    if np.asarray(run.arrays["t"]).size < 3:
        raise ValueError(f"{path} holds fewer than 3 samples")
    with_master = complete_rows(run, ("master_q", "master_v"), "without the master's state their energy is not "
                                                               "counted (the observer identity gap shows it)")
    return longest_start(with_master)


def stylus_twists(master_q, master_v, master: str = DEFAULT_MASTER) -> np.ndarray:
    """[v_E; ω_E] (N, 6; m/s, rad/s, in B) = J_M(q)·q̇ of the bundled ``master`` at each logged sample."""
    plant = MakeMasterPlant(master)
    chain = SerialChain(plant, plant.GetFrameByName(BASE_FRAME), plant.GetFrameByName(STYLUS_FRAME))
    twists = []
    for q, v in zip(np.asarray(master_q, dtype=float), np.asarray(master_v, dtype=float), strict=True):
        chain.update(q)
        twists.append(chain.J @ v)
    return np.array(twists).reshape(-1, 6)


def sensor_twists(robot: str, t, slave_q) -> np.ndarray:
    """[v_S; ω_S] (N, 6; m/s, rad/s, in S) of the sensor frame, from the slave's joint angles
    (N, n; rad) differentiated by central differences (one-sided at the ends)."""
    plant, S = MakeArmPlant(robot)
    context = plant.CreateDefaultContext()
    R = plant.world_frame()  # the arm's base, welded at W
    slave_q = np.asarray(slave_q, dtype=float)
    rates = np.gradient(slave_q, np.asarray(t, dtype=float), axis=0)
    twists = []
    for q, rate in zip(slave_q, rates, strict=True):
        plant.SetPositions(context, q)
        J = plant.CalcJacobianSpatialVelocity(context, JacobianWrtVariable.kV, S, np.zeros(3), R, S)
        twists.append(np.concatenate((J[3:] @ rate, J[:3] @ rate)))
    return np.array(twists)


def paired_rows(values, lag: int = 1) -> np.ndarray:
    """Logged rows (N, k) moved down ``lag`` rows (zeros first), so that row k holds what the observer's
    update logged at row k met (module docstring)."""
    values = np.asarray(values, dtype=float)
    return np.concatenate((np.zeros((lag, values.shape[1])), values[:len(values) - lag]))


def _flows(power_into_network, holds) -> tuple[float, float]:
    """(energy in, energy out) (J): the positive and negative parts of the power, integrated."""
    energy = power_into_network * holds
    return float(energy[energy > 0].sum()), 0.0 - float(energy[energy < 0].sum())


def analyze_log(log: dict, robot: str = "rx90", twist=None, observer_lag: int = 1,
                master: str = DEFAULT_MASTER) -> dict:
    """The passivity report of a log (keys as `heft simulate` writes them; ``hold`` if the log
    has one): per channel the master port's energy in/out and final value, the PC's summary,
    and the largest gap between the observer's energy and the port energy plus what the PC
    dissipated (J) (zero up to rounding when the log and the observer agree); where the log has the
    wrench applied on the hand (``master_force_applied``), what the device's clamp
    withheld from the hand, Σ (f_PC − f_applied)·v·T (J, ``passivity_controller`` key
    ``{channel}_clamp_withheld_J``), which the observer counts back; with the environment keys, the
    environment port's energies too. ``twist``: `stylus_twists` of the
    log, if already computed (not yet paired); ``observer_lag``: as `paired_rows`'s ``lag`` (module docstring);
    ``master``: the run's bundled master."""
    t = np.asarray(log["t"], dtype=float)
    holds = sample_periods(t, log.get("hold"))
    twist = paired_rows(stylus_twists(log["master_q"], log["master_v"], master) if twist is None else twist,
                        observer_lag)
    wrench = paired_rows(log["master_force"], observer_lag)
    damping = np.asarray(log["passivity_damping"], dtype=float)
    observed = np.asarray(log["passivity_energy"], dtype=float)
    summary = passivity_controller_summary(t, damping, observed, twist, period=holds)
    port = port_energy(t, wrench, twist, period=holds)
    speed_squared = np.stack(((twist[:, :3] ** 2).sum(1), (twist[:, 3:] ** 2).sum(1)), axis=1)
    dissipated = np.cumsum(damping * speed_squared * holds[:, None], axis=0)
    withheld = np.zeros_like(dissipated)
    if "master_force_applied" in log:  # the PC's wrench f − α·v, less what reached the hand
        # The PC's output: in either log, on the row of the energy the observer kept with it.
        unclamped = wrench - np.repeat(damping, 3, axis=1) * twist
        cut = (unclamped - np.asarray(log["master_force_applied"], dtype=float)) * twist
        withheld = np.cumsum(np.stack((cut[:, :3].sum(1), cut[:, 3:].sum(1)), axis=1) * holds[:, None], axis=0)
        for i, name in enumerate(CHANNELS):
            summary[f"{name}_clamp_withheld_J"] = float(withheld[-1, i])
    gap = np.abs(observed - (port + dissipated + withheld)).max(axis=0)
    power_in = -port_power(wrench, twist)
    report = {"duration_s": float(t[-1] - t[0] + holds[-1]), "master_port": {}, "passivity_controller": summary}
    for i, name in enumerate(CHANNELS):
        energy_in, energy_out = _flows(power_in[:, i], holds)
        report["master_port"][name] = {
            "energy_in_J": energy_in, "energy_out_J": energy_out, "final_J": float(port[-1, i]),
            "min_J": float(port[:, i].min()), "observer_identity_gap_J": float(gap[i])}
    if all(key in log for key in ENVIRONMENT_KEYS):
        sensor = sensor_twists(robot, t, log["slave_q"])
        contact = np.asarray(log["wrench_contact_true"], dtype=float)
        into_environment = (contact * sensor).sum(axis=1)
        energy_in, energy_out = _flows(into_environment, holds)
        report["environment_port"] = {"energy_in_J": energy_in, "energy_out_J": energy_out,
                                      "final_J": energy_in - energy_out}
    return report


def add_arguments(parser) -> None:
    """The options of ``heft analyze passivity``."""
    parser.add_argument("log", help="a run's log.npz (from `heft simulate`) or LCM log (from `heft teleop --hardware "
                                    "--record`)")
    parser.add_argument("--kind", choices=KINDS, default=None,
                        help="the log's kind (default: told by the file's first bytes)")
    parser.add_argument("--robot", default="rx90", choices=tuple(BUNDLED_ARMS),
                        help="the slave of the run, for the environment port (default rx90)")
    parser.add_argument("--master", default=DEFAULT_MASTER, choices=tuple(BUNDLED_MASTERS),
                        help=f"the haptic master of the run, for the stylus twist (default {DEFAULT_MASTER})")
    add_out(parser, "passivity.png, passivity.json", shown="the log's folder")


def run(args) -> int:
    """Writes passivity.png and passivity.json and prints a one-line summary; returns 0."""
    run_log = read_log(args.log, args.kind)
    log = run_log.arrays
    out = Path(args.out) if args.out else Path(args.log).parent
    out.mkdir(parents=True, exist_ok=True)
    twist = stylus_twists(log["master_q"], log["master_v"], args.master)
    report = analyze_log(log, args.robot, twist, run_log.observer_lag)
    report["log"] = {"path": str(args.log), "kind": run_log.kind, "notes": run_log.notes}
    paired = {**log, "master_force": paired_rows(log["master_force"], run_log.observer_lag)}
    passivity_figure(paired, out / "passivity.png", twist=paired_rows(twist, run_log.observer_lag),
                     period=log.get("hold"), title=Path(args.log).name)
    (out / "passivity.json").write_text(json.dumps(report, indent=2) + "\n")
    pc = report["passivity_controller"]
    ports = "; ".join(f"master {name}: in {p['energy_in_J']:.4g} J, out {p['energy_out_J']:.4g} J"
                      for name, p in report["master_port"].items())
    if "environment_port" in report:
        environment = report["environment_port"]
        ports += f"; environment: in {environment['energy_in_J']:.4g} J, out {environment['energy_out_J']:.4g} J"
    active = ", ".join(f"{name} {100 * pc[f'{name}_active_fraction']:.1f} % active, "
                       f"{pc[f'{name}_dissipated_J']:.4g} J dissipated" for name in CHANNELS)
    notes = "".join(f"; {note}" for note in run_log.notes)
    say.info(f"{ports}; PC: {active}{notes}; wrote {out / 'passivity.png'} and {out / 'passivity.json'}")
    return 0
