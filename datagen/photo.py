"""Pit masks from a photo of a flank, along the spur paper's image-processing route.

The spur paper [1]_ extracts pitting from a flank photo with OpenCV: Gaussian
smoothing, a gradient operator, a binary threshold and morphology, then
discretises the flank into ``m x n`` pixels. The steps here
(:func:`extraction_steps` keeps every intermediate image):

1. grayscale in [0, 1]; crop to the flank (a box in pixels, or ``"auto"``: the
   bounding box of the largest bright region); optional quarter turns so rows
   run along the profile (row 0 = start of active profile) and columns across
   the face;
2. area-averaged down to at most :data:`WORK_PER_GRID_PX` working pixels per
   flank-grid pixel in each direction; Gaussian smoothing (``sigma_grid_px``);
   every size below is in grid pixels, so the result depends little on the
   photo's resolution;
3. gradient operator: Sobel magnitude of the log of the smoothed image (smooth
   lighting barely shows, pit outlines do), thresholded with Otsu's method [2]_
   (floored at 3 x its median, the noise level); for the whole-flank lighting
   models the brightest large region free of edges is taken as intact flank;
4. lighting flattening: divide by a background fitted to the photo with the
   pits left out. The default (``"rows"``) fits each row (profile height)
   its own quartic across the face, dropping outliers on both sides (pit
   floors, lit pit walls) and clipped pixels: a flank's light changes fast
   along the curved profile (a specular streak along the face, shading towards
   root and tip) and slowly across the straight face, and pits only cover part
   of a row. The older whole-flank models, fitted to the brightest edge-free
   region only -- a quadratic surface (``"polynomial"``) or a normalised
   Gaussian blur (``"blur"``) -- assume light smooth in both directions: a
   streak leaves the band beside it darker than their fit, read as pits;
5. threshold halfway between the intact level and the median pit floor (where
   a blurred step edge crosses, so outlines do not move with the smoothing),
   never closer than 4 noise sigmas plus :data:`MIN_PIT_CONTRAST` to the
   intact level (an intact flank gives no pits, also under a lighting gradient
   and a specular streak: tested);
6. morphology: opening with a 1-pixel disc, holes filled (bright spots on
   rough pit floors), regions smaller than ``min_area_grid_px`` removed; steps 4-6
   are run twice, the second time with the found pits excluded from the
   lighting fit;
7. resampling to the flank grid: area average of the mask, pitted where >= 0.5.

Limits: the intact flank must be most of each row (``"rows"``) or the
brightest large edge-free region (the others), so flanks pitted over more
than about half their area, or pits whose outline is
broken by a rough floor, can come back empty (tested: IoU >= 0.8 for pitted
fractions 5-45 %, see tests/test_photo.py). Depth cannot be read from one
photo; :func:`pit_map_from_image` gives every pit one depth.

References
----------
.. [1] Spur-gear pitting model based on image processing (Gaussian filter,
   gradient operator, binary image of the pitting, 219 x 1000 pixel flank);
   /work/shared/seeds/000_3879ffd8da6fd0be.txt.
.. [2] N. Otsu, "A threshold selection method from gray-level histograms",
   IEEE Trans. SMC 9(1), 62-66, 1979.
"""
from __future__ import annotations

import warnings

from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
from scipy import ndimage
from skimage.filters import threshold_otsu

from datagen.flank import FlankGrid, PitMap
from datagen.photo_input import PhotoWarning, check_flank_aspect, photo_warnings, read_gray
from datagen.photo_lighting import SATURATED, background_blur, background_polynomial, background_rows
from datagen.pitshapes import DEFAULT_DEPTH_M, require_depth
from gearpit.errors import require, require_positive

FLATTEN_METHODS = ("rows", "polynomial", "blur", "none")


