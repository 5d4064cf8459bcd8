"""`heft bench regressor`: the cost of the non-contact wrench V·φ, beside Drake.

Drake's side is the same wrench from a MultibodyPlant (inverse dynamics, forward
dynamics and the weld's reaction force), handed in by the caller as
``drake_wrench(q, v, vdot)``; both sides are timed in the same run.
"""

from __future__ import annotations

import time

import numpy as np

from heft.systems.load_dynamics import noncontact_wrench


def _per_call_seconds(fn, min_time: float = 0.3) -> float:
    """Median over 5 rounds of the mean time per call, each round ≥ min_time/5."""
    fn()
    calls = 1
    while True:
        start = time.perf_counter()
        for _ in range(calls):
            fn()
        if time.perf_counter() - start > min_time / 5:
            break
        calls *= 2
    rounds = []
    for _ in range(5):
        start = time.perf_counter()
        for _ in range(calls):
            fn()
        rounds.append((time.perf_counter() - start) / calls)
    return float(np.median(rounds))


def run(phi, drake_wrench, drake_motion, random_state, rng: np.random.Generator,
        batch_size: int = 100_000) -> dict:
    """Times V·φ for one sample and for ``batch_size`` samples against Drake's
    per-sample cost; returns the numbers (seconds) and prints a table."""
    q, v, vdot = random_state(rng)
    a, alpha, omega, g = drake_motion(q, v, vdot)
    single = _per_call_seconds(lambda: noncontact_wrench(phi, a, alpha, omega, g))
    drake_single = _per_call_seconds(lambda: drake_wrench(q, v, vdot))
    batch = [rng.normal(size=(batch_size, 3)) for _ in range(4)]
    batch_total = _per_call_seconds(lambda: noncontact_wrench(phi, *batch), min_time=1.0)
    results = {
        "single_sample_s": single,
        "drake_single_sample_s": drake_single,
        "batch_per_sample_s": batch_total / batch_size,
        "batch_size": batch_size,
    }
    print(f"{'':34s}{'heft':>12s}{'Drake plant':>14s}{'Drake/heft':>12s}")
    print(f"{'one sample (µs)':34s}{single * 1e6:12.2f}{drake_single * 1e6:14.2f}"
          f"{drake_single / single:12.1f}")
    print(f"{f'batch of {batch_size} (µs per sample)':34s}{batch_total / batch_size * 1e6:12.3f}"
          f"{drake_single * 1e6:14.2f}{drake_single / (batch_total / batch_size):12.1f}")
    print(f"one sample uses {single / 500e-6:.2%} of a 2 kHz tick")
    return results
