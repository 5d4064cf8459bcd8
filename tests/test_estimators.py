"""Estimators against independent references: the true load, Drake's simulated wrench,
scipy's least squares, closed-form IV, Monte Carlo spread."""

import copy

import numpy as np
import pytest
import scipy.linalg

from heft.analysis.bench_identify import cramer_rao_bound
from heft.diagrams.stations.load_on_sensor import simulate_random_motion
from heft.systems.identification.batch_estimation import batch_estimate, stack
from heft.systems.load_dynamics import PARAMETER_NAMES, PHI_NAMES, InertialParameters, regressor
from heft.systems.identification.recursive_estimation import (
    RecursiveInstrumentalVariables, RecursiveLeastSquares, RecursiveTotalLeastSquares, information_update)
from heft.systems.identification.regression_noise import NoiseLevels

RECURSIVE = (RecursiveLeastSquares, RecursiveInstrumentalVariables, RecursiveTotalLeastSquares)
WRENCH_NOISE = np.repeat([0.1, 0.005], 3)  # N, N·m: docs/design.md §6


def unit_gravity(rng, n):
    g = rng.normal(size=(n, 3))
    return 9.81 * g / np.linalg.norm(g, axis=1)[:, None]


def rich_motion(rng, n):
    """Independent random a, α, ω and gravity directions per sample: every column excited."""
    return (rng.normal(scale=3.0, size=(n, 3)), rng.normal(scale=5.0, size=(n, 3)),
            rng.normal(scale=2.0, size=(n, 3)), unit_gravity(rng, n))


def multisine(rng, t, amplitude):
    """Smooth band-limited (0.5–4 Hz) motion signal, (len(t), 3)."""
    f, phase = rng.uniform(0.5, 4.0, (5, 3)), rng.uniform(0, 2 * np.pi, (5, 3))
    return amplitude * np.sin(2 * np.pi * f * t[:, None, None] + phase).sum(axis=1) / 2


def random_load_and_offsets(rng):
    return InertialParameters.random(rng).to_phi(), rng.normal(size=6) * np.repeat([3.0, 0.2], 3)


def feed(estimator, wrench, a, alpha, omega, g, instrument=None):
    """One update per row; RIV's instrument defaults to the regressor's own signals."""
    if isinstance(estimator, RecursiveInstrumentalVariables):
        source = instrument if instrument is not None else (a, alpha, omega, g)
        for k in range(len(wrench)):
            estimator.update(wrench[k], a[k], alpha[k], omega[k], g[k], instrument=tuple(x[k] for x in source))
    else:
        for sample in zip(wrench, a, alpha, omega, g):
            estimator.update(*sample)


# --- exact data ---------------------------------------------------------------------

@pytest.mark.parametrize("offsets", [True, False])
@pytest.mark.parametrize("method", ["ols", "wls", "tls", "eiv_ml"])
def test_batch_methods_recover_exact_parameters(method, offsets):
    rng = np.random.default_rng(10)
    for _ in range(5):
        phi, bias = random_load_and_offsets(rng)
        bias = bias if offsets else np.zeros(6)
        a, alpha, omega, g = rich_motion(rng, 200)
        wrench = regressor(a, alpha, omega, g) @ phi + bias
        estimate = batch_estimate(wrench, a, alpha, omega, g, method=method, offsets=offsets)
        np.testing.assert_allclose(estimate.phi, phi, rtol=0, atol=1e-8 * np.abs(phi).max())
        np.testing.assert_allclose(estimate.offsets, bias, rtol=0, atol=1e-8)
        assert estimate.identifiable.all() and len(estimate.identifiable) == (16 if offsets else 10)
        assert estimate.covariance.shape == (len(estimate.identifiable),) * 2
        assert estimate.num_samples == 200 and estimate.method == method
        assert estimate.residual_rms.max() < 1e-9 and estimate.condition_number < 100
        assert estimate.violations() == []
        body = estimate.inertial_parameters()
        np.testing.assert_allclose(body.to_phi(), phi, atol=1e-8)


def test_batch_estimate_recovers_a_load_from_drake_simulated_motion():
    """Drake's weld reaction along a physically simulated tumble (the regressor is not used
    to make the data), with sensor offsets added."""
    rng = np.random.default_rng(11)
    load = InertialParameters.random(rng)
    _, wrench, a, alpha, omega, g = simulate_random_motion(load, rng, duration=0.5)
    bias = rng.normal(size=6)
    estimate = batch_estimate(wrench + bias, a, alpha, omega, g)
    assert estimate.identifiable.all()
    np.testing.assert_allclose(estimate.phi, load.to_phi(), atol=1e-8)
    np.testing.assert_allclose(estimate.offsets, bias, atol=1e-8)


