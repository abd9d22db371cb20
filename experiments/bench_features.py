"""Benchmark: seconds per 1 s / 12.8 kHz record for the full feature vector, with EMD and with EEMD.

Signal: ``features.synthetic.gear_signal_example`` (28/37 teeth, 25 Hz pinion, a
pinion fault of depth 0.3, SNR 20 dB). References measured in the same run on the
same records: PyEMD's ``EMD.emd`` alone, and the feature vector without HHT; the
ratio ``full / (no-HHT + EMD alone)`` close to 1 says the wrapper adds nothing.

Usage::

    python3 experiments/bench_features.py [--records 3] [--eemd-trials 100] [--eemd-records 1]

Last line: a JSON object with ``seconds_per_signal_emd`` and ``seconds_per_signal_eemd``.
"""
from __future__ import annotations

import argparse
import json
import time

import numpy as np
from PyEMD import EMD

from features.synthetic import gear_signal_example
from features.table import FeatureConfig, feature_units, signal_features


def _median_seconds(fn, items) -> float:
    times = []
    for it in items:
        t0 = time.perf_counter()
        fn(it)
        times.append(time.perf_counter() - t0)
    return float(np.median(times))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--records", type=int, default=3, help="records timed for EMD / no-HHT (median)")
    ap.add_argument("--eemd-records", type=int, default=1, help="records timed for EEMD (median)")
    ap.add_argument("--eemd-trials", type=int, default=100, help="EEMD ensemble size (Wu & Huang 2009: 100)")
    args = ap.parse_args()

    sigs = [gear_signal_example(fault_depth=0.3, snr_db=20.0, seed=i).x for i in range(max(args.records, args.eemd_records))]
    base = dict(fs_hz=12800.0, z_pinion=28, z_wheel=37)
    cfg_none = FeatureConfig(**base, hht_method="none")
    cfg_emd = FeatureConfig(**base, hht_method="emd")
    cfg_eemd = FeatureConfig(**base, hht_method="eemd", hht_trials=args.eemd_trials)

    signal_features(sigs[0], cfg_none, fr_pinion_hz=25.0)  # warm-up (imports, FFT plans)
    recs = sigs[: args.records]
    t_emd_alone = _median_seconds(lambda x: EMD().emd(x), recs)
    t_none = _median_seconds(lambda x: signal_features(x, cfg_none, fr_pinion_hz=25.0), recs)
    t_emd = _median_seconds(lambda x: signal_features(x, cfg_emd, fr_pinion_hz=25.0), recs)
    t_eemd = _median_seconds(lambda x: signal_features(x, cfg_eemd, fr_pinion_hz=25.0, seed=1),
                             sigs[: args.eemd_records])

    n_emd = len(feature_units(cfg_emd))
    print(f"record: 1 s at 12.8 kHz (12800 samples); {n_emd} features")
    print(f"PyEMD EMD alone (reference):          {t_emd_alone:8.3f} s")
    print(f"feature vector without HHT:           {t_none:8.3f} s")
    print(f"full feature vector, EMD:             {t_emd:8.3f} s  "
          f"(ratio to no-HHT + EMD alone: {t_emd / (t_none + t_emd_alone):.2f})")
    print(f"full feature vector, EEMD x{args.eemd_trials:<4d}:      {t_eemd:8.3f} s  "
          f"(ratio to EMD alone: {t_eemd / t_emd_alone:.1f}; {args.eemd_trials} trials)")
    print(json.dumps({
        "seconds_per_signal_emd": round(t_emd, 4),
        "seconds_per_signal_eemd": round(t_eemd, 4),
        "eemd_trials": args.eemd_trials,
        "seconds_emd_alone": round(t_emd_alone, 4),
        "seconds_no_hht": round(t_none, 4),
        "ratio_emd_full_to_parts": round(t_emd / (t_none + t_emd_alone), 3),
        "n_features": n_emd,
        "n_samples": 12800,
    }))


if __name__ == "__main__":
    main()
