"""Progressive pitting on a flank grid: small pits near the pitch line that grow and merge.

:func:`cluster` draws one tooth's pits to a target severity, the pitted fraction of the active band
(:attr:`datagen.flank.FlankGrid.active_cols`), up to :data:`datagen.pitshapes.CLUSTER_MAX_SEVERITY`. Positions
and sizes are in metres on the flank, and each pit is an ellipse drawn by the rules of :mod:`datagen.pitshapes`
(a pixel is pitted when its centre lies inside the outline; depth profiles :data:`DEPTH_PROFILES`; overlapping
pits keep the larger depth; the severity lands within ``tolerance`` of the target or raises
:class:`InputError`). Per-tooth maps and the TOML description are in :mod:`datagen.pits`.

References
----------
.. [1] Spur-gear pitting model based on image processing (pits made near the pitch line, severities 15/20/25 %
   of the flank); /work/shared/seeds/000_3879ffd8da6fd0be.txt.
"""
from __future__ import annotations

import math
import numpy as np

from datagen.flank import FlankGrid
from datagen.pitshapes import (CLUSTER_MAX_SEVERITY, DEFAULT_DEPTH_M, DEPTH_PROFILES, _band, _check_reached, _depth,
                               _radius, default_tolerance)
from gearpit.errors import InputError, require, require_positive, require_range

_BATCH = 256  # cluster pits drawn per batch (fixed, so the sequence never depends on the target)


