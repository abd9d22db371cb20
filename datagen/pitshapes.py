"""Drawing pits on a flank grid: single ellipses and rectangles, placed or sized to a severity.

Every position and size is in metres on the flank: ``s`` along the profile from
the start of the active profile, ``w`` across the face from one edge (see
:class:`datagen.flank.FlankGrid`). A pixel belongs to a pit when its centre lies
inside the pit outline, so the pit footprint is a pixel set and the severity
(pitted area / active flank area) is the fraction of pitted pixels of the
active band (:attr:`FlankGrid.active_cols`). The pits drawn to a severity
(:func:`sized_pit`, and :func:`datagen.pitcluster.cluster`, progressive pitting
drawn by this module's rules) lie on that band: on the wider gear of a pair
with unequal face widths they never reach the strips that make no contact.
:func:`ellipse` and :func:`rectangle` draw where they are told.

Depth profiles (one vocabulary, :data:`DEPTH_PROFILES`):

- ``"flat"`` (default) -- the same depth everywhere in the pit, as the helical
  paper's "uniform depth of 0.2 mm" [1]_;
- ``"bowl"`` -- a paraboloid ``depth_m * max(1 - r**2, BOWL_RIM_FRACTION)``
  with ``r`` the normalised distance from the pit centre (1 on the outline); the
  floor at the rim keeps the footprint identical to the flat pit's (real pits
  have steep walls).

Overlapping pits keep the larger depth. Functions sized to a severity
(:func:`sized_pit`, :func:`datagen.pitcluster.cluster`) land within ``tolerance`` (default
:func:`default_tolerance`, ``max(0.002, 4 / pixels)``) of the target or raise
:class:`gearpit.errors.InputError`. Per-tooth maps and the TOML description are in
:mod:`datagen.pits`.

References
----------
.. [1] Dynamics and diagnostics of fatigue pitting in helical gears: a combined
   simulation and experimental study (ellipsoidal / rectangular pits, uniform
   depth 0.2 mm); /work/shared/seeds/001_79b645ef5780dc4a.txt.
.. [2] Spur-gear pitting model based on image processing (pits made near the
   pitch line, severities 15/20/25 % of the flank, 219 x 1000 pixel flank);
   /work/shared/seeds/000_3879ffd8da6fd0be.txt.
"""
from __future__ import annotations

import math
import numpy as np

from datagen.flank import FlankGrid
from gearpit.errors import require, require_positive, require_range

DEPTH_PROFILES = ("flat", "bowl")
#: depth at the rim of a "bowl" pit, as a fraction of its maximum depth
BOWL_RIM_FRACTION = 0.1
#: default pit depth (m): the helical paper's uniform 0.2 mm [1]
DEFAULT_DEPTH_M = 0.2e-3
#: allowed pit depth (m), wherever a depth is given (pit tables, sweeps, masks, photos, the tooth_pit effect): 1 um
#: (the resolution of a 16-bit depth PNG) to 5 mm (a broken tooth's section loss,
#: :data:`datagen.effects.tooth_breakage.BROKEN_DEPTH_M`)
DEPTH_RANGE_M = (1e-6, 5e-3)
#: units a pit depth is given in: factor to m
_DEPTH_UNITS = {"m": 1.0, "mm": 1e-3, "um": 1e-6}
#: highest severity a progressive cluster is asked to reach (beyond it the flank is spalled)
CLUSTER_MAX_SEVERITY = 0.6


def require_depth(field: str, value, unit: str = "m") -> None:
    """Raise :class:`InputError` unless the pit depth ``value`` (in ``unit``: "m", "mm" or "um") lies in
    :data:`DEPTH_RANGE_M`; the message states the range in ``unit``.

    >>> require_depth("pits.depth_mm", 0.2, "mm")
    >>> require_depth("pits.depth_mm", 4000.0, "mm")
    Traceback (most recent call last):
    ...
    gearpit.errors.InputError: pits.depth_mm: got 4000.0; allowed: a number in [0.001, 5] mm
    """
    scale = _DEPTH_UNITS[unit]
    lo, hi = DEPTH_RANGE_M
    ok = (isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, bool)
          and math.isfinite(value) and lo <= value * scale <= hi)
    require(ok, field, value, f"a number in [{lo / scale:g}, {hi / scale:g}] {unit}")


