"""Pit maps on disk: PNG images a user can paint, and compressed NPZ archives.

PNG: one grayscale image per tooth, rows = profile (row 0 = start of active
profile), columns = face, exactly the flank grid's shape.

- 16-bit PNG: pixel value = pit depth in micrometres (0 = intact), so depths
  round-trip to 1 um (a pitted pixel shallower than 1 um is stored as 1 um so it
  stays pitted); written by :func:`write_depth_png` / :func:`save_pit_pngs`.
- 8-bit or 1-bit PNG (gray or colour, e.g. painted by hand): a mask; pixels with
  gray value >= 128 (white) are pits of depth ``default_depth_m``, or the dark
  ones with ``invert=True``.

One tooth from one PNG: :func:`load_mask_png`; a directory of ``tooth_NNN.png``
files: :func:`save_pit_pngs` / :func:`load_pit_pngs`, with a JSON sidecar ``pitmap.json`` holding the
pair name, the gear and the grid (refused on load if they differ; a directory without it is read with a
warning that gear and grid could not be checked).

NPZ (:func:`save_npz`, :func:`load_npz`): a compressed archive with the grid
fields, the gear, the tooth indices and the depth arrays (m) in float64, so a
pit map round-trips exactly. Keys: ``format`` (``"gearpit.pitmap/1"``),
``n_profile``, ``n_face``, ``profile_length_m``, ``face_width_m``,
``pitch_s_m``, ``contact_face_width_m`` (the active band; absent in older files,
read as the whole face), ``gear``, ``teeth`` (k,), ``depth_m`` (k, n_profile, n_face).

Every write is atomic (:func:`gearpit.atomic.atomic_path`).
"""
from __future__ import annotations

import json
import re
import warnings
import zipfile
from pathlib import Path

import cv2
import numpy as np

from datagen.flank import FlankGrid, PitMap
from datagen.pitshapes import DEFAULT_DEPTH_M, require_depth
from gearpit.atomic import atomic_path
from gearpit.errors import InputError, require

NPZ_FORMAT = "gearpit.pitmap/1"
_TOOTH_PNG = re.compile(r"^tooth_(\d+)\.png$")
_UM = 1e-6
_MAX_UM = np.iinfo(np.uint16).max


def tooth_png_name(tooth: int) -> str:
    """File name of one tooth's PNG in a pit-map directory: ``tooth_007.png``."""
    return f"tooth_{int(tooth):03d}.png"


def write_depth_png(path: str | Path, depth_m: np.ndarray) -> Path:
    """Write one depth map (m) as a 16-bit grayscale PNG in micrometres."""
    d = np.asarray(depth_m, dtype=np.float64)
    require(d.ndim == 2, "png.depth_m.shape", d.shape, "a 2-D array (profile rows, face columns)")
    require(bool(np.all(np.isfinite(d))) and bool(np.all(d >= 0)), "png.depth_m", "negative or non-finite values",
            "finite depths >= 0 m")
    require(float(d.max(initial=0.0)) <= _MAX_UM * _UM, "png.depth_m", float(d.max(initial=0.0)),
            f"depths <= {_MAX_UM} um (16-bit PNG in micrometres)")
    um = np.where(d > 0, np.maximum(np.rint(d / _UM), 1), 0).astype(np.uint16)
    ok, buf = cv2.imencode(".png", um)
    if not ok:  # pragma: no cover - OpenCV always encodes uint16 gray PNG
        raise InputError("png", str(path), "an image OpenCV can encode")
    target = Path(path)
    with atomic_path(target) as tmp:
        tmp.write_bytes(buf.tobytes())
    return target


def read_depth_png(path: str | Path, grid: FlankGrid, *, default_depth_m: float = DEFAULT_DEPTH_M,
                   invert: bool = False) -> np.ndarray:
    """Depth map (m) of one tooth from a PNG (see the module docstring for the two kinds).

    Parameters
    ----------
    path : path
    grid : FlankGrid
        The image must have exactly ``grid.shape`` (rows = profile, columns = face).
    default_depth_m : float
        Depth (m) given to the pits of an 8-/1-bit mask image, in :data:`datagen.pitshapes.DEPTH_RANGE_M`.
    invert : bool
        For a mask image: dark pixels (< 128) are the pits.

    Raises
    ------
    InputError
        Unreadable file, wrong shape, or an unsupported pixel type.
    """
    require_depth("png.default_depth_m", default_depth_m)
    img = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    if img is None:
        raise InputError("png", str(path), "a readable PNG file")
    if img.ndim == 3:
        img = cv2.cvtColor(img[:, :, :3], cv2.COLOR_BGR2GRAY)
    if img.shape != grid.shape:
        raise InputError(f"png.shape ({Path(path).name})", img.shape,
                         f"the flank grid shape {grid.shape} (rows = profile, columns = face)")
    if img.dtype == np.uint16:
        deepest_um = int(img.max(initial=0))
        if deepest_um > 0:      # the deepest pixel, in the image's own unit (um)
            require_depth(f"png.depth ({Path(path).name}, deepest pixel)", deepest_um, "um")
        return img.astype(np.float64) * _UM
    require(img.dtype == np.uint8, f"png.dtype ({Path(path).name})", str(img.dtype),
            "8-bit (mask) or 16-bit (depth in um) grayscale")
    pit = img < 128 if invert else img >= 128
    return np.where(pit, float(default_depth_m), 0.0)


