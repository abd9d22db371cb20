"""Scores of predictions against labels: accuracy, macro-F1, confusion matrices,
severity MAE, and the same broken down per speed and per load.

:func:`evaluate` returns a plain dict (JSON-ready); :func:`report_markdown`
renders it; :func:`write_report` writes ``metrics.json``, ``metrics.md`` and
``predictions.csv`` (figures: :mod:`models.plots`).

Definitions: accuracy = fraction of records whose predicted class equals the
label; macro-F1 = unweighted mean over the classes present in the labels or the
predictions of ``2 P R / (P + R)`` (scikit-learn ``f1_score(average="macro")``);
confusion matrix ``C[i, j]`` = records of true class ``i`` predicted as ``j``;
severity MAE = mean absolute error of the severity fraction.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
from sklearn.metrics import confusion_matrix, f1_score

from gearpit.atomic import atomic_path
from gearpit.errors import require
from models.data import BINARY_CLASSES, SignalSet
from models.novelty import batch_warning
from models.spec import Predictions

#: label columns a breakdown is made for (quantile bins when a column takes many values)
BREAKDOWN_COLUMNS: tuple[str, ...] = ("speed_rpm", "torque_nm", "load_percent")
MAX_GROUPS = 6


def _class_scores(y_true: np.ndarray, y_pred: np.ndarray, classes: list[str]) -> dict:
    present = [c for c in classes if c in set(y_true) | set(y_pred)]
    return {
        "accuracy": float(np.mean(y_true == y_pred)),
        "macro_f1": float(f1_score(y_true, y_pred, labels=present, average="macro", zero_division=0)),
        "classes": list(classes),
        "confusion": confusion_matrix(y_true, y_pred, labels=list(classes)).tolist(),
        "n": int(y_true.size),
    }


def _groups(values: np.ndarray) -> tuple[np.ndarray, list[str]]:
    """Group labels of a numeric column: its values, or quantile bins if there are many."""
    uniq = np.unique(values)
    if uniq.size <= MAX_GROUPS:
        names = [f"{u:g}" for u in uniq]
        return np.searchsorted(uniq, values), names
    edges = np.unique(np.quantile(values, np.linspace(0, 1, MAX_GROUPS + 1)))
    idx = np.clip(np.searchsorted(edges, values, side="right") - 1, 0, edges.size - 2)
    return idx, [f"[{edges[i]:.4g}, {edges[i + 1]:.4g}{']' if i == edges.size - 2 else ')'}" for i in range(edges.size - 1)]


def truth_for(data: SignalSet, pred: Predictions) -> tuple[np.ndarray, np.ndarray | None]:
    """True severity class and teeth class (None if not labelled) of ``data`` in the model's class
    vocabulary (a binary model is scored on healthy versus damaged)."""
    require(data.has_labels(), "DATA", data.source, "labelled records (a severity_class label)")
    d = data.as_binary() if list(pred.severity_classes) == list(BINARY_CLASSES) else data
    teeth = data.teeth_classes() if data.has_teeth_labels() else None
    return d.labels["severity_class"].astype(str).to_numpy(dtype=object), teeth


def evaluate(data: SignalSet, pred: Predictions) -> dict:
    """Scores of ``pred`` against the labels of ``data`` (dict, JSON-ready).

    Pitted-teeth scores only where teeth are labelled; severity MAE only over
    records with a known severity.
    """
    y_sev, y_teeth = truth_for(data, pred)
    p_sev, p_teeth = pred.severity_class, pred.teeth_class
    out = {"n_records": len(data), "source": data.source,
           "severity_class": _class_scores(y_sev, p_sev, list(pred.severity_classes))}
    if y_teeth is not None:
        out["teeth"] = _class_scores(y_teeth, p_teeth, list(pred.teeth_classes))
    unknown = sorted(set(y_sev) - set(pred.severity_classes))
    if unknown:
        out["severity_class"]["unknown_true_classes"] = unknown
    sev_true = data.labels["severity"].to_numpy(dtype=float) if "severity" in data.labels else np.full(len(data), np.nan)
    known = np.isfinite(sev_true)
    if known.any():
        out["severity_mae"] = float(np.mean(np.abs(pred.severity[known] - sev_true[known])))
        out["severity_mae_n"] = int(known.sum())
    out["mean_confidence"] = float(pred.confidence.mean())
    out["n_warnings"] = int(sum(1 for w in pred.warnings if w))
    if pred.novelty is not None:
        out["novelty"] = novelty_scores(pred.novelty, y_sev == p_sev)
        if pred.novelty_batch is not None:
            out["novelty"]["batch"] = pred.novelty_batch
    breakdown = {}
    for col in BREAKDOWN_COLUMNS:
        if col not in data.labels:
            continue
        gi, names = _groups(data.labels[col].to_numpy(dtype=float))
        rows = []
        for g, name in enumerate(names):
            m = gi == g
            if not m.any():
                continue
            row = {"group": name, "n": int(m.sum()), "accuracy": float(np.mean(y_sev[m] == p_sev[m]))}
            if y_teeth is not None:
                row["teeth_accuracy"] = float(np.mean(y_teeth[m] == p_teeth[m]))
            if (m & known).any():
                row["severity_mae"] = float(np.mean(np.abs(pred.severity[m & known] - sev_true[m & known])))
            rows.append(row)
        breakdown[col] = rows
    out["breakdown"] = breakdown
    return out


def novelty_scores(novelty: np.ndarray, correct: np.ndarray) -> dict:
    """How many records the novelty warning flags (novelty > 1, :mod:`models.novelty`) and the severity accuracy
    on the flagged and the other records (None where there are none)."""
    flagged = np.asarray(novelty) > 1.0
    ok = np.asarray(correct, dtype=bool)
    return {"median": float(np.median(novelty)), "flagged": int(flagged.sum()),
            "flagged_fraction": float(flagged.mean()),
            "accuracy_flagged": float(ok[flagged].mean()) if flagged.any() else None,
            "accuracy_not_flagged": float(ok[~flagged].mean()) if (~flagged).any() else None}


def _confusion_md(scores: dict) -> list[str]:
    cls = scores["classes"]
    lines = ["| true \\ predicted | " + " | ".join(cls) + " |", "|---" * (len(cls) + 1) + "|"]
    for c, row in zip(cls, scores["confusion"]):
        lines.append(f"| {c} | " + " | ".join(str(v) for v in row) + " |")
    return lines


def report_markdown(metrics: dict, *, title: str = "Evaluation") -> str:
    """Markdown rendering of :func:`evaluate`'s dict."""
    s, t = metrics["severity_class"], metrics.get("teeth")
    lines = [f"# {title}", "", f"Records: {metrics['n_records']} ({metrics['source']})", "",
             "| task | accuracy | macro-F1 |", "|---|---|---|",
             f"| severity class | {s['accuracy']:.4f} | {s['macro_f1']:.4f} |"]
    lines += [f"| pitted teeth | {t['accuracy']:.4f} | {t['macro_f1']:.4f} |" if t else "| pitted teeth | not labelled | - |", ""]
    if "severity_mae" in metrics:
        n_mae = metrics.get("severity_mae_n", metrics["n_records"])
        lines += [f"Severity MAE: {metrics['severity_mae']:.4f} (pitted fraction; over the {n_mae} of "
                  f"{metrics['n_records']} records with a known severity)", ""]
    lines += [f"Mean confidence: {metrics['mean_confidence']:.3f}; records with warnings: {metrics['n_warnings']}", ""]
    if "novelty" in metrics:
        nv = metrics["novelty"]

        def pct(v):
            return "-" if v is None else f"{100 * v:.1f} %"

        lines += [f"Records unlike the training records (novelty > 1): {nv['flagged']} "
                  f"({pct(nv['flagged_fraction'])}); severity accuracy on them {pct(nv['accuracy_flagged'])}, on the "
                  f"others {pct(nv['accuracy_not_flagged'])}; median novelty {nv['median']:.2f}", ""]
        if nv.get("batch", {}).get("shifted"):
            lines += ["**Warning:** " + batch_warning(nv["batch"]), ""]
    lines += ["## Severity class confusion", ""] + _confusion_md(s)
    if t:
        lines += ["", "## Pitted-teeth confusion", ""] + _confusion_md(t)
    for col, rows in metrics.get("breakdown", {}).items():
        lines += ["", f"## Per {col}", "", "| group | n | accuracy | teeth accuracy | severity MAE |", "|---|---|---|---|---|"]
        for r in rows:
            mae = f"{r['severity_mae']:.4f}" if "severity_mae" in r else "-"
            ta = f"{r['teeth_accuracy']:.4f}" if "teeth_accuracy" in r else "-"
            lines.append(f"| {r['group']} | {r['n']} | {r['accuracy']:.4f} | {ta} | {mae} |")
    return "\n".join(lines) + "\n"


def write_report(metrics: dict, pred: Predictions, data: SignalSet, out_dir: str | Path, *, title: str = "Evaluation"
                 ) -> list[Path]:
    """Write ``metrics.json``, ``metrics.md`` and ``predictions.csv`` into ``out_dir``."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = [out / "metrics.json", out / "metrics.md", out / "predictions.csv"]
    with atomic_path(paths[0]) as tmp:
        tmp.write_text(json.dumps(metrics, indent=1))
    with atomic_path(paths[1]) as tmp:
        tmp.write_text(report_markdown(metrics, title=title))
    table = pd.concat([data.labels.reset_index(drop=True), pred.to_frame().add_prefix("pred_")], axis=1)
    with atomic_path(paths[2]) as tmp:
        table.to_csv(tmp, index=False)
    return paths