def default_tolerance(grid: FlankGrid) -> float:
    """Allowed |achieved - target| severity: ``max(0.002, 4 / pixels)`` (pixels of the active flank)."""
    return max(0.002, 4.0 / grid.n_active_pixels)


# ---------------------------------------------------------------- single pits

def _window(grid: FlankGrid, cs: float, cw: float, hs: float, hw: float):
    """Row and column slices of the pixels whose centres lie in a bounding box, and one more on each side (a
    pixel on the box's edge must not fall out by rounding: :data:`TIE_BREAK_PX`)."""
    r0 = max(0, math.ceil((cs - hs) / grid.ds_m - 0.5) - 1)
    r1 = min(grid.n_profile, math.floor((cs + hs) / grid.ds_m - 0.5) + 2)
    c0 = max(0, math.ceil((cw - hw) / grid.dw_m - 0.5) - 1)
    c1 = min(grid.n_face, math.floor((cw + hw) / grid.dw_m - 0.5) + 2)
    return slice(r0, max(r0, r1)), slice(c0, max(c0, c1))


def _radius(grid: FlankGrid, kind: str, cs: float, cw: float, half_s: float, half_w: float, angle: float):
    """Window slices and normalised radius ``r`` (<= 1 inside) of one pit outline."""
    c, s = math.cos(angle), math.sin(angle)
    if kind == "ellipse":
        hs, hw = math.hypot(half_s * c, half_w * s), math.hypot(half_s * s, half_w * c)
    else:
        hs, hw = half_s * abs(c) + half_w * abs(s), half_s * abs(s) + half_w * abs(c)
    rows, cols = _window(grid, cs, cw, hs, hw)
    ds = grid.s_centres_m[rows][:, None] - cs
    dw = grid.w_centres_m[cols][None, :] - cw
    u = (ds * c + dw * s) / half_s
    v = (-ds * s + dw * c) / half_w
    r = np.hypot(u, v) if kind == "ellipse" else np.maximum(np.abs(u), np.abs(v))
    return rows, cols, r


def _depth(r: np.ndarray, depth_m: float, profile: str) -> np.ndarray:
    inside = r <= 1.0
    if profile == "flat":
        return np.where(inside, depth_m, 0.0)
    return np.where(inside, depth_m * np.maximum(1.0 - r * r, BOWL_RIM_FRACTION), 0.0)


def _stamp(out: np.ndarray, grid: FlankGrid, kind: str, cs, cw, axis_s, axis_w, angle, depth_m, profile) -> None:
    rows, cols, r = _radius(grid, kind, cs, cw, axis_s / 2, axis_w / 2, angle)
    np.maximum(out[rows, cols], _depth(r, depth_m, profile), out=out[rows, cols])


def _check_pit(kind, centre_s_m, centre_w_m, axis_s_m, axis_w_m, depth_m, angle_rad, profile):
    for name, v in (("centre_s_m", centre_s_m), ("centre_w_m", centre_w_m), ("angle_rad", angle_rad)):
        require(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v),
                f"{kind}.{name}", v, "a finite number")
    require_positive(f"{kind}.axis_s_m", axis_s_m)
    require_positive(f"{kind}.axis_w_m", axis_w_m)
    require_positive(f"{kind}.depth_m", depth_m)
    require(profile in DEPTH_PROFILES, f"{kind}.profile", profile, f"one of: {', '.join(DEPTH_PROFILES)}")


