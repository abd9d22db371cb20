"""The time-synchronous average of the ``tsa`` representation (:mod:`models.representations`, whose docstring
says what it is and why) and its difference signal: the comb of integer shaft orders of the segment of whole
revolutions, the filters of the spec (high-pass, the shaft lines' removal, the low-pass below ``c`` mesh
orders), back to the angle domain.

With the low-pass on, only the orders it keeps are computed, by a direct DFT at their bins
(:func:`models.order_filters.dft_at`) with the shaft lines taken off in closed form
(:func:`models.order_filters.lines_dft_at`); without it, by the FFT of the filtered segment.
"""
from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np

from gearpit.errors import require
from models.input_checks import check_inputs
from models.order_filters import (dft_at, highpass, lines_dft_at, lowpass_gain, remove_shaft_lines,
                                  shaft_line_fit)
from models.segments import _normalise, _per_record, _split_pair, _starts

if TYPE_CHECKING:
    from models.representation_spec import RepresentationSpec


def _difference_mask(n_orders: int, z_pinion: int) -> np.ndarray:
    """True for the orders kept in the difference signal (not 0-2, not ``m z + {-1, 0, 1}``)."""
    k = np.arange(n_orders)
    near_mesh = np.minimum(k % z_pinion, z_pinion - k % z_pinion) <= 1
    return (k > 2) & ~near_mesh