def load_mask_png(path: str | Path, grid: FlankGrid, *, gear: str = "pinion", tooth: int = 0,
                  depth_m: float = DEFAULT_DEPTH_M, invert: bool = False) -> PitMap:
    """Pit map with one tooth read from one PNG (16-bit depth in um, or a painted mask at ``depth_m``).

    See :func:`read_depth_png`; ``depth_m`` (m) is only used for 8-/1-bit masks.
    """
    require(isinstance(tooth, (int, np.integer)) and not isinstance(tooth, bool) and tooth >= 0, "pits.tooth",
            tooth, "an integer >= 0")
    depth = read_depth_png(path, grid, default_depth_m=depth_m, invert=invert)
    return PitMap(grid=grid, depth_m={int(tooth): depth}, gear=gear)


#: sidecar of a pit-map PNG directory: the gear and the grid the tooth images were drawn on
PNG_SIDECAR = "pitmap.json"
PNG_SIDECAR_FORMAT = "gearpit.pitmap-png/1"
#: grid fields the sidecar stores (FlankGrid fields in m, plus the pixel sizes ds_m / dw_m they imply)
_GRID_INT = ("n_profile", "n_face")
_GRID_M = ("profile_length_m", "face_width_m", "pitch_s_m", "contact_face_width_m", "ds_m", "dw_m")
_SIDECAR_KEYS = {"format", "pair", "gear", *_GRID_INT, *_GRID_M}


def _sidecar(pit_map: PitMap, pair_name: str | None) -> dict:
    g = pit_map.grid
    return {"format": PNG_SIDECAR_FORMAT, "pair": pair_name, "gear": pit_map.gear,
            **{k: int(getattr(g, k)) for k in _GRID_INT}, **{k: float(getattr(g, k)) for k in _GRID_M}}


def save_pit_pngs(pit_map: PitMap, directory: str | Path, *, pair_name: str | None = None) -> list[Path]:
    """Write one 16-bit depth PNG per tooth of ``pit_map`` (``tooth_007.png``, ...) into ``directory``, and the
    sidecar :data:`PNG_SIDECAR` (JSON: ``pair_name`` if given, the gear, and the grid: ``n_profile``, ``n_face``,
    ``profile_length_m``, ``face_width_m``, ``pitch_s_m``, ``contact_face_width_m``, ``ds_m``, ``dw_m``), which
    :func:`load_pit_pngs` checks. Returns the tooth PNGs' paths."""
    require(not pit_map.coverage, "pits.coverage", f"sub-pixel shares on teeth {sorted(pit_map.coverage)}",
            "none: a depth PNG holds whole pixels only; write a map with sub-pixel outlines with save_npz")
    out = Path(directory)
    paths = [write_depth_png(out / tooth_png_name(t), d) for t, d in sorted(pit_map.depth_m.items())]
    out.mkdir(parents=True, exist_ok=True)
    with atomic_path(out / PNG_SIDECAR) as tmp:
        tmp.write_text(json.dumps(_sidecar(pit_map, pair_name), indent=2))
    return paths


def _read_sidecar(path: Path) -> dict:
    try:
        meta = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        raise InputError(PNG_SIDECAR, str(path), f"a readable JSON sidecar written by save_pit_pngs ({exc})") from None
    require(isinstance(meta, dict), PNG_SIDECAR, type(meta).__name__, "a JSON object")
    require(meta.get("format") == PNG_SIDECAR_FORMAT, f"{PNG_SIDECAR}.format", meta.get("format"),
            PNG_SIDECAR_FORMAT)
    require(set(meta) == _SIDECAR_KEYS, f"{PNG_SIDECAR} keys", sorted(meta), f"exactly: {', '.join(sorted(_SIDECAR_KEYS))}")
    return meta


