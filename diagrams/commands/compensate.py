"""`heft compensate`: a recorded run's non-contact wrench (Eq. 12) and contact estimate (Eq. 13) per
wrench sample, from a recording (docs/recordings.md) and a load estimate."""

from __future__ import annotations

import json
from pathlib import Path

from heft.diagrams.commands.console import logger
from heft.diagrams.commands.options import add_out

say = logger(__name__)

HELP = ("the non-contact wrench V·φ̂ and the contact estimate per wrench sample of a recording "
        "(docs/recordings.md), with a figure and metrics")


def add_arguments(parser) -> None:
    parser.add_argument("--recording", required=True, help="the recording's YAML file")
    parser.add_argument("--estimate", required=True,
                        help="estimate.yaml (`heft identify`): φ̂, the offsets and, if the recording's accelerometer "
                             "says R_SA or bias 'estimate', its calibration")
    add_out(parser, "compensated.csv (or .parquet), figure.png, metrics.json", default="out/compensate")
    parser.add_argument("--format", choices=("csv", "parquet"), default="csv",
                        help="compensated.csv (default) or compensated.parquet (same columns; faster to write)")
    parser.add_argument("--contact-threshold", type=float,
                        help="contact force magnitude (N) above which a sample is in contact (default: from the "
                             "recording's quietest stretches, see metrics.json)")
    parser.add_argument("--offset-window", type=float, nargs=2, metavar=("START", "DURATION"),
                        help="wrench time (s) over which clock offsets marked 'estimate' and the differentiation "
                             "window, unless stated, are found (default: the first 60 s the streams share)")
    parser.add_argument("--offset-search", type=float, default=0.05,
                        help="largest clock offset (s) searched either way (default 0.05)")


def _return_freed_arrays_to_the_system() -> None:
    """glibc raises its mmap threshold each time a large block is freed, after which the chunks' arrays
    come from the heap and fragment it: fixed at 256 kB, a freed chunk goes back to the system (peak
    memory of a 5 min, 8 kHz recording 291 → 262 MB). Elsewhere than glibc, nothing is done."""
    import ctypes

    try:
        ctypes.CDLL("libc.so.6").mallopt(-3, 256 * 1024)  # M_MMAP_THRESHOLD
    except (OSError, AttributeError):
        pass


def _with_progress(chunks, rows: int):
    """``chunks`` (``MergedSamples``) passed on, the wrench rows done shown as progress."""
    from heft.diagrams.progress import ProgressBar

    bar, done = ProgressBar(rows, "compensate", unit=" rows"), 0
    for chunk in chunks:
        yield chunk
        done += len(chunk)
        bar.update(done)
    bar.close()


def run(args) -> int:
    from heft.analysis.clock_offsets import estimate_clock_offsets
    from heft.analysis.compensation import compensate, compensation_figure, contact_threshold, scan_stride
    from heft.analysis.differentiation_window import estimate_differentiation_window
    from heft.analysis.recording import ESTIMATE
    from heft.diagrams.load_estimate import read_load_estimate
    from heft.diagrams.recordings import open_recording

    _return_freed_arrays_to_the_system()
    estimate = read_load_estimate(args.estimate)
    source = open_recording(args.recording, args.estimate)
    recording = source.recording
    for key, value in source.choices.items():
        if not key.endswith("_span"):
            say.info(f"{key}: {value}")
    offsets = {}
    fits = {}
    if ESTIMATE in source.stated_offsets().values():
        window = tuple(args.offset_window) if args.offset_window else None
        fits = estimate_clock_offsets(source, estimate.phi, window=window, search=args.offset_search,
                                      sensor_offsets=estimate.offsets)
        for name, fit in fits.items():
            offsets[name] = fit.offset
            say.info(f"clock offset of {name}: {1e3 * fit.offset:.3f} ms (estimated: V·φ̂ against the wrench"
                     + ("" if fit.observable else f"; NOT observable: {fit.why_not()}") + ")")
    offsets = source.resolved_offsets(offsets)
    window_fit = None
    if recording.differentiation.window == ESTIMATE and source.differentiated():
        window = tuple(args.offset_window) if args.offset_window else None
        window_fit = estimate_differentiation_window(source, estimate.phi, offsets, window=window,
                                                     sensor_offsets=estimate.offsets)
        source.state_differentiation_window(window_fit.window, window_fit.how())
        recording = source.recording
        say.info(f"differentiation window: {1e3 * window_fit.window:.3g} ms ({window_fit.how()})")
        if fits:  # the clock offsets again, their search's kernel that of the window found
            fits = estimate_clock_offsets(source, estimate.phi, streams=list(fits), window=window,
                                          search=args.offset_search, initial=offsets, sensor_offsets=estimate.offsets)
            for name, fit in fits.items():
                offsets[name] = fit.offset
                say.info(f"clock offset of {name} with that window: {1e3 * fit.offset:.3f} ms"
                         + ("" if fit.observable else f"; NOT observable: {fit.why_not()}"))
    sign = -1.0 if recording.wrench.exerted_on == "sensor" else 1.0
    rows = source.spans["wrench"][2]
    threshold = contact_threshold(source.chunks(offsets, stride=scan_stride(rows), every_row=True), estimate.phi,
                                  estimate.offsets, args.contact_threshold,
                                  None if estimate.residual_rms is None else estimate.residual_rms[:3])
    say.info("every row checked before writing: " + ", ".join(f"{name} {n}" for name, n in source.checked.items()))
    say.info(f"contact threshold {threshold.value:.3g} N: {threshold.reason}")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    path = out / f"compensated.{args.format}"
    result = compensate(_with_progress(source.chunks(offsets), rows), estimate.phi, estimate.offsets, sign, path,
                        threshold, rows)
    compensation_figure(result, out / "figure.png")
    choices = {**source.choices, "clock_offsets_s": {
        name: {"offset_s": value, "how": "estimated" if name in fits else "stated",
               **(fits[name].summary() if name in fits else {})} for name, value in offsets.items()},
               "differentiation_window": window_fit.summary() if window_fit is not None else
               {"window_s": recording.differentiation.seconds, "how": "stated" if recording.differentiation.window
                != ESTIMATE else "not needed: ω and α recorded"}}
    metrics = {"recording": str(args.recording), "estimate": str(args.estimate), "output": str(path),
               "choices": choices, "wrench_rows_outside_the_other_streams": source.dropped,
               **result.metrics()}
    (out / "metrics.json").write_text(json.dumps(metrics, indent=2, default=str) + "\n")
    rms = ", ".join(f"{a} {v:.4g}" for a, v in zip(("fx", "fy", "fz", "tx", "ty", "tz"), result.rms))
    say.info(f"compensated {result.samples} samples ({result.duration_s:.6g} s) in {result.elapsed_s:.3g} s "
             f"({result.duration_s / result.elapsed_s:.3g}× real time; CPU {result.cpu_s:.3g} s, "
             f"{result.duration_s / result.cpu_s:.3g}×) → {path}")
    say.info(f"contact: {len(result.intervals)} interval(s) above {result.threshold_N:.3g} N "
             f"({100 * result.contact_share:.2g} % of samples); residual RMS without contact (N, N·m): {rms}")
    return 0