@pytest.mark.parametrize("offsets", [True, False])
@pytest.mark.parametrize("estimator_class", RECURSIVE)
def test_recursive_estimators_recover_exact_parameters(estimator_class, offsets):
    rng = np.random.default_rng(12)
    phi, bias = random_load_and_offsets(rng)
    bias = bias if offsets else np.zeros(6)
    a, alpha, omega, g = rich_motion(rng, 400)
    wrench = regressor(a, alpha, omega, g) @ phi + bias
    estimator = estimator_class(offsets=offsets)
    feed(estimator, wrench, a, alpha, omega, g)
    np.testing.assert_allclose(estimator.phi, phi, rtol=0, atol=1e-8 * np.abs(phi).max())
    np.testing.assert_allclose(estimator.offsets, bias, rtol=0, atol=1e-8)
    assert estimator.identifiable.all() and estimator.num_samples == 400
    assert estimator.residual_rms.max() < 1e-6
    estimator.reset()
    assert estimator.num_samples == 0 and not estimator.phi.any()


@pytest.mark.parametrize("estimator_class", RECURSIVE)
def test_a_deep_copy_or_a_reloaded_state_vector_continues_exactly(estimator_class):
    """Drake deep-copies the estimator kept as scratch; the System reloads state vectors."""
    rng = np.random.default_rng(27)
    phi, bias = random_load_and_offsets(rng)
    a, alpha, omega, g = rich_motion(rng, 60)
    wrench = regressor(a, alpha, omega, g) @ phi + bias
    original = estimator_class(forgetting=0.99)
    feed(original, *(x[:30] for x in (wrench, a, alpha, omega, g)))
    clone = copy.deepcopy(original)
    reloaded = estimator_class(forgetting=0.99)
    reloaded.load_state_vector(original.state_vector())
    for estimator in (original, clone, reloaded):
        feed(estimator, *(x[30:] for x in (wrench, a, alpha, omega, g)))
    np.testing.assert_array_equal(clone.state_vector(), original.state_vector())
    np.testing.assert_array_equal(reloaded.state_vector(), original.state_vector())
    clone.reset()
    assert original.num_samples == 60 and clone.num_samples == 0


# --- noise ---------------------------------------------------------------------------

def test_ols_agrees_with_scipy_lstsq_on_noisy_data():
    rng = np.random.default_rng(13)
    phi, bias = random_load_and_offsets(rng)
    a, alpha, omega, g = rich_motion(rng, 300)
    wrench = regressor(a, alpha, omega, g) @ phi + bias + rng.normal(size=(300, 6)) * WRENCH_NOISE
    A, y = stack(wrench, a, alpha, omega, g)
    reference = scipy.linalg.lstsq(A, y)[0]
    estimate = batch_estimate(wrench, a, alpha, omega, g)
    np.testing.assert_allclose(np.concatenate((estimate.offsets, estimate.phi)), reference, rtol=1e-9, atol=1e-12)


def test_ols_is_unbiased_and_its_covariance_matches_the_monte_carlo_spread():
    """100 noisy records of one motion: the mean error is within a few standard errors of
    zero and the reported standard deviations match the empirical ones (force and torque
    noise differ 20×, so a pooled σ̂² would fail this)."""
    rng = np.random.default_rng(14)
    phi, bias = random_load_and_offsets(rng)
    truth = np.concatenate((bias, phi))
    a, alpha, omega, g = rich_motion(rng, 300)
    clean = regressor(a, alpha, omega, g) @ phi + bias
    errors, stds = [], []
    for _ in range(100):
        estimate = batch_estimate(clean + rng.normal(size=clean.shape) * WRENCH_NOISE, a, alpha, omega, g)
        errors.append(np.concatenate((estimate.offsets, estimate.phi)) - truth)
        stds.append(estimate.std)
    errors, stds = np.array(errors), np.array(stds)
    standard_error = errors.std(axis=0, ddof=1) / np.sqrt(len(errors))
    assert np.all(np.abs(errors.mean(axis=0)) < 4 * standard_error)
    ratio = errors.std(axis=0, ddof=1) / np.sqrt(np.mean(stds ** 2, axis=0))
    assert np.all((ratio > 0.7) & (ratio < 1.3)), dict(zip(PARAMETER_NAMES, ratio.round(2)))