def ellipse(grid: FlankGrid, *, centre_s_m: float, centre_w_m: float, axis_s_m: float, axis_w_m: float,
            depth_m: float, angle_rad: float = 0.0, profile: str = "flat") -> np.ndarray:
    """Depth map (m) of one elliptical pit, clipped to the flank.

    Parameters
    ----------
    grid : FlankGrid
    centre_s_m, centre_w_m : float
        Pit centre along the profile and across the face (m).
    axis_s_m, axis_w_m : float
        Full axis lengths (m); ``axis_s_m`` lies along the profile when
        ``angle_rad == 0``.
    depth_m : float
        Pit depth (m), the maximum depth for ``profile="bowl"``.
    angle_rad : float
        Rotation of the ``axis_s_m`` axis from the profile direction towards
        the face direction (rad).
    profile : {"flat", "bowl"}
        Depth profile, see the module docstring.

    Returns
    -------
    ndarray, shape ``grid.shape``
        Depth (m), 0 outside the pit. An unclipped pit covers
        ``pi * axis_s_m * axis_w_m / 4`` up to the pixels on its outline.
    """
    _check_pit("ellipse", centre_s_m, centre_w_m, axis_s_m, axis_w_m, depth_m, angle_rad, profile)
    out = np.zeros(grid.shape)
    _stamp(out, grid, "ellipse", centre_s_m, centre_w_m, axis_s_m, axis_w_m, angle_rad, depth_m, profile)
    return out


def rectangle(grid: FlankGrid, *, centre_s_m: float, centre_w_m: float, axis_s_m: float, axis_w_m: float,
              depth_m: float, angle_rad: float = 0.0, profile: str = "flat") -> np.ndarray:
    """Depth map (m) of one rectangular pit, clipped to the flank.

    Same parameters as :func:`ellipse`; ``axis_s_m`` and ``axis_w_m`` are the
    full side lengths (m), so an unclipped pit covers ``axis_s_m * axis_w_m``.
    """
    _check_pit("rectangle", centre_s_m, centre_w_m, axis_s_m, axis_w_m, depth_m, angle_rad, profile)
    out = np.zeros(grid.shape)
    _stamp(out, grid, "rectangle", centre_s_m, centre_w_m, axis_s_m, axis_w_m, angle_rad, depth_m, profile)
    return out


# ------------------------------------------------------ sized to a severity

def max_severity(grid: FlankGrid, shape: str, aspect_w_to_s: float | None = None) -> float:
    """Largest severity ``make_pit_map`` can give one tooth with this shape.

    An ellipse or rectangle must fit whole on the active flank (its centre
    moves off the pitch line towards mid-profile when needed); a cluster stops
    at :data:`CLUSTER_MAX_SEVERITY`.
    """
    if shape == "cluster":
        return CLUSTER_MAX_SEVERITY
    aspect = _aspect(grid, aspect_w_to_s)
    axis_s = min(grid.profile_length_m, _band_width(grid) / aspect)
    area = axis_s * axis_s * aspect * (math.pi / 4 if shape == "ellipse" else 1.0)
    return min(1.0, area / (grid.profile_length_m * _band_width(grid)))


def _band(grid: FlankGrid) -> tuple[float, float]:
    """Face positions (m) where the active columns start and end: the contact band at pixel resolution."""
    cols = grid.active_cols
    return (0.0 if cols.start == 0 else cols.start * grid.dw_m,
            grid.face_width_m if cols.stop == grid.n_face else cols.stop * grid.dw_m)


def _band_width(grid: FlankGrid) -> float:
    """Width of the active columns (m)."""
    w_lo, w_hi = _band(grid)
    return w_hi - w_lo


def _aspect(grid: FlankGrid, aspect_w_to_s: float | None) -> float:
    return _band_width(grid) / grid.profile_length_m if aspect_w_to_s is None else float(aspect_w_to_s)


