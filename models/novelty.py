"""How unlike the training records an input is: the novelty warning of a trained classifier.

Why
---
A classifier answers every input with a class and a confidence, also an input from a machine, a sensor path or
a simulator it has never seen, and its softmax confidence does not fall there (measured on the records of another
simulator, ``experiments/foreign_classifier_check.py``: the CNN trained on the default dataset called every
healthy foreign record pitted). The range checks of :func:`models.spec.check_input` see the operating point
(speed, load, SNR, sampling rate, gear pair) but not the signal itself. This module measures the signal.

What
----
The record's features as the classifier sees them - the CNN's pooled convolution features
(:meth:`models.cnn.GearCNN.pooled`, before the operating-point side inputs, which the range checks cover), or a
feature baseline's standardised feature table - are compared with those of the training records by the
Mahalanobis distance to the nearest class mean, the class-conditional Gaussians sharing one covariance matrix
(Lee et al. 2018), shrunk towards a scaled identity by the Ledoit-Wolf estimate (Ledoit & Wolf 2004: a few
hundred records in a few hundred dimensions give a singular sample covariance). The scale comes from records the
fit did not see: the distances of the validation records (the CNN's early-stopping split; a held-out fifth of the
training records for a baseline). A record's **novelty** is its distance divided by their :data:`QUANTILE`
quantile, so a novelty above 1 is farther from every class than 99 % of held-out records of the training
distribution; such a record gets a warning. By construction about 1 % of records like the training ones are
flagged (tested) when the held-out records are many (the rate is about ``max(1 - QUANTILE, 1 / (n + 1))`` for
``n`` of them); with fewer than :data:`MIN_HELD_OUT` no novelty model is fitted and no such warning is given.
What is flagged elsewhere is measured, not assumed.

**A batch as a whole.** A shift too small to carry single records past the 99th percentile can still move a
whole batch into the tail (measured: every SpectraQuest record read by the real-data CNN of
``experiments/eval_protocol.py`` had a novelty of 0.78-1.0, where half the held-out records lie below about 0.45,
and only 0-4 % passed 1). So :meth:`NoveltyModel.batch_shift` counts the records beyond the held-out
:data:`BATCH_QUANTILE` quantile (10 % of records like the training ones are) and gives the one-sided binomial
p-value of that count; a batch of at least :data:`BATCH_MIN_RECORDS` with p below :data:`BATCH_ALPHA` is
reported as unlike the training records as a whole. The held-out quantile is itself estimated from a few hundred
distances, so the p-value is approximate (it treats the quantile as exact); hence the small ``BATCH_ALPHA``.

Limits: the distance knows only the training records; a shift that moves the features along the directions the
training data already spread over is not flagged, and a flagged record may still be classified right. It says
"this record is unlike what the model learnt from", not why.

References
----------
Lee, K., Lee, K., Lee, H., Shin, J. (2018). A simple unified framework for detecting out-of-distribution samples
    and adversarial attacks. Advances in Neural Information Processing Systems 31.
Ledoit, O., Wolf, M. (2004). A well-conditioned estimator for large-dimensional covariance matrices. Journal of
    Multivariate Analysis 88(2), 365-411.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gearpit.errors import require

#: the held-out distance quantile a novelty is measured in (novelty 1 = this quantile)
QUANTILE = 0.99
#: the batch test (module docstring): records beyond this held-out quantile are counted ...
BATCH_QUANTILE = 0.9
#: ... in batches of at least this many records, and the batch is reported below this p-value
BATCH_MIN_RECORDS = 10
BATCH_ALPHA = 1e-3
#: fewest held-out records that set a scale: below it no novelty model is fitted (a quantile of a handful of
#: distances is their maximum, and its false-alarm rate about 1 / (n + 1), not 1 - QUANTILE)
MIN_HELD_OUT = 10
#: file of a saved model directory holding the fitted arrays (read with ``allow_pickle=False``)
NOVELTY_FILE = "novelty.npz"


@dataclass(frozen=True)
class NoveltyModel:
    """Class means, shared precision matrix and the held-out distances that set the scale (module docstring).

    Attributes
    ----------
    means : ndarray, (n_classes, n_features)
    precision : ndarray, (n_features, n_features)
        Inverse of the shrunk shared covariance.
    reference : ndarray, (n_reference,)
        Sorted distances of the held-out records.
    quantile : float
        Quantile of ``reference`` that a novelty of 1 stands for.
    """

    means: np.ndarray
    precision: np.ndarray
    reference: np.ndarray
    quantile: float = QUANTILE

    @property
    def threshold(self) -> float:
        """The distance of novelty 1."""
        return float(max(np.quantile(self.reference, self.quantile), 1e-12))

    def distance(self, features: np.ndarray) -> np.ndarray:
        """Mahalanobis distance of every row of ``features`` to the nearest class mean."""
        f = np.asarray(features, dtype=float)
        require(f.ndim == 2 and f.shape[1] == self.means.shape[1], "features", f.shape,
                f"(n, {self.means.shape[1]}) array (the features the novelty model was fitted on)")
        # precision = L L^T: (x - mu)^T P (x - mu) = |L^T x - L^T mu|^2, one matrix product for every class
        w = self._whitener()
        z, zm = f @ w, self.means @ w
        d2 = np.stack([((z - m) ** 2).sum(axis=1) for m in zm], axis=1)
        return np.sqrt(np.maximum(d2.min(axis=1), 0.0))

    def _whitener(self) -> np.ndarray:
        """The Cholesky factor ``L`` of the precision matrix (``P = L L^T``), computed once."""
        w = self.__dict__.get("_w")
        if w is None:
            w = np.linalg.cholesky(self.precision)
            object.__setattr__(self, "_w", w)
        return w

    def novelty(self, features: np.ndarray) -> np.ndarray:
        """Distance over :attr:`threshold` (> 1: farther than ``quantile`` of the held-out records)."""
        return self.distance(features) / self.threshold

    def to_arrays(self) -> dict:
        return {"means": self.means, "precision": self.precision, "reference": self.reference,
                "quantile": np.array(self.quantile)}

    @classmethod
    def from_arrays(cls, arrays: dict) -> "NoveltyModel":
        for key in ("means", "precision", "reference", "quantile"):
            require(key in arrays, NOVELTY_FILE, sorted(arrays), f"arrays including {key!r}")
        return cls(np.asarray(arrays["means"], float), np.asarray(arrays["precision"], float),
                   np.sort(np.asarray(arrays["reference"], float)), float(arrays["quantile"]))

    def batch_shift(self, novelty: np.ndarray) -> dict:
        """Whether a batch of records (their :meth:`novelty` values) lies in the tail of the held-out records as a
        whole (module docstring): the share beyond the held-out :data:`BATCH_QUANTILE` quantile, the share
        expected, the one-sided binomial p-value and the verdict (``shifted``: at least
        :data:`BATCH_MIN_RECORDS` records and p < :data:`BATCH_ALPHA`)."""
        from scipy.stats import binomtest

        v = np.asarray(novelty, dtype=float)
        cut = float(np.quantile(self.reference, BATCH_QUANTILE)) / self.threshold
        k, n = int(np.count_nonzero(v > cut)), int(v.size)
        p = float(binomtest(k, n, 1.0 - BATCH_QUANTILE, alternative="greater").pvalue) if n else 1.0
        return {"n": n, "beyond_fraction": k / n if n else 0.0, "expected_fraction": 1.0 - BATCH_QUANTILE,
                "novelty_cut": cut, "p_value": p, "shifted": bool(n >= BATCH_MIN_RECORDS and p < BATCH_ALPHA)}

    def summary(self) -> dict:
        """What the model spec records of it."""
        return {"quantile": self.quantile, "threshold": self.threshold, "n_reference": int(self.reference.size),
                "n_features": int(self.means.shape[1]), "n_classes": int(self.means.shape[0])}


def fit_novelty(train_features: np.ndarray, train_classes: np.ndarray, held_out_features: np.ndarray, *,
                quantile: float = QUANTILE) -> NoveltyModel:
    """Fit the class means and the shared Ledoit-Wolf covariance on ``train_features`` (rows: records), labelled
    ``train_classes``; set the scale from the distances of ``held_out_features`` (records the fit did not see)."""
    from sklearn.covariance import LedoitWolf

    x = np.asarray(train_features, dtype=float)
    y = np.asarray(train_classes)
    h = np.asarray(held_out_features, dtype=float)
    require(x.ndim == 2 and x.shape[0] >= 3, "train_features", x.shape, "(n >= 3, n_features) array")
    require(y.shape == (x.shape[0],), "train_classes", y.shape, f"one label per training record ({x.shape[0]})")
    require(h.ndim == 2 and h.shape[0] >= 1 and h.shape[1] == x.shape[1], "held_out_features", h.shape,
            f"(n >= 1, {x.shape[1]}) array")
    require(bool(np.all(np.isfinite(x)) and np.all(np.isfinite(h))), "features", "non-finite values",
            "finite numbers")
    require(0.5 <= quantile < 1.0, "quantile", quantile, "a number in [0.5, 1)")
    classes = np.unique(y)
    means = np.stack([x[y == c].mean(axis=0) for c in classes])
    resid = x - means[np.searchsorted(classes, y)]
    lw = LedoitWolf(assume_centered=True).fit(resid)
    precision = np.linalg.inv(lw.covariance_)
    precision = 0.5 * (precision + precision.T)
    model = NoveltyModel(means, precision, np.zeros(1), quantile)
    return NoveltyModel(means, precision, np.sort(model.distance(h)), quantile)


def novelty_warning(value: float, quantile: float = QUANTILE) -> str:
    """The warning of a record of novelty ``value`` (> 1), or ''."""
    if not np.isfinite(value) or value <= 1.0:
        return ""
    return (f"signal unlike the training records (novelty {value:.1f}: its features lie farther from every class "
            f"than {100 * quantile:g} % of held-out training records)")


def join_warnings(first: list[str], second: list[str]) -> list[str]:
    """Per record, the warnings of both lists joined by '; '."""
    return ["; ".join(w for w in pair if w) for pair in zip(first, second)]


def batch_warning(batch: dict) -> str:
    """The warning of a :meth:`NoveltyModel.batch_shift` result that is ``shifted``, or ''."""
    if not batch.get("shifted"):
        return ""
    return (f"the records as a whole are unlike the training records: {100 * batch['beyond_fraction']:.0f} % of them "
            f"lie beyond the novelty of {batch['novelty_cut']:.2f} that {100 * batch['expected_fraction']:.0f} % of "
            f"held-out training records pass (binomial p = {batch['p_value']:.1e}); treat every prediction with care")