def _check_sidecar(meta: dict, grid: FlankGrid, gear: str | None, pair_name: str | None, where: str) -> None:
    """Refuse a directory whose stored gear, pair or grid differs from the one it is loaded onto."""
    if gear is not None:
        require(meta["gear"] == gear, f"{PNG_SIDECAR}.gear", meta["gear"],
                f"the gear the map is loaded for ({gear}); {where} holds a {meta['gear']} pit map")
    if pair_name is not None and meta["pair"] is not None:
        require(meta["pair"] == pair_name, f"{PNG_SIDECAR}.pair", meta["pair"],
                f"the pair the map is loaded onto ({pair_name}); {where} was drawn on another pair")
    for k in _GRID_INT:
        require(meta[k] == getattr(grid, k), f"{PNG_SIDECAR}.{k}", meta[k],
                f"the grid's {k} = {getattr(grid, k)} ({where} was drawn on another grid)")
    for k in _GRID_M:
        want = float(getattr(grid, k))
        ok = isinstance(meta[k], (int, float)) and abs(meta[k] - want) <= 1e-9 * abs(want)
        require(ok, f"{PNG_SIDECAR}.{k}", meta[k],
                f"the grid's {k} = {want:.9g} m, within 1e-9 relative ({where} was drawn on another grid)")


def load_pit_pngs(directory: str | Path, grid: FlankGrid, *, gear: str | None = None, pair_name: str | None = None,
                  default_depth_m: float = DEFAULT_DEPTH_M, invert: bool = False) -> PitMap:
    """Pit map from the ``tooth_NNN.png`` files of a directory (see :func:`read_depth_png`).

    The directory's sidecar :data:`PNG_SIDECAR` must agree with ``grid`` (every stored grid field), with ``gear``
    and with ``pair_name`` when these are given; otherwise InputError names the field. ``gear`` None takes the
    sidecar's gear. A directory without a sidecar (written before it existed, or painted by hand) is read as
    before, on ``grid`` and as ``gear`` (default pinion), with a UserWarning that gear and grid were not checked.
    """
    d = Path(directory)
    require(d.is_dir(), "pits.directory", str(d), "an existing directory of tooth_NNN.png files")
    files = {int(m.group(1)): p for p in sorted(d.iterdir()) if (m := _TOOTH_PNG.match(p.name))}
    require(len(files) > 0, "pits.directory", str(d), "a directory holding tooth_NNN.png files")
    if (d / PNG_SIDECAR).is_file():
        meta = _read_sidecar(d / PNG_SIDECAR)
        _check_sidecar(meta, grid, gear, pair_name, str(d))
        gear = meta["gear"]
    else:
        gear = "pinion" if gear is None else gear
        warnings.warn(f"{d}: no {PNG_SIDECAR}, so the gear and grid the tooth PNGs were drawn on could not be checked; "
                      f"read as {gear} teeth on the given {grid.n_profile}x{grid.n_face} grid", UserWarning,
                      stacklevel=2)
    depth = {t: read_depth_png(p, grid, default_depth_m=default_depth_m, invert=invert) for t, p in files.items()}
    return PitMap(grid=grid, depth_m=depth, gear=gear)


def save_npz(pit_map: PitMap, path: str | Path) -> Path:
    """Write a pit map with its grid to a compressed NPZ archive (exact round trip; the sub-pixel shares of
    :attr:`datagen.flank.PitMap.coverage`, when the map has them, as ``coverage_teeth`` and ``coverage``)."""
    teeth = sorted(pit_map.depth_m)
    g = pit_map.grid
    stack = (np.stack([pit_map.depth_m[t] for t in teeth]) if teeth
             else np.zeros((0,) + g.shape, dtype=np.float64))
    target = Path(path)
    with atomic_path(target) as tmp:
        with open(tmp, "wb") as fh:
            np.savez_compressed(fh, format=np.array(NPZ_FORMAT), n_profile=np.int64(g.n_profile),
                                n_face=np.int64(g.n_face), profile_length_m=np.float64(g.profile_length_m),
                                face_width_m=np.float64(g.face_width_m), pitch_s_m=np.float64(g.pitch_s_m),
                                contact_face_width_m=np.float64(g.contact_face_width_m),
                                gear=np.array(pit_map.gear), teeth=np.asarray(teeth, dtype=np.int64),
                                depth_m=stack.astype(np.float64), **_coverage_arrays(pit_map))
    return target


def _coverage_arrays(pit_map: PitMap) -> dict:
    if not pit_map.coverage:
        return {}
    teeth = sorted(pit_map.coverage)
    return {"coverage_teeth": np.asarray(teeth, dtype=np.int64),
            "coverage": np.stack([pit_map.coverage[t] for t in teeth]).astype(np.float64)}


