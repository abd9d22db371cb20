"""Input representations of vibration records for the classifiers: what each one is, and its computation
(:func:`represent`, :func:`represent_crops`). Which one a classifier reads, and its size, is a
:class:`~models.representation_spec.RepresentationSpec`.

Every record is first normalised (zero mean, unit standard deviation). Each
representation then reads *segments* of it and returns a fixed-size array
``(channels, length)``. Where the first segment starts is a fraction of the free
room, so a random start is the "random phase / crop" augmentation and evenly
spaced starts are test-time crops (:func:`represent_crops` computes them together,
sharing what does not depend on the start). The spectra average the power of every
half-overlapping segment that fits in the record (Welch [4]_), and the TSA
averages every whole revolution that fits (less one, the room for the start
phase; at least ``n_revs``): a longer record gives a less noisy input of the
same size.

``raw``
    the segment itself, ``n_samples`` samples (bound to the sampling rate).
``envelope``
    log amplitude spectrum of the envelope of ``n_samples``-sample segments, first
    ``n_samples // 8`` bins, i.e. 0 to ``fs / 16`` (bound to the sampling rate).
``tsa``
    two channels of ``samples_per_rev`` samples: the time-synchronous average of
    the pinion over ``n_revs`` revolutions (the FFT bins of an ``n_revs``-revolution
    segment at integer shaft orders, i.e. the TSA comb filter [1]_, back to the
    angle domain), and its *difference signal*: the same without shaft orders
    0-2 and without the mesh harmonics ``m z`` and their first sidebands
    ``m z +/- 1`` [3]_, where a local tooth fault stands out. With
    ``lowpass_mesh_orders = c > 0`` both keep only shaft orders below ``c z`` (a
    cosine roll-off from ``0.75 c z`` to ``c z``, zero phase): a quasi-static
    window of the signal whose width is fixed in mesh periods, so structural
    resonances (fixed in Hz, hence at orders that fall as the speed rises) stay
    out of it at every speed where they sit above ``c`` mesh orders. With
    ``highpass_orders = h > 0`` the record is first high-passed at ``h`` pinion
    orders (:func:`models.order_filters.highpass`): the once-per-revolution lines of both shafts
    (shaft-encoder eccentricity and run-out on a measured transmission error)
    and their leakage into the TSA's comb are removed, but so is the low-order
    content of a pit's dip. ``remove_shaft_1x = True`` removes only the two
    lines themselves (:func:`models.order_filters.remove_shaft_lines`: least-squares sinusoids at the
    pinion's and the wheel's shaft frequency, needs ``z_wheel``).
``order``
    two channels, log order spectrum and log envelope order spectrum of an
    ``n_revs``-revolution segment, on the grid ``k / n_revs`` pinion shaft orders
    up to ``max_order``. Independent of the speed and of the sampling rate [2]_.
``mesh_order``
    as ``order`` but on a grid of *mesh* orders (frequency over mesh frequency,
    ``n_mesh_periods`` mesh periods per segment, up to ``max_order`` mesh orders).
    Needs only the mesh frequency in cycles per sample, which can be estimated
    from a record whose sampling rate and tooth counts are unknown.

With ``reference = True`` each record comes with a *healthy reference*:
a recording of the same machine at the same operating point before the fault (a commissioning record, the
same gearbox last month). The records given to the representation are then *pairs*, the record followed by
its reference (:meth:`models.data.SignalSet.paired_signals`, ``2 n_samples`` samples), and the two channels are
``log10`` of the record's spectrum over the reference's (both scaled by the reference's standard deviation,
the reference's spectrum averaged over all its segments), clipped to +/- :data:`REFERENCE_CLIP`, not
standardised: the change since the reference in decades. What the machine adds to every record alike (the
sensor's gain and mounting, the housing's transfer function, the gear's own tooth-to-tooth spacing and
profile errors, its eccentricity) is a factor of both spectra and cancels; what the fault changes remains [5]_.
For ``tsa`` the two channels are the record's TSA and its *residual*: the TSA less the reference's, turned to the
angle where the two correlate best (a reference starts at another angle), both over the reference TSA's standard
deviation. The residual holds what the fault adds to the mesh vibration, also where the machine's own deviations
excite the same orders (a log ratio of spectra cannot undo a sum of two complex amplitudes; a difference of
synchronous averages can); a sensor gain that changed between the two recordings does not cancel in it.

Spectra are window-corrected Hann amplitude spectra, linearly interpolated from
the FFT bins onto the order grid (a segment holds a whole number of
revolutions up to rounding to a sample, so bins and grid nearly coincide),
compressed by ``log10(a + 1e-5)`` and standardised per signal and channel.

A *speed factor* ``s`` mimics a speed error: the order-domain representations
assume the shaft turned at ``s`` times the given speed; ``raw`` and ``envelope``
take ``s * n_samples`` samples and resample them (FFT) to ``n_samples``, as if the
machine had run ``s`` times faster.

References
----------
.. [1] McFadden, P. D. (1987). A revised model for the extraction of periodic
   waveforms by time domain averaging. Mechanical Systems and Signal Processing
   1(1), 83-95.
.. [2] Randall, R. B. (2011). Vibration-based Condition Monitoring. Wiley,
   sections 3.6 (order tracking) and 5.3 (envelope analysis).
.. [3] Lebold, M. et al. (2000). Review of vibration analysis methods for gearbox
   diagnostics and prognostics. Proc. 54th MFPT, 623-634 (regular, residual and
   difference signals).
.. [4] Welch, P. D. (1967). The use of fast Fourier transform for the estimation
   of power spectra. IEEE Transactions on Audio and Electroacoustics 15(2), 70-73.
.. [5] Randall, R. B. (2011), chapter 5 (fault detection): spectrum comparison with a reference ("baseline") spectrum of the
   same machine, the first step of condition monitoring in practice.
"""
from __future__ import annotations

