"""``heft analyze apparent-mass``: the mass the operator feels, against σ.

Runs `diagrams.studies.apparent_mass.apparent_mass_study` on a free-space scenario and writes
apparent_mass.png and apparent_mass.json to ``--out``.
"""

from pathlib import Path

from heft.diagrams.commands.options import add_noise, add_out, add_scenario, parse_numbers
from heft.diagrams.studies.apparent_mass import apparent_mass_study, write_study
from heft.diagrams.scenario import NOISE_OFF, overrides_text, resolve_scenario
from heft.diagrams.commands.console import logger

say = logger(__name__)


def add_arguments(parser) -> None:
    """The options of ``heft analyze apparent-mass``."""
    add_scenario(parser, more="one in free space")
    parser.add_argument("--sigmas", default="0,0.5,1,1.5,2", help="σ values, comma separated (default 0,0.5,1,1.5,2)")
    parser.add_argument("--etas", default="0,1",
                        help="η values of the gripper/object runs, comma separated; '' skips them (default 0,1)")
    parser.add_argument("--amplitude-scale", type=float, default=0.4,
                        help="factor on the operator's motion amplitude, keeping the largest σ's force under "
                             "the device limit (default 0.4)")
    parser.add_argument("--duration", type=float, default=None,
                        help="simulated seconds per run (default: the scenario's)")
    add_noise(parser, default="off")
    add_out(parser, "apparent_mass.png, apparent_mass.json", default="out/apparent_mass")


def run(args) -> int:
    """Runs the study and prints a one-line summary; returns 0."""
    sigmas = parse_numbers(args.sigmas, "--sigmas")
    etas = parse_numbers(args.etas, "--etas") if args.etas.strip() else []
    if any(eta > 1 for eta in etas):
        raise ValueError(f"--etas values must lie in [0, 1]; got {args.etas}")
    scenario = resolve_scenario(args.scenario, overrides_text(
        {**(NOISE_OFF if args.noise == "off" else {}), "duration": args.duration}))
    study = apparent_mass_study(scenario, sigmas, etas, amplitude_scale=args.amplitude_scale,
                                progress=lambda label: say.info(f"  running {label}"))
    png, document = write_study(study, Path(args.out))
    parts = [f"σ={row['sigma']:g}: {row['measured_kg']['hand']:.4f}/{row['expected_kg']:.4f} kg"
             for row in study["sigma_runs"]]
    parts += [f"η={row['eta']:g}: {row['measured_kg']['hand']:.4f}/{row['expected_kg']:.4f} kg"
              for row in study["split_runs"]]
    say.info(f"apparent mass at the handle, measured/expected (k_f·s·σ·m): {', '.join(parts)}; "
             f"wrote {png} and {document}")
    return 0
