"""Can the accelerometer be read as a transmission error? A Wiener inverse of the sensor path, learnt on simulated
records that carry both channels, then the transmission-error CNN.

Why: on the transmission error of two shaft encoders the ``tsa_te_diff`` CNN meets every target (RESULTS.md,
section "Sensor"), on the housing accelerometer no CNN passes ~90 % severity even with the sensor noise, the housing
path and the gear errors held fixed (section "Taking the nuisances away"), with the record's absolute level as a side
input too (``tsa_level``). The acceleration is the transmission error's excitation passed through the drive train
and the housing; on one rig that path is fixed, and a simulator of that rig has both channels. So the question:
does an inverse of the path, estimated from the simulated records, give the TE CNN what it needs?

What: the default dataset made again (``nuisance_ceiling_check.VARIANTS``) with both the accelerometer and
``dte_m`` stored; the in-domain split of the protocol (70/30, split seed 0). On the training records the
frequency response from the acceleration to the transmission error is estimated as a Wiener filter
``G(f) = sum S_ay(f) / sum S_aa(f)`` (Welch cross- and auto-spectra summed over every training record: the
least-squares linear estimate of ``y`` from ``a``, Bendat & Piersol 2010, ch. 6, the H1 estimator with the
acceleration as input), turned into a non-causal FIR filter (``NPERSEG - 1`` taps, Hann-windowed); every record's
acceleration filtered by it is the estimated transmission error. Printed: the coherence of the two channels
by band (how much of the TE the acceleration can give back linearly at all) and the acceleration's level in each
band over its own sensor noise, then the ``tsa_te_diff`` CNN
(training seed 0) on the true TE and on the estimated one, severity and teeth accuracy on the held-out records.

Run: ``python experiments/path_inverse_check.py [--only VARIANT ...]`` (generation 2-3 min per variant with two
workers, each CNN 2-6 min). The last line is JSON; datasets under ``experiments/out/models/path_inverse/``.

References
----------
Bendat, J. S., Piersol, A. G. (2010). Random Data: Analysis and Measurement Procedures, 4th ed., Wiley, ch. 6
    (single-input/single-output relationships: optimum frequency response function, ordinary coherence).
"""
from __future__ import annotations

import argparse
import functools
import json
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
from scipy import signal

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "experiments"))

import classifier_runs as cr  # noqa: E402  (experiments/classifier_runs.py)
from nuisance_ceiling_check import VARIANTS, variant_doc  # noqa: E402
from sensor_protocol_design import SENSOR_VARIANTS  # noqa: E402

OUT = ROOT / "experiments" / "out" / "models" / "path_inverse"
ACC, TE = "acc_pinion_loa_m_s2", "dte_m"
#: Welch segment and FIR length (samples): 0.16 s at 12.8 kHz, 6.25 Hz resolution
NPERSEG = 2048
#: bands (Hz) of the printed coherence
BANDS = ((10, 100), (100, 300), (300, 1000), (1000, 2000), (2000, 4000), (4000, 6400))


