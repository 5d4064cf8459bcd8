import numpy as np
import pytest

from heft.systems.identification.periodic_differentiation import differentiate_periodic


def fourier(t, f, rho, delta, q0):
    k = np.arange(1, rho.shape[1] + 1)
    w = 2 * np.pi * f * k
    s, c = np.sin(np.outer(t, w)), np.cos(np.outer(t, w))
    return (q0 + s @ rho.T + c @ delta.T, (c * w) @ rho.T - (s * w) @ delta.T,
            -(s * w ** 2) @ rho.T - (c * w ** 2) @ delta.T)


def test_exact_for_a_band_limited_periodic_motion_and_filters_quantisation():
    rng = np.random.default_rng(0)
    f, harmonics, T = 0.2, 5, 0.0005
    rho, delta, q0 = rng.normal(size=(6, harmonics)) * 0.1, rng.normal(size=(6, harmonics)) * 0.1, rng.normal(size=6)
    t = np.arange(int(round(2 / f / T))) * T  # two periods
    q, qd, qdd = fourier(t, f, rho, delta, q0)
    got = differentiate_periodic(q, T, f, harmonics)
    for a, b in zip(got, (q, qd, qdd)):
        np.testing.assert_allclose(a, b, atol=1e-9)
    step = 2 * np.pi / 2 ** 16  # a coarse encoder
    got = differentiate_periodic(np.round(q / step) * step, T, f, harmonics)
    assert np.abs(got[2] - qdd).max() < 0.01 * np.abs(qdd).max()
    naive = np.gradient(np.gradient(np.round(q / step) * step, T, axis=0), T, axis=0)
    assert np.abs(naive - qdd).max() > 10 * np.abs(got[2] - qdd).max()


def test_rejects_partial_periods_and_aliasing():
    q = np.zeros((1000, 6))
    with pytest.raises(ValueError, match="whole number of periods"):
        differentiate_periodic(q, 0.001, 0.3, 3)
    with pytest.raises(ValueError, match="Nyquist"):
        differentiate_periodic(q, 0.001, 1.0, 600)
    with pytest.raises(ValueError, match="finite"):
        differentiate_periodic(np.full((1000, 6), np.nan), 0.001, 1.0, 3)