def _npz_scalar(data: dict, key: str, name: str, kind: str):
    """One scalar field of a pit-map NPZ as ``int``, ``float`` or ``str``; anything else raises InputError."""
    v = data[key]
    allowed = {"int": "a single integer (0-d array)", "float": "a single number (0-d array)",
               "str": "a single string (0-d array)"}[kind]
    if v.ndim != 0:
        raise InputError(f"npz.{key}", f"an array of shape {v.shape} in {name}", allowed)
    if kind == "str":
        require(v.dtype.kind == "U", f"npz.{key}", v.item(), allowed)
        return str(v)
    require(v.dtype.kind in "iuf" and bool(np.isfinite(v)), f"npz.{key}", v.item(), allowed)
    if kind == "int":
        require(float(v) == int(v), f"npz.{key}", v.item(), allowed)
        return int(v)
    return float(v)


def _npz_teeth(teeth: np.ndarray) -> list[int]:
    """Tooth indices of a pit-map NPZ: integers >= 0, each once (a float or repeated tooth is refused by name)."""
    require(teeth.ndim == 1 and (teeth.dtype.kind in "iuf" or teeth.size == 0), "npz.teeth",
            f"an array of shape {teeth.shape}, dtype {teeth.dtype}", "a 1-D array of integer tooth indices")
    out = []
    for t in teeth.tolist():
        require(float(t) == int(t) and t >= 0, "npz.teeth", t, "integer tooth indices >= 0 (tooth "
                f"{t!r} is not one; the archive would otherwise put its depths on tooth {int(t)})")
        require(int(t) not in out, "npz.teeth", int(t),
                f"each tooth once (tooth {int(t)} appears {teeth.tolist().count(t)} times; its depth maps would be "
                f"merged)")
        out.append(int(t))
    return out


def load_npz(path: str | Path) -> PitMap:
    """Read a pit map written by :func:`save_npz`.

    Raises
    ------
    InputError
        Not a pit-map NPZ archive (a ``.npy`` file, a truncated or pickled one), a missing key, a non-scalar grid
        field, a non-integer or repeated tooth, a wrong depth shape, or a tooth whose deepest pixel lies outside
        :data:`datagen.pitshapes.DEPTH_RANGE_M` (1 um .. 5 mm; e.g. depths written in mm as if in m).
    """
    p = Path(path)
    try:
        z = np.load(p, allow_pickle=False)
        if not isinstance(z, np.lib.npyio.NpzFile):
            raise InputError("npz", str(p), f"a gearpit pit-map NPZ archive (this is a .npy file holding one bare "
                             f"{type(z).__name__} of shape {getattr(z, 'shape', ())}, without the grid, gear and "
                             f"teeth; write pit maps with datagen.pitio.save_npz)")
        with z:
            data = {k: z[k] for k in z.files}
    except (OSError, ValueError, EOFError, zipfile.BadZipFile) as exc:
        if isinstance(exc, InputError):
            raise
        raise InputError("npz", str(p), f"a readable gearpit pit-map NPZ ({exc})") from None
    keys = ("format", "n_profile", "n_face", "profile_length_m", "face_width_m", "pitch_s_m", "gear", "teeth",
            "depth_m")
    for key in keys:
        require(key in data, f"npz.{key}", None, f"present in {p.name} (keys: {', '.join(keys)})")
    fmt = _npz_scalar(data, "format", p.name, "str")
    require(fmt == NPZ_FORMAT, "npz.format", fmt, NPZ_FORMAT)
    num = {k: _npz_scalar(data, k, p.name, "int") for k in ("n_profile", "n_face")}
    num.update({k: _npz_scalar(data, k, p.name, "float")
                for k in ("profile_length_m", "face_width_m", "pitch_s_m", "contact_face_width_m") if k in data})
    grid = FlankGrid(**num)
    gear = _npz_scalar(data, "gear", p.name, "str")
    teeth, depth = _npz_teeth(data["teeth"]), data["depth_m"]
    expected = (len(teeth),) + grid.shape
    if depth.shape != expected:
        raise InputError("npz.depth_m.shape", depth.shape, f"{expected} (teeth, profile rows, face columns)")
    for i, t in enumerate(teeth):
        deepest = float(np.max(depth[i], initial=0.0))
        if deepest > 0:     # the same range every other entry point enforces (PNGs, masks, photos, pit tables)
            require_depth(f"npz.depth_m (tooth {t}, deepest pixel)", deepest)
    coverage = {}
    if "coverage_teeth" in data or "coverage" in data:
        require("coverage_teeth" in data and "coverage" in data, "npz.coverage", sorted(data),
                "both coverage_teeth and coverage, or neither")
        c_teeth, c = _npz_teeth(data["coverage_teeth"]), data["coverage"]
        if c.shape != (len(c_teeth),) + grid.shape:
            raise InputError("npz.coverage.shape", c.shape, f"{(len(c_teeth),) + grid.shape} (teeth, rows, columns)")
        coverage = {t: c[i] for i, t in enumerate(c_teeth)}
    return PitMap(grid=grid, depth_m={t: depth[i] for i, t in enumerate(teeth)}, gear=gear, coverage=coverage)