@pytest.mark.parametrize("pull", [0.0, 1e-3])
def test_the_information_update_is_the_r_factor_of_the_stacked_rows(pull):
    """Against numpy's Householder QR of [√λ·S √λ·z; c·E c·θ̂; rows]: the same triangle up to the
    rows' signs, and θ̂ the least-squares solution of the stack's first p columns against its last."""
    rng = np.random.default_rng(7)
    p, sqrt_forgetting = 10, 0.9995
    root = np.triu(rng.normal(size=(p + 1, p + 1))) + 3 * np.eye(p + 1)
    theta, rows = rng.normal(size=p), rng.normal(size=(6, p + 1))
    pull_rows = np.hstack((pull * np.eye(p), pull * theta[:, None]))
    stacked = np.vstack((sqrt_forgetting * root, pull_rows if pull else np.zeros((0, p + 1)), rows))
    expected = np.linalg.qr(stacked, mode="r")
    information_update(root, theta, rows.copy(), sqrt_forgetting, pull, np.empty(p + 1))
    signs = np.sign(np.diag(expected)) * np.sign(np.diag(root))
    np.testing.assert_allclose(root, signs[:, None] * expected, atol=1e-12)
    np.testing.assert_allclose(np.tril(root, -1), 0.0)
    np.testing.assert_allclose(theta, np.linalg.lstsq(stacked[:, :p], stacked[:, p], rcond=None)[0], atol=1e-12)


@pytest.mark.parametrize("scale", [1e-170, 1e170])
def test_the_information_update_holds_where_the_squares_leave_a_doubles_range(scale):
    """Every row and the root scaled alike by ``scale``: the same θ̂ (S θ = z does not see a common factor), the
    root scaled by it, where a² + b² under- or overflows (the rotations' hypot fallback)."""
    rng = np.random.default_rng(8)
    p = 10
    root = np.triu(rng.normal(size=(p + 1, p + 1))) + 3 * np.eye(p + 1)
    theta, rows = rng.normal(size=p), rng.normal(size=(6, p + 1))
    expected_root, expected_theta = root.copy(), theta.copy()
    information_update(expected_root, expected_theta, rows.copy(), 0.9995, 0.0, np.empty(p + 1))
    scaled_root = scale * root
    information_update(scaled_root, theta, scale * rows, 0.9995, 0.0, np.empty(p + 1))
    np.testing.assert_allclose(theta, expected_theta, rtol=1e-12)
    np.testing.assert_allclose(scaled_root / scale, expected_root, rtol=1e-12, atol=1e-12)


def test_rls_equals_batch_wls_with_the_same_weights():
    rng = np.random.default_rng(15)
    phi, bias = random_load_and_offsets(rng)
    a, alpha, omega, g = rich_motion(rng, 300)
    wrench = regressor(a, alpha, omega, g) @ phi + bias + rng.normal(size=(300, 6)) * WRENCH_NOISE
    noise = NoiseLevels()
    batch = batch_estimate(wrench, a, alpha, omega, g, method="wls", weights=noise.wrench_weights())
    rls = RecursiveLeastSquares(noise=noise)
    feed(rls, wrench, a, alpha, omega, g)
    np.testing.assert_allclose(rls.phi, batch.phi, atol=1e-3 * batch.std[6:].min())
    np.testing.assert_allclose(rls.offsets, batch.offsets, atol=1e-3 * batch.std[:6].min())
    np.testing.assert_allclose(np.sqrt(np.diag(rls.covariance)), batch.std, rtol=0.15)


def test_riv_equals_the_closed_form_instrumental_variable_solution():
    rng = np.random.default_rng(16)
    phi, bias = random_load_and_offsets(rng)
    a, alpha, omega, g = rich_motion(rng, 300)
    wrench = regressor(a, alpha, omega, g) @ phi + bias + rng.normal(size=(300, 6)) * WRENCH_NOISE
    noisy_a, noisy_alpha = a + rng.normal(size=a.shape), alpha + rng.normal(size=alpha.shape)
    A, y = stack(wrench, noisy_a, noisy_alpha, omega, g)
    Z, _ = stack(wrench, a, alpha, omega, g)
    W = np.tile(NoiseLevels().wrench_weights(), 300)
    reference = np.linalg.solve(Z.T @ (W[:, None] * A), Z.T @ (W * y))
    riv = RecursiveInstrumentalVariables()
    feed(riv, wrench, noisy_a, noisy_alpha, omega, g, instrument=(a, alpha, omega, g))
    np.testing.assert_allclose(np.concatenate((riv.offsets, riv.phi)), reference, rtol=1e-6, atol=1e-8)