@dataclass(frozen=True)
class ExtractionSteps:
    """Every intermediate image of one extraction (photo resolution, after crop and rotation).

    Attributes
    ----------
    gray, background, flattened, smoothed, gradient : ndarray of float
        Grayscale in [0, 1]; lighting estimate; ``gray / background``; after
        the Gaussian filter; Sobel gradient magnitude (per pixel).
    dark, edges, mask : ndarray of bool
        Below the dark threshold; above the gradient threshold; final pit mask.
    crop : tuple of int
        ``(top, bottom, left, right)`` box used, in pixels of the input image.
    """

    gray: np.ndarray
    background: np.ndarray
    flattened: np.ndarray
    smoothed: np.ndarray
    gradient: np.ndarray
    dark: np.ndarray
    edges: np.ndarray
    mask: np.ndarray
    crop: tuple[int, int, int, int]
    photo_shape: tuple[int, int]


def flank_crop_box(gray: np.ndarray) -> tuple[int, int, int, int]:
    """``(top, bottom, left, right)`` bounding box of the largest bright region (the flank).

    The image is lightly blurred and thresholded with Otsu's method [2]_; holes
    (dark pits inside the flank) are filled and thin bright specks opened
    away before the largest region is taken.
    """
    blur = cv2.GaussianBlur(gray.astype(np.float32), (0, 0), 1.5)
    bright = ndimage.binary_opening(blur > _otsu(blur), np.ones((5, 5)))
    bright = ndimage.binary_fill_holes(bright)
    labels, n = ndimage.label(bright)
    require(n > 0, "image.crop", "auto", "a photo with a bright flank on a darker background")
    sizes = np.bincount(labels.ravel())
    sizes[0] = 0
    rows, cols = ndimage.find_objects(labels)[int(np.argmax(sizes)) - 1]
    return rows.start, rows.stop, cols.start, cols.stop


def _crop(gray: np.ndarray, crop) -> tuple[np.ndarray, tuple[int, int, int, int]]:
    if crop is None:
        box = (0, gray.shape[0], 0, gray.shape[1])
    elif isinstance(crop, str):
        require(crop == "auto", "image.crop", crop, "None, 'auto' or (top, bottom, left, right) in pixels")
        box = flank_crop_box(gray)
    else:
        box = tuple(int(v) for v in crop) if isinstance(crop, (tuple, list)) and len(crop) == 4 else ()
        ok = len(box) == 4 and 0 <= box[0] < box[1] <= gray.shape[0] and 0 <= box[2] < box[3] <= gray.shape[1]
        require(ok and box[1] - box[0] >= 8 and box[3] - box[2] >= 8, "image.crop", crop,
                f"(top, bottom, left, right) with 0 <= top < bottom <= {gray.shape[0]}, "
                f"0 <= left < right <= {gray.shape[1]}, at least 8 x 8 pixels")
    return gray[box[0]:box[1], box[2]:box[3]], box


#: least relative darkening (of the lighting estimate) read as a pit: what is left of the lighting after the
#: per-row fit (a few %, at a streak's ends) is not a pit; the pit floors of the tests and the audit photos
#: are 40-65 % darker than the flank
MIN_PIT_CONTRAST = 0.05

#: working pixels per flank-grid pixel, at most, in each direction: a larger photo is area-averaged down to this
#: before any processing (a 4000 x 6000 photo took 24 s and 2.5 GB for a 219 x 1000 grid); finer detail than
#: half a grid pixel cannot change the grid's mask
WORK_PER_GRID_PX = 2


def working_shape(photo_shape: tuple[int, int], grid: FlankGrid) -> tuple[int, int]:
    """Shape the photo is processed at: at most :data:`WORK_PER_GRID_PX` x the grid per direction, never larger
    than the photo."""
    return (min(photo_shape[0], WORK_PER_GRID_PX * grid.n_profile),
            min(photo_shape[1], WORK_PER_GRID_PX * grid.n_face))


#: default Gaussian smoothing (flank-grid pixels): half a working pixel on a photo at least twice the grid (the
#: area averaging down to it already smooths); 0.25 gave the best IoU of 0.25 / 0.35 / 0.5 on the tests' photos
#: and the auditor's p2_scale photos
DEFAULT_SIGMA_GRID_PX = 0.25

#: default smallest pit kept (flank-grid pixels): a smaller region cannot fill a grid pixel to the 0.5 of the
#: area resampling
DEFAULT_MIN_AREA_GRID_PX = 1.0

#: radius of the opening that removes specks from the dark mask (flank-grid pixels)
OPEN_RADIUS_GRID_PX = 0.5


