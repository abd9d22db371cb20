"""Rank features by how well they separate damage classes, follow severity, and
ignore the operating point.

Criteria, each computed per feature on the rows where it is finite:

- ``f_severity``, ``f_teeth``: one-way ANOVA F statistic between severity classes
  and between pitted-tooth-count classes (:func:`sklearn.feature_selection.f_classif`).
  For two classes F is the square of Student's t; for one feature it is the
  Fisher score times ``(n - C) / (C - 1)``.
- ``mi_severity``, ``mi_teeth``: mutual information (nats) between the feature and
  the class (:func:`sklearn.feature_selection.mutual_info_classif`, k-NN estimator
  of Ross 2014, seeded).
- ``monotonicity``: ``|Spearman rho|`` between the feature and the continuous
  severity; ``spearman_severity`` keeps the sign.
- ``robustness_<col>`` for each nuisance column (speed, SNR): ``S / (S + N_col)``
  with ``S`` the standard deviation of the severity-class means and ``N_col`` the
  standard deviation of the means over the groups of ``col`` within one severity
  class, averaged over classes. 1 when speed (or noise) does not move the feature
  at all compared with damage, 0.5 when it moves it as much as damage does.
  ``robustness`` is the smallest of them. The groups (:func:`nuisance_groups`) are
  the levels of a nuisance set on a grid (at most ``MAX_LEVELS`` distinct values,
  each used at least twice on average); a nuisance drawn from a range is cut into
  equal-frequency bins [4]_ with edges pooled over the classes (the same speeds
  are "low" for every class): terciles, so that a dependence confined to mid-range
  (a resonance crossed) is seen too, or halves (low / high) when the largest class
  has fewer than ``3 * MIN_PER_BIN`` records. Only bins holding at least
  ``MIN_PER_BIN`` records of a class enter its ``N_col``, and only classes with two
  such bins (a small healthy class may sit out; none: NaN), since means of fewer
  records would mostly measure the within-class scatter. Taking each drawn value
  as its own level would do exactly that: ``N_col`` would be the within-class
  spread, the same for every nuisance.
- Severity classes: the ``severity_class`` column; without one they are made from the
  continuous severity (:func:`severity_classes`): its distinct values when they are
  few (a grid, at most ``MAX_LEVELS`` values each used twice on average), else the
  healthy records (severity 0) and equal-frequency bins [4]_ of the damaged ones
  (terciles, or halves when there are fewer than ``3 * MIN_PER_BIN``). Each record
  as its own class (the former fallback) leaves the ANOVA one record per class and
  the mutual-information estimator no neighbours within a class.
- ``score``: mean over the criteria of the feature's percentile rank (1 best);
  ``rank`` orders by it.

References
----------
.. [1] Duda, R. O., Hart, P. E., Stork, D. G. (2001). Pattern Classification, 2nd
   ed., Wiley (Fisher criterion).
.. [2] Ross, B. C. (2014). Mutual information between discrete and continuous data
   sets. PLoS ONE 9(2), e87357.
.. [3] Coble, J., Hines, J. W. (2009). Identifying optimal prognostic parameters from
   data: a genetic algorithms approach. Annual Conference of the PHM Society
   (monotonicity as a prognostic-parameter criterion).
.. [4] Dougherty, J., Kohavi, R., Sahami, M. (1995). Supervised and unsupervised
   discretization of continuous features. Proc. 12th International Conference on
   Machine Learning, 194-202 (equal-frequency binning).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
from scipy.stats import spearmanr
from sklearn.feature_selection import f_classif, mutual_info_classif
from threadpoolctl import threadpool_limits

from gearpit.atomic import atomic_path
from gearpit.errors import require

#: criteria that enter the score, best = largest
SCORE_CRITERIA: tuple[str, ...] = ("f_severity", "mi_severity", "monotonicity", "f_teeth", "mi_teeth", "robustness")
#: a nuisance with at most this many distinct values (each used twice on average) keeps its levels
MAX_LEVELS = 10
#: records per class and bin of a nuisance drawn from a range (terciles need 3x, halves 2x per class)
MIN_PER_BIN = 5


def _anova_f(v: np.ndarray, y: np.ndarray) -> float:
    if np.unique(y).size < 2 or v.size < 3 or np.ptp(v) == 0:
        return float("nan")
    return float(f_classif(v[:, None], y)[0][0])


def _mutual_information(values: np.ndarray, finite: np.ndarray, y: np.ndarray, seed: int) -> np.ndarray:
    """Per-column MI with ``y``; columns sharing the same finite rows go to sklearn in one call."""
    out = np.full(values.shape[1], np.nan)
    groups: dict[bytes, list[int]] = {}
    for j in range(values.shape[1]):
        groups.setdefault(np.packbits(finite[:, j]).tobytes(), []).append(j)
    for cols in groups.values():
        rows = finite[:, cols[0]]
        yy = y[rows]
        block = values[np.ix_(rows, cols)]
        spread = np.ptp(block, axis=0) if block.shape[0] else np.zeros(len(cols))
        keep = [c for c, s in zip(cols, spread) if s > 0]
        if np.unique(yy).size < 2 or block.shape[0] < 4 or not keep:
            continue
        sub = values[np.ix_(rows, keep)]
        sub = (sub - sub.mean(axis=0)) / sub.std(axis=0)
        # one thread: the k-NN dispatcher's OpenMP start-up dominates on small tables and busy machines
        with threadpool_limits(1):
            out[keep] = mutual_info_classif(sub, yy, discrete_features=False, n_neighbors=3, random_state=seed)
    return out


def nuisance_groups(nuisance: np.ndarray, cls: np.ndarray) -> tuple[np.ndarray, bool]:
    """Group of each record for the robustness to one nuisance column (module docstring).

    Parameters
    ----------
    nuisance : array (n,)
        Nuisance value per record (e.g. speed in rpm, SNR in dB); NaN for unknown.
    cls : array of int (n,)
        Severity class index per record.

    Returns
    -------
    groups : array of int (n,)
        Level index (a grid of at most ``MAX_LEVELS`` values, or labels), or
        tercile / half index (values drawn from a range); -1 where the value is
        unknown, and everywhere when even the largest class has fewer than
        ``2 * MIN_PER_BIN`` records.
    binned : bool
        Whether the groups are bins of a nuisance drawn from a range.

    Examples
    --------
    >>> speed = np.linspace(800.0, 2000.0, 60)
    >>> g, binned = nuisance_groups(speed, np.arange(60) % 2)
    >>> np.bincount(g).tolist(), binned
    ([20, 20, 20], True)
    """
    codes, levels = pd.factorize(pd.Series(nuisance), sort=True)
    if not pd.api.types.is_numeric_dtype(levels) or pd.api.types.is_bool_dtype(levels):
        return codes, False   # labels (e.g. "low", "high"): their levels, -1 where missing
    x = np.asarray(nuisance, dtype=float)
    out = np.full(x.size, -1)
    known = np.isfinite(x)
    if not known.any():
        return out, False
    if levels.size <= MAX_LEVELS and 2 * levels.size <= known.sum():
        return codes, False
    per_class = np.bincount(cls[known & (cls >= 0)])
    n_bins = min(3, int(per_class.max(initial=0)) // MIN_PER_BIN)
    if n_bins < 2:
        return out, True
    ranks = pd.Series(x[known]).rank(method="average").to_numpy()
    out[known] = np.minimum(((ranks - 0.5) * n_bins / known.sum()).astype(int), n_bins - 1)
    return out, True


_MADE = "severity classes made from the severity (no class column):"


def severity_classes(severity: np.ndarray) -> tuple[np.ndarray, str]:
    """Severity classes made from a continuous severity, for a table without class labels (module docstring).

    Parameters
    ----------
    severity : array (n,)
        Severity per record (0 = healthy); NaN for unknown.

    Returns
    -------
    classes : array of int (n,)
        Class index per record (-1 where the severity is unknown).
    description : str
        How the classes were made, with their severity ranges and sizes (for the ranking's note).

    Raises
    ------
    InputError
        When fewer than two classes can be made (too few damaged records for two bins and no healthy ones, or
        a single severity).

    Examples
    --------
    >>> sev = np.r_[np.zeros(6), np.linspace(0.05, 0.3, 15)]
    >>> cls, how = severity_classes(sev)
    >>> np.bincount(cls).tolist()
    [6, 5, 5, 5]
    """
    x = np.asarray(severity, dtype=float)
    out = np.full(x.size, -1)
    known = np.isfinite(x)
    levels = np.unique(x[known])
    if 2 <= levels.size <= MAX_LEVELS and 2 * levels.size <= known.sum():
        out[known] = np.searchsorted(levels, x[known])
        return out, (f"{_MADE} its {levels.size} distinct values "
                     f"({', '.join(f'{v:g}' for v in levels)})")
    healthy = known & (x == 0)
    own_class = healthy.sum() >= 2           # a lone healthy record joins the lowest bin instead
    pool = known & ~healthy if own_class else known
    n_bins = min(3, int(pool.sum()) // MIN_PER_BIN)
    if own_class and pool.any():
        n_bins = max(n_bins, 1)
    require(int(own_class) + n_bins >= 2 and levels.size >= 2, "severity_class",
            f"absent ({int(healthy.sum())} healthy, {int((known & ~healthy).sum())} damaged records)",
            "a severity_class column, or severities to make two classes of (>= 2 distinct values, and >= 2 "
            f"healthy records (severity 0) beside damaged ones, or >= {2 * MIN_PER_BIN} records)")
    first = int(own_class)
    out[healthy] = 0
    ranks = pd.Series(x[pool]).rank(method="average").to_numpy()
    out[pool] = first + np.minimum(((ranks - 0.5) * n_bins / pool.sum()).astype(int), n_bins - 1)
    parts = []
    for c in range(int(out.max()) + 1):
        v = x[out == c]
        parts.append(f"{v.min():g}-{v.max():g} ({v.size})" if v.min() < v.max() else f"{v.min():g} ({v.size})")
    if n_bins == 1:
        which = "healthy and damaged records"
    else:
        kind = {2: "halves", 3: "terciles"}[n_bins]
        which = f"healthy and equal-frequency {kind} of the damaged records" if first else \
            f"equal-frequency {kind} of the records"
    return out, f"{_MADE} {which}: " + ", ".join(parts)


def _robustness(v: np.ndarray, cls: np.ndarray, groups: np.ndarray, min_cell: int = 1) -> float:
    """``S / (S + N)`` (module docstring); a class's ``N`` from its groups with ``>= min_cell`` records."""
    keep = groups >= 0
    v, cls, g = v[keep], cls[keep], groups[keep]
    if np.unique(cls).size < 2 or np.unique(g).size < 2:
        return float("nan")
    n_cls, n_g = int(cls.max()) + 1, int(g.max()) + 1
    class_means = np.bincount(cls, weights=v, minlength=n_cls) / np.maximum(np.bincount(cls, minlength=n_cls), 1)
    present = np.bincount(cls, minlength=n_cls) > 0
    s = float(np.std(class_means[present]))
    cell = cls * n_g + g
    counts = np.bincount(cell, minlength=n_cls * n_g).reshape(n_cls, n_g)
    sums = np.bincount(cell, weights=v, minlength=n_cls * n_g).reshape(n_cls, n_g)
    spreads = []
    for c in np.nonzero(present)[0]:
        full = counts[c] >= max(min_cell, 1)
        if full.sum() >= (2 if min_cell > 1 else 1):
            spreads.append(float(np.std(sums[c, full] / counts[c, full])))
    if not spreads:
        return float("nan")
    noise = float(np.mean(spreads))
    return s / (s + noise) if s + noise > 0 else float("nan")


def rank_features(table: pd.DataFrame, feature_columns: list[str] | None = None, *, severity_col: str = "severity",
                  severity_class_col: str | None = "severity_class", teeth_col: str | None = "n_pitted_teeth",
                  nuisance_cols: tuple[str, ...] = ("speed_rpm", "snr_db"), seed: int = 0) -> pd.DataFrame:
    """Rank feature columns of ``table`` (see module docstring for the criteria).

    Parameters
    ----------
    table : DataFrame
        One row per record: feature columns and label columns.
    feature_columns : list of str, optional
        Columns to rank; default every numeric column that is not a label or
        nuisance column.
    severity_col : str
        Continuous severity (e.g. pitted area fraction).
    severity_class_col : str or None
        Severity class labels; if None or missing, classes made from ``severity_col``
        (:func:`severity_classes`; how, in ``attrs["severity_classes"]`` of the result).
    teeth_col : str or None
        Number of pitted teeth; skipped if None or missing.
    nuisance_cols : tuple of str
        Operating-point columns for the robustness criteria; missing ones are skipped.
    seed : int
        Seed of the mutual-information estimator.

    Returns
    -------
    DataFrame
        One row per feature, best first: ``feature, rank, score`` and every criterion.
    """
    require(isinstance(table, pd.DataFrame) and len(table) >= 3, "table", type(table).__name__,
            "a DataFrame with >= 3 rows")
    require(severity_col in table.columns, "severity_col", severity_col, "a column of the table: " +
            ", ".join(map(str, table.columns[:12])))
    cls_col = severity_class_col if severity_class_col is not None and severity_class_col in table.columns else None
    teeth = teeth_col if teeth_col is not None and teeth_col in table.columns else None
    nuis = [c for c in nuisance_cols if c in table.columns]
    labels = {severity_col, *(c for c in (severity_class_col, teeth_col) if c), *nuisance_cols}
    if feature_columns is None:
        feature_columns = [c for c in table.columns if c not in labels and pd.api.types.is_numeric_dtype(table[c])]
    missing = [c for c in feature_columns if c not in table.columns]
    require(not missing, "feature_columns", missing[:3], "columns of the table")
    require(len(feature_columns) >= 1, "feature_columns", feature_columns, "at least one numeric feature column")

    sev = table[severity_col].to_numpy(dtype=float)
    if cls_col is not None:
        cls, how = pd.factorize(table[cls_col])[0], None
    else:
        cls, how = severity_classes(sev)
    tee = pd.factorize(table[teeth])[0] if teeth else None
    values = table[feature_columns].to_numpy(dtype=float)
    finite = np.isfinite(values) & np.isfinite(sev)[:, None]
    mi_sev = _mutual_information(values, finite, cls, seed)
    mi_tee = _mutual_information(values, finite, tee, seed) if tee is not None else None
    groups = {c: nuisance_groups(table[c].to_numpy(), cls) for c in nuis}
    min_cell = {c: MIN_PER_BIN if binned else 1 for c, (_, binned) in groups.items()}
    rows = []
    for j, col in enumerate(feature_columns):
        ok = finite[:, j]
        vv = values[ok, j]
        row = {"feature": col, "f_severity": _anova_f(vv, cls[ok]), "mi_severity": float(mi_sev[j])}
        if vv.size >= 3 and np.ptp(vv) > 0 and np.ptp(sev[ok]) > 0:
            rho = float(spearmanr(vv, sev[ok]).statistic)
        else:
            rho = float("nan")
        row["spearman_severity"] = rho
        row["monotonicity"] = abs(rho)
        if tee is not None:
            row["f_teeth"] = _anova_f(vv, tee[ok])
            row["mi_teeth"] = float(mi_tee[j])
        rob = []
        for c in nuis:
            r = _robustness(vv, cls[ok], groups[c][0][ok], min_cell[c])
            row[f"robustness_{c}"] = r
            rob.append(r)
        finite_rob = [r for r in rob if np.isfinite(r)]
        row["robustness"] = min(finite_rob) if finite_rob else float("nan")
        rows.append(row)
    out = pd.DataFrame(rows)
    crit = [c for c in SCORE_CRITERIA if c in out.columns and out[c].notna().any()]
    pct = out[crit].rank(pct=True, ascending=True, na_option="keep").fillna(0.0)
    out["score"] = pct.mean(axis=1)
    out = out.sort_values(["score", "feature"], ascending=[False, True], kind="mergesort").reset_index(drop=True)
    out.insert(1, "rank", np.arange(1, len(out) + 1))
    score = out.pop("score")
    out.insert(2, "score", score)
    if how is not None:
        out.attrs["severity_classes"] = how
    return out


def ranking_markdown(ranking: pd.DataFrame, *, top: int | None = None, digits: int = 3) -> str:
    """A GitHub Markdown table of the ranking (first ``top`` rows)."""
    frame = ranking if top is None else ranking.head(top)
    cols = list(frame.columns)

    def fmt(v) -> str:
        if isinstance(v, (float, np.floating)):
            if not np.isfinite(v):
                return "-"
            return f"{v:.{digits}g}" if abs(v) >= 1e4 or (v != 0 and abs(v) < 1e-3) else f"{v:.{digits}f}"
        return str(v)

    lines = ["| " + " | ".join(cols) + " |", "|" + "|".join("---" for _ in cols) + "|"]
    for _, r in frame.iterrows():
        lines.append("| " + " | ".join(fmt(r[c]) for c in cols) + " |")
    return "\n".join(lines) + "\n"


def write_ranking(ranking: pd.DataFrame, csv_path: str | Path, markdown_path: str | Path, *,
                  top: int | None = None, note: str | None = None) -> None:
    """Write the full ranking as CSV and (the first ``top`` rows) as Markdown, atomically; ``note`` (e.g. that
    the dataset is incomplete) heads the Markdown as ``**Note:** ...``."""
    with atomic_path(csv_path) as tmp:
        ranking.to_csv(tmp, index=False)
    head = f"**Note:** {note}\n\n" if note else ""
    with atomic_path(markdown_path) as tmp:
        Path(tmp).write_text(head + ranking_markdown(ranking, top=top))