@pytest.fixture(scope="module")
def errors_in_variables():
    """A record where the accelerometer is very noisy (1 m/s², 3 rad/s² RMS, against signals
    of a few m/s² and rad/s²): least squares is biased towards zero, strongly on the inertia."""
    rng = np.random.default_rng(17)
    load = InertialParameters(2.0, [0.02, -0.03, 0.08], np.diag([0.02, 0.03, 0.015]))
    n = 4000
    t = np.arange(n) * 5e-4
    a, alpha, omega = multisine(rng, t, 2.0), multisine(rng, t, 4.0), multisine(rng, t, 1.5)
    g = unit_gravity(rng, n)
    bias = np.array([3.0, -2.0, 1.0, 0.1, -0.05, 0.2])
    wrench = regressor(a, alpha, omega, g) @ load.to_phi() + bias + rng.normal(size=(n, 6)) * WRENCH_NOISE
    noise = NoiseLevels(linear_acceleration=1.0, angular_acceleration=3.0)
    measured_a = a + rng.normal(scale=noise.linear_acceleration, size=a.shape)
    measured_alpha = alpha + rng.normal(scale=noise.angular_acceleration, size=alpha.shape)
    return load.to_phi(), noise, wrench, (measured_a, measured_alpha, omega, g), (a, alpha, omega, g)


def test_tls_and_riv_remove_the_least_squares_bias_of_noisy_accelerations(errors_in_variables):
    phi, noise, wrench, measured, clean = errors_in_variables
    diagonal = [0, 4, 7, 9]  # m, Ixx, Iyy, Izz

    def relative_error(estimated_phi):
        return np.abs(estimated_phi - phi)[diagonal] / phi[diagonal]

    ols = batch_estimate(wrench, *measured)
    rls = RecursiveLeastSquares(noise=noise)
    feed(rls, wrench, *measured)
    for biased in (ols.phi, rls.phi):
        assert relative_error(biased)[1:].min() > 0.2       # ≥ 20 % low on every principal moment
        assert np.all(biased[[4, 7, 9]] < phi[[4, 7, 9]])   # attenuated
    tls = batch_estimate(wrench, *measured, method="tls", noise=noise)
    riv = RecursiveInstrumentalVariables(noise=noise)
    feed(riv, wrench, *measured, instrument=clean)
    rtls = RecursiveTotalLeastSquares(noise=noise)
    feed(rtls, wrench, *measured)
    for name, estimated_phi, std in (("tls", tls.phi, tls.std[6:]),
                                     ("riv", riv.phi, np.sqrt(np.diag(riv.covariance))[6:]),
                                     ("rtls", rtls.phi, np.sqrt(np.diag(rtls.covariance))[6:])):
        assert np.all(relative_error(estimated_phi) < 0.3 * relative_error(ols.phi)), name
        assert np.all(np.abs(estimated_phi - phi) < 4 * std), name


def test_rtls_tracks_the_batch_tls_solution(errors_in_variables):
    """Same pencil, one inverse iteration per sample: RTLS trails the batch TLS solution of
    all the data by a small fraction of its standard deviation."""
    _, noise, wrench, measured, _ = errors_in_variables
    tls = batch_estimate(wrench, *measured, method="tls", noise=noise)
    rtls = RecursiveTotalLeastSquares(noise=noise)
    feed(rtls, wrench, *measured)
    assert np.all(np.abs(rtls.phi - tls.phi) < 0.2 * tls.std[6:])
    assert np.all(np.abs(rtls.offsets - tls.offsets) < 0.2 * tls.std[:6])
    np.testing.assert_allclose(np.sqrt(np.diag(rtls.covariance)), tls.std, rtol=0.05)


@pytest.mark.parametrize("seed", [2, 4, 5])
def test_rtls_recovers_from_a_start_up_transient_when_the_kinematics_are_cleaner_than_assumed(seed):
    """a and α as differentiated encoders give them: exact but for a start-up transient (10×
    the assumed noise, decaying in 0.1 s), then far cleaner than the default noise levels
    assumed. The transient drives the early estimate out along directions the data excite
    below one noise unit; RTLS must still end at the batch TLS solution. (A pseudo-measurement
    "φ = φ̂" in φ's coordinates froze the scale of such an inflated estimate: it ran away, to
    ~10⁴ batch standard deviations.)"""
    rng = np.random.default_rng(seed)
    phi, bias = random_load_and_offsets(rng)
    n = 4000
    t = np.arange(n) * 5e-4
    ramp = np.minimum(t, 1.0)[:, None]                       # from rest to full motion in 1 s
    a, alpha, omega = ramp * multisine(rng, t, 2.0), ramp * multisine(rng, t, 4.0), ramp * multisine(rng, t, 1.5)
    tilt = ramp * multisine(rng, t, 0.5)
    g = np.column_stack((tilt[:, 0], tilt[:, 1], np.ones(n)))
    g *= 9.81 / np.linalg.norm(g, axis=1)[:, None]
    wrench = regressor(a, alpha, omega, g) @ phi + bias + rng.normal(size=(n, 6)) * WRENCH_NOISE
    noise = NoiseLevels()
    transient = 10.0 * np.exp(-t / 0.1)[:, None]
    measured = (a + transient * noise.linear_acceleration * multisine(rng, t, 1.0),
                alpha + transient * noise.angular_acceleration * multisine(rng, t, 1.0), omega, g)
    tls = batch_estimate(wrench, *measured, method="tls", noise=noise)
    assert abs(tls.phi[0] - phi[0]) < 0.01 * phi[0]
    rtls = RecursiveTotalLeastSquares(noise=noise)
    feed(rtls, wrench, *measured)
    assert np.all(np.abs(rtls.phi - tls.phi) < 0.5 * tls.std[6:])
    assert np.all(np.abs(rtls.offsets - tls.offsets) < 0.5 * tls.std[:6])