def _disc(radius: int) -> np.ndarray:
    r = max(int(radius), 1)
    y, x = np.ogrid[-r:r + 1, -r:r + 1]
    return x * x + y * y <= r * r


def extraction_steps(image: str | Path | np.ndarray, grid: FlankGrid, *, crop=None, rot90: int = 0,
                     check_aspect: bool = True,
                     sigma_grid_px: float = DEFAULT_SIGMA_GRID_PX, flatten: str = "rows",
                     background_grid_px: float | None = None,
                     min_area_grid_px: float | None = None) -> ExtractionSteps:
    """Run the extraction and keep every intermediate image.

    Parameters are those of :func:`mask_from_image`. The cropped, rotated
    photo is first area-averaged down to :func:`working_shape` (at most
    :data:`WORK_PER_GRID_PX` working pixels per grid pixel in each direction);
    ``sigma_grid_px``, ``background_grid_px`` and ``min_area_grid_px`` are in
    grid pixels and converted to working pixels per direction.
    """
    require(flatten in FLATTEN_METHODS, "image.flatten", flatten, f"one of: {', '.join(FLATTEN_METHODS)}")
    require(isinstance(rot90, int) and not isinstance(rot90, bool), "image.rot90", rot90, "an integer (quarter turns)")
    require_positive("image.sigma_grid_px", sigma_grid_px)
    if background_grid_px is not None:
        require_positive("image.background_grid_px", background_grid_px)
    require(min_area_grid_px is None or (isinstance(min_area_grid_px, (int, float))
                                         and not isinstance(min_area_grid_px, bool) and min_area_grid_px >= 0),
            "image.min_area_grid_px", min_area_grid_px, "None or a number >= 0 (grid pixels)")
    gray, box = _crop(read_gray(image), crop)
    gray = np.ascontiguousarray(np.rot90(gray, rot90))
    photo_shape = gray.shape
    if check_aspect:
        check_flank_aspect(photo_shape, grid)
    work = working_shape(photo_shape, grid)
    if work != photo_shape:
        gray = cv2.resize(gray, (work[1], work[0]), interpolation=cv2.INTER_AREA)
    # working pixels per grid pixel: along the profile (rows), across the face (columns), and their mean
    k_rows, k_cols = work[0] / grid.n_profile, work[1] / grid.n_face
    k = float(np.sqrt(k_rows * k_cols))
    smooth_raw = cv2.GaussianBlur(gray, (0, 0), sigmaX=sigma_grid_px * k_cols, sigmaY=sigma_grid_px * k_rows,
                                  borderType=cv2.BORDER_REFLECT)

    # gradient of the log image: smooth lighting is nearly invisible, pit outlines are strong
    log_img = np.log(smooth_raw + 0.01)
    gradient = np.hypot(cv2.Sobel(log_img, cv2.CV_64F, 1, 0, ksize=3),
                        cv2.Sobel(log_img, cv2.CV_64F, 0, 1, ksize=3)) / 8.0
    edges = gradient > max(_otsu(gradient), 3 * float(np.median(gradient)))
    # the row fit rejects pits itself and takes every pixel (a streak's steep sides are calm nowhere along a
    # row); the whole-flank fits take the brightest calm region
    if flatten == "rows":   # clipped highlights do not show the lighting
        calm = gray < SATURATED
        # rows crossing the brightest edge-free region start from it (a row more than half pitted is not
        # fitted to its pit floor); the others (a streak's steep sides are edge-free nowhere) from every pixel
        intact = _intact_region(~edges, smooth_raw) & calm
        crossing = np.count_nonzero(intact, axis=1) >= 0.25 * gray.shape[1]
        support = np.where(crossing[:, None], intact, calm)
    else:
        calm = ~edges
        support = _intact_region(calm, smooth_raw)

    min_area_grid = min_area_grid_px if min_area_grid_px is not None else DEFAULT_MIN_AREA_GRID_PX
    min_area = int(round(min_area_grid * k_rows * k_cols))
    bg_px = background_grid_px * k if background_grid_px is not None else 0.25 * min(gray.shape)
    grow = _disc(int(round(2 * sigma_grid_px * k)) + 1)
    open_radius = int(round(OPEN_RADIUS_GRID_PX * k))   # 0 (no opening) on a photo coarser than 1.5x the grid
    for _ in range(2):  # lighting from the intact pixels, then again without the pits found
        if flatten == "rows":
            background = background_rows(gray, support)
        elif flatten == "polynomial":
            background = background_polynomial(gray, support)
        elif flatten == "blur":
            background = background_blur(gray, support, bg_px)
        else:
            background = np.full(gray.shape, max(float(np.median(gray[support])), 1e-3))
        smoothed = smooth_raw / background
        dark, pit = _dark_regions(smoothed, support, min_area, open_radius)
        support = ~ndimage.binary_dilation(pit, grow) & calm
        if not support.any():
            break
    return ExtractionSteps(gray=gray, background=background, flattened=gray / background, smoothed=smoothed,
                           gradient=gradient, dark=dark, edges=edges, mask=pit, crop=box,
                           photo_shape=photo_shape)


