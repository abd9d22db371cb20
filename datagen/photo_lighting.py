"""The lighting of a flank photo: what the extraction (:mod:`datagen.photo`) divides out before it looks for pits.

Three estimates of the illumination from the intact pixels (``support``): :func:`background_rows` (default: a
robust polynomial across the face for each profile height, clipped highlights and pits left out, so a specular
streak along the face is lighting), :func:`background_polynomial` (one smooth surface over the flank) and
:func:`background_blur` (a normalised Gaussian of the intact pixels). The last two read the surroundings of a
streak as pits; they are kept as options.
"""
from __future__ import annotations

import cv2
import numpy as np

#: gray level at and above which a pixel is taken as clipped (a saturated highlight)
SATURATED = 0.995

#: degree of the per-row lighting polynomial across the face (a streak's fall-off along the face is not quadratic)
_ROW_DEGREE = 4


def background_rows(gray: np.ndarray, support: np.ndarray, n_iter: int = 10) -> np.ndarray:
    """Lighting as one robust quadratic across the face per row (per profile height).

    A flank's lighting changes quickly along the curved profile (a specular
    streak along the face at one height, shading towards root and tip) and
    slowly across the straight face, so every row gets its own quadratic in
    the face coordinate, fitted to its intact pixels with outliers on both
    sides (pit floors, lit pit walls) dropped beyond 2.5 sigma. Pits only
    cover part of a row, so they cannot pull a row's fit down; rows with
    fewer than 10 % intact pixels take the coefficients of the nearest rows
    that have them. Unlike one surface for the whole flank, a streak (a
    bright band spanning the face) does not leave the rows beside it darker
    than their fit.
    """
    h, w = gray.shape
    x = (np.arange(w) + 0.5) / w - 0.5
    basis = np.stack([x ** k for k in range(_ROW_DEGREE + 1)])   # (n, w)
    gram_terms = basis[:, None, :] * basis[None, :, :]       # (3, 3, w)
    base = support if np.count_nonzero(support) >= 100 else np.ones(gray.shape, bool)

    def fit(keep):
        wts = keep.astype(np.float64)
        gram = np.einsum("rw,ijw->rij", wts, gram_terms) + 1e-9 * np.eye(len(basis))
        rhs = np.einsum("rw,iw->ri", wts * gray, basis)
        return np.linalg.solve(gram, rhs[..., None])[..., 0], wts.sum(axis=1)

    coef, count = fit(base)
    keep = base & (gray >= coef @ basis)   # start from the upper half: pits only pull the fit down
    for _ in range(n_iter):
        coef, count = fit(keep)
        resid = gray - coef @ basis
        r_keep = resid[keep]
        sigma = 1.4826 * float(np.median(np.abs(r_keep - np.median(r_keep)))) + 1e-9 if r_keep.size else 1.0
        new_keep = base & (np.abs(resid) < 2.5 * sigma)
        if np.array_equal(new_keep, keep):
            break
        keep = new_keep
    good = count >= max(0.1 * w, 6)
    if not good.any():
        return np.full(gray.shape, max(float(np.median(gray)), 1e-3))
    if not good.all():
        rows = np.arange(h)
        coef = np.stack([np.interp(rows, rows[good], coef[good, i]) for i in range(len(basis))], axis=1)
    background = coef @ basis
    clipped = gray >= SATURATED    # left out of the fit, where the polynomial may run away: lit, not pitted
    background[clipped] = gray[clipped]
    return np.maximum(background, 1e-3)


def background_polynomial(gray: np.ndarray, support: np.ndarray, n_iter: int = 8) -> np.ndarray:
    """Lighting as a quadratic surface least-squares fitted to the intact pixels.

    Fitted on at most ~20 000 support pixels (a regular subsample), then
    refitted without pixels more than 2.5 sigma below the surface (pits are
    dark, so only low outliers are dropped).
    """
    h, w = gray.shape
    rows, cols = np.nonzero(support if np.count_nonzero(support) >= 100 else np.ones(gray.shape, bool))
    step = max(1, rows.size // 20_000)
    rows, cols = rows[::step], cols[::step]
    y, x = (rows + 0.5) / h - 0.5, (cols + 0.5) / w - 0.5
    basis = np.stack([np.ones_like(x), x, y, x * x, x * y, y * y], axis=-1)
    z = gray[rows, cols]
    coef, *_ = np.linalg.lstsq(basis, z, rcond=None)
    keep = z - basis @ coef >= 0  # start from the upper half: pits only pull the fit down
    for _ in range(n_iter):
        coef, *_ = np.linalg.lstsq(basis[keep], z[keep], rcond=None)
        resid = z - basis @ coef
        sigma = 1.4826 * np.median(np.abs(resid[keep] - np.median(resid[keep]))) + 1e-9
        new_keep = resid > -2.5 * sigma
        if new_keep.sum() < 6 or np.array_equal(new_keep, keep):
            break
        keep = new_keep
    y, x = np.mgrid[0:h, 0:w]
    y, x = (y + 0.5) / h - 0.5, (x + 0.5) / w - 0.5
    surface = coef[0] + coef[1] * x + coef[2] * y + coef[3] * x * x + coef[4] * x * y + coef[5] * y * y
    return np.maximum(surface, 1e-3)


def background_blur(gray: np.ndarray, support: np.ndarray, background_px: float) -> np.ndarray:
    """Lighting as a normalised Gaussian blur of the intact pixels (any smooth lighting).

    ``blur(gray * support) / blur(support)`` with standard deviation
    ``background_px``: pits are left out of the average instead of being
    smeared into it.
    """
    wts = support.astype(np.float64)
    num = cv2.GaussianBlur(gray * wts, (0, 0), background_px, borderType=cv2.BORDER_REFLECT)
    den = cv2.GaussianBlur(wts, (0, 0), background_px, borderType=cv2.BORDER_REFLECT)
    fallback = float(np.median(gray[support])) if support.any() else float(np.median(gray))
    return np.maximum(np.where(den > 1e-3, num / np.maximum(den, 1e-12), fallback), 1e-3)
