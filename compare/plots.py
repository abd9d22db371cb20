"""Figures of a comparison (matplotlib, Agg) - the only module of ``compare`` that draws.

Each function takes computed results and returns PNG bytes; nothing here computes a view.
"""
from __future__ import annotations

import io

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from compare.plan import VIEWS  # noqa: E402

MEAS = dict(color="#1f4e9c", lw=0.8, label="measured")
MODEL = dict(color="#d9541e", lw=0.8, label="model (gain fitted)", alpha=0.85)


def _png(fig) -> bytes:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=90, bbox_inches="tight")
    plt.close(fig)
    return buf.getvalue()


def _db(p):
    return 10 * np.log10(np.maximum(p, 1e-30))


def order_spectrum(comparison) -> bytes:
    """Order spectrum (pinion-angle resampled, Hz at the mean speed): full range and a zoom on fm."""
    ref, ev = comparison.reference, comparison.evaluation
    g = ev.residuals.gain_db
    f = ref.views.curves["order_hz"]
    pm, py = ref.views.curves["order_power"], ev.views.curves["order_power"]
    plan = ref.plan
    fig, axes = plt.subplots(2, 1, figsize=(10, 6))
    for ax, (lo, hi) in zip(axes, ((0, 0.45 * plan.fs_hz), (plan.fm_hz - 8 * plan.fr_pinion_hz,
                                                             plan.fm_hz + 8 * plan.fr_pinion_hz))):
        sel = (f >= lo) & (f <= hi)
        ax.plot(f[sel], _db(pm[sel]), **MEAS)
        ax.plot(f[sel], _db(py[sel]) + g, **MODEL)
        for m in range(1, plan.n_harmonics + 1):
            if lo <= m * plan.fm_hz <= hi:
                ax.axvline(m * plan.fm_hz, color="grey", lw=0.5, ls=":")
        ax.set_xlim(lo, hi)
        ax.set_ylabel("line power (dB)")
    axes[0].set_title("order spectrum (dotted: mesh harmonics)")
    axes[1].set_title("around fm: sidebands of both shafts")
    axes[1].set_xlabel("frequency at the mean speed (Hz)")
    axes[0].legend(loc="upper right", fontsize=8)
    return _png(fig)


def location_levels(comparison, view: str, title: str) -> bytes:
    """Measured and model levels at the view's locations (bars), residual on a second axis."""
    ref, ev = comparison.reference, comparison.evaluation
    idx = ref.plan.view_index(view)
    locs = [ref.plan.locations[i] for i in idx]
    g = ev.residuals.gain_db
    a = ref.views.levels[idx]
    b = ev.views.levels[idx] + np.array([g if loc.gain else 0.0 for loc in locs])
    fig, ax = plt.subplots(figsize=(10, 3.6))
    x = np.arange(len(idx))
    ax.bar(x - 0.2, a, width=0.4, color=MEAS["color"], label="measured")
    ax.bar(x + 0.2, b, width=0.4, color=MODEL["color"], label="model (gain fitted)")
    ax.set_xticks(x)
    ax.set_xticklabels([loc.label.replace(" band (no order structure)", "").replace(": not a shaft order", "")
                        for loc in locs], rotation=70, ha="right", fontsize=7)
    ax.set_ylabel("level (dB)")
    ax.set_title(title)
    ax.legend(fontsize=8)
    return _png(fig)


def envelope_spectrum(comparison) -> bytes:
    ref, ev = comparison.reference, comparison.evaluation
    g = ev.residuals.gain_db
    f = ref.views.curves["order_hz"][:len(ref.views.curves["envelope_power"])]
    sel = f <= 1.2 * ref.plan.fm_hz
    fig, ax = plt.subplots(figsize=(10, 3.2))
    ax.plot(f[sel], _db(ref.views.curves["envelope_power"][sel]), **MEAS)
    ax.plot(f[sel], _db(ev.views.curves["envelope_power"][sel]) + g, **MODEL)
    ax.set_xlabel("frequency at the mean speed (Hz)")
    ax.set_ylabel("envelope line power (dB)")
    ax.set_title(f"envelope spectrum (band {ref.plan.envelope_band_hz[0]:.0f}-{ref.plan.envelope_band_hz[1]:.0f} Hz)")
    ax.legend(fontsize=8)
    return _png(fig)


def tsa(comparison) -> bytes:
    ref, ev = comparison.reference, comparison.evaluation
    gain = 10 ** (ev.residuals.gain_db / 20)
    fig, axes = plt.subplots(2, 1, figsize=(10, 4.5))
    for ax, shaft in zip(axes, ("pinion", "wheel")):
        a = ref.views.curves[f"tsa_{shaft}"]
        b = ev.views.curves[f"tsa_{shaft}"] * gain
        th = np.arange(a.size) * 360.0 / a.size
        ax.plot(th, a - a.mean(), **MEAS)
        ax.plot(th, b - b.mean(), **MODEL)
        ax.set_ylabel(f"TSA {shaft}")
        ax.set_xlim(0, 360)
    axes[1].set_xlabel("shaft angle (deg; the origin of each record is its own)")
    axes[0].legend(fontsize=8)
    return _png(fig)


def residual_map(comparison) -> bytes:
    """Residual (dB) at every location, one panel per view."""
    ref, ev = comparison.reference, comparison.evaluation
    r = ev.residuals.residual_db
    fig, axes = plt.subplots(len(VIEWS), 1, figsize=(10, 9))
    for ax, view in zip(axes, VIEWS):
        idx = ref.plan.view_index(view)
        vals = r[idx]
        ax.bar(np.arange(idx.size), vals, color=np.where(vals > 0, MEAS["color"], MODEL["color"]))
        ax.axhline(0, color="k", lw=0.5)
        ax.set_ylabel(f"{view}\n(dB)", fontsize=8)
        ax.set_xlim(-1, max(idx.size, 1))
        ax.set_xticks([])
        ax.set_title(f"{view}: error {ev.residuals.view_error_db.get(view, float('nan')):.2f} dB", fontsize=8)
    axes[0].set_title(f"residuals, measured - model (blue: the measurement has more); "
                      f"order: {ev.residuals.view_error_db.get('order', float('nan')):.2f} dB", fontsize=8)
    return _png(fig)


def ledger_history(rows: list[dict]) -> bytes:
    fig, ax = plt.subplots(figsize=(8, 3))
    runs = [r.get("run", i + 1) for i, r in enumerate(rows)]
    def db(r, key):     # null in the ledger (no finite value): a gap in the line
        v = r["error_db"].get(key)
        return np.nan if v is None else v

    ax.plot(runs, [db(r, "total") for r in rows], "o-", color="k", label="total")
    for view in VIEWS:
        ax.plot(runs, [db(r, view) for r in rows], ".--", lw=0.7, label=view)
    ax.set_xlabel("run")
    ax.set_ylabel("error (dB)")
    ax.set_title("ledger: error per comparison")
    ax.legend(fontsize=7, ncol=3)
    return _png(fig)
