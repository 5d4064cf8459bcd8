"""The Cramér–Rao bounds of `heft bench identify`: the errors-in-variables bound is the Schur
complement of the full Fisher information with the true accelerations as nuisance parameters,
built here from the model's Jacobians directly, and ∂(V·φ)/∂[a; α] matches finite differences."""

import numpy as np

from heft.analysis.bench_identify import cramer_rao_bound
from heft.systems.identification.regression_noise import NoiseLevels, wrench_motion_jacobian
from heft.systems.load_dynamics import InertialParameters, regressor, regressor_with_offsets


def motion(rng, samples):
    a, alpha, omega = (rng.normal(scale=s, size=(samples, 3)) for s in (3.0, 5.0, 2.0))
    g = rng.normal(size=(samples, 3))
    return a, alpha, omega, 9.81 * g / np.linalg.norm(g, axis=1, keepdims=True)


def test_wrench_motion_jacobian_matches_finite_differences():
    rng = np.random.default_rng(4)
    phi = InertialParameters.random(rng).to_phi()
    a, alpha, omega, g = (x[0] for x in motion(rng, 1))
    J = wrench_motion_jacobian(phi)
    h = 1e-6
    for i in range(6):
        step = np.zeros(6)
        step[i] = h
        plus = regressor(a + step[:3], alpha + step[3:], omega, g) @ phi
        minus = regressor(a - step[:3], alpha - step[3:], omega, g) @ phi
        np.testing.assert_allclose(J[:, i], (plus - minus) / (2 * h), atol=1e-7)


def test_errors_in_variables_bound_is_the_schur_complement_of_the_full_fisher():
    """θ and every sample's true [a; α] as unknowns, the wrench and the accelerometer as
    observations: the information left for θ after the nuisances is what the bound inverts."""
    rng = np.random.default_rng(5)
    phi = InertialParameters.random(rng).to_phi()
    samples = 40
    a, alpha, omega, g = motion(rng, samples)
    noise = NoiseLevels()
    sigma_y = np.array([noise.force] * 3 + [noise.torque] * 3)
    sigma_x = np.array([noise.linear_acceleration] * 3 + [noise.angular_acceleration] * 3)
    A = regressor_with_offsets(a, alpha, omega, g)
    J = wrench_motion_jacobian(phi)
    unknowns = 16 + 6 * samples
    H = np.zeros((12 * samples, unknowns))  # rows: (wrench, accelerometer) per sample, whitened
    for k in range(samples):
        rows = slice(12 * k, 12 * k + 6)
        H[rows, :16] = A[k] / sigma_y[:, None]
        H[rows, 16 + 6 * k:22 + 6 * k] = J / sigma_y[:, None]
        H[12 * k + 6:12 * k + 12, 16 + 6 * k:22 + 6 * k] = np.diag(1 / sigma_x)
    full = H.T @ H
    nuisance = full[16:, 16:]
    schur = full[:16, :16] - full[:16, 16:] @ np.linalg.solve(nuisance, full[16:, :16])
    bound = cramer_rao_bound(a, alpha, omega, g, noise, phi)
    np.testing.assert_allclose(np.linalg.inv(bound), schur, rtol=1e-8, atol=1e-6 * np.abs(schur).max())
    wrench_only = cramer_rao_bound(a, alpha, omega, g, noise)
    assert np.all(np.diag(bound) >= np.diag(wrench_only) * (1 - 1e-9))  # the accelerometer costs information