def cluster(grid: FlankGrid, *, target_severity: float, rng: np.random.Generator, depth_m: float = DEFAULT_DEPTH_M,
            tolerance: float | None = None, pit_diameter_m: float | None = None, spread_s_m: float | None = None,
            nucleation_scale: float = 0.02, profile: str = "flat", max_pits: int = 50_000) -> np.ndarray:
    """Irregular progressive pitting: small pits near the pitch line that grow and merge.

    Pits are drawn one after another, each an ellipse with full major axis
    ``pit_diameter_m * LogNormal(0, 0.4)``, minor/major ratio ``U(0.5, 1)`` and a
    random orientation. While the pitted fraction ``f`` is small, pits nucleate
    afresh at ``s ~ Normal(pitch_s_m, spread_s_m)`` (clipped to the flank) and
    ``w`` uniform across the contact band; with probability ``1 - exp(-f /
    nucleation_scale)`` a pit instead grows from the outline of an earlier one
    (offset along the profile halved, so damage spreads along the pitch line).
    Early damage is therefore many small pits near the pitch line, later damage
    grows and merges them into fewer, larger craters. Pits are clipped to the active flank (the
    contact band, see :class:`datagen.flank.FlankGrid`) and added until the
    pitted fraction reaches ``target_severity``; the last pit is shrunk
    (bisection on its scale) to land on the target. The pit sequence does not
    depend on the target, so with the same generator state a larger severity
    gives a superset of a smaller one's pits (progressive damage).

    Parameters
    ----------
    grid : FlankGrid
    target_severity : float
        Pitted fraction of the flank, in ``[0, CLUSTER_MAX_SEVERITY]``.
    rng : numpy.random.Generator
    depth_m : float
        Depth of every pit (m), the maximum depth for ``profile="bowl"``.
    tolerance : float, optional
        Allowed |achieved - target|; default :func:`default_tolerance`.
    pit_diameter_m : float, optional
        Median pit size (m); default 10 % of the smaller active flank dimension.
    spread_s_m : float, optional
        Standard deviation of new pit centres about the pitch line (m);
        default 15 % of the profile length.
    nucleation_scale : float
        Pitted fraction over which nucleation of new pits dies out (e-fold).
    profile : {"flat", "bowl"}
    max_pits : int
        Guard on the number of pits.

    Returns
    -------
    ndarray, shape ``grid.shape``
        Depth (m), 0 = intact.
    """
    tol = default_tolerance(grid) if tolerance is None else tolerance
    require_range("pits.severity", target_severity, 0.0, CLUSTER_MAX_SEVERITY)
    require_positive("pits.depth_m", depth_m)
    require_positive("pits.tolerance", tol)
    require_positive("pits.nucleation_scale", nucleation_scale)
    require(profile in DEPTH_PROFILES, "pits.profile", profile, f"one of: {', '.join(DEPTH_PROFILES)}")
    band = grid.active_cols
    w_lo, w_hi = _band(grid)
    size = 0.1 * min(grid.profile_length_m, w_hi - w_lo) if pit_diameter_m is None else pit_diameter_m
    spread = 0.15 * grid.profile_length_m if spread_s_m is None else spread_s_m
    require_positive("pits.pit_diameter_m", size)
    require_positive("pits.spread_s_m", spread)
    require(isinstance(rng, np.random.Generator), "pits.rng", type(rng).__name__, "a numpy.random.Generator")

    out = np.zeros(grid.shape)
    n_pix = grid.n_active_pixels
    target = 0 if target_severity == 0 else max(1, round(target_severity * n_pix))
    count = 0
    centres: list[tuple[float, float, float]] = []  # (s, w, mean semi-axis) of pits that added area
    mask = np.zeros(grid.shape, bool)
    k = 0
    while count < target:
        if k >= max_pits:
            raise InputError("pits.severity", target_severity,
                             f"a severity this {grid.n_profile}x{grid.n_face} grid resolves for pits of "
                             f"{size * 1e3:.3g} mm on {grid.ds_m * 1e3:.3g} x {grid.dw_m * 1e3:.3g} mm pixels: "
                             f"growth stalled at {count / n_pix:.4f} after {max_pits} pits (the grid's resolution "
                             f"limits it, not the cluster limit {CLUSTER_MAX_SEVERITY}); nearest reachable here: "
                             f"{count / n_pix:.4f} or below, in steps of {1 / n_pix:.4f}; use a finer grid or a "
                             f"larger pit_diameter_mm")
        if k % _BATCH == 0:
            draw = rng.random((_BATCH, 5))
            normal = rng.standard_normal((_BATCH, 2))
        u, pick, phi, ecc, theta = draw[k % _BATCH]
        z_s, z_d = normal[k % _BATCH]
        k += 1
        major = size * math.exp(0.4 * z_d)
        minor = major * (0.5 + 0.5 * ecc)
        if centres and u >= math.exp(-count / n_pix / nucleation_scale):
            ps, pw, pr = centres[int(pick * len(centres))]
            cs, cw = ps + 0.5 * pr * math.cos(2 * math.pi * phi), pw + pr * math.sin(2 * math.pi * phi)
        else:
            cs = min(max(grid.pitch_s_m + spread * z_s, 0.0), grid.profile_length_m)
            cw = w_lo + (w_hi - w_lo) * pick if w_lo > 0.0 else grid.face_width_m * pick
        cs = min(max(cs, 0.0), grid.profile_length_m)
        cw = min(max(cw, w_lo), w_hi)
        angle = math.pi * theta
        rows, cols, r = _radius(grid, "ellipse", cs, cw, major / 2, minor / 2, angle)
        if cols.start < band.start or cols.stop > band.stop:  # clipped to the contact band
            c0 = max(cols.start, band.start)
            c1 = max(min(cols.stop, band.stop), c0)
            r, cols = r[:, c0 - cols.start:c1 - cols.start], slice(c0, c1)
        new = (r <= 1.0) & ~mask[rows, cols]
        gain = int(np.count_nonzero(new))
        if gain == 0:  # wholly inside earlier pits: not a growth front
            continue
        last = count + gain > target
        if last:  # shrink the last pit onto the target
            r = _shrink_last(r, mask[rows, cols], target - count, count + gain - target)
            gain = int(np.count_nonzero((r <= 1.0) & ~mask[rows, cols]))
        mask[rows, cols] |= r <= 1.0
        np.maximum(out[rows, cols], _depth(r, depth_m, profile), out=out[rows, cols])
        count += gain
        centres.append((cs, cw, (major + minor) / 4))
        if last:
            break
    _check_reached(target_severity, count / n_pix, tol, "cluster")
    return out


def _shrink_last(r: np.ndarray, taken: np.ndarray, need: int, over: int) -> np.ndarray:
    """Rescale radii ``r`` by 1/t so the pit adds the pixel count closest to ``need``."""
    free = ~taken
    best_t, best_err = 1.0, over
    lo, hi = 0.0, 1.0
    for _ in range(40):
        t = 0.5 * (lo + hi)
        gain = int(np.count_nonzero((r <= t) & free))
        if abs(gain - need) < best_err or (abs(gain - need) == best_err and t < best_t):
            best_t, best_err = t, abs(gain - need)
        if gain < need:
            lo = t
        elif gain > need:
            hi = t
        else:
            break
    return r / best_t
