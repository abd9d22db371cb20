"""Order-domain filters of a record for the TSA representation (:mod:`models.representations`) and the level
side inputs (:mod:`models.operating`).

- :func:`lowpass_gain`: the gain per shaft order of the TSA's low-pass below ``c`` mesh orders;
- :func:`highpass`: zero-phase high-pass of a record at a number of shaft orders;
- :func:`remove_shaft_lines`: least-squares removal of lines at known frequencies (both shafts' first order).

Why: a pit's dip in the transmission error is quasi-static, so its window in mesh periods is fixed, while the
drive train's resonances (fixed in Hz) and the shaft encoders' once-per-revolution errors are not about the
teeth (experiments/RESULTS.md, section "Sensor").
"""
from __future__ import annotations

import numpy as np
from scipy import fft as scipy_fft


def lowpass_gain(n_orders: int, z_pinion: int, mesh_orders: float) -> np.ndarray:
    """Gain per shaft order 0..n_orders-1: 1 below ``0.75 c z``, a cosine roll-off to 0 at ``c z``
    (``c = mesh_orders``; 0 = all ones)."""
    if mesh_orders <= 0:
        return np.ones(n_orders)
    k = np.arange(n_orders, dtype=float)
    hi = mesh_orders * z_pinion
    lo = 0.75 * hi
    return np.where(k <= lo, 1.0, np.where(k >= hi, 0.0, 0.5 * (1 + np.cos(np.pi * (k - lo) / (hi - lo)))))


def highpass(x: np.ndarray, fs_hz: float, shaft_hz: float, orders: float) -> np.ndarray:
    """``x`` (last axis) high-passed at ``orders`` times ``shaft_hz`` with zero phase and the magnitude of an
    8th-order Butterworth, ``|H|^2 = 1 / (1 + (f_c / f)^16)`` (a 4th-order one run forwards and backwards: a line
    at a tenth of the cut-off loses 160 dB, one at 0.4 of it 64 dB, one at twice it 0.03 dB), applied in the
    frequency domain to the record extended by its mirror image (continuous at both ends, so no edge step),
    which costs two FFTs (0.31 ms for 12800 samples against 0.74 ms for scipy.signal.sosfiltfilt, measured)."""
    n = x.shape[-1]
    spec = scipy_fft.rfft(np.concatenate([x, x[..., ::-1]], axis=-1), axis=-1)
    fc = orders * shaft_hz
    f = np.arange(min(spec.shape[-1], int(np.ceil(4.0 * fc * 2 * n / fs_hz)) + 1)) * (fs_hz / (2 * n))
    with np.errstate(divide="ignore"):  # above 4 f_c the gain is 1 within 1e-19
        spec[..., :f.size] *= 1.0 / np.sqrt(1.0 + (fc / f) ** 16)
    return scipy_fft.irfft(spec, n=2 * n, axis=-1)[..., :n]


def _phasor(cycles_per_sample: float, n: int) -> np.ndarray:
    """``exp(2 pi i c k)`` for ``k = 0 .. n - 1`` as the outer product of two short exponentials (block starts
    times the steps inside a block): ~2 sqrt(n) transcendental evaluations instead of n, exact to rounding."""
    b = max(1, int(np.ceil(np.sqrt(n))))
    inner = np.exp(2j * np.pi * cycles_per_sample * np.arange(b))
    starts = np.exp(2j * np.pi * cycles_per_sample * np.arange(0, n, b))
    return (starts[:, None] * inner[None, :]).ravel()[:n]


def _line_regressors(n: int, fs_hz: float, freqs_hz) -> np.ndarray:
    """The regressors of :func:`remove_shaft_lines`: a constant, then the cosine and sine of each frequency."""
    rows = [np.ones(n)]
    for f in freqs_hz:
        e = _phasor(f / fs_hz, n)
        rows += [e.real, e.imag]
    return np.stack(rows)


