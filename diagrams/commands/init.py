"""`heft init lab`: a commented lab file (a scenario) that `heft stand-in`, `heft teleop --hardware`,
`heft identify --hardware` and `heft load` take as ``--scenario``."""

from __future__ import annotations

import textwrap
from pathlib import Path

from heft.diagrams.arm_params import BUNDLED_ARMS
from heft.diagrams.commands.console import logger
from heft.diagrams.commands.options import LAB_SETTINGS

say = logger(__name__)

HELP = "write a commented lab.yaml for `--scenario` (`heft init lab --robot rx90 --out .`)"
LAB_FILE = "lab.yaml"

TEMPLATE = """\
# heft lab file (`heft init lab --robot {robot}`): a scenario, as docs/scenarios.md describes, for
#   heft stand-in --scenario {name}              (a stand-in lab on this machine)
#   heft teleop --hardware --scenario {name}     (the controller, against the lab or the stand-in)
#   heft identify --hardware --scenario {name}   (the load's identification on the arm)
#   heft load --rezero --scenario {name}         (commands to a running controller)
# Every field left out keeps heft's default. The two marked MEASURE are the simulated lab's values,
# which the stand-in plays: replace them with your lab's before running on hardware.

robot: {robot}  # the slave: {robots} (docs/arms.md); its status and commands carry its {joints} joints
{null_space}slave_initial_q: {slave_q}  # rad: the pose the stand-in's arm starts in

accelerometer:
{position_how}
  position: {position}

controller:
  motion:
    translation_scale: {scale}  # m of the slave's stroke per m of the stylus's{scale_why}
  force:
{notch_how}
    mount_notch: {notch}
    sigma: {sigma}  # share of the load's non-contact wrench fed back (0: eliminated)
    gamma: {gamma}  # share of the contact wrench fed back
  # load_estimate: estimate.yaml   # the load from `heft identify` (or give --estimate)

controller_period: {period}  # s: the control loop's period ({rate:g} Hz)

lab:
  lcm:
    lcm_url: "{lcm_url}"  # what the drivers and `heft load` send to the controller
    command_url: "{command_url}"  # what the controller sends back; "": lcm_url's group, one port up
  station:
    watchdog:
      timeout: {timeout}  # s: a channel older than this is stale (forces ramp out, arm held)
      ramp_time: {ramp}  # s: forces ramp in over this once every channel is fresh
"""


def lab_text(robot: str, name: str = LAB_FILE) -> str:
    """The lab file for the bundled arm ``robot``, every value heft's default for it (the simulated lab's, the arm's
    own start posture and motion scale: ``with_arm_defaults``), ``name`` in its usage lines."""
    from heft.diagrams.scenario import Scenario, with_arm_defaults

    if robot not in BUNDLED_ARMS:
        raise ValueError(f"--robot must be one of {', '.join(BUNDLED_ARMS)}; got {robot!r}")
    default = with_arm_defaults(Scenario(robot=robot), {"robot": robot}, Scenario().robot)
    force, lab = default.controller.force, default.lab
    joints = len(default.slave_initial_q)
    own_scale = BUNDLED_ARMS[robot].translation_scale is not None
    return TEMPLATE.format(
        robot=robot, robots=", ".join(BUNDLED_ARMS), joints=joints, name=name, slave_q=list(default.slave_initial_q),
        null_space="# 7 joints: the inverse kinematics draws the arm's redundant motion toward this posture\n"
        if joints > 6 else "",
        scale=default.controller.motion.translation_scale,
        scale_why=f" (the {robot}'s: its joint speeds)" if own_scale else "",
        position_how=_measure("accelerometer.position", "  "), position=list(default.accelerometer.position),
        notch_how=_measure("controller.force.mount_notch", "    "), notch=force.mount_notch,
        sigma=force.sigma, gamma=force.gamma, period=default.controller_period, rate=1 / default.controller_period,
        lcm_url=lab.lcm.lcm_url, command_url=lab.lcm.command_url, timeout=lab.station.watchdog.timeout,
        ramp=lab.station.watchdog.ramp_time)


def _measure(field: str, indent: str) -> str:
    """The comment on a ``LAB_SETTINGS`` field: how a lab finds its value."""
    return textwrap.fill(f"MEASURE: {LAB_SETTINGS[field][0]}.", width=100, initial_indent=f"{indent}# ",
                         subsequent_indent=f"{indent}#   ")


def add_arguments(parser) -> None:
    parser.add_argument("what", choices=("lab",), help="lab: the lab file")
    parser.add_argument("--robot", choices=tuple(BUNDLED_ARMS), default="rx90",
                        help="the slave, a bundled arm (default rx90; docs/arms.md)")
    parser.add_argument("--out", metavar="DIR", default=".",
                        help=f"output folder (default .): {LAB_FILE}; a path ending in .yaml names the file itself")
    parser.add_argument("--force", action="store_true", help="overwrite an existing file")


def lab_path(out: str) -> Path:
    """The file ``--out`` names: ``lab.yaml`` in a folder, or a .yaml path itself."""
    path = Path(out)
    return path if path.suffix in (".yaml", ".yml") else path / LAB_FILE


def run(args) -> int:
    path = lab_path(args.out)
    if path.exists() and not args.force:
        raise ValueError(f"{path} exists; give --force to overwrite it")
    text = lab_text(args.robot, path.name)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    say.info(f"wrote {path}: state your lab's accelerometer position and mount notch there (MEASURE), then "
             f"`heft stand-in --scenario {path}` or `heft teleop --hardware --scenario {path}`")
    return 0
