"""`heft load`: re-zero, offset tracking, a new tool, a grasp or a release for a running controller."""

from __future__ import annotations



from heft.diagrams.commands.exit_status import LOAD_REFUSED, OK
from heft.diagrams.commands.options import add_lcm_urls, add_scenario, add_set, scenario_from
from heft.diagrams.commands.console import logger

say = logger(__name__)

HELP = ("re-zero the sensor, switch offset tracking, change the tool or tell a grasp or release "
        "to a running `heft teleop --hardware`")


def add_arguments(parser) -> None:
    parser.add_argument("--rezero", action="store_true",
                      help="measure the offsets (hold the slave still, out of contact), as soon as the "
                           "controller's station is healthy")
    parser.add_argument("--tracking", choices=("on", "off"), help="slow offset tracking at rest")
    parser.add_argument("--estimate", help="a new tool's estimate.yaml from `heft identify`")
    parser.add_argument("--grasp", action="store_true",
                        help="the gripper closed on an object: keep the gripper's φ, learn the object's "
                             "(needs controller.estimator.mode: online); answered again once it is learned")
    parser.add_argument("--release", action="store_true", help="the gripper let go: back to the gripper's φ")
    add_scenario(parser, more="the lab's, for its LCM URLs (lab.lcm)")
    add_set(parser)
    add_lcm_urls(parser)
    parser.add_argument("--timeout", type=float, default=5.0, help="seconds to wait for the answers (default 5)")


def run(args) -> int:
    from heft.hardware_interface.load_command_sender import send_load_command

    chosen = [name for name, given in (("rezero", args.rezero), ("tracking", args.tracking),
                                       ("estimate", args.estimate), ("grasp", args.grasp),
                                       ("release", args.release)) if given]
    if len(chosen) != 1:
        raise ValueError("give exactly one of --rezero, --tracking on|off, --estimate FILE, --grasp, --release")
    channels = scenario_from(args).lab.lcm
    if args.estimate:  # a TimeoutError is the `heft` command's timeout status
        # Only here: the estimate's checks (load_dynamics) bring numba, which the other actions need not load.
        from heft.diagrams.load_estimate import read_load_estimate

        load = read_load_estimate(args.estimate)
        answers = send_load_command(channels, "new_estimate", load.phi, load.offsets, args.timeout)
    else:
        action = chosen[0] if chosen[0] != "tracking" else f"tracking_{args.tracking}"
        answers = send_load_command(channels, action, timeout=args.timeout)
    for answer in answers:
        say.info(f"heft load: {answer.message}")
    final = answers[-1]
    say.info("heft load: offsets in use [" + ", ".join(f"{x:.4g}" for x in final.offsets)
             + f"] (N, N·m); m = {final.phi[0]:.4g} kg in all; tracking {'on' if final.tracking else 'off'}")
    return OK if final.accepted else LOAD_REFUSED