def sized_pit(grid: FlankGrid, *, shape: str, severity: float, depth_m: float = DEFAULT_DEPTH_M,
              aspect_w_to_s: float | None = None, profile: str = "flat", tolerance: float | None = None) -> np.ndarray:
    """One ellipse or rectangle near the pitch line covering ``severity`` of the flank.

    The pit is axis-aligned with ``axis_w_m / axis_s_m = aspect_w_to_s``
    (default: the active flank's proportions, contact band width over
    ``profile_length_m``), centred on the contact band and on the pitch line ``grid.pitch_s_m``, moved along
    the profile just enough to stay whole on the flank. An ellipse's scale is
    solved by bisection on its pixel count; a rectangle is a block of whole
    pixels whose row count follows the aspect and whose column count then
    gives the pixel count closest to the target.

    Returns
    -------
    ndarray, shape ``grid.shape``
        Depth (m), 0 = intact.

    Raises
    ------
    InputError
        ``severity`` outside ``[0, max_severity(grid, shape, aspect_w_to_s)]``
        (+ tolerance), or not reachable within ``tolerance`` on this grid.
    """
    require(shape in ("ellipse", "rectangle"), "pits.shape", shape, "one of: ellipse, rectangle")
    if aspect_w_to_s is not None:
        require_positive("pits.aspect_w_to_s", aspect_w_to_s)
    tol = default_tolerance(grid) if tolerance is None else tolerance
    require_range("pits.severity", severity, 0.0, min(1.0, max_severity(grid, shape, aspect_w_to_s) + tol))
    require_positive("pits.depth_m", depth_m)
    require(profile in DEPTH_PROFILES, "pits.profile", profile, f"one of: {', '.join(DEPTH_PROFILES)}")
    out = np.zeros(grid.shape)
    if severity == 0:
        return out
    n_pix = grid.n_active_pixels
    target = max(1, round(severity * n_pix))
    aspect = _aspect(grid, aspect_w_to_s)
    if shape == "rectangle":
        rows, cols, r = _pixel_block(grid, target, aspect)
    else:
        rows, cols, r = _sized_ellipse(grid, target, aspect)
    _check_reached(severity, np.count_nonzero(r <= 1.0) / n_pix, tol, shape)
    out[rows, cols] = _depth(r, depth_m, profile)
    return out


#: sub-samples per pixel side with which :func:`subpixel_pit` measures an ellipse's share of each pixel (16: a
#: share to 1/256 of a pixel; a severity step of 1e-4 on a 64 x 64 flank moves ~100 sub-samples)
SUBSAMPLES = 16