def _intact_region(calm: np.ndarray, smooth_raw: np.ndarray) -> np.ndarray:
    """The brightest of the large edge-free regions (at least 20 % of the largest): the intact flank.

    Taking the brightest rather than the largest keeps a flank that is mostly
    pitted (one big dark pit floor) from being read as intact.
    """
    labels, n = ndimage.label(calm)
    if n == 0:
        return np.ones(calm.shape, bool)
    sizes = np.bincount(labels.ravel(), minlength=n + 1)
    sizes[0] = 0
    large = np.flatnonzero(sizes >= 0.2 * sizes.max())
    brightness = ndimage.median(smooth_raw, labels, index=large)
    return labels == int(large[int(np.argmax(brightness))])


def _dark_regions(smoothed: np.ndarray, support: np.ndarray, min_area: int,
                  open_radius: int) -> tuple[np.ndarray, np.ndarray]:
    """Threshold halfway between the intact level and the pit floor, then clean up.

    Halfway is where a blurred step edge crosses, so the pit outline does not
    move with the smoothing. The floor level is the median of the clearly dark
    pixels (at least :data:`MIN_PIT_CONTRAST` below the intact level, less 5
    noise sigmas); with none, there are no pits. The threshold is never above
    ``level (1 - MIN_PIT_CONTRAST) - 4 noise``.
    """
    ref = smoothed[support] if support.any() else smoothed.ravel()
    level = float(np.median(ref))
    for _ in range(5):  # intact level and noise from the bright side (pits in ref only lie below)
        noise = 1.4826 * float(np.median(ref[ref >= level] - level)) + 1e-6
        level = float(np.median(ref[ref > level - 3 * noise]))
    clearly = smoothed < level - 5 * noise
    if np.count_nonzero(clearly) < max(min_area, 1):
        empty = np.zeros(smoothed.shape, bool)
        return empty, empty
    floor = float(np.median(smoothed[clearly]))
    dark = smoothed < min(0.5 * (level + floor), level * (1 - MIN_PIT_CONTRAST) - 4 * noise)
    pit = ndimage.binary_opening(dark, _disc(open_radius)) if open_radius >= 1 else dark
    pit = ndimage.binary_fill_holes(pit)
    return dark, _drop_small(pit, min_area)


def _drop_small(mask: np.ndarray, min_area: int) -> np.ndarray:
    """Remove 8-connected regions with fewer than ``min_area`` pixels."""
    labels, n = ndimage.label(mask, structure=np.ones((3, 3)))
    if n == 0 or min_area <= 1:
        return mask
    sizes = np.bincount(labels.ravel(), minlength=n + 1)
    keep = sizes >= min_area
    keep[0] = False
    return keep[labels]


def _otsu(values: np.ndarray) -> float:
    v = values.ravel()
    return float(threshold_otsu(v)) if v.max() > v.min() else float(v.max())


