"""The mass the operator feels at the master handle, estimated from a log.

Model along one motion axis u of the handle (in the master base B): the wrench the master
renders on the hand has the force component

    f_u(t) = −m_a·a_u(t) + b

where a_u is the handle's acceleration along u and b a constant (the load's weight as far
as it falls on u, sensor offsets). A mass m_a carried in the hand pushes back against the
hand's acceleration, hence the minus sign. m_a and b come from a least-squares fit.

How the paper's apparent mass appears at the hand. Scaling the non-contact wrench by σ
gives the load the apparent mass σ·m at the slave (Kubus & Wahl, Sec. V). With the
motion scale s (slave m per master m: a_slave = s·a_handle) and the force scale k_f
(master N per slave N), the force on the hand is k_f·σ·m·a_slave = k_f·s·σ·m·a_handle,
so the mass felt at the hand is ``hand_mass(sigma, mass, force_scale, motion_scale)`` =
k_f·s·σ·m.

Acceleration from positions. Differentiating sampled, quantized positions twice
amplifies their noise; `estimate_apparent_mass` therefore smooths the handle position
AND the force with the same zero-phase (symmetric Gaussian FIR) filter before
differentiating. The filter is linear and time-invariant, so f = −m_a·a + b holds
unchanged between the filtered signals: the filter's attenuation of the motion cancels
out of m_a, its lack of phase adds no lag between force and acceleration, and only
high-frequency noise is removed.
"""

import dataclasses

import numpy as np

Z_95 = 1.959963984540054
"""Two-sided 95 % quantile of the standard normal distribution."""


@dataclasses.dataclass
class ApparentMassFit:
    """A fit of f = −m_a·a + b: m_a (kg), its confidence interval (kg), b (N), the RMS of
    the residual (N), the share of the force's variance the fit explains, and the number
    of samples used."""
    mass: float
    interval: tuple[float, float]
    offset: float
    residual_rms: float
    r_squared: float
    samples: int

    def as_dict(self) -> dict:
        """The fit as plain JSON-ready numbers."""
        return {"mass_kg": self.mass, "interval_kg": list(self.interval), "offset_N": self.offset,
                "residual_rms_N": self.residual_rms, "r_squared": self.r_squared, "samples": self.samples}


def hand_mass(sigma: float, mass: float, force_scale: float, motion_scale: float) -> float:
    """The load's mass felt at the master handle (kg): k_f·s·σ·m (module docstring), for the
    non-contact scale σ, the load's mass m (kg), the force scale k_f (master N per slave N)
    and the motion scale s (slave m per master m)."""
    return force_scale * motion_scale * sigma * mass


def _correlation_inflation(residual: np.ndarray) -> float:
    """1 + 2·Σρ_k of the residual, summed over lags until the autocorrelation first drops
    to ≤ 0 (at least 1): how much correlated samples widen the variance of a mean."""
    centred = residual - residual.mean()
    spectrum = np.fft.rfft(centred, 2 * centred.size)
    autocovariance = np.fft.irfft(spectrum * np.conj(spectrum))[:centred.size]
    if autocovariance[0] <= 0.0:
        return 1.0
    rho = autocovariance[1:] / autocovariance[0]
    stop = np.flatnonzero(rho <= 0.0)
    return max(1.0, 1.0 + 2.0 * float(rho[:stop[0] if stop.size else rho.size].sum()))


