"""The spur paper's indicator study on simulated signals (its Figs 27, 30, 32).

spur-gds at 1500 rpm, 11.3 N m, 12.8 kHz, pinion housing acceleration with a transmission path and white noise
(SNR 10 dB, five noise seeds per state, as the paper's "five groups"), cluster pitting on pinion tooth 0:
healthy, 15 %, 20 %, 25 %. For each signal: RMS, kurtosis, crest factor of the raw signal and of the selected IMF
(EMD; IMF chosen by the most energy in [fm, 2fm], the band the paper gives for its IMF6; the paper's fixed IMF6 is
reported too), and the mean energy index E(t) of that IMF. Prints the means per state and which of the paper's
claims hold:
  C1 raw-signal indicators are NOT monotonic in severity at small pitting (paper: 20 % below 15 %, even healthy);
  C2 the IMF indicators increase steadily with severity;
  C3 the energy index E(t) increases with severity.
Figure: experiments/out/indicator_study.png.
Usage: python experiments/indicator_study.py
"""
from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from datagen.geometry import spur_pair_example  # noqa: E402
from datagen.pits import PitSpec  # noqa: E402
from datagen.simulate import Case, OperatingPoint, StiffnessOptions, simulate  # noqa: E402
from features.hht import decompose, energy_index, hilbert_spectrum, select_imf  # noqa: E402
from features.statistics import crest_factor, kurtosis, rms  # noqa: E402

SEVERITIES = {"healthy": None, "15%": 0.15, "20%": 0.20, "25%": 0.25}
N_SEEDS = 5


def main() -> None:
    pair = spur_pair_example()
    speed, torque, fs = 1500.0, 11.3, 12800.0
    fm = pair.mesh_frequency_hz(speed)
    grid = pair.flank_grid("pinion", 110, 200)
    effects = ({"name": "transmission_path"}, {"name": "noise", "snr_db": 10.0})
    cases = []
    for sev in SEVERITIES.values():
        pits = None if sev is None else PitSpec(shape="cluster", teeth=(0,), severity=sev, seed=5).build(grid)
        for seed in range(N_SEEDS):
            cases.append(Case(pair=pair, operating=OperatingPoint(speed, torque), duration_s=0.24, fs_hz=fs, pits=pits,
                              effects=effects, seed=seed, stiffness=StiffnessOptions(positions_per_cycle=64, n_slices=200)))
    sigs = simulate(cases)
    rows = {k: [] for k in SEVERITIES}
    for i, s in enumerate(sigs):
        state = list(SEVERITIES)[i // N_SEEDS]
        x = s.channels["acc_pinion_loa_m_s2"]
        dec = decompose(x, method="emd", seed=0)
        k = select_imf(dec.imfs, fs, criterion="mesh_band_energy", fm_hz=fm).index
        imf = dec.imfs[k]
        imf6 = dec.imfs[min(5, len(dec.imfs) - 1)]
        e_t = energy_index(hilbert_spectrum(imf[None, :], fs))
        rows[state].append([rms(x), kurtosis(x), crest_factor(x), rms(imf), kurtosis(imf), crest_factor(imf),
                            float(np.mean(e_t)), kurtosis(imf6), k + 1])
    names = ["rms raw", "kurt raw", "crest raw", "rms imf", "kurt imf", "crest imf", "mean E(t)", "kurt IMF6", "imf #"]
    means = {k: np.mean(np.array(v, dtype=float), axis=0) for k, v in rows.items()}
    print(f"spur-gds {speed:g} rpm, {torque} N m, SNR 10 dB, {N_SEEDS} seeds per state; means:")
    print(f"{'state':>8} " + " ".join(f"{n:>10}" for n in names))
    for k, m in means.items():
        print(f"{k:>8} " + " ".join(f"{v:10.4g}" for v in m))
    m = np.array([means[k] for k in SEVERITIES])

    def monotonic(col):
        return bool(np.all(np.diff(m[:, col]) > 0))

    raw_mono = [monotonic(c) for c in (0, 1, 2)]
    imf_mono = [monotonic(c) for c in (3, 4, 5)]
    print(f"\nC1 raw indicators not monotonic at small pitting (paper): "
          f"{'HOLDS' if not all(raw_mono) else 'DOES NOT HOLD'} (monotonic rms/kurt/crest: {raw_mono})")
    print(f"C2 IMF indicators increase steadily with severity (paper): "
          f"{'HOLDS' if all(imf_mono) else 'PARTLY' if any(imf_mono) else 'DOES NOT HOLD'} (rms/kurt/crest: {imf_mono})")
    print(f"C3 energy index E(t) increases with severity (paper): {'HOLDS' if monotonic(6) else 'DOES NOT HOLD'} "
          f"({np.round(m[:, 6], 4)})")
    fig, axes = plt.subplots(1, 4, figsize=(13, 3))
    x = np.arange(len(SEVERITIES))
    for ax, (cols, title) in zip(axes, [((0, 3), "RMS"), ((1, 4), "kurtosis"), ((2, 5), "crest factor"),
                                        ((6,), "mean E(t) of IMF")]):
        for c in cols:
            ax.plot(x, m[:, c] / m[0, c], "o-", label=names[c])
        ax.set_xticks(x, list(SEVERITIES))
        ax.set_title(f"{title} (relative to healthy)")
        ax.legend(fontsize=7)
    fig.tight_layout()
    out = Path("experiments/out/indicator_study.png")
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=110)
    print(f"figure: {out}")


if __name__ == "__main__":
    main()