def subpixel_pit(grid: FlankGrid, *, shape: str, severity: float, depth_m: float = DEFAULT_DEPTH_M,
                 aspect_w_to_s: float | None = None, profile: str = "flat") -> tuple[np.ndarray, np.ndarray]:
    """The pit of :func:`sized_pit` with its outline at sub-pixel resolution: depth map and pitted share per pixel.

    :func:`sized_pit` draws a pixel set, so its footprint (and every record made from it) moves in whole-pixel
    steps as the severity grows: on the far helical rig of :data:`compare.synthetic.OTHER_RIGS` the sensor's RMS
    jumped 43.7 -> 34.0 -> 27.8 m/s^2 between severities 0.200, 0.205 and 0.210 of a 64 x 64 flank (the 5-6 kHz
    housing band by 5.9 dB), since a pixel flip at an edge moves that slice's contact loss by a pixel (0.11 mm, a
    phase of ~1 rad at that band), and a fit of the size met a needle at the exact pixel map
    (docs/compare_validation.md, stops 64-66). Here the outline is exact: the same axis-aligned ellipse or
    rectangle, centred on the pitch line and the contact band (moved along the profile to stay whole), sized by
    its *area* (``severity`` times the active flank's area: an ellipse ``pi a b / 4``, a rectangle ``a b``), and
    each pixel it touches holds the share of its area inside it (a rectangle's exactly; an ellipse's from
    :data:`SUBSAMPLES` squared sub-samples). The severity of the map (:meth:`datagen.flank.PitMap.severity`,
    shares summed) is the target to the sub-samples' resolution, and the record moves continuously with it.

    Returns
    -------
    depth, share : ndarray, shape ``grid.shape``
        Depth (m; a ``bowl`` pit's depth at the pixel centre, its rim depth on a pixel whose centre lies outside)
        and pitted share of each pixel (0 outside the pit), for :class:`datagen.flank.PitMap` ``coverage``.
    """
    require(shape in ("ellipse", "rectangle"), "pits.shape", shape, "one of: ellipse, rectangle")
    if aspect_w_to_s is not None:
        require_positive("pits.aspect_w_to_s", aspect_w_to_s)
    top = max_severity(grid, shape, aspect_w_to_s)
    require_range("pits.severity", severity, 0.0, top)
    require_positive("pits.depth_m", depth_m)
    require(profile in DEPTH_PROFILES, "pits.profile", profile, f"one of: {', '.join(DEPTH_PROFILES)}")
    depth, share = np.zeros(grid.shape), np.zeros(grid.shape)
    if severity == 0:
        return depth, share
    aspect = _aspect(grid, aspect_w_to_s)
    area = severity * grid.n_active_pixels * grid.pixel_area_m2
    axis_s = math.sqrt(area / aspect / (math.pi / 4 if shape == "ellipse" else 1.0))
    axis_s = min(axis_s, grid.profile_length_m, _band_width(grid) / aspect)     # the largest whole pit, to rounding
    axis_w = axis_s * aspect
    w_lo, w_hi = _band(grid)
    cs, cw = _centre_s(grid, axis_s), (grid.face_width_m / 2 if w_lo == 0.0 else (w_lo + w_hi) / 2)
    rows, cols = _window(grid, cs, cw, axis_s / 2, axis_w / 2)
    s_lo = np.arange(rows.start, rows.stop) * grid.ds_m
    w_lo_px = np.arange(cols.start, cols.stop) * grid.dw_m
    if shape == "rectangle":
        over_s = np.clip(np.minimum(s_lo + grid.ds_m, cs + axis_s / 2) - np.maximum(s_lo, cs - axis_s / 2), 0, None)
        over_w = np.clip(np.minimum(w_lo_px + grid.dw_m, cw + axis_w / 2) - np.maximum(w_lo_px, cw - axis_w / 2),
                         0, None)
        part = (over_s / grid.ds_m)[:, None] * (over_w / grid.dw_m)[None, :]
    else:
        n = SUBSAMPLES
        u = ((s_lo[:, None] + (np.arange(n) + 0.5)[None, :] * grid.ds_m / n - cs) / (axis_s / 2)) ** 2
        v = ((w_lo_px[:, None] + (np.arange(n) + 0.5)[None, :] * grid.dw_m / n - cw) / (axis_w / 2)) ** 2
        inside = (u[:, None, :, None] + v[None, :, None, :]) <= 1.0         # (rows, cols, n, n)
        part = inside.mean(axis=(2, 3))
    part = np.where(part > 1e-12, np.where(part > 1.0 - 1e-9, 1.0, part), 0.0)   # whole pixels whole, to rounding
    share[rows, cols] = part
    _, _, r = _radius(grid, shape, cs, cw, axis_s / 2, axis_w / 2, 0.0)
    depth[rows, cols] = np.where(part > 0, _depth(np.minimum(r, 1.0), depth_m, profile), 0.0)
    return depth, share


def _centre_s(grid: FlankGrid, axis_s: float) -> float:
    """Pitch line, moved along the profile so a pit of length ``axis_s`` stays whole."""
    return min(max(grid.pitch_s_m, axis_s / 2), grid.profile_length_m - axis_s / 2)


#: An ellipse must not depend on the last bit of the geometry. A pair read back from its file form (2.1 mm ->
#: 0.0021000000000000003 m) drew a 20 % pit on the helical-dct pinion (64x64) with 34 of its 691 pixels elsewhere,
#: the mesh stiffness 1.8e7 N/m apart, and a comparison model holding the true pit missed its own noise-free
#: measurement by 2.8 dB. Cause: centred on the pitch line and the band, the ellipse meets pixels in pairs and
#: fours at equal distance, which only rounding told apart; the scale bisection (to 1e-18) then reached odd pixel
#: counts in one geometry and not in the other, and a clamped ellipse's end lay exactly on a row of pixel centres.
#: Now the centre sits this fraction of a pixel (rows, columns) off, which orders such pixels the same way in
#: every geometry (an ulp of the positions is ~1e-12 of a pixel), and the window takes one pixel more per side.
#: The two offsets are in an irrational ratio (the golden ratio): with a rational one, pixels whose distances from
#: the centre differ by a matching step still tied (square pixels, the pitch line on a pixel edge: 13:7 tied the
#: offsets (9.5, 13.5) and (16.5, 0.5)).
TIE_BREAK_PX = (1.3e-6, 1.3e-6 * 2.0 / (1.0 + math.sqrt(5.0)))