# --- errors-in-variables maximum likelihood ------------------------------------------------

def smooth_record(rng, n):
    """A load with offsets and n samples (2 kHz) of smooth multisine motion."""
    phi, bias = random_load_and_offsets(rng)
    t = np.arange(n) * 5e-4
    a, alpha, omega = multisine(rng, t, 2.0), multisine(rng, t, 4.0), multisine(rng, t, 1.5)
    return phi, bias, (a, alpha, omega, unit_gravity(rng, n))


def test_eiv_ml_reaches_the_errors_in_variables_cramer_rao_bound():
    """Gaussian noise of the default sensor model on the wrench and on a, α, 150 runs of one
    motion: per parameter, eiv_ml's spread is within 1.2× the errors-in-variables bound (the
    Schur complement of the full Fisher information, test_bench_identify), its mean within 3
    standard errors of the truth and its reported σ the bound's within 5 %. The accelerometer
    matters here: it raises the bound's σ 1.2–3.3× above the wrench-only one."""
    rng = np.random.default_rng(30)
    phi, bias, (a, alpha, omega, g) = smooth_record(rng, 500)
    noise = NoiseLevels()
    bound = np.sqrt(np.diag(cramer_rao_bound(a, alpha, omega, g, noise, phi)))
    assert np.all(bound / np.sqrt(np.diag(cramer_rao_bound(a, alpha, omega, g, noise))) > 1.2)
    clean = regressor(a, alpha, omega, g) @ phi + bias
    truth = np.concatenate((bias, phi))
    estimates, stds = [], []
    for _ in range(150):
        wrench = clean + rng.normal(size=clean.shape) * WRENCH_NOISE
        noisy_a = a + rng.normal(scale=noise.linear_acceleration, size=a.shape)
        noisy_alpha = alpha + rng.normal(scale=noise.angular_acceleration, size=alpha.shape)
        estimate = batch_estimate(wrench, noisy_a, noisy_alpha, omega, g, method="eiv_ml", noise=noise)
        estimates.append(np.concatenate((estimate.offsets, estimate.phi)))
        stds.append(estimate.std)
    estimates = np.array(estimates)
    spread = estimates.std(axis=0, ddof=1)
    assert np.all(spread < 1.2 * bound), dict(zip(PARAMETER_NAMES, (spread / bound).round(2)))
    standard_error = spread / np.sqrt(len(estimates))
    assert np.all(np.abs(estimates.mean(axis=0) - truth) < 3 * standard_error)
    np.testing.assert_allclose(np.mean(stds, axis=0), bound, rtol=0.05)


def test_eiv_ml_with_exact_accelerations_is_weighted_least_squares():
    """Noise-free a and α: the likelihood is that of weighted least squares, and the reported
    covariance is the wrench-only Cramér–Rao bound times the fit's variance factor (≈ 1)."""
    rng = np.random.default_rng(31)
    phi, bias, (a, alpha, omega, g) = smooth_record(rng, 1000)
    noise = NoiseLevels(linear_acceleration=0.0, angular_acceleration=0.0)
    wrench = regressor(a, alpha, omega, g) @ phi + bias + rng.normal(size=(1000, 6)) * WRENCH_NOISE
    ml = batch_estimate(wrench, a, alpha, omega, g, method="eiv_ml", noise=noise)
    wls = batch_estimate(wrench, a, alpha, omega, g, method="wls", weights=noise.wrench_weights())
    np.testing.assert_allclose(ml.phi, wls.phi, rtol=0, atol=1e-9 * wls.std[6:].min())
    np.testing.assert_allclose(ml.offsets, wls.offsets, rtol=0, atol=1e-9 * wls.std[:6].min())
    ratio = ml.covariance / cramer_rao_bound(a, alpha, omega, g, noise)
    np.testing.assert_allclose(ratio, ratio[0, 0], rtol=1e-6)
    assert 0.95 < ratio[0, 0] < 1.05


