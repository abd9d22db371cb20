"""Reading a flank photo and checking that it can be one (:mod:`datagen.photo` extracts the pits).

:func:`read_gray` reads 8/16-bit gray or colour files (EXIF orientation applied; a truncated JPEG refused) or
arrays into [0, 1]; :func:`check_flank_aspect` refuses a photo whose proportions cannot be the flank's (turned a
quarter, not cropped); :func:`photo_warnings` says when an image is unlike a lit flank (:class:`PhotoWarning`).
"""
from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from datagen.flank import FlankGrid
from gearpit.errors import InputError, require

def read_gray(image: str | Path | np.ndarray) -> np.ndarray:
    """Grayscale image in [0, 1] (float64) from a file or an array.

    Accepts 8- or 16-bit, gray, BGR or BGRA images (alpha ignored), or a 2-D
    float array already in [0, 1]. An unreadable file, or a JPEG cut short
    (no end-of-image marker in its last 4 kB), raises InputError naming it.
    """
    if isinstance(image, (str, Path)):
        require(not (Path(image).is_file() and _truncated_jpeg(Path(image))), "image", str(image),
                "a complete JPEG (this one ends before its end-of-image marker: truncated or corrupt)")
        # ANYCOLOR | ANYDEPTH: 8- or 16-bit, gray or colour, turned as the camera's EXIF orientation says (a
        # phone's portrait photo is stored sideways with an orientation tag; IMREAD_UNCHANGED ignores the tag)
        arr = cv2.imread(str(image), cv2.IMREAD_ANYCOLOR | cv2.IMREAD_ANYDEPTH)
        if arr is None:
            raise InputError("image", str(image), "a readable image file (PNG, JPEG, TIFF, BMP)")
    else:
        arr = np.asarray(image)
    require(arr.ndim in (2, 3) and min(arr.shape[:2]) >= 8, "image.shape", arr.shape,
            "a 2-D gray or 3-D colour image at least 8 x 8 pixels")
    if arr.ndim == 3:
        require(arr.shape[2] in (3, 4), "image.channels", arr.shape[2], "3 (BGR) or 4 (BGRA)")
        arr = cv2.cvtColor(arr[:, :, :3], cv2.COLOR_BGR2GRAY)
    if arr.dtype == np.uint8:
        return arr.astype(np.float64) / 255.0
    if arr.dtype == np.uint16:
        return arr.astype(np.float64) / 65535.0
    if arr.dtype == bool:
        return arr.astype(np.float64)
    out = arr.astype(np.float64)
    require(bool(np.all(np.isfinite(out))) and out.min() >= 0 and out.max() <= 1, "image.values",
            f"{out.dtype} in [{out.min():g}, {out.max():g}]", "uint8, uint16, or floats in [0, 1]")
    return out


def _truncated_jpeg(path: Path) -> bool:
    """True for a JPEG without its end-of-image marker (FF D9) near the end: OpenCV decodes such a file,
    filling the missing part with grey, and only prints "Premature end of JPEG file"."""
    with open(path, "rb") as f:
        if f.read(2) != b"\xff\xd8":
            return False
        f.seek(0, 2)
        f.seek(max(f.tell() - 4096, 0))
        return b"\xff\xd9" not in f.read()


class PhotoWarning(UserWarning):
    """A photo that does not look like a lit flank (:func:`photo_warnings`): its mask says little."""


#: :func:`photo_warnings`: the intact surface's level (fraction of full scale) below which the photo is too dark or
#: mostly background, its noise (robust sigma over that level) above which no pit (5 % + 4 sigma darker) can be
#: told from it, and the 1-99 % range below which the image holds no contrast at all
MIN_LIT_LEVEL = 0.2
MAX_RELATIVE_NOISE = 0.2
MIN_RANGE = 0.02


def photo_warnings(steps) -> list[str]:
    """What makes a photo unlike a lit flank, one sentence each (empty for a usable photo); ``steps`` a
    :class:`datagen.photo.ExtractionSteps`. Measured on an
    auditor's images: rendered flank photos (pitted, pit-free, with rust) have an intact level 0.72-0.73 and a
    noise 0.037-0.040; a uniform image has no range; random noise 0.74 and a checkerboard 0.74 of noise; a dark
    image 0.26; a page of text and an uncropped scene photo (a flank on a dark background) a level of 0.16 and
    0.13. Each gave severity 0 (the scene 0.12) without a word."""
    out = []
    g = steps.gray
    p1, p99 = np.percentile(g, [1, 99])
    if p99 - p1 < MIN_RANGE:
        return [f"no contrast (1-99 % range {p99 - p1:.3g} of full scale): a uniform image, not a flank photo"]
    intact = ~steps.mask
    lit = float(np.median(g[intact])) if intact.any() else 0.0
    if lit < MIN_LIT_LEVEL:
        out.append(f"the intact surface's level is {lit:.2f} of full scale (below {MIN_LIT_LEVEL}): an underexposed "
                   "photo, or one mostly of background (crop it to the flank: --photo-crop)")
    flat = steps.flattened[intact] if intact.any() else steps.flattened.ravel()
    noise = 1.4826 * float(np.median(np.abs(flat - np.median(flat))))
    if noise > MAX_RELATIVE_NOISE:
        out.append(f"the surface's noise is {noise:.2f} of its level (above {MAX_RELATIVE_NOISE}): pits, at least 5 % "
                   "plus 4 noise sigmas darker, cannot be told from it (not a flank photo, or far too noisy)")
    return out


#: a photo's height / width may differ from the flank's (profile length / contact face width) by this factor
#: either way (a loose crop, a photo stretched to the grid's pixel shape); a photo turned a quarter is off by the
#: square of the flank's aspect (30x for spur-gds's 3.6 x 20 mm flank)
MAX_ASPECT_FACTOR = 4.0


def check_flank_aspect(photo_shape: tuple, grid: FlankGrid) -> None:
    """Refuse a photo whose shape cannot be the flank's (:data:`MAX_ASPECT_FACTOR`), naming both aspects and
    the remedies (rot90 / --photo-rot90, crop / --photo-crop, check_aspect=False / --photo-any-aspect)."""
    width = grid.contact_face_width_m or grid.face_width_m
    flank = grid.profile_length_m / width
    photo = photo_shape[0] / photo_shape[1]
    factor = max(photo / flank, flank / photo)
    require(factor <= MAX_ASPECT_FACTOR, "image.aspect",
            f"{photo_shape[0]} x {photo_shape[1]} px (height / width {photo:.3g})",
            f"a flank's proportions: profile (rows, start of active profile at the top) over face width "
            f"(columns) {flank:.3g}, within a factor {MAX_ASPECT_FACTOR:g}; a photo turned a quarter needs rot90 = 1 "
            "(--photo-rot90 1), a photo of more than the flank a crop (--photo-crop), or check_aspect=False "
            "(--photo-any-aspect) when its proportions are known to differ")
