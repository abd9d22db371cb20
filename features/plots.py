"""Figures of the features package (matplotlib, Agg backend); no computation here."""
from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from features.ranking import SCORE_CRITERIA  # noqa: E402
from gearpit.atomic import atomic_path  # noqa: E402


def plot_feature_ranking(ranking: pd.DataFrame, path: str | Path, *, top: int = 25, title: str | None = None) -> Path:
    """Heat map of the criteria of the ``top`` best features, plus their score.

    Each criterion column is scaled to [0, 1] over all ranked features (max = 1;
    robustness and monotonicity are already in [0, 1] and kept as they are).
    Written atomically as PNG; returns the path.
    """
    frame = ranking.head(top)
    crit = [c for c in SCORE_CRITERIA if c in frame.columns and ranking[c].notna().any()]
    values = np.empty((len(frame), len(crit)))
    for j, c in enumerate(crit):
        col = frame[c].to_numpy(dtype=float)
        if c in ("robustness", "monotonicity"):
            values[:, j] = col
        else:
            vmax = np.nanmax(ranking[c].to_numpy(dtype=float))
            values[:, j] = col / vmax if vmax > 0 else np.nan
    fig, (ax, axs) = plt.subplots(1, 2, figsize=(10, 0.32 * len(frame) + 1.8), sharey=True,
                                  gridspec_kw={"width_ratios": [len(crit), 2]})
    im = ax.imshow(values, aspect="auto", cmap="viridis", vmin=0, vmax=1)
    ax.set_xticks(range(len(crit)), crit, rotation=30, ha="right")
    ax.set_yticks(range(len(frame)), frame["feature"])
    for i in range(values.shape[0]):
        for j in range(values.shape[1]):
            if np.isfinite(values[i, j]):
                ax.text(j, i, f"{values[i, j]:.2f}", ha="center", va="center", fontsize=7,
                        color="white" if values[i, j] < 0.6 else "black")
    fig.colorbar(im, ax=ax, fraction=0.04, pad=0.02, label="criterion (scaled)")
    axs.barh(range(len(frame)), frame["score"], color="tab:gray")
    axs.set_xlim(0, 1)
    axs.set_xlabel("score")
    fig.suptitle(title or f"Feature ranking (top {len(frame)} of {len(ranking)})")
    fig.tight_layout()
    target = Path(path)
    with atomic_path(target) as tmp:
        fig.savefig(tmp, dpi=120, format="png")
    plt.close(fig)
    return target
