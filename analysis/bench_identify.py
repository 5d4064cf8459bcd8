"""`heft bench identify`: each estimator's accuracy against the Cramér–Rao bound,
and the cost of a recursive update beside a batch solve.

The data are one noise-free excitation record (exact wrench and [a; α] of S, ω
and g from the encoders), handed in by the caller. Every Monte Carlo run adds
seeded Gaussian noise of the sensor model; two noise models are run:

* ``wrench``: noise on the wrench only. The model is then linear with Gaussian
  noise, and (Σ_k V_kᵀ Σ⁻¹ V_k)⁻¹ is the Cramér–Rao bound that an efficient
  estimator (WLS) reaches;
* ``wrench+accelerometer``: the full sensor model, judged against the bound of
  the errors-in-variables model: with the true a, α as nuisance parameters the
  Fisher information of θ is Σ_k A_kᵀ (Σ_f + J Σ_x Jᵀ)⁻¹ A_k (the Schur
  complement, by Woodbury), J = ∂(V·φ)/∂[a; α] and Σ_x the accelerometer's
  noise (``equation_error_covariance``). The wrench-only bound is printed
  beside it: what the accelerometer's noise costs at best. The
  errors-in-variables maximum likelihood (``eiv_ml``) is the estimator meant to
  reach it.
"""

import functools
import time

import numpy as np

from heft.analysis.parallel import run_points
from heft.systems.identification.batch_estimation import METHODS, batch_estimate
from heft.systems.load_dynamics import PARAMETER_NAMES
from heft.systems.identification.recursive_estimation import (
    RecursiveInstrumentalVariables, RecursiveLeastSquares, RecursiveTotalLeastSquares, feed)
from heft.systems.identification.regression_noise import NoiseLevels, equation_error_covariance
from heft.systems.load_dynamics import regressor_with_offsets

RECURSIVE = {"rls": RecursiveLeastSquares, "riv": RecursiveInstrumentalVariables, "rtls": RecursiveTotalLeastSquares}
SHOWN = ("fz_o", "m", "m*cz", "Ixx", "Izz")  # parameters printed in the table (all are in the JSON)
TARGET_RATIO = 1.2  # σ/σ_CR an efficient estimator should stay within, per parameter


def cramer_rao_bound(a, alpha, omega, g, noise: NoiseLevels, phi=None) -> np.ndarray:
    """(16, 16) covariance bound for θ = [offsets; φ]: white wrench noise only, or with ``phi``
    (the true φ) also the accelerometer's white noise on a and α (module docstring)."""
    V = regressor_with_offsets(a, alpha, omega, g)                      # (S, 6, 16)
    if phi is None:
        covariance = np.diag(1.0 / noise.wrench_weights())
    else:
        covariance = equation_error_covariance(phi, noise)
    fisher = np.einsum("sip,ij,sjq->pq", V, np.linalg.inv(covariance), V)
    return np.linalg.inv(fisher)


def _estimate(method, wrench, signals, instruments, noise):
    a, alpha, omega, g = signals
    if method in METHODS:
        result = batch_estimate(wrench, a, alpha, omega, g, method=method, noise=noise)
        return np.concatenate((result.offsets, result.phi))
    estimator = RECURSIVE[method](noise=noise)
    for _ in feed(estimator, wrench, a, alpha, omega, g, instruments):
        pass
    return np.concatenate((estimator.offsets, estimator.phi))


def noisy_run(data: tuple, point: int, seed_sequence: np.random.SeedSequence) -> dict:
    """One Monte Carlo run (``point`` is its index): the sensor model's noise, drawn from
    ``seed_sequence``, on the exact ``data`` = (wrench, a, alpha, omega, g, noise,
    methods, accelerometer_noise); returns {method: (16,) estimate [offsets; φ]}."""
    wrench, a, alpha, omega, g, noise, methods, accelerometer_noise = data
    rng = np.random.default_rng(seed_sequence)
    wrench_sigma = np.array([noise.force] * 3 + [noise.torque] * 3)
    noisy_wrench = wrench + wrench_sigma * rng.standard_normal(wrench.shape)
    a_n, alpha_n = a, alpha
    if accelerometer_noise:
        a_n = a + noise.linear_acceleration * rng.standard_normal(a.shape)
        alpha_n = alpha + noise.angular_acceleration * rng.standard_normal(alpha.shape)
    return {method: _estimate(method, noisy_wrench, (a_n, alpha_n, omega, g), (a, alpha, omega, g), noise)
            for method in methods}


