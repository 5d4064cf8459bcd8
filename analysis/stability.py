"""Stability of simulated runs and of sampled-data / two-port haptic models.

Classification rule (`oscillation_growth`): split a signal x(t) into thirds; in the
middle and the last third remove the low-frequency trend (the least-squares line over
that third) and take the RMS of what remains, the oscillation. With the ratio
r = RMS_last / RMS_middle and Δt the time between the thirds' centres, the envelope
growth rate is λ = ln r / Δt (1/s; an envelope e^{λt}, oscillation energy e^{2λt}).

    r > GROWTH_RATIO          → "growing"   (unstable)
    r < 1 / GROWTH_RATIO      → "decaying"  (stable)
    otherwise                 → "sustained" (marginal: undamped or a limit cycle; stable)

A third whose oscillation RMS is at or below ``quiet`` (the signal's noise floor, in its
units; never below 1e-9·max|x|, the numerical floor) counts as quiet: both quiet →
"decaying"; quiet middle, loud last → "growing". The rule needs each third to span several oscillation periods.
"""

import dataclasses
import math

import numpy as np

GROWTH_RATIO = 1.2
"""RMS ratio (last ÷ middle third) beyond which the oscillation counts as growing or
decaying: energy changing by a factor 1.44 over a third of the run."""


@dataclasses.dataclass
class GrowthVerdict:
    """Result of `oscillation_growth`."""
    verdict: str            # "decaying", "sustained" or "growing"
    stable: bool            # verdict != "growing"
    growth_rate: float      # λ (1/s); ±inf when one third is exactly zero
    ratio: float            # RMS_last / RMS_middle
    rms_middle: float       # oscillation RMS of the middle third (units of x)
    rms_last: float         # oscillation RMS of the last third (units of x)


def _oscillation_rms(t: np.ndarray, x: np.ndarray) -> float:
    """RMS about the least-squares line (the trend), summed over the columns of x."""
    basis = np.stack((np.ones_like(t), t - t.mean()), axis=1)
    residual = x - basis @ np.linalg.lstsq(basis, x, rcond=None)[0]
    return float(np.sqrt((residual ** 2).sum(axis=1).mean()))


def oscillation_growth(t, x, quiet: float = 0.0, ratio_threshold: float = GROWTH_RATIO) -> GrowthVerdict:
    """The module's classification rule for a signal ``x`` (N or N×m, any units; the
    columns' oscillations add in energy) sampled at times ``t`` (N; s)."""
    t = np.asarray(t, dtype=float)
    x = np.asarray(x, dtype=float).reshape(t.size, -1)
    if t.size < 9:
        raise ValueError(f"need at least 9 samples; got {t.size}")
    third = t.size // 3
    middle, last = slice(third, 2 * third), slice(t.size - third, t.size)
    rms_middle, rms_last = _oscillation_rms(t[middle], x[middle]), _oscillation_rms(t[last], x[last])
    span = t[last].mean() - t[middle].mean()
    quiet = max(quiet, 1e-9 * float(np.abs(x).max()))
    ratio = rms_last / rms_middle if rms_middle > 0 else (math.inf if rms_last > 0 else 1.0)
    rate = (math.log(ratio) if ratio > 0 else -math.inf) / span
    if rms_last <= quiet:
        verdict = "decaying"
    elif rms_middle <= quiet or ratio > ratio_threshold:
        verdict = "growing"
    elif ratio < 1.0 / ratio_threshold:
        verdict = "decaying"
    else:
        verdict = "sustained"
    return GrowthVerdict(verdict, verdict != "growing", rate, ratio, rms_middle, rms_last)


def llewellyn_absolutely_stable(h11, h12, h21, h22, tol: float = 1e-9) -> tuple[bool, np.ndarray]:
    """Llewellyn's criterion for the absolute stability of a linear two-port from its
    hybrid parameters, each an array over a frequency grid (complex; h11 in Ω-like
    force/velocity units, h22 its inverse, h12, h21 dimensionless):

        Re h11 ≥ 0,  Re h22 ≥ 0,  2·Re h11·Re h22 − Re(h12·h21) − |h12·h21| ≥ 0.

    Each inequality is tested with slack ``tol`` (absolute), so a marginal case (equality)
    passes. Returns (true iff all hold at every frequency, per-frequency booleans)."""
    h11, h12, h21, h22 = (np.atleast_1d(np.asarray(h, dtype=complex)) for h in (h11, h12, h21, h22))
    product = h12 * h21
    third = 2.0 * h11.real * h22.real - product.real - np.abs(product)
    ok = (h11.real >= -tol) & (h22.real >= -tol) & (third >= -tol)
    return bool(ok.all()), ok


def virtual_wall_stiffness_limit(b: float, T: float, virtual_damping: float = 0.0) -> float:
    """Largest passive stiffness K (N/m) of a virtual wall sampled with period ``T`` (s)
    and zero-order hold, on a device with physical damping ``b`` (N·s/m): Colgate &
    Schenkel's b > K·T/2 + |B|, i.e. K < 2(b − |B|)/T, B the wall's virtual damping
    (N·s/m). 0 when |B| ≥ b."""
    if not (T > 0 and b >= 0):
        raise ValueError(f"need T > 0 and b >= 0; got T = {T}, b = {b}")
    return max(0.0, 2.0 * (b - abs(virtual_damping)) / T)