def test_eiv_ml_refuses_data_it_cannot_estimate_from():
    rng = np.random.default_rng(32)
    phi, bias, (a, alpha, omega, g) = smooth_record(rng, 500)
    zero = np.zeros(3)
    at_rest = regressor(zero, zero, zero, g[0]) @ phi + bias + np.zeros((500, 6))
    with pytest.raises(ValueError, match="excite none of phi's directions"):
        batch_estimate(at_rest, zero, zero, zero, g[0], method="eiv_ml")
    # a hundredth of the motion: α's RMS (≈ 0.04 rad/s²) far below the accelerometer's noise (0.5 rad/s²)
    a, alpha, omega = 0.01 * a, 0.01 * alpha, 0.01 * omega
    noise = NoiseLevels()
    wrench = regressor(a, alpha, omega, g) @ phi + bias + rng.normal(size=(500, 6)) * WRENCH_NOISE
    noisy_a = a + rng.normal(scale=noise.linear_acceleration, size=a.shape)
    noisy_alpha = alpha + rng.normal(scale=noise.angular_acceleration, size=alpha.shape)
    with pytest.raises(ValueError, match="excites phi too little against the accelerometer's noise"):
        batch_estimate(wrench, noisy_a, noisy_alpha, omega, g, method="eiv_ml", noise=noise)
    with pytest.raises(ValueError, match="noise.angular_velocity must be 0"):
        batch_estimate(wrench, a, alpha, omega, g, method="eiv_ml", noise=NoiseLevels(angular_velocity=0.01))


# --- identifiability -----------------------------------------------------------------

@pytest.mark.parametrize("method", ["ols", "wls", "tls", "eiv_ml"])
def test_static_poses_leave_the_inertia_unidentifiable(method):
    rng = np.random.default_rng(18)
    phi, bias = random_load_and_offsets(rng)
    zero, g = np.zeros(3), unit_gravity(rng, 40)
    wrench = regressor(zero, zero, zero, g) @ phi + bias
    estimate = batch_estimate(wrench, zero, zero, zero, g, method=method)
    expected = np.array([True] * 10 + [False] * 6)            # offsets, m, m·c | inertia
    np.testing.assert_array_equal(estimate.identifiable, expected)
    np.testing.assert_allclose(estimate.phi[:4], phi[:4], atol=1e-9)
    np.testing.assert_allclose(estimate.offsets, bias, atol=1e-9)
    np.testing.assert_array_equal(estimate.phi[4:], 0.0)      # minimum norm, not a guess
    assert np.isinf(estimate.std[10:]).all() and np.isfinite(estimate.std[:10]).all()
    assert np.isnan(estimate.covariance[10:, :10]).all()
    assert estimate.condition_number == np.inf
    assert sorted(estimate.violations()) == sorted(f"{name} is not identifiable from these data"
                                                   for name in PHI_NAMES[4:])
    with pytest.raises(ValueError, match="Ixx, Ixy, Ixz, Iyy, Iyz, Izz not identifiable"):
        estimate.inertial_parameters()


def test_two_static_poses_leave_the_com_partly_unidentifiable():
    """g1 = −9.81 z and g2 = 9.81 x: (τ_o, m·c) is blind to m·c ∥ g1 − g2 ∝ (1, 0, 1) together
    with τ_o ∝ g1 × (1, 0, 1) ∝ y, so m·cx, m·cz and τ_oy are unidentifiable, the rest not."""
    phi, bias = random_load_and_offsets(np.random.default_rng(19))
    g = np.repeat([[0.0, 0.0, -9.81], [9.81, 0.0, 0.0]], 5, axis=0)
    zero = np.zeros(3)
    estimate = batch_estimate(regressor(zero, zero, zero, g) @ phi + bias, zero, zero, zero, g)
    unidentifiable = {name for name, ok in zip(estimate.names, estimate.identifiable) if not ok}
    assert unidentifiable == {"ty_o", "m*cx", "m*cz", "Ixx", "Ixy", "Ixz", "Iyy", "Iyz", "Izz"}
    np.testing.assert_allclose(estimate.phi[[0, 2]], phi[[0, 2]], atol=1e-9)


def test_rotation_about_one_axis_leaves_the_predicted_inertia_entries_unobservable():
    """ω, α ∥ z: τ = Iα + ω×(Iω) only involves I's third column, so Ixx, Ixy, Iyy are blind."""
    rng = np.random.default_rng(20)
    phi, bias = random_load_and_offsets(rng)
    n = 300
    omega, alpha = np.zeros((n, 3)), np.zeros((n, 3))
    omega[:, 2], alpha[:, 2] = rng.normal(scale=3.0, size=n), rng.normal(scale=5.0, size=n)
    a, g = rng.normal(size=(n, 3)), unit_gravity(rng, n)
    wrench = regressor(a, alpha, omega, g) @ phi + bias
    expected = np.array([name not in ("Ixx", "Ixy", "Iyy") for name in PARAMETER_NAMES])
    estimate = batch_estimate(wrench, a, alpha, omega, g)
    np.testing.assert_array_equal(estimate.identifiable, expected)
    for estimator in (RecursiveLeastSquares(), RecursiveTotalLeastSquares()):
        feed(estimator, wrench, a, alpha, omega, g)
        np.testing.assert_array_equal(estimator.identifiable, expected)
        np.testing.assert_allclose(estimator.phi[expected[6:]], phi[expected[6:]], atol=1e-8)
        assert np.isinf(np.diag(estimator.covariance)[~expected]).all()