def fit_apparent_mass(force, acceleration, z: float = Z_95, correlated: bool = True) -> ApparentMassFit:
    """Least-squares fit of ``force`` (N,; N) = −m_a·``acceleration`` (N,; m/s²) + b.

    The interval is m_a ± z·SE with the usual regression standard error, widened by the
    residual's autocorrelation (`_correlation_inflation`) when ``correlated`` (filtered or
    oversampled signals are not independent sample to sample); z = 1.96 gives 95 % for
    more than a few dozen effective samples."""
    force, acceleration = np.asarray(force, dtype=float), np.asarray(acceleration, dtype=float)
    if force.ndim != 1 or force.shape != acceleration.shape:
        raise ValueError(f"force and acceleration must be 1-D arrays of one length; got shapes "
                         f"{force.shape} and {acceleration.shape}")
    if force.size < 3 or not (np.isfinite(force).all() and np.isfinite(acceleration).all()):
        raise ValueError("force and acceleration need at least 3 finite samples each")
    spread = acceleration - acceleration.mean()
    sxx = float(spread @ spread)
    if sxx <= 1e-12 * force.size:
        raise ValueError("the acceleration does not vary: the handle must move back and forth along "
                         "the axis for a mass to show")
    mass = -float(spread @ (force - force.mean())) / sxx
    offset = float(force.mean() + mass * acceleration.mean())
    residual = force - (offset - mass * acceleration)
    variance = float(residual @ residual) / (force.size - 2)
    if correlated:
        variance *= _correlation_inflation(residual)
    half_width = z * np.sqrt(variance / sxx)
    total = float(((force - force.mean()) ** 2).sum())
    return ApparentMassFit(mass=mass, interval=(mass - half_width, mass + half_width), offset=offset,
                           residual_rms=float(np.sqrt(np.mean(residual ** 2))),
                           r_squared=1.0 - float(residual @ residual) / total if total > 0 else 0.0,
                           samples=int(force.size))


def gaussian_smooth(x, period: float, width: float) -> np.ndarray:
    """``x`` (N,) sampled every ``period`` s convolved with a unit-gain Gaussian of standard
    deviation ``width`` s (truncated at ±4 widths): a symmetric FIR, so zero phase. Samples
    within 4 widths of either end are not fully filtered; `estimate_apparent_mass` drops them."""
    x = np.asarray(x, dtype=float)
    half = int(np.ceil(4.0 * width / period))
    if 2 * half + 1 > x.size:
        raise ValueError(f"{x.size} samples are too few for a {width:g} s smoothing at {period:g} s; "
                         "record longer or smooth less")
    lags = np.arange(-half, half + 1) * period
    kernel = np.exp(-0.5 * (lags / width) ** 2)
    return np.convolve(x, kernel / kernel.sum(), mode="same")


def estimate_apparent_mass(t, force, position, smoothing: float = 0.01, window=None,
                           z: float = Z_95) -> ApparentMassFit:
    """m_a from a handle's ``position`` (N,; m along the axis) and the ``force`` (N,; N along
    the axis) rendered on it, sampled uniformly at times ``t`` (N,; s).

    Both are smoothed by `gaussian_smooth` of ``smoothing`` s, the position differentiated
    twice by central differences, and `fit_apparent_mass` run on the samples inside
    ``window`` = (start, end) s (default: all) that the filter reached fully."""
    t, force, position = (np.asarray(x, dtype=float) for x in (t, force, position))
    if not (t.ndim == 1 and t.shape == force.shape == position.shape and t.size >= 3):
        raise ValueError(f"t, force and position must be 1-D of one length >= 3; got shapes {t.shape}, "
                         f"{force.shape} and {position.shape}")
    steps = np.diff(t)
    period = float(steps.mean())
    if not (period > 0 and np.allclose(steps, period, rtol=1e-6, atol=1e-9)):
        raise ValueError("t must be uniformly sampled and increasing")
    if not smoothing > 0:
        raise ValueError(f"smoothing must be > 0 s; got {smoothing}")
    acceleration = np.zeros_like(position)
    smoothed = gaussian_smooth(position, period, smoothing)
    acceleration[1:-1] = (smoothed[2:] - 2.0 * smoothed[1:-1] + smoothed[:-2]) / period ** 2
    margin = 4.0 * smoothing + 2.0 * period
    keep = (t >= t[0] + margin) & (t <= t[-1] - margin)
    if window is not None:
        keep &= (t >= window[0]) & (t <= window[1])
    if keep.sum() < 3:
        raise ValueError(f"fewer than 3 samples left inside the window {window} after dropping "
                         f"{margin:g} s at each end for the filter")
    return fit_apparent_mass(gaussian_smooth(force, period, smoothing)[keep], acceleration[keep], z)