def shaft_line_fit(x: np.ndarray, fs_hz: float, freqs_hz) -> np.ndarray:
    """The least-squares coefficients of :func:`remove_shaft_lines`'s fit of ``x`` (1-D): a constant, then the
    cosine and sine amplitude of each of ``freqs_hz`` (the regressors ``cos(2 pi f k / fs)``, ``sin(...)``).

    Without forming the regressors: with the complex lines ``u_p = exp(2 pi i c_p k)``, ``c_p`` in ``0, +/-c_1,
    +/-c_2, ...``, the real regressors are ``T u`` (``cos = (u_+ + u_-) / 2``, ``sin = (u_+ - u_-) / 2i``), their
    Gram matrix ``T G T^H`` with ``G_pq = sum_k exp(2 pi i (c_p - c_q) k)`` in closed form, and the projections
    ``T (u x)``, each ``u_p x`` a sum over blocks of the record (:func:`_phasor`'s factorisation). Equal to the
    normal equations on the formed regressors to rounding (tested)."""
    return _line_fit(x, fs_hz, freqs_hz)[0]


def rms_without_lines(x: np.ndarray, fs_hz: float, freqs_hz) -> float:
    """The RMS of :func:`remove_shaft_lines` of ``x`` (1-D) without forming it: a least-squares residual is
    orthogonal to the regressors, so its energy is ``x.x - coef . (A x)``."""
    x = np.asarray(x, dtype=float)
    coef, ax = _line_fit(x, fs_hz, freqs_hz)
    return float(np.sqrt(max(float(x @ x - coef @ ax), 0.0) / x.size))