# --- long runs with forgetting ---------------------------------------------------------

@pytest.mark.parametrize("estimator_class", RECURSIVE)
def test_at_rest_with_forgetting_only_what_rest_reveals_stays_identifiable(estimator_class):
    """Held still with g ∥ z, the wrench is f = f_o − m·g, τ = τ_o − (m·c) × g: only f_ox,
    f_oy and τ_oz remain observable. Once forgetting has faded the excitation's information,
    exactly those are identifiable, and the estimate is held where the excitation left it."""
    rng = np.random.default_rng(28)
    phi, bias = random_load_and_offsets(rng)
    estimator = estimator_class(forgetting=0.99)
    excitation = rich_motion(rng, 1000)
    feed(estimator, regressor(*excitation) @ phi + bias, *excitation)
    zero, g = np.zeros(3), np.array([0.0, 0.0, -9.81])
    n = 5000                                                   # 0.99⁵⁰⁰⁰ ≈ 1e-22
    feed(estimator, np.tile(regressor(zero, zero, zero, g) @ phi + bias, (n, 1)), *(np.tile(x, (n, 1))
                                                                                  for x in (zero, zero, zero, g)))
    expected = np.array([name in ("fx_o", "fy_o", "tz_o") for name in PARAMETER_NAMES])
    np.testing.assert_array_equal(estimator.identifiable, expected)
    np.testing.assert_allclose(estimator.phi, phi, atol=1e-8 * np.abs(phi).max())
    assert estimator.condition_number == np.inf



def test_rls_with_forgetting_stays_sound_over_200k_samples_with_idle_stretches():
    """λ = 0.999 (1000-sample memory); excitation, 60k samples at rest, excitation, a load
    change, excitation, 60k at rest. The information R = SᵀS stays symmetric with R⁻¹ ⪯ P₀·E and
    λ_max(R) ≤ (E/P₀ + max AᵀWA)/(1−λ); the estimate is held at rest, correct after
    excitation resumes, and follows the load change."""
    rng = np.random.default_rng(21)
    forgetting, initial_covariance = 0.999, 1e6
    rls = RecursiveLeastSquares(forgetting=forgetting, initial_covariance=initial_covariance)
    phi_1, bias = random_load_and_offsets(rng)
    phi_2 = InertialParameters.random(rng).to_phi()
    excitation = rich_motion(rng, 2000)
    weights = NoiseLevels().wrench_weights()
    A, _ = stack(np.zeros((2000, 6)), *excitation)
    upper = 1 / initial_covariance + np.linalg.eigvalsh(A.T @ (np.tile(weights, 2000)[:, None] * A)).max()
    zero, g_rest = np.zeros(3), np.array([0.0, 0.0, -9.81])

    def excite(phi, repeats):
        wrench = regressor(*excitation) @ phi + bias
        for _ in range(repeats):
            feed(rls, wrench, *excitation)

    def rest(phi, samples):
        wrench = regressor(zero, zero, zero, g_rest) @ phi + bias
        for _ in range(samples):
            rls.update(wrench, zero, zero, zero, g_rest)

    def check_information():
        information = rls.information
        np.testing.assert_array_equal(information, information.T)
        assert np.linalg.eigvalsh(information).max() <= upper / (1 - forgetting)
        # R⁻¹ ⪯ P₀·E (no blow-up), checked on the square root: R's condition (~1e15) is beyond
        # what an eigen-decomposition of R itself resolves.
        singular_values = np.linalg.svd(rls.information_root, compute_uv=False)
        assert np.isfinite(singular_values).all()
        assert singular_values.min() ** 2 >= (1 - 1e-6) / initial_covariance

    def check_estimate(phi):
        np.testing.assert_allclose(rls.phi, phi, atol=1e-8 * np.abs(phi).max())
        np.testing.assert_allclose(rls.offsets, bias, atol=1e-8)
        assert rls.identifiable.all() and np.isfinite(rls.covariance).all()

    excite(phi_1, 10)
    check_estimate(phi_1)
    rest(phi_1, 60_000)
    check_information()
    assert not rls.identifiable[10:].any()       # the inertia information has faded to the prior
    np.testing.assert_allclose(rls.phi, phi_1, atol=1e-8 * np.abs(phi_1).max())  # held, not drifted
    excite(phi_1, 10)
    check_estimate(phi_1)
    excite(phi_2, 20)                             # the load changes
    check_estimate(phi_2)
    rest(phi_2, 60_000)
    check_information()
    covariance = rls.covariance
    finite = np.isfinite(covariance)
    np.testing.assert_array_equal(covariance[finite], covariance.T[finite])
    assert rls.num_samples == 200_000


