"""The flank pixel grid and the pit-depth maps that live on it.

A flank is an image: rows are the profile position ``s`` (involute arc length,
m) from the start of the active profile (row 0) to the tip (last row); columns
are the face position ``w`` (m) from one face edge (column 0) to the other.
Rows are uniform in arc length, so every pixel has the same area.

The active flank is where the tooth can touch its mate: from the start of the
active profile to the tip (all rows), across the contact face width (the
narrower gear's face, centred on the wider one, as in
:mod:`datagen.pit_stiffness`). On the wider gear of a pair with unequal face
widths the columns outside that band never make contact. The severity (pitted
area / active flank area) is the pitted fraction of the pixels of the active
band (:attr:`FlankGrid.active_cols`: the columns whose centre lies in it); pits
a user's map or photo puts in the non-contact strips are kept but do not count
(nor do they change the mesh stiffness). With equal face widths every column is
active.

A pit map holds, per pitted tooth, the pit depth (m) of every pixel; 0 means
intact. Depth matters to the stiffness (section loss), the boolean mask to the
contact. A map may also say which share of a pitted pixel's area the pit covers
(``coverage``: a pit outline drawn with sub-pixel edges, :func:`datagen.pitshapes.subpixel_pit`);
a pixel without one is pitted over its whole area. The severity then counts each
pixel by its share, and the contact of a partly pitted pixel keeps its intact
share (:mod:`datagen.pit_stiffness`), so a pit's record moves continuously with
its size instead of in whole-pixel steps.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from gearpit.errors import InputError, require, require_positive

GEARS = ("pinion", "wheel")


@dataclass(frozen=True)
class FlankGrid:
    """Pixel grid of one gear's active flank.

    Parameters
    ----------
    n_profile : int
        Rows, along the profile from the start of active profile (row 0) to the tip.
    n_face : int
        Columns, across the face width.
    profile_length_m : float
        Involute arc length from the start of active profile to the tip (m).
    face_width_m : float
        Face width of this gear (m).
    pitch_s_m : float
        Arc length from the start of active profile to the pitch circle (m);
        where real pitting starts.
    contact_face_width_m : float, optional
        Face width in contact with the mate (m), centred on this gear's face;
        default (None) the whole face width.
    """

    n_profile: int
    n_face: int
    profile_length_m: float
    face_width_m: float
    pitch_s_m: float
    contact_face_width_m: float | None = None

    def __post_init__(self):
        for name in ("n_profile", "n_face"):
            v = getattr(self, name)
            require(isinstance(v, (int, np.integer)) and 2 <= v <= 20000, f"grid.{name}", v, "an integer in [2, 20000]")
        require_positive("grid.profile_length_m", self.profile_length_m)
        require_positive("grid.face_width_m", self.face_width_m)
        require(0 <= self.pitch_s_m <= self.profile_length_m, "grid.pitch_s_m", self.pitch_s_m,
                f"within the profile [0, {self.profile_length_m}] m")
        if self.contact_face_width_m is None:
            object.__setattr__(self, "contact_face_width_m", self.face_width_m)
        require_positive("grid.contact_face_width_m", self.contact_face_width_m)
        require(self.contact_face_width_m <= self.face_width_m * (1 + 1e-12), "grid.contact_face_width_m",
                self.contact_face_width_m, f"at most the face width {self.face_width_m} m")
        cols = self.active_cols
        require(cols.stop > cols.start, "grid.n_face", self.n_face,
                f"enough columns that at least one centre lies in the contact band of "
                f"{self.contact_face_width_m * 1e3:.4g} mm")

    @property
    def shape(self) -> tuple[int, int]:
        return (self.n_profile, self.n_face)

    @property
    def ds_m(self) -> float:
        """Pixel height along the profile (m)."""
        return self.profile_length_m / self.n_profile

    @property
    def dw_m(self) -> float:
        """Pixel width across the face (m)."""
        return self.face_width_m / self.n_face

    @property
    def pixel_area_m2(self) -> float:
        return self.ds_m * self.dw_m

    @property
    def contact_offset_m(self) -> float:
        """Face position where the contact band starts (m): ``(face_width_m - contact_face_width_m) / 2``."""
        return (self.face_width_m - self.contact_face_width_m) / 2.0

    @property
    def active_cols(self) -> slice:
        """Columns of the active flank: those whose centre lies in the contact band (all with equal widths); a
        centre on the band's edge counts on both sides (to 1e-9 of a column: the last bit of a width read from a
        file used to decide it, and on one side only)."""
        if self.contact_face_width_m >= self.face_width_m:
            return slice(0, self.n_face)
        lo, hi = self.contact_offset_m / self.dw_m, (self.contact_offset_m + self.contact_face_width_m) / self.dw_m
        c0 = max(0, math.ceil(lo - 0.5 - 1e-9))
        c1 = min(self.n_face, math.floor(hi - 0.5 + 1e-9) + 1)
        return slice(c0, max(c0, c1))

    @property
    def n_active_cols(self) -> int:
        return self.active_cols.stop - self.active_cols.start

    @property
    def n_active_pixels(self) -> int:
        """Pixels of the active flank (the severity's denominator)."""
        return self.n_profile * self.n_active_cols

    def severity_of(self, mask: np.ndarray) -> float:
        """Pitted fraction of the active flank: pitted pixels of the active columns / their pixels."""
        return np.count_nonzero(np.asarray(mask)[:, self.active_cols]) / self.n_active_pixels

    @property
    def s_centres_m(self) -> np.ndarray:
        """Profile position of each row centre (m)."""
        return (np.arange(self.n_profile) + 0.5) * self.ds_m

    @property
    def w_centres_m(self) -> np.ndarray:
        """Face position of each column centre (m)."""
        return (np.arange(self.n_face) + 0.5) * self.dw_m


@dataclass(frozen=True, eq=False)
class PitMap:
    """Pit depths on the teeth of one gear.

    Parameters
    ----------
    grid : FlankGrid
        The flank grid every depth map lives on.
    depth_m : dict[int, ndarray]
        Tooth index -> pit depth (m) per pixel, shape ``grid.shape``; 0 = intact.
        Teeth are numbered in the order they come into mesh, tooth 0 first.
    gear : {"pinion", "wheel"}
        Which gear carries the pits.
    coverage : dict[int, ndarray], optional
        Tooth -> pitted share of each pixel's area, in (0, 1] where the depth is > 0 and 0 elsewhere (sub-pixel
        pit edges); a tooth without an entry is pitted over the whole area of its pitted pixels.
    """

    grid: FlankGrid
    depth_m: dict[int, np.ndarray] = field(default_factory=dict)
    gear: str = "pinion"
    coverage: dict[int, np.ndarray] = field(default_factory=dict)

    def __post_init__(self):
        require(self.gear in GEARS, "pits.gear", self.gear, "one of: pinion, wheel")
        clean = {}
        for tooth, d in self.depth_m.items():
            require(isinstance(tooth, (int, np.integer)) and tooth >= 0, "pits.tooth", tooth, "an integer >= 0")
            arr = np.asarray(d, dtype=np.float64)
            if arr.shape != self.grid.shape:
                raise InputError(f"pits.tooth[{tooth}].shape", arr.shape, f"the flank grid shape {self.grid.shape}")
            require(bool(np.all(np.isfinite(arr))) and bool(np.all(arr >= 0)), f"pits.tooth[{tooth}].depth_m",
                    "negative or non-finite values", "finite depths >= 0 m")
            clean[int(tooth)] = arr
        object.__setattr__(self, "depth_m", clean)
        shares = {}
        for tooth, c in self.coverage.items():
            require(tooth in clean, "pits.coverage.tooth", tooth, f"a tooth of depth_m ({sorted(clean)})")
            arr = np.asarray(c, dtype=np.float64)
            if arr.shape != self.grid.shape:
                raise InputError(f"pits.coverage[{tooth}].shape", arr.shape, f"the flank grid shape {self.grid.shape}")
            pitted = clean[int(tooth)] > 0
            ok = (bool(np.all(np.isfinite(arr))) and bool(np.all(arr[~pitted] == 0.0))
                  and bool(np.all((arr[pitted] > 0.0) & (arr[pitted] <= 1.0))))
            require(ok, f"pits.coverage[{tooth}]", "shares outside their range",
                    "a share in (0, 1] on every pixel with a depth > 0, and 0 on the others")
            shares[int(tooth)] = arr
        object.__setattr__(self, "coverage", shares)

    @property
    def pitted_teeth(self) -> list[int]:
        """Teeth with at least one pitted pixel, sorted."""
        return sorted(t for t, d in self.depth_m.items() if np.any(d > 0))

    def mask(self, tooth: int) -> np.ndarray:
        """Boolean pit mask of one tooth (all False for an intact tooth)."""
        d = self.depth_m.get(tooth)
        return np.zeros(self.grid.shape, bool) if d is None else d > 0

    def share(self, tooth: int) -> np.ndarray:
        """Pitted share of each pixel's area of one tooth (the mask as 0/1 where the map has no coverage)."""
        c = self.coverage.get(tooth)
        return self.mask(tooth).astype(np.float64) if c is None else c

    def severity(self, tooth: int) -> float:
        """Pitted area / active flank area of one tooth (pits outside the contact band do not count; a partly
        pitted pixel counts by its share)."""
        return float(self.share(tooth)[:, self.grid.active_cols].sum() / self.grid.n_active_pixels)

    def severities(self) -> dict[int, float]:
        return {t: self.severity(t) for t in self.pitted_teeth}

    @classmethod
    def healthy(cls, grid: FlankGrid, gear: str = "pinion") -> "PitMap":
        return cls(grid=grid, depth_m={}, gear=gear)
