"""Figures of an evaluation (matplotlib, Agg): confusion matrices and the
per-speed / per-load breakdown. The only module of :mod:`models` that draws."""
from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from gearpit.atomic import atomic_path  # noqa: E402


def _confusion(ax, scores: dict, title: str) -> None:
    c = np.asarray(scores["confusion"], dtype=float)
    norm = c / np.maximum(c.sum(axis=1, keepdims=True), 1)
    ax.imshow(norm, cmap="Blues", vmin=0, vmax=1)
    cls = scores["classes"]
    ax.set_xticks(range(len(cls)), cls, rotation=45, ha="right")
    ax.set_yticks(range(len(cls)), cls)
    for i in range(c.shape[0]):
        for j in range(c.shape[1]):
            ax.text(j, i, f"{int(c[i, j])}", ha="center", va="center", color="white" if norm[i, j] > 0.5 else "black",
                    fontsize=8)
    ax.set_xlabel("predicted")
    ax.set_ylabel("true")
    ax.set_title(f"{title}\naccuracy {scores['accuracy']:.3f}, macro-F1 {scores['macro_f1']:.3f}", fontsize=9)


def plot_confusions(metrics: dict, path: str | Path) -> Path:
    """Severity-class and pitted-teeth confusion matrices side by side (row-normalised colour, counts)."""
    panels = [("severity_class", "severity class"), ("teeth", "pitted teeth")]
    panels = [(k, t) for k, t in panels if k in metrics]
    fig, axes = plt.subplots(1, len(panels), figsize=(4.5 * len(panels), 4.2), squeeze=False)
    for ax, (key, title) in zip(axes[0], panels):
        _confusion(ax, metrics[key], title)
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110, format="png")
    plt.close(fig)
    return Path(path)


def plot_breakdown(metrics: dict, path: str | Path) -> Path | None:
    """Accuracy of both tasks per speed and per load group (bar charts); None if there is no breakdown."""
    groups = [(k, v) for k, v in metrics.get("breakdown", {}).items() if v]
    if not groups:
        return None
    fig, axes = plt.subplots(1, len(groups), figsize=(4.5 * len(groups), 3.6), squeeze=False)
    for ax, (col, rows) in zip(axes[0], groups):
        x = np.arange(len(rows))
        ax.bar(x - 0.2, [r["accuracy"] for r in rows], 0.4, label="severity class")
        if all("teeth_accuracy" in r for r in rows):
            ax.bar(x + 0.2, [r["teeth_accuracy"] for r in rows], 0.4, label="pitted teeth")
        ax.set_xticks(x, [r["group"] for r in rows], rotation=30, ha="right", fontsize=8)
        ax.set_ylim(0, 1.05)
        ax.set_xlabel(col)
        ax.set_ylabel("accuracy")
        ax.legend(fontsize=8, loc="lower left")
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110, format="png")
    plt.close(fig)
    return Path(path)