def _line_fit(x: np.ndarray, fs_hz: float, freqs_hz) -> tuple[np.ndarray, np.ndarray]:
    """:func:`shaft_line_fit`'s coefficients and the projections ``A x`` of ``x`` on the real regressors."""
    x = np.asarray(x, dtype=float)
    n = x.size
    c = np.array([0.0] + [s * f / fs_hz for f in freqs_hz for s in (1.0, -1.0)])
    if n < 64 * c.size:                                  # too short for the normal equations to be safe
        a = _line_regressors(n, fs_hz, freqs_hz)
        return _fit(x, a), a @ x
    t = np.zeros((c.size, c.size), dtype=complex)
    t[0, 0] = 1.0
    for j in range(len(freqs_hz)):
        p = 1 + 2 * j
        t[p, p], t[p, p + 1] = 0.5, 0.5
        t[p + 1, p], t[p + 1, p + 1] = -0.5j, 0.5j
    theta = c[:, None] - c[None, :]
    gram = (t @ geometric_sum(n, theta) @ t.conj().T).real
    b = max(1, int(np.ceil(np.sqrt(n))))
    nb = -(-n // b)
    xb = np.zeros(nb * b)
    xb[:n] = x
    xb = xb.reshape(nb, b)
    half = c[1::2]                                         # the positive frequencies; u_- x is the conjugate
    inner = np.exp(2j * np.pi * half[None, :] * np.arange(b)[:, None])            # (b, k)
    starts = np.exp(2j * np.pi * half[None, :] * np.arange(0, nb * b, b)[:, None])  # (nb, k)
    z = np.einsum("bk,bk->k", xb @ inner, starts)
    ux = np.empty(c.size, dtype=complex)
    ux[0] = x.sum()
    ux[1::2], ux[2::2] = z, z.conj()
    ax = (t @ ux).real
    return np.linalg.solve(gram, ax), ax


def geometric_sum(n: int, theta: np.ndarray) -> np.ndarray:
    """``sum_k exp(2 pi i theta k)`` over ``k = 0 .. n - 1`` (the Dirichlet kernel), elementwise."""
    theta = np.asarray(theta, dtype=float)
    den = np.sin(np.pi * theta)
    small = np.abs(den) < 1e-300
    ratio = np.where(small, float(n), np.sin(np.pi * n * theta) / np.where(small, 1.0, den))
    return np.exp(1j * np.pi * (n - 1) * theta) * ratio


def _unit_powers(bins: np.ndarray, count: int, step: int, n: int) -> np.ndarray:
    """``exp(-2 pi i m k step / n)`` for ``k = 0 .. count - 1`` and every integer bin ``m`` of ``bins``:
    ``(count, len(bins))``, the outer product of two tables of ~sqrt(count) rows whose phases are reduced modulo
    ``n`` in integers (exact), so the error is that of one complex product."""
    s = max(1, int(np.ceil(np.sqrt(count))))
    coarse = np.exp(-2j * np.pi * ((np.arange(0, count, s)[:, None] * step * bins[None, :]) % n) / n)
    fine = np.exp(-2j * np.pi * ((np.arange(s)[:, None] * step * bins[None, :]) % n) / n)
    return (coarse[:, None, :] * fine[None, :, :]).reshape(-1, bins.size)[:count]


def dft_at(x: np.ndarray, bins, n: int | None = None) -> np.ndarray:
    """The DFT ``X[m] = sum_k x[k] exp(-2 pi i m k / n)`` of ``x`` (the last axis, ``n`` samples; default its
    length) at the integer bins ``bins`` only, equal to ``np.fft.fft(x)[..., bins]`` to rounding (tested); the
    rows of a 2-D ``x`` (the crops of one record) share the phasors.

    Why: the TSA's low-pass keeps a few dozen shaft orders, i.e. a few dozen bins of a segment whose length is
    whatever whole number of revolutions the record holds: often a length with a large prime factor, whose FFT
    (Bluestein) cost 0.42 ms for ~11000 samples against 0.07 ms for 12800 (measured). Here the segment is cut
    into ``b = ceil(sqrt(n))``-sample blocks, ``X[m] = sum_j exp(-2 pi i m j b / n) sum_i x[j b + i]
    exp(-2 pi i m i / n)``: one real matrix product of the blocks with the ``b`` in-block phasors of every bin,
    then one weighted sum over the blocks."""
    x = np.asarray(x, dtype=float)
    rows = x.reshape(-1, x.shape[-1])
    n = x.shape[-1] if n is None else int(n)
    m = np.asarray(bins, dtype=np.int64)
    b = max(1, int(np.ceil(np.sqrt(n))))
    nb = -(-n // b)
    blocks = np.zeros((rows.shape[0], nb * b))
    blocks[:, :n] = rows[:, :n]
    inner = _unit_powers(m, b, 1, n)
    y = (blocks.reshape(-1, b) @ np.concatenate([inner.real, inner.imag], axis=1)).reshape(rows.shape[0], nb, -1)
    out = np.einsum("rjm,jm->rm", y[..., :m.size] + 1j * y[..., m.size:], _unit_powers(m, nb, b, n))
    return out.reshape(x.shape[:-1] + (m.size,))


def lines_dft_at(coef: np.ndarray, freqs_hz, fs_hz: float, n: int, bins, starts=0) -> np.ndarray:
    """The DFT at the integer ``bins`` of the ``n`` samples from each of ``starts`` (a scalar or 1-D: one row
    each) of the lines whose :func:`shaft_line_fit` coefficients are ``coef`` (a constant, then the cosine and
    sine amplitude of each of ``freqs_hz``, phases referred to sample 0), in closed form: ``a cos + b sin =
    (a - i b) / 2 exp(+) + (a + i b) / 2 exp(-)``, each complex line a geometric sum (:func:`geometric_sum`),
    shifted to its start by its phase there. By linearity ``dft_at(x - lines) = dft_at(x) - lines_dft_at(...)``."""
    m = np.asarray(bins, dtype=np.int64)
    st = np.asarray(starts, dtype=float)
    c = np.array([s * f / fs_hz for f in freqs_hz for s in (1.0, -1.0)])
    half = (coef[1::2] - 1j * coef[2::2]) / 2
    weights = np.stack([half, half.conj()], axis=1).ravel() * np.exp(2j * np.pi * c * st[..., None])
    out = weights @ geometric_sum(n, c[:, None] - m[None, :] / n)
    return out + coef[0] * np.where(m % n == 0, float(n), 0.0)


def _fit(x: np.ndarray, a: np.ndarray) -> np.ndarray:
    # normal equations (2 k + 1 unknowns): the regressors of lines a few cycles apart over the record are far from
    # collinear, and the solve costs nothing beside the regressors (lstsq's SVD of the
    # (N, 2 k + 1) matrix cost as much as building them)
    if x.size < 64 * a.shape[0]:                         # too short for the normal equations to be safe
        coef, *_ = np.linalg.lstsq(a.T, x, rcond=None)
        return coef
    return np.linalg.solve(a @ a.T, a @ x)


def remove_shaft_lines(x: np.ndarray, fs_hz: float, freqs_hz) -> np.ndarray:
    """``x`` (1-D) less its least-squares fit by a constant and a sinusoid at each of ``freqs_hz`` (their
    amplitudes and phases free): removal of stationary lines at known frequencies with no edge effects; other
    content is left alone up to the regressors' overlap with it, ~1 / (pi df T) for a line df away in a record
    of T seconds (0.6 % for 2.9 Hz over 2 s)."""
    a = _line_regressors(x.size, fs_hz, freqs_hz)
    return x - _fit(x, a) @ a