def monte_carlo(wrench, a, alpha, omega, g, noise: NoiseLevels, runs: int, methods, seed: int,
                accelerometer_noise: bool, progress=None, workers: int | None = None,
                dask_address: str | None = None) -> dict:
    """{method: (runs, 16) estimates} over noise realisations, run r seeded by the r-th child
    of SeedSequence(seed), in parallel (``analysis.parallel.run_points``)."""
    data = (wrench, a, alpha, omega, g, noise, tuple(methods), accelerometer_noise)
    results = run_points(functools.partial(noisy_run, data), range(runs), seed, dask_address=dask_address,
                         workers=workers, label="bench identify run", progress=progress)
    return {method: np.array([result[method] for result in results]).reshape(runs, 16) for method in methods}


def update_costs(wrench, a, alpha, omega, g, noise: NoiseLevels, samples: int = 2000) -> dict:
    """Seconds per sample: each recursive update, and a batch solve divided by its samples."""
    costs = {}
    n = min(samples, len(wrench))
    for method, cls in RECURSIVE.items():
        estimator = cls(noise=noise)
        signals = (x[:n] for x in (wrench, a, alpha, omega, g))
        start = time.perf_counter()
        for _ in feed(estimator, *signals, instruments=(a[:n], alpha[:n], omega[:n], g[:n])):
            pass
        costs[method] = (time.perf_counter() - start) / n
    for method in METHODS:
        start = time.perf_counter()
        batch_estimate(wrench, a, alpha, omega, g, method=method, noise=noise)
        costs[method] = (time.perf_counter() - start) / len(wrench)
    return costs


def summarise(estimates: dict, theta_true, bound) -> dict:
    """Per method and parameter: bias, standard deviation, Cramér–Rao σ, efficiency σ²_CR / MSE."""
    crb_std = np.sqrt(np.diag(bound))
    summary = {}
    for method, values in estimates.items():
        bias = values.mean(axis=0) - theta_true
        std = values.std(axis=0, ddof=1)
        mse = bias ** 2 + std ** 2
        summary[method] = {name: {"bias": float(bias[i]), "std": float(std[i]), "crb_std": float(crb_std[i]),
                                  "efficiency": float(crb_std[i] ** 2 / mse[i])}
                           for i, name in enumerate(PARAMETER_NAMES)}
    return summary


def print_table(title: str, summary: dict):
    print(f"\n{title}")
    header = "".join(f"{name:>30s}" for name in SHOWN)
    print(f"{'method':7s}{header}")
    print(f"{'':7s}" + "".join(f"{'bias/σ/σ_CR (eff.)':>30s}" for _ in SHOWN))
    for method, parameters in summary.items():
        cells = []
        for name in SHOWN:
            p = parameters[name]
            cells.append(f"{p['bias']:9.1e}/{p['std']:7.1e}/{p['crb_std']:7.1e} ({p['efficiency']:.2f})")
        print(f"{method:7s}" + "".join(f"{c:>30s}" for c in cells))


def print_ratios(summary: dict, target: float):
    """σ/σ_CR of every parameter per method, its largest, and whether that is within ``target``."""
    print(f"{'σ/σ_CR':7s}" + "".join(f"{name:>7s}" for name in PARAMETER_NAMES) + f"{'max':>7s}")
    for method, parameters in summary.items():
        ratios = [parameters[name]["std"] / parameters[name]["crb_std"] for name in PARAMETER_NAMES]
        verdict = "" if max(ratios) <= target else f"  > {target:g}"
        print(f"{method:7s}" + "".join(f"{r:7.2f}" for r in ratios) + f"{max(ratios):7.2f}{verdict}")