def resample_mask(mask: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """Resample a boolean mask to ``shape``: area average (or bilinear when enlarging), >= 0.5."""
    require(len(shape) == 2 and min(shape) >= 1, "grid.shape", shape, "(rows, columns) >= 1")
    src = np.asarray(mask, dtype=np.float32)
    if src.shape == tuple(shape):
        return src >= 0.5
    shrinking = shape[0] <= src.shape[0] and shape[1] <= src.shape[1]
    interp = cv2.INTER_AREA if shrinking else cv2.INTER_LINEAR
    return cv2.resize(src, (shape[1], shape[0]), interpolation=interp) >= 0.5


def mask_from_image(image: str | Path | np.ndarray, grid: FlankGrid, *, crop=None, rot90: int = 0,
                    check_aspect: bool = True,
                    sigma_grid_px: float = DEFAULT_SIGMA_GRID_PX, flatten: str = "rows",
                    background_grid_px: float | None = None, min_area_grid_px: float | None = None) -> np.ndarray:
    """Boolean pit mask on ``grid`` from a photo of one flank.

    Parameters
    ----------
    image : path or ndarray
        Photo (any format OpenCV reads) or a gray/BGR array.
    grid : FlankGrid
        Target grid; the (cropped, rotated) photo is stretched onto it.
    crop : None, "auto" or (top, bottom, left, right)
        Flank region in photo pixels (half-open); None keeps the whole photo,
        "auto" takes the bounding box of the bright flank (:func:`flank_crop_box`).
    rot90 : int
        Quarter turns counter-clockwise (``numpy.rot90``) after cropping, so that
        rows run from the start of active profile (top) to the tip and columns
        across the face.
    check_aspect : bool
        Refuse a (cropped, rotated) photo whose height over width is further than
        :data:`MAX_ASPECT_FACTOR` from the flank's (profile length over contact face
        width): a photo turned a quarter, or not cropped to the flank.
    sigma_grid_px : float
        Gaussian smoothing, in flank-grid pixels (per direction), default 0.25.
    flatten : {"rows", "polynomial", "blur", "none"}
        Lighting correction, see the module docstring: ``"rows"`` (default)
        a robust quartic across the face per row; ``"polynomial"`` and
        ``"blur"`` whole-flank fits that read a specular streak's surroundings
        as pits; ``"none"`` only for evenly lit photos.
    background_grid_px : float, optional
        Standard deviation (grid pixels) of the ``"blur"`` background,
        default a quarter of the smaller side; larger than the pits.
    min_area_grid_px : float, optional
        Smallest pit kept, in grid pixels (default 1). The photo is worked at most at twice the grid per direction,
        so a photo coarser than that (fewer pixels than twice the grid) gets
        outlines only as sharp as its own pixels.

    Returns
    -------
    ndarray of bool, shape ``grid.shape``
    """
    steps = extraction_steps(image, grid, crop=crop, rot90=rot90, check_aspect=check_aspect,
                             sigma_grid_px=sigma_grid_px, flatten=flatten,
                             background_grid_px=background_grid_px, min_area_grid_px=min_area_grid_px)
    for text in photo_warnings(steps):
        warnings.warn(PhotoWarning(f"{image if isinstance(image, (str, Path)) else 'photo'}: {text}"), stacklevel=2)
    return resample_mask(steps.mask, grid.shape)


def pit_map_from_image(path: str | Path | np.ndarray, grid: FlankGrid, *, gear: str = "pinion", tooth: int = 0,
                       depth_m: float = DEFAULT_DEPTH_M, crop=None, rot90: int = 0, check_aspect: bool = True,
                       sigma_grid_px: float = DEFAULT_SIGMA_GRID_PX, flatten: str = "rows",
                       background_grid_px: float | None = None, min_area_grid_px: float | None = None) -> PitMap:
    """Pit map with one tooth whose pits are extracted from a photo, at uniform depth ``depth_m`` (m).

    Extraction parameters as in :func:`mask_from_image`.
    """
    require_depth("pits.depth_m", depth_m)
    require(isinstance(tooth, int) and not isinstance(tooth, bool) and tooth >= 0, "pits.tooth", tooth,
            "an integer >= 0")
    mask = mask_from_image(path, grid, crop=crop, rot90=rot90, check_aspect=check_aspect,
                           sigma_grid_px=sigma_grid_px, flatten=flatten,
                           background_grid_px=background_grid_px, min_area_grid_px=min_area_grid_px)
    return PitMap(grid=grid, depth_m={tooth: np.where(mask, depth_m, 0.0)}, gear=gear)
