"""The largest disagreements between measurement and model, ranked, in physical terms.

A disagreement is a location (:mod:`compare.views`) whose residual (after the
gain fit and the noise floors of :mod:`compare.error`) exceeds
:data:`THRESHOLD_DB` in magnitude. They are ranked by ``|r|``, then by weight,
and described as an expert would say it: ``"2 fm - 1 fr_wheel: measured +12.0 dB"``,
``"2.69-3.39 kHz band (no order structure): measured +9.1 dB"``,
``"envelope line at 0.57 x fr_pinion: not a shaft order: measured +15.0 dB"``.
For statistics the two values are given too (they carry no gain).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from compare.plan import INDICATORS, STATS

THRESHOLD_DB = 3.0
MAX_LISTED = 20


@dataclass(frozen=True)
class Disagreement:
    """One ranked disagreement.

    Attributes
    ----------
    key, view, label : str
        Location (see :class:`compare.views.Location`).
    residual_db : float
        Measured minus model (dB) after gain and floors; > 0: the measurement has more.
    measured_db, model_db : float
        The two levels (model with the gain applied), dB.
    freq_hz : float or None
    text : str
        The sentence for reports.
    """

    key: str
    view: str
    label: str
    residual_db: float
    measured_db: float
    model_db: float
    freq_hz: float | None
    weight: float
    text: str

    def to_dict(self) -> dict:
        return {k: getattr(self, k) for k in ("key", "view", "label", "residual_db", "measured_db", "model_db",
                                              "freq_hz", "weight", "text")}


def _stat_value(key: str, level_db: float) -> float:
    name = key.split(":", 1)[1]
    factor = STATS[name][0] if name in STATS else INDICATORS[name.split("_", 1)[1]][0]
    return 10 ** (level_db / factor) if factor == 10 else 10 ** (level_db / 20)


def describe(loc, r: float, a: float, b: float) -> str:
    text = f"{loc.label}: measured {r:+.1f} dB"
    if loc.view == "stats" and not loc.gain:
        text += f" ({_stat_value(loc.key, a):.3g} vs model {_stat_value(loc.key, b):.3g})"
    return text


def rank_disagreements(ref, evaluation, *, threshold_db: float = THRESHOLD_DB,
                       max_listed: int = MAX_LISTED) -> list[Disagreement]:
    """Disagreements of ``evaluation`` (a :class:`compare.comparison.Evaluation`) against ``ref``."""
    plan = ref.plan
    r = evaluation.residuals.residual_db
    g = evaluation.residuals.gain_db
    w = evaluation.residuals.weights
    order = np.lexsort((-w, -np.abs(r)))
    out = []
    for i in order:
        if abs(r[i]) < threshold_db or len(out) >= max_listed:
            break
        loc = plan.locations[i]
        a = float(ref.views.levels[i])
        b = float(evaluation.views.levels[i] + (g if loc.gain else 0.0))
        out.append(Disagreement(key=loc.key, view=loc.view, label=loc.label, residual_db=float(r[i]), measured_db=a,
                                model_db=b, freq_hz=loc.freq_hz, weight=float(w[i]), text=describe(loc, float(r[i]), a, b)))
    return out