def _tsa_segment(size: int, spec: RepresentationSpec, fs_hz: float, fr: float) -> tuple[int, np.ndarray]:
    """Samples in the TSA's segment of a record of ``size`` samples (as many whole revolutions as the record
    holds, less one for the start phase, at least ``n_revs``), and where integer shaft orders 0 ..
    ``samples_per_rev // 2`` fall among its FFT bins (fractional bins)."""
    rev = fs_hz / fr
    n_rev = max(spec.n_revs, int(np.floor(size / rev)) - 1)
    n_seg = min(int(round(n_rev * rev)), size)
    # bin j of the segment is shaft order j / (revolutions it holds): keep the integer orders
    return n_seg, np.arange(spec.samples_per_rev // 2 + 1) * (n_seg / rev)


#: the TSA comb's bins come from a direct DFT (:func:`~models.order_filters.dft_at`) when the low-pass keeps at
#: most this many shaft orders (two bins each), from the segment's FFT otherwise
DIRECT_MAX_ORDERS = 128


def _kept_orders(spec: RepresentationSpec, n_orders: int, z_pinion: int) -> tuple[int, np.ndarray]:
    """How many shaft orders (from 0) the low-pass keeps, and its gain on them (all, gain 1, without it)."""
    gain = lowpass_gain(n_orders, z_pinion, spec.lowpass_mesh_orders)
    k = int(np.count_nonzero(gain))  # the gain does not rise with the order
    return k, gain[:k]


def _interp_bins(dft: np.ndarray, bins: np.ndarray, n_seg: int) -> np.ndarray:
    """``np.interp(bins, arange(top + 1), X, right=0)`` of the rfft ``X`` of an ``n_seg``-sample segment
    (``top = n_seg // 2``) from its values ``dft`` (last axis) at ``floor(bins)`` then at ``floor(bins) + 1``
    (the real and imaginary parts interpolated alike)."""
    m0 = np.floor(bins).astype(np.int64)
    w = bins - m0
    top = n_seg // 2
    lo, hi = dft[..., :bins.size], dft[..., bins.size:]
    return np.where(m0 + 1 <= top, (hi - lo) * w + lo, np.where((m0 == top) & (w == 0), lo, 0.0))


def _needed_bins(bins: np.ndarray) -> np.ndarray:
    m0 = np.floor(bins).astype(np.int64)
    return np.concatenate([m0, m0 + 1])


def _comb_of_kept(dft: np.ndarray, bins: np.ndarray, k: int, gain: np.ndarray, n_seg: int) -> np.ndarray:
    """The comb at every order of ``bins`` from the DFT ``dft`` at :func:`_needed_bins` of the ``k`` kept
    orders, low-passed by their ``gain``: zero above them."""
    comb = np.zeros(dft.shape[:-1] + (bins.size,), dtype=complex)
    comb[..., :k] = _interp_bins(dft, bins[:k], n_seg) * gain
    return comb


def integrated(comb: np.ndarray, times: int) -> np.ndarray:
    """The comb (last axis: integer shaft orders 0, 1, ...) of its angle-domain signal integrated ``times`` times
    over the pinion's angle in radians: order ``k`` divided by ``(i k)^times``; orders 0-2 set to zero (the
    integral's unknown constant, and the once- and twice-per-revolution content of the shafts' eccentricity and
    cumulative pitch error, which the integration would raise above everything else; the difference signal drops
    them too). ``times = 0``: the comb itself."""
    if times == 0:
        return comb
    k = np.arange(comb.shape[-1], dtype=float)
    factor = np.zeros(k.size, dtype=complex)
    factor[INTEGRATED_FROM:] = (1j * k[INTEGRATED_FROM:]) ** (-times)
    return comb * factor


#: the lowest shaft order an integrated comb keeps (:func:`integrated`)
INTEGRATED_FROM = 3


def _tsa_comb(x: np.ndarray, spec: RepresentationSpec, fs_hz: float, fr: float, starts, z_pinion: int,
              z_wheel: int = 0) -> np.ndarray:
    """:func:`_filtered_comb`, integrated ``spec.integrate`` times over the angle (:func:`integrated`)."""
    return integrated(_filtered_comb(x, spec, fs_hz, fr, starts, z_pinion, z_wheel), spec.integrate)


def _filtered_comb(x: np.ndarray, spec: RepresentationSpec, fs_hz: float, fr: float, starts, z_pinion: int,
                   z_wheel: int = 0) -> np.ndarray:
    """The TSA comb of record ``x`` (pinion at ``fr`` Hz) for each start of ``starts``: the spectrum of the
    segment of whole revolutions at integer shaft orders 0 .. ``samples_per_rev // 2``, filtered as ``spec``
    says (high-pass, shaft lines removed, low-pass): ``(len(starts), samples_per_rev // 2 + 1)`` complex.

    With the low-pass on, only the orders it keeps are computed: their bins by a direct DFT
    (:func:`~models.order_filters.dft_at`) and the shaft lines taken off those bins in closed form
    (:func:`~models.order_filters.lines_dft_at`, from the fit over the whole record), instead of an FFT of the
    filtered segment; equal to the FFT path to rounding (tested) and 1.45 times as fast on the transmission error
    model's records (0.58 against 0.84 s for one epoch's 960, measured)."""
    if spec.highpass_orders > 0:
        x = highpass(x, fs_hz, fr, spec.highpass_orders)
    n_seg, bins = _tsa_segment(x.size, spec, fs_hz, fr)
    i0s = [_starts(x.size, n_seg, st, False)[0] for st in starts]
    freqs = (fr, fr * z_pinion / z_wheel) if spec.remove_shaft_1x else ()
    k, gain = _kept_orders(spec, bins.size, z_pinion)
    if spec.lowpass_mesh_orders > 0 and k <= DIRECT_MAX_ORDERS:
        need = _needed_bins(bins[:k])
        dft = dft_at(np.stack([x[i0:i0 + n_seg] for i0 in i0s]), need)
        if freqs:
            dft = dft - lines_dft_at(shaft_line_fit(x, fs_hz, freqs), freqs, fs_hz, n_seg, need, i0s)
        return _comb_of_kept(dft, bins, k, gain, n_seg)
    if freqs:
        x = remove_shaft_lines(x, fs_hz, freqs)
    spec_c = np.fft.rfft(np.stack([x[i0:i0 + n_seg] for i0 in i0s]), axis=-1)  # one FFT plan for all crops
    idx = np.arange(spec_c.shape[1])
    comb = np.stack([np.interp(bins, idx, c.real, right=0.0) + 1j * np.interp(bins, idx, c.imag, right=0.0)
                     for c in spec_c])
    if spec.lowpass_mesh_orders > 0:      # the low-pass's gain on the kept orders, zero above them
        comb[:, :k] *= gain
        comb[:, k:] = 0.0
    return comb


def _lines_comb(x: np.ndarray, spec: RepresentationSpec, fs_hz: float, fr: float, z_pinion: int,
                z_wheel: int) -> np.ndarray:
    """The TSA comb (start 0, filtered as ``spec``) of the two shaft lines that
    :func:`~models.order_filters.remove_shaft_lines` fits to ``x`` (a constant, the pinion's and the wheel's
    first order), in closed form (:func:`~models.order_filters.lines_dft_at`): the comb of
    ``remove_shaft_lines(x)`` is the comb of ``x`` less this one, by linearity, without a second FFT of the
    record."""
    freqs = (fr, fr * z_pinion / z_wheel)
    n_seg, bins = _tsa_segment(x.size, spec, fs_hz, fr)
    k, gain = _kept_orders(spec, bins.size, z_pinion)
    dft = lines_dft_at(shaft_line_fit(x, fs_hz, freqs), freqs, fs_hz, n_seg, _needed_bins(bins[:k]))
    return integrated(_comb_of_kept(dft, bins, k, gain, n_seg), spec.integrate)


def _tsa_channels(comb: np.ndarray, samples_per_rev: int, z_pinion: int) -> tuple[np.ndarray, np.ndarray]:
    """The synchronous average and its difference signal (the module docstring), one revolution each."""
    avg = np.fft.irfft(comb, n=samples_per_rev, axis=-1)
    diff = np.fft.irfft(comb * _difference_mask(comb.shape[1], z_pinion), n=samples_per_rev, axis=-1)
    return avg, diff


def _tsa_normalised(comb: np.ndarray, samples_per_rev: int, z_pinion: int) -> tuple[np.ndarray, np.ndarray]:
    """The ``tsa`` representation of each crop's comb, ``(n_crops, 2, samples_per_rev)``, and the difference
    signals before their scaling."""
    avg, diff = _tsa_channels(comb, samples_per_rev, z_pinion)
    # both scaled by the TSA's standard deviation: the difference keeps its level relative to the mesh tone
    sd = avg.std(axis=-1, keepdims=True)
    sd = np.where(sd > 0, sd, 1.0)
    return np.stack([(avg - avg.mean(axis=-1, keepdims=True)) / sd,
                     (diff - diff.mean(axis=-1, keepdims=True)) / sd], axis=1), diff


#: fine grid of the angle alignment of a reference's TSA, points per sample of the revolution
ALIGN_OVERSAMPLING = 8


def align_comb(comb: np.ndarray, ref: np.ndarray) -> np.ndarray:
    """``ref`` (a TSA comb, orders 0 .. K) turned in angle to line up with each row of ``comb``: the shift ``d``
    that maximises the circular cross-correlation ``Re sum_k comb_k conj(ref_k) e^{i k d}`` (on a grid of
    ``ALIGN_OVERSAMPLING`` points per TSA sample, refined by a parabola through the peak and its neighbours),
    applied as ``ref_k e^{-i k d}``: ``(n_rows, K + 1)``. A reference recorded at another start angle (another
    file, another crop) then subtracts from the record order by order."""
    rows = np.atleast_2d(comb)
    k = np.arange(ref.size)
    n = ALIGN_OVERSAMPLING * 2 * (ref.size - 1)
    r = np.fft.irfft(rows * np.conj(ref)[None, :], n=n, axis=-1)          # r[j] at shift 2 pi j / n
    j = np.argmax(r, axis=-1)
    lo, mid, hi = (r[np.arange(r.shape[0]), (j + o) % n] for o in (-1, 0, 1))
    curv = lo - 2 * mid + hi
    frac = np.where(curv < 0, 0.5 * (lo - hi) / np.where(curv < 0, curv, -1.0), 0.0)
    d = 2 * np.pi * (j + frac) / n
    return ref[None, :] * np.exp(-1j * k[None, :] * d[:, None])


#: whitening by the reference (``RepresentationSpec.whiten``): the regularisation of one over a mesh harmonic,
#: as a fraction of the strongest (40 dB, as :data:`models.representations.REFERENCE_CLIP`): a harmonic the
#: reference does not hold above it (beyond the sensor's band, above the sampling rate's reach) is weighted down
WHITEN_FLOOR = 1e-2


def mesh_whitening(ref_comb: np.ndarray, z_pinion: int) -> np.ndarray:
    """Complex weights ``(n_rows, K + 1)`` for orders ``0 .. K`` of each row of ``ref_comb`` (a reference's TSA
    comb, already turned to its record, :func:`align_comb`): one over the reference's mesh harmonics, regularised
    (``conj(a) / (|a|^2 + (f a_max)^2)``, ``f`` = :data:`WHITEN_FLOOR`: a harmonic that the reference does not
    hold above that is weighted down, not blown up), its modulus interpolated in log between the harmonics and
    its phase that of the nearest harmonic (the first for the orders below it, the last above the last).

    Why: between a gear's vibration and an accelerometer lies the sensor path ``H`` (housing resonances,
    mounting), which lifts some mesh harmonics by tens of dB and turns their phases; a pit's excitation, spread
    over the orders around every harmonic, reaches the sensor through the same path. A record's order ``k`` is
    ``H_k X_k``, the reference's harmonic ``h`` is ``H_h X0_h``; their quotient is ``(X_k / X0_h)(H_k / H_h)``,
    and the path is smooth over one harmonic's sidebands (``H_k ~ H_h``), so every harmonic region is read
    relative to the healthy mesh excitation that passed the same path: the shape no longer depends on where the
    path's resonance lies. With no mesh harmonic in the comb the weights are 1."""
    ref = np.atleast_2d(np.asarray(ref_comb))
    z = int(z_pinion)
    K = ref.shape[1] - 1
    H = K // z
    if H < 1:
        return np.ones(ref.shape)
    harm = ref[:, z * np.arange(1, H + 1)]                                # (n_rows, H)
    top = np.abs(harm).max(axis=1, keepdims=True)
    if not np.all(top > 0):
        return np.ones(ref.shape)
    w = np.conj(harm) / (np.abs(harm) ** 2 + (WHITEN_FLOOR * top) ** 2)  # regularised 1 / harm
    # modulus interpolated in log between the harmonics (the path's slope across a harmonic's sidebands), phase
    # of the nearest harmonic
    orders = np.arange(K + 1)
    mag = np.exp(np.stack([np.interp(orders, z * np.arange(1, H + 1), np.log(np.abs(row) + 1e-300)) for row in w]))
    h = np.clip(np.rint(orders / z).astype(int), 1, H)
    return mag * np.exp(1j * np.angle(w[:, h - 1]))


def tsa_against_reference(comb: np.ndarray, ref_comb: np.ndarray, samples_per_rev: int, *,
                          whiten_z: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The ``tsa`` representation read against a reference (:mod:`models.representations`): for each crop's
    comb, the record's TSA and its residual, the TSA less the reference's aligned one (:func:`align_comb`),
    both over the reference TSA's standard deviation: ``(n_crops, 2, samples_per_rev)``; and the residual combs
    ``(n_crops, K + 1)`` (not whitened). ``whiten_z``: the pinion's teeth, to whiten all three by the aligned
    reference's mesh harmonics first (:func:`mesh_whitening`)."""
    aligned = align_comb(comb, ref_comb)
    residual = comb - aligned
    if whiten_z is None:
        sd = float(np.fft.irfft(ref_comb, n=samples_per_rev).std()) or 1.0
        avg = np.fft.irfft(comb, n=samples_per_rev, axis=-1)
        res = np.fft.irfft(residual, n=samples_per_rev, axis=-1)
    else:
        w = mesh_whitening(aligned, whiten_z)
        sd = np.fft.irfft(aligned * w, n=samples_per_rev, axis=-1).std(axis=-1, keepdims=True)
        sd = np.where(sd > 0, sd, 1.0)
        avg = np.fft.irfft(comb * w, n=samples_per_rev, axis=-1)
        res = np.fft.irfft(residual * w, n=samples_per_rev, axis=-1)
    return np.stack([(avg - avg.mean(axis=-1, keepdims=True)) / sd, (res - res.mean(axis=-1, keepdims=True)) / sd],
                    axis=1), residual


def residual_difference(signals: np.ndarray, reference: np.ndarray, spec: RepresentationSpec, *, fs_hz: float,
                        shaft_hz, z_pinion: int, z_wheel: int | None = None) -> np.ndarray:
    """The difference signal of each record's TSA *residual* against its reference (:func:`align_comb`, start 0
    for both) in the record's own unit, not normalised: ``(n_records, samples_per_rev)``. What the fault changed
    in the orders a difference signal keeps (not 0-2, not the mesh harmonics and their first sidebands), without
    the machine's own tooth-to-tooth deviations, which the record and the reference share. ``spec``: a ``tsa``
    spec whose filters apply to both."""
    x = np.asarray(signals, dtype=float)
    r = np.asarray(reference, dtype=float)
    require(spec.kind == "tsa", "representation.kind", spec.kind, "'tsa' (the residual is the TSA's)")
    require(x.ndim == 2 and r.shape == x.shape, "reference", r.shape, f"the records' shape {x.shape}")
    fr = _per_record(shaft_hz, x.shape[0], "shaft_hz")
    check_inputs(spec, x.shape[1], fs_hz, fr, None, z_pinion=z_pinion, max_speed_factor=1.0, z_wheel=z_wheel)
    zw, zp = (int(z_wheel) if z_wheel else 0), int(z_pinion)
    out = np.empty((x.shape[0], spec.samples_per_rev))
    for i in range(x.shape[0]):
        c = _tsa_comb(x[i] - x[i].mean(), spec, float(fs_hz), float(fr[i]), (0.0,), zp, zw)
        c0 = _tsa_comb(r[i] - r[i].mean(), spec, float(fs_hz), float(fr[i]), (0.0,), zp, zw)[0]
        out[i] = _tsa_channels(c - align_comb(c, c0), spec.samples_per_rev, zp)[1][0]
    return out


def represent_crops_and_residual(pairs: np.ndarray, spec: RepresentationSpec, *, fs_hz: float, crops, shaft_hz,
                                 z_pinion: int, z_wheel: int) -> tuple[np.ndarray, np.ndarray]:
    """``represent_crops`` of a ``tsa`` ``spec`` read against the reference (``pairs``: record then reference) and,
    from the same combs, the residual difference signal of every record at start 0 in the record's unit (as
    :func:`residual_difference` with ``spec``): ``(rep, diff)``. ``crops[0]`` must be 0. Used for the side inputs
    ``residual_rms`` / ``residual_profile`` at prediction, instead of two more TSAs per record."""
    x = np.asarray(pairs)
    require(spec.kind == "tsa" and spec.reference, "representation", spec.to_dict(), "a tsa spec with reference")
    require(x.ndim == 2 and x.shape[1] % 2 == 0, "signals", x.shape, "pairs of record and reference")
    st = tuple(float(v) for v in crops)
    require(len(st) >= 1 and st[0] == 0.0, "crops", list(st), "starts whose first is 0")
    n = x.shape[0]
    fr = _per_record(shaft_hz, n, "shaft_hz")
    check_inputs(spec, x.shape[1] // 2, fs_hz, fr, None, z_pinion=z_pinion, z_wheel=z_wheel)
    rep = np.empty((n, len(st), spec.n_channels, spec.length), dtype=np.float32)
    diff = np.empty((n, spec.samples_per_rev))
    zp, zw, spr = int(z_pinion), int(z_wheel), spec.samples_per_rev
    for i in range(n):
        rec, ref, sd = _split_pair(x[i])
        comb = _tsa_comb(rec, spec, float(fs_hz), float(fr[i]), st, zp, zw)
        ref_comb = _tsa_comb(ref, spec, float(fs_hz), float(fr[i]), (0.0,), zp, zw)[0]
        rep[i], residual = tsa_against_reference(comb, ref_comb, spr, whiten_z=zp if spec.whiten else None)
        diff[i] = _tsa_channels(residual[:1], spr, zp)[1][0] * sd
    return rep, diff


def tsa_difference(signals: np.ndarray, spec: RepresentationSpec, *, fs_hz: float, shaft_hz, z_pinion: int,
                   z_wheel: int | None = None) -> np.ndarray:
    """The TSA difference signal of every record in the record's own unit (not normalised), from the segment
    that starts at the record's start: ``(n_records, samples_per_rev)``. ``spec`` must be a ``tsa`` spec; its
    filters apply (``remove_shaft_1x`` needs ``z_wheel``). Up to the per-record scale, channel 1 of
    ``represent(..., starts=0.0)``."""
    x = np.asarray(signals, dtype=float)
    require(spec.kind == "tsa", "representation.kind", spec.kind, "'tsa' (the difference signal is the TSA's)")
    require(x.ndim == 2 and x.shape[0] >= 1, "signals", x.shape, "a 2-D array (records, samples)")
    fr = _per_record(shaft_hz, x.shape[0], "shaft_hz")
    check_inputs(spec, x.shape[1], fs_hz, fr, None, z_pinion=z_pinion, max_speed_factor=1.0, z_wheel=z_wheel)
    zw = int(z_wheel) if z_wheel else 0
    return np.stack([_tsa_channels(_tsa_comb(row - row.mean(), spec, float(fs_hz), float(f), (0.0,), int(z_pinion),
                                             zw), spec.samples_per_rev, int(z_pinion))[1][0]
                     for row, f in zip(x, fr)])


def represent_crops_and_difference(signals: np.ndarray, spec: RepresentationSpec, *, fs_hz: float, crops,
                                   shaft_hz, z_pinion: int, z_wheel: int,
                                   difference_spec: RepresentationSpec) -> tuple[np.ndarray, np.ndarray]:
    """:func:`represent_crops` of a ``tsa`` ``spec`` and, from the same FFT, the difference signal of every record
    under ``difference_spec`` at start 0 (as :func:`tsa_difference` of the normalised record): ``(rep, diff)``,
    ``diff`` of shape ``(n_records, samples_per_rev)``.

    ``difference_spec`` may differ from ``spec`` only in ``remove_shaft_1x`` (True), and ``crops[0]`` must be 0:
    the two shaft lines are then taken off the first crop's comb in closed form (:func:`_lines_comb`) instead of
    the record being filtered and transformed again. Equal to
    the direct computation to rounding (tested). Used for the pitted-teeth profile side input at prediction.
    """
    x = np.asarray(signals)
    require(x.ndim == 2 and x.shape[0] >= 1, "signals", x.shape, "a 2-D array (records, samples)")
    require(spec.kind == "tsa" and spec.highpass_orders == 0 and replace(spec, remove_shaft_1x=True)
            == replace(difference_spec, remove_shaft_1x=True) and difference_spec.remove_shaft_1x,
            "difference_spec", difference_spec.to_dict(), f"{spec.to_dict()} with remove_shaft_1x = true")
    st = tuple(float(v) for v in crops)
    require(len(st) >= 1 and st[0] == 0.0, "crops", list(st), "starts whose first is 0")
    n = x.shape[0]
    fr = _per_record(shaft_hz, n, "shaft_hz")
    check_inputs(spec, x.shape[1], fs_hz, fr, None, z_pinion=z_pinion, z_wheel=z_wheel)
    check_inputs(difference_spec, x.shape[1], fs_hz, fr, None, z_pinion=z_pinion, z_wheel=z_wheel)
    rep = np.empty((n, len(st), spec.n_channels, spec.length), dtype=np.float32)
    diff = np.empty((n, spec.samples_per_rev))
    zp, zw, spr = int(z_pinion), int(z_wheel), spec.samples_per_rev
    for i in range(n):
        xi = _normalise(x[i].astype(float))
        comb = _tsa_comb(xi, spec, float(fs_hz), float(fr[i]), st, zp, zw)
        rep[i], d = _tsa_normalised(comb, spr, zp)
        if spec.remove_shaft_1x:
            diff[i] = d[0]
        else:
            first = comb[:1] - _lines_comb(xi, spec, float(fs_hz), float(fr[i]), zp, zw)
            diff[i] = _tsa_channels(first, spr, zp)[1][0]
    return rep, diff