def _sized_ellipse(grid: FlankGrid, target: int, aspect: float):
    fit_s = min(grid.profile_length_m, _band_width(grid) / aspect)  # axis_s of the largest whole ellipse
    w_lo, w_hi = _band(grid)
    centre_w = grid.face_width_m / 2 if w_lo == 0.0 else (w_lo + w_hi) / 2

    def place(k: float, shift_s: float, shift_w: float):
        axis_s = k * fit_s
        rows, cols, r = _radius(grid, "ellipse", _centre_s(grid, axis_s) + shift_s + TIE_BREAK_PX[0] * grid.ds_m,
                                centre_w + shift_w + TIE_BREAK_PX[1] * grid.dw_m, axis_s / 2, axis_s * aspect / 2, 0.0)
        return rows, cols, r, int(np.count_nonzero(r <= 1.0))

    def bisect(shift_s: float, shift_w: float):
        lo, hi = 0.0, 1.0 + 1e-9
        best = place(hi, shift_s, shift_w)
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            cand = place(mid, shift_s, shift_w)
            if abs(cand[3] - target) < abs(best[3] - target):
                best = cand
            if cand[3] == target:
                break
            lo, hi = (mid, hi) if cand[3] < target else (lo, mid)
        return best

    # a centre on a pixel corner or edge (even row or column counts) grows the ellipse in pairs or fours of
    # pixels, so an odd target (a single pixel) may be missed or come back empty: then the centre also tries the
    # nearest pixel centres (half a pixel off) and the count closest to the target wins (the first on a tie)
    best = bisect(0.0, 0.0)
    for shift in ((0.0, grid.dw_m / 2), (grid.ds_m / 2, 0.0), (grid.ds_m / 2, grid.dw_m / 2)):
        if best[3] == target:
            break
        cand = bisect(*shift)
        if abs(cand[3] - target) < abs(best[3] - target):
            best = cand
    return best[:3]


def _pixel_block(grid: FlankGrid, target: int, aspect: float):
    n_rows0 = math.sqrt(target * grid.pixel_area_m2 / aspect) / grid.ds_m
    best = None
    for n_r in {math.floor(n_rows0), math.ceil(n_rows0), math.ceil(target / grid.n_face)}:
        n_r = min(max(n_r, 1), grid.n_profile)
        n_c = min(max(round(target / n_r), 1), grid.n_active_cols)
        key = (abs(n_r * n_c - target), abs(n_r - n_rows0))
        if best is None or key < best[0]:
            best = (key, n_r, n_c)
    _, n_r, n_c = best
    # half a row up on a tie (round() went to the even row, which the last bit of the pitch line decided)
    r0 = min(max(math.floor(grid.pitch_s_m / grid.ds_m - n_r / 2 + 0.5 + 1e-9), 0), grid.n_profile - n_r)
    c0 = grid.active_cols.start + (grid.n_active_cols - n_c) // 2
    return _radius(grid, "rectangle", (r0 + n_r / 2) * grid.ds_m, (c0 + n_c / 2) * grid.dw_m,
                   n_r * grid.ds_m / 2, n_c * grid.dw_m / 2, 0.0)


def _check_reached(target: float, achieved: float, tol: float, shape: str) -> None:
    require(abs(achieved - target) <= tol, "pits.severity", target,
            f"a severity this {shape} reaches within tolerance {tol:g} on this grid "
            f"(closest {achieved:.5f}); use a finer grid or a larger tolerance")