import numpy as np
from scipy.signal import resample

from gearpit.errors import require
from models.input_checks import check_inputs
from models.representation_spec import RepresentationSpec
from models.segments import _normalise, _per_record, _split_pair, _starts
from models.tsa import _tsa_comb, _tsa_normalised, tsa_against_reference

LOG_FLOOR = 1e-5
#: largest change of a referenced channel, decades either way (40 dB): beyond it, the record or the reference
#: has no content at that order (noise floor over a dead band), and the ratio says nothing
REFERENCE_CLIP = 2.0


def _standardise(v: np.ndarray) -> np.ndarray:
    sd = v.std()
    return (v - v.mean()) / sd if sd > 0 else v - v.mean()


def _hann_amplitude(segs: np.ndarray) -> np.ndarray:
    """Hann amplitude spectrum of each segment (last axis)."""
    w = np.hanning(segs.shape[-1] + 1)[:-1]  # periodic Hann
    return 2.0 * np.abs(np.fft.rfft(segs * w, axis=-1)) / w.sum()


def _envelope(segs: np.ndarray) -> np.ndarray:
    """Hilbert envelope of each segment (last axis), less its mean."""
    n = segs.shape[-1]
    spec = np.fft.fft(segs, axis=-1)
    gain = np.zeros(n)
    gain[0] = 1.0
    gain[1:(n + 1) // 2] = 2.0
    if n % 2 == 0:
        gain[n // 2] = 1.0
    e = np.abs(np.fft.ifft(spec * gain, axis=-1))
    return e - e.mean(axis=-1, keepdims=True)


def _log_on_grid(amp: np.ndarray, bin_units: float, length: int, step: float, standardise: bool = True) -> np.ndarray:
    """Log amplitude interpolated from FFT bins (spacing ``bin_units``) onto ``k * step``, k < length
    (standardised unless asked not to)."""
    grid = np.arange(length) * step
    src = np.arange(amp.size) * bin_units
    v = np.log10(np.interp(grid, src, amp) + LOG_FLOOR)
    return _standardise(v) if standardise else v


def _mean_amplitudes(x: np.ndarray, n_seg: int, crop_starts: list[list[int]], envelope: bool) -> np.ndarray:
    """Root-mean-square over each crop's segments of the Hann amplitude spectrum (of the envelope if asked):
    ``(n_crops, n_seg // 2 + 1)``. A segment shared by several crops is transformed once, and all in one
    call (one FFT plan per record)."""
    unique = sorted({i0 for starts in crop_starts for i0 in starts})
    row = {i0: r for r, i0 in enumerate(unique)}
    segs = np.stack([x[i0:i0 + n_seg] for i0 in unique])
    power = _hann_amplitude(_envelope(segs) if envelope else segs - segs.mean(axis=-1, keepdims=True)) ** 2
    out = np.empty((len(crop_starts), power.shape[1]))
    for c, starts in enumerate(crop_starts):
        total = 0.0
        for i0 in starts:  # summed segment by segment, in order
            total = total + power[row[i0]]
        out[c] = np.sqrt(total / len(starts))
    return out


def _crops(x: np.ndarray, spec: RepresentationSpec, fs_hz: float, shaft_hz: float | None, mesh_cps: float | None,
           starts: tuple[float, ...], speed_factor: float, z_pinion: int, z_wheel: int = 0) -> np.ndarray:
    """Representation of one record at every start of ``starts``: ``(len(starts), n_channels, length)``.

    The work that does not depend on the start (normalisation, the stretched record of ``envelope``,
    the FFT plan of a segment length) is done once for all crops.
    """
    # a pair: the record, then its reference, both scaled by the reference's spread
    x, ref = _split_pair(x)[:2] if spec.reference else (_normalise(x.astype(float)), None)
    k = spec.kind
    n_seg = spec.segment_length(fs_hz, shaft_hz, mesh_cps, speed_factor)
    if k == "raw":
        out = []
        for st in starts:
            i0 = _starts(x.size, n_seg, st, False)[0]
            seg = x[i0:i0 + n_seg]
            out.append(_normalise(resample(seg, spec.n_samples) if n_seg != spec.n_samples else seg)[None, :])
        return np.stack(out)
    if k == "envelope":
        if n_seg != spec.n_samples:  # speed error: stretch the record, then cut as usual
            x = resample(x, int(round(x.size * spec.n_samples / n_seg)))
        amp = _mean_amplitudes(x, spec.n_samples, [_starts(x.size, spec.n_samples, st, True) for st in starts], True)
        return np.stack([_standardise(np.log10(a[:spec.length] + LOG_FLOOR))[None, :] for a in amp])
    if k == "tsa":
        comb = _tsa_comb(x, spec, fs_hz, shaft_hz * speed_factor, starts, z_pinion, z_wheel)
        if ref is not None:
            ref_comb = _tsa_comb(ref, spec, fs_hz, shaft_hz * speed_factor, (0.0,), z_pinion, z_wheel)[0]
            return tsa_against_reference(comb, ref_comb, spec.samples_per_rev,
                                         whiten_z=z_pinion if spec.whiten else None)[0]
        return _tsa_normalised(comb, spec.samples_per_rev, z_pinion)[0]
    if k == "order":
        # bin j of the segment is shaft order j * (revolutions in the segment)^-1
        unit = 1.0 / (n_seg * (shaft_hz * speed_factor) / fs_hz)
        step = 1.0 / spec.n_revs
    else:
        unit = 1.0 / (n_seg * mesh_cps * speed_factor)
        step = 1.0 / spec.n_mesh_periods
    crop_starts = [_starts(x.size, n_seg, st, True) for st in starts]
    amp = _mean_amplitudes(x, n_seg, crop_starts, False)
    env = _mean_amplitudes(x, n_seg, crop_starts, True)
    if ref is not None:   # log ratio to the reference's spectra (all its segments), not standardised, clipped
        def log(a):
            return _log_on_grid(a, unit, spec.length, step, standardise=False)

        every = [_starts(ref.size, n_seg, 0.0, True)]
        base = [log(_mean_amplitudes(ref, n_seg, every, e)[0]) for e in (False, True)]
        return np.stack([np.clip(np.stack([log(a) - base[0], log(e) - base[1]]), -REFERENCE_CLIP, REFERENCE_CLIP)
                         for a, e in zip(amp, env)])
    return np.stack([np.stack([_log_on_grid(a, unit, spec.length, step), _log_on_grid(e, unit, spec.length, step)])
                     for a, e in zip(amp, env)])


def represent(signals: np.ndarray, spec: RepresentationSpec, *, fs_hz: float, shaft_hz=None, mesh_cps=None,
              z_pinion: int | None = None, starts=0.0, speed_factors=1.0, z_wheel: int | None = None) -> np.ndarray:
    """Representation of every record: array ``(n_records, spec.n_channels, spec.length)``, float32.

    Parameters
    ----------
    signals : array_like, shape (n_records, n_samples)
        Records sampled at ``fs_hz`` (with ``spec.reference``: pairs, each record followed by its healthy
        reference of the same length, ``(n_records, 2 * n_samples)``).
    spec : RepresentationSpec
    fs_hz : float
        Sampling rate (Hz); for ``mesh_order`` any positive value (unused).
    shaft_hz : float or array_like, optional
        Pinion shaft frequency (Hz) per record (``tsa``, ``order``).
    mesh_cps : float or array_like, optional
        Mesh frequency in cycles per sample per record (``mesh_order``).
    z_pinion : int, optional
        Pinion tooth count (``tsa``).
    z_wheel : int, optional
        Wheel tooth count (``tsa`` with ``remove_shaft_1x``).
    starts : float or array_like
        Where each segment starts, as a fraction in [0, 1] of the free room.
    speed_factors : float or array_like
        Speed error factors (see the module docstring); 1 = none.

    See Also
    --------
    represent_crops : several starts per record (test-time crops), sharing the work between them.
    """
    x = np.asarray(signals)
    require(x.ndim == 2 and x.shape[0] >= 1, "signals", x.shape, "a 2-D array (records, samples)")
    st = _per_record(starts, x.shape[0], "starts")
    return _represent(x, spec, fs_hz, shaft_hz, mesh_cps, z_pinion, st[:, None], speed_factors, z_wheel)[:, 0]


def represent_crops(signals: np.ndarray, spec: RepresentationSpec, *, fs_hz: float, crops, shaft_hz=None,
                    mesh_cps=None, z_pinion: int | None = None, speed_factors=1.0,
                    z_wheel: int | None = None) -> np.ndarray:
    """Representation of every record at every start of ``crops`` (test-time crops): array
    ``(n_records, len(crops), spec.n_channels, spec.length)``, float32.

    Element ``[:, c]`` equals ``represent(..., starts=crops[c])`` bit for bit; the work that does not
    depend on the start (normalisation, the stretched record of ``envelope``, the FFT plan of the
    segment length, Welch segments shared by two crops) is done once per record.

    Parameters
    ----------
    crops : sequence of float
        Segment starts, fractions in [0, 1] of the free room, the same for every record.
    signals, spec, fs_hz, shaft_hz, mesh_cps, z_pinion, speed_factors, z_wheel
        As in :func:`represent`.

    Examples
    --------
    >>> from models.toy import toy_signal_set
    >>> d = toy_signal_set(n_per_class=1)
    >>> spec = RepresentationSpec(kind="tsa", n_revs=4, samples_per_rev=256)
    >>> r = represent_crops(d.signals, spec, fs_hz=d.fs_hz, crops=(0.0, 1.0), shaft_hz=d.shaft_hz(), z_pinion=13)
    >>> r.shape
    (3, 2, 2, 256)
    >>> bool(np.array_equal(r[:, 1], represent(d.signals, spec, fs_hz=d.fs_hz, shaft_hz=d.shaft_hz(),
    ...                                        z_pinion=13, starts=1.0)))
    True
    """
    x = np.asarray(signals)
    require(x.ndim == 2 and x.shape[0] >= 1, "signals", x.shape, "a 2-D array (records, samples)")
    st = np.asarray(crops, dtype=float)
    require(st.ndim == 1 and st.size >= 1, "crops", st.shape, "a sequence of at least one fraction")
    return _represent(x, spec, fs_hz, shaft_hz, mesh_cps, z_pinion, np.broadcast_to(st, (x.shape[0], st.size)),
                      speed_factors, z_wheel)


def _represent(x: np.ndarray, spec: RepresentationSpec, fs_hz: float, shaft_hz, mesh_cps, z_pinion,
               starts: np.ndarray, speed_factors, z_wheel=None) -> np.ndarray:
    """Checked inputs -> ``(n_records, n_crops, channels, length)``; ``starts``: ``(n_records, n_crops)``."""
    n = x.shape[0]
    fr = _per_record(shaft_hz, n, "shaft_hz")
    mc = _per_record(mesh_cps, n, "mesh_cps")
    sf = _per_record(speed_factors, n, "speed_factors")
    require(bool(np.all((starts >= 0) & (starts <= 1))), "starts", "outside [0, 1]", "fractions in [0, 1]")
    require(bool(np.all(sf > 0)), "speed_factors", "non-positive", "factors > 0")
    require(not spec.reference or x.shape[1] % 2 == 0, "signals", x.shape,
            "pairs of record and reference of equal length (SignalSet.paired_signals)")
    check_inputs(spec, x.shape[1] // 2 if spec.reference else x.shape[1], fs_hz, fr, mc, z_pinion=z_pinion,
                 max_speed_factor=float(max(sf.max(), 1.0 / sf.min())), z_wheel=z_wheel)
    out = np.empty((n, starts.shape[1], spec.n_channels, spec.length), dtype=np.float32)
    z = int(z_pinion) if z_pinion is not None else 0
    for i in range(n):
        out[i] = _crops(x[i], spec, float(fs_hz), None if fr is None else fr[i], None if mc is None else mc[i],
                        tuple(float(v) for v in starts[i]), float(sf[i]), z, int(z_wheel) if z_wheel else 0)
    return out
