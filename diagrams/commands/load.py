"""`heft load`: re-zero, offset tracking or a new tool for a running controller."""

from __future__ import annotations

import sys


from heft.diagrams.commands.options import add_lcm_urls, lcm_channels

HELP = ("re-zero the sensor, switch offset tracking or change the tool "
       "of a running `heft teleop --hardware`")


def add_arguments(parser) -> None:
    parser.add_argument("--rezero", action="store_true",
                      help="measure the offsets now (hold the slave still, out of contact)")
    parser.add_argument("--tracking", choices=("on", "off"), help="slow offset tracking at rest")
    parser.add_argument("--estimate", help="a new tool's estimate.yaml from `heft identify`")
    add_lcm_urls(parser)
    parser.add_argument("--timeout", type=float, default=5.0, help="seconds to wait for the answers (default 5)")


def run(args) -> int:
    from heft.diagrams.load_estimate import read_load_estimate
    from heft.hardware_interface.load_commands import send_load_command

    chosen = [name for name, given in (("rezero", args.rezero), ("tracking", args.tracking),
                                       ("estimate", args.estimate)) if given]
    if len(chosen) != 1:
        raise ValueError("give exactly one of --rezero, --tracking on|off, --estimate FILE")
    channels = lcm_channels(args)
    try:
        if args.estimate:
            load = read_load_estimate(args.estimate)
            answers = send_load_command(channels, "new_estimate", load.phi, load.offsets, args.timeout)
        else:
            action = "rezero" if args.rezero else f"tracking_{args.tracking}"
            answers = send_load_command(channels, action, timeout=args.timeout)
    except TimeoutError as error:
        print(f"heft load: {error}", file=sys.stderr)
        return 5
    for answer in answers:
        print(f"heft load: {answer.message}")
    final = answers[-1]
    print("heft load: offsets in use [" + ", ".join(f"{x:.4g}" for x in final.offsets)
          + f"] (N, N·m); m = {final.phi[0]:.4g} kg; tracking {'on' if final.tracking else 'off'}")
    return 0 if final.accepted else 4
