"""Velocities and accelerations of a periodic joint motion from its encoder samples.

With a periodic excitation (Eqs. 9–10), the measured positions over whole periods
carry the motion only at the harmonics k·f (k ≤ N); everything else is noise. A
discrete Fourier transform over whole periods, keeping those harmonics and
multiplying by (j2πkf) and (j2πkf)², gives noise-free-as-possible q, q̇, q̈
(Swevers et al., IEEE T-RA 1997 §IV) — the way to derive a and α from encoders.
"""

import numpy as np


def differentiate_periodic(q, sample_period: float, base_frequency: float, harmonics: int):
    """(q, q̇, q̈), each (S, n), from samples q (S, n) spanning whole periods of 1/base_frequency.

    Raises ValueError unless the samples cover an integer number of periods (to 1e-6 of a
    sample) and the harmonics stay below the Nyquist frequency."""
    q = np.asarray(q, dtype=float)
    if q.ndim != 2 or not np.isfinite(q).all():
        raise ValueError(f"q must be a finite (samples, joints) array; got shape {q.shape}")
    samples = q.shape[0]
    periods = samples * sample_period * base_frequency
    if abs(periods - round(periods)) > 1e-6 * samples or round(periods) < 1:
        raise ValueError(f"the {samples} samples span {periods:.6f} periods of {base_frequency} Hz; "
                         "pass a whole number of periods")
    periods = int(round(periods))
    if harmonics * periods >= samples // 2:
        raise ValueError(f"{harmonics} harmonics of {base_frequency} Hz exceed the Nyquist frequency "
                         f"of sampling at {1 / sample_period:g} Hz")
    spectrum = np.fft.rfft(q, axis=0)
    bins = np.arange(spectrum.shape[0])
    keep = (bins == 0) | ((bins % periods == 0) & (bins <= harmonics * periods))
    spectrum[~keep] = 0.0
    j_omega = 2j * np.pi * np.fft.rfftfreq(samples, d=sample_period)[:, None]
    inverse = lambda s: np.fft.irfft(s, n=samples, axis=0)  # noqa: E731
    return inverse(spectrum), inverse(spectrum * j_omega), inverse(spectrum * j_omega ** 2)