def spectra(a: np.ndarray, y: np.ndarray, fs_hz: float, nperseg: int = NPERSEG):
    """Welch auto- and cross-spectra summed over records (rows): (f, S_aa, S_yy, S_ay)."""
    kw = dict(fs=fs_hz, nperseg=nperseg, noverlap=nperseg // 2, window="hann", detrend="constant", axis=-1)
    f, s_aa = signal.welch(a, **kw)
    _, s_yy = signal.welch(y, **kw)
    _, s_ay = signal.csd(a, y, **kw)
    return f, s_aa.sum(axis=0), s_yy.sum(axis=0), s_ay.sum(axis=0)


def wiener_fir(a: np.ndarray, y: np.ndarray, fs_hz: float, nperseg: int = NPERSEG) -> np.ndarray:
    """The non-causal FIR of ``G = S_ay / S_aa`` (``y ~ a * g``): ``nperseg - 1`` taps, lag 0 at the middle one
    (where :func:`apply_fir`'s ``same`` convolution puts it), Hann-windowed."""
    _, s_aa, _, s_ay = spectra(a, y, fs_hz, nperseg)
    G = np.where(s_aa > 0, s_ay / np.where(s_aa > 0, s_aa, 1.0), 0.0)
    h = np.fft.irfft(G, nperseg)                       # lag k at index k, negative lags wrapped to the end
    half = nperseg // 2 - 1
    return np.roll(h, half)[:2 * half + 1] * np.hanning(2 * half + 1)


def apply_fir(a: np.ndarray, g: np.ndarray) -> np.ndarray:
    """Every record (row) of ``a`` filtered by the FIR ``g`` of odd length, lag 0 at its middle tap (output
    aligned with the input)."""
    return signal.fftconvolve(a, g[None, :], mode="same", axes=-1)


def coherence_by_band(a, y, fs_hz) -> dict:
    """Ordinary coherence ``|S_ay|^2 / (S_aa S_yy)`` of the summed spectra, its mean in each band of :data:`BANDS`."""
    f, s_aa, s_yy, s_ay = spectra(a, y, fs_hz)
    coh = np.abs(s_ay) ** 2 / np.maximum(s_aa * s_yy, 1e-300)
    return {f"{lo}-{hi} Hz": round(float(coh[(f >= lo) & (f < hi)].mean()), 3) for lo, hi in BANDS}


def band_levels_db(acc) -> dict:
    """The median (over records) acceleration PSD in each band of :data:`BANDS`, in dB over the median PSD of the
    record's own sensor noise (white, ``noise_snr_db`` below the record's RMS, over 0..fs/2): below 0 dB a band
    of the acceleration is the sensor's noise."""
    f, p = signal.welch(acc.signals, fs=acc.fs_hz, nperseg=NPERSEG, axis=-1)
    snr = acc.labels["noise_snr_db"].to_numpy(dtype=float)
    noise = np.median(acc.signals.var(axis=1) * 10 ** (-snr / 10) / (acc.fs_hz / 2))
    return {f"{lo}-{hi} Hz": round(float(10 * np.log10(np.median(p[:, (f >= lo) & (f < hi)].mean(axis=1)) / noise)), 1)
            for lo, hi in BANDS}


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--only", nargs="+", choices=sorted(VARIANTS), default=["quiet_one_rig", "protocol"])
    ap.add_argument("--cnn", default="tsa_te_diff", choices=sorted(SENSOR_VARIANTS))
    ap.add_argument("--skip-true-te", action="store_true", help="train on the estimated TE only")
    ap.add_argument("--workers", type=int, default=2)
    args = ap.parse_args(argv)

    cr.OUT = OUT
    rows = {}
    for name in args.only:
        edit = functools.partial(variant_doc, name)
        where = OUT / name
        acc_tr, acc_te = cr.edited_default_split(where, edit, args.workers, name, channels=(ACC, TE), channel=ACC)
        te_tr, te_te = cr.edited_default_split(where, edit, args.workers, name, channels=(ACC, TE), channel=TE)
        fs = acc_tr.fs_hz
        coh = coherence_by_band(acc_tr.signals, te_tr.signals, fs)
        levels = band_levels_db(acc_tr)
        cr.log(f"{name}: coherence acc -> TE by band {coh}; acceleration over its sensor noise (dB) {levels}")
        g = wiener_fir(acc_tr.signals, te_tr.signals, fs)
        est_tr = replace(acc_tr, signals=apply_fir(acc_tr.signals, g), channel="te_estimated")
        est_te = replace(acc_te, signals=apply_fir(acc_te.signals, g), channel="te_estimated")
        diff = signal.detrend(est_te.signals - te_te.signals, type="constant", axis=-1)
        err = float(np.sqrt(np.mean(diff ** 2) / np.mean(signal.detrend(te_te.signals, type="constant", axis=-1) ** 2)))
        cr.log(f"{name}: test records' TE estimate, RMS error / RMS of the TE (means removed) {err:.3f}")
        runs = {"te_estimated": (est_tr, est_te)}
        if not args.skip_true_te:
            runs["te_true"] = (te_tr, te_te)
        for tag, (tr, te) in runs.items():
            r = cr.cnn_run(tr, {"test": te}, args.cnn, where / f"{args.cnn}_{tag}", variants=SENSOR_VARIANTS)
            rows[f"{name}/{tag}"] = {"dataset": name, "input": tag, "cnn": args.cnn,
                                     "severity_accuracy": r["test"]["accuracy"],
                                     "teeth_accuracy": r["test"]["teeth_accuracy"], "epochs": r["epochs"],
                                     "n_train": len(tr), "n_test": len(te), "coherence": coh,
                                     "acceleration_over_noise_db": levels,
                                     "te_estimate_relative_rms_error": round(err, 4)}
            cr.log(f"{name}, {tag}: severity {100 * r['test']['accuracy']:.1f} %, "
                   f"teeth {100 * r['test']['teeth_accuracy']:.1f} %")
    print("\n| dataset | CNN input | severity acc. % | teeth acc. % |")
    print("|---|---|---|---|")
    for r in rows.values():
        print(f"| {r['dataset']} | {r['input']} | {100 * r['severity_accuracy']:.1f} | {100 * r['teeth_accuracy']:.1f} |")
    out = {"runs": rows}
    print(json.dumps(out))
    return out


if __name__ == "__main__":
    main()