# --- bad input ----------------------------------------------------------------------------

def test_batch_estimate_rejects_bad_input_naming_the_argument():
    rng = np.random.default_rng(25)
    a, alpha, omega, g = rich_motion(rng, 10)
    wrench = rng.normal(size=(10, 6))
    with pytest.raises(ValueError, match="wrench must have shape"):
        batch_estimate(wrench[:, :5], a, alpha, omega, g)
    with pytest.raises(ValueError, match=r"alpha must have shape \(10, 3\)"):
        batch_estimate(wrench, a, alpha[:9], omega, g)
    bad = omega.copy()
    bad[3, 1] = np.nan
    with pytest.raises(ValueError, match=r"omega has NaN or inf .*first rows \[3\]"):
        batch_estimate(wrench, a, alpha, bad, g)
    with pytest.raises(ValueError, match="wrench has 2 sample"):
        batch_estimate(wrench[:2], a[:2], alpha[:2], omega[:2], g[:2])
    with pytest.raises(ValueError, match="method must be one of"):
        batch_estimate(wrench, a, alpha, omega, g, method="lasso")
    with pytest.raises(ValueError, match="weights apply to method='wls'"):
        batch_estimate(wrench, a, alpha, omega, g, weights=np.ones(6))
    with pytest.raises(ValueError, match="weights must be 6 positive"):
        batch_estimate(wrench, a, alpha, omega, g, method="wls", weights=-np.ones(6))
    with pytest.raises(ValueError, match="noise.linear_acceleration"):
        batch_estimate(wrench, a, alpha, omega, g, method="tls", noise=NoiseLevels(linear_acceleration=0.0))
    with pytest.raises(ValueError, match="rcond"):
        batch_estimate(wrench, a, alpha, omega, g, rcond=2.0)


def test_recursive_update_rejects_bad_samples_and_keeps_its_state():
    rng = np.random.default_rng(26)
    a, alpha, omega, g = (rng.normal(size=3) for _ in range(4))
    wrench = rng.normal(size=6)
    for estimator in (RecursiveLeastSquares(), RecursiveTotalLeastSquares()):
        estimator.update(wrench, a, alpha, omega, g)
        before = estimator.state_vector()
        with pytest.raises(ValueError, match="wrench contains NaN"):
            estimator.update(np.full(6, np.nan), a, alpha, omega, g)
        with pytest.raises(ValueError, match="omega contains NaN"):
            estimator.update(wrench, a, alpha, np.array([0.0, np.inf, 0.0]), g)
        with pytest.raises(ValueError, match=r"shape \(3,\)"):
            estimator.update(wrench, np.zeros((2, 3)), alpha, omega, g)
        with pytest.raises(ValueError, match=r"wrench must have shape \(6,\)"):
            estimator.update(wrench[:3], a, alpha, omega, g)
        np.testing.assert_array_equal(estimator.state_vector(), before)
    riv = RecursiveInstrumentalVariables()
    with pytest.raises(ValueError, match="instrument: a contains NaN"):
        riv.update(wrench, a, alpha, omega, g, instrument=(np.full(3, np.nan), alpha, omega, g))
    with pytest.raises(ValueError, match="instrument must be"):
        riv.update(wrench, a, alpha, omega, g, instrument=None)
    with pytest.raises(ValueError, match="forgetting"):
        RecursiveLeastSquares(forgetting=1.5)
    with pytest.raises(ValueError, match="initial_covariance"):
        RecursiveInstrumentalVariables(initial_covariance=0.0)
    with pytest.raises(ValueError, match="prior_weight"):
        RecursiveTotalLeastSquares(prior_weight=0.5)
    with pytest.raises(ValueError, match="noise.torque"):
        NoiseLevels(torque=0.0)


def test_feed_runs_every_sample_and_requires_instruments_for_riv():
    from heft.systems.identification.recursive_estimation import feed
    rng = np.random.default_rng(11)
    signals = [rng.normal(size=(50, 3)) for _ in range(4)]
    wrench = rng.normal(size=(50, 6))
    estimator = RecursiveLeastSquares()
    assert list(feed(estimator, wrench, *signals)) == list(range(1, 51))
    assert estimator.num_samples == 50
    with pytest.raises(ValueError, match="needs instruments"):
        next(feed(RecursiveInstrumentalVariables(), wrench, *signals))
