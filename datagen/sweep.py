"""Dataset sweep configuration: what to generate, read from TOML and checked before any work.

A sweep is the cross product of gear pairs x severity bins x pitted-teeth
classes x pit shape families (the *class grid*, :mod:`datagen.class_grid`),
with ``samples_per_class`` samples in every class, and per-sample ranges for
the operating point, the pit details and the nuisance physics (effects and
drive train). Every range is drawn per sample by :mod:`datagen.sampling`.

TOML layout (units in key names; every table and key is checked, unknown keys
are errors)::

    [sweep]
    name = "small"
    seed = 7
    samples_per_class = 4
    shard_size = 16                     # samples per stored shard (and per simulate batch)
    fs_hz = 12800.0
    duration_s = 1.0
    pairs = ["spur-gds"]                # preset names or {preset = ..., ...} tables
    channels = ["acc_pinion_loa_m_s2"]  # stored signal channels
    healthy_reference = false           # also store each sample's healthy twin (channels "<name>@reference")
    plugins = ["my_effects.py"]         # optional: user effect files (relative to this file); [effects.NAME] may use them

    [classes]
    shapes = ["ellipse", "rectangle", "cluster"]
    teeth = ["0", "1", "2", "3+"]       # "k" exactly k teeth, "k+" k .. max_pitted_teeth
    max_pitted_teeth = 4
    [classes.severity_bins]             # pitted fraction of one flank, [min, max)
    healthy = [0.0, 0.0]                # the healthy bin: exactly [0, 0]
    minor = [0.02, 0.08]
    moderate = [0.08, 0.16]
    severe = [0.16, 0.30]

    [pits]
    gear = "pinion"
    grid_px = [73, 200]                 # flank pixels (profile x face)
    depth_mm = [0.1, 0.3]                # within [0.001, 5] (datagen.pits.DEPTH_RANGE_M)
    aspect_w_to_s = [2.0, 6.0]          # optional (default: the flank's proportions)
    profiles = ["flat", "bowl"]

    [operating]
    speed_rpm = [600.0, 1800.0]
    torque_nm = [20.0, 100.0]

    [effects.noise]                     # any registered effect; its field names (SI)
    snr_db = [10.0, 40.0]
    [effects.transmission_path]
    housing_frequency_hz = [2000.0, 6000.0]

    [drive_train]                       # fields of datagen.lumped_model.DriveTrain
    mesh_damping_ratio = [0.03, 0.10]

    [stiffness]                         # optional, fixed: datagen.case_options.StiffnessOptions
    positions_per_cycle = "auto"        # the default (chosen by the band); 64 with edges = "point" is the
    edges = "box"                       # record of datasets made before commit d1b9c53

A value is fixed (``x``), a uniform range (``[lo, hi]``, integers for integer
fields), a set of levels drawn with equal probability (``{choices = [600.0,
1200.0, 1800.0]}``) or, for string options, a list of choices (``["a", "b"]``).
Discrete speed levels are also faster: the simulator batches cases that share
a time grid, i.e. a speed (:func:`datagen.dynamics.solve`).

Healthy references: with ``healthy_reference = true`` every sample is simulated a second time without its
pits (the same pair, operating point, effects and drive train; the noise and any other random draw of the
simulation from another seed, ``reference_simulation_seed``), and stored as the channels
``<channel>@reference``: the record a user would have of the same machine before the fault, which models read
against (:mod:`models.representations`, ``reference = true``). It doubles the simulation time.

Severity semantics: every pitted tooth of a sample gets its own severity,
drawn uniformly in ``[min + 1.1 tol, max - 1.1 tol]`` of its bin (``tol`` = the pit
generator's severity tolerance), so the *achieved* severity of every tooth,
and hence the sample's ``severity`` (max over its pitted teeth), lies in
``[min, max)`` of the labelled bin.
"""
from __future__ import annotations

import hashlib
import json
import math
import re
from collections.abc import Mapping
from dataclasses import dataclass, fields
from pathlib import Path

from datagen.case_options import TORQUE_RANGE_NM, StiffnessOptions, options_from_table
from datagen.class_grid import SeverityBin, TeethClass, class_grid, read_severity_bins, read_teeth_classes
from datagen.draws import Draw, is_int, read_draw, read_int, read_names, read_number
from datagen.geometry import GearPair, preset
from datagen.pair_file import pair_from_dict
from datagen.lumped_model import DriveTrain
from datagen.pits import DEPTH_PROFILES, DEPTH_RANGE_M, SHAPES, default_tolerance, max_severity
from gearpit.errors import require
from gearpit.tomlio import check_keys, read_toml

#: bump when the stored layout or the sampling rules change (recorded in metadata.json)
FORMAT_VERSION = 1

_TOP = {"sweep", "classes", "pits", "operating", "effects", "drive_train", "stiffness"}
_SWEEP = {"name", "seed", "samples_per_class", "shard_size", "fs_hz", "duration_s", "pairs", "channels",
          "healthy_reference", "plugins"}
#: suffix of the stored channels of the healthy twins (``healthy_reference = true``)
REFERENCE_SUFFIX = "@reference"
_CLASSES = {"shapes", "teeth", "max_pitted_teeth", "severity_bins"}
_PITS = {"gear", "grid_px", "depth_mm", "aspect_w_to_s", "profiles", "tolerance"}
_OPERATING = {"speed_rpm", "torque_nm"}
#: signal channels a simulation produces (datagen.simulate.Signals; axial ones for helical pairs only)
CHANNELS = ("acc_pinion_loa_m_s2", "acc_wheel_loa_m_s2", "force_bearing_pinion_loa_n", "force_bearing_wheel_loa_n",
            "acc_pinion_axial_m_s2", "acc_wheel_axial_m_s2", "force_bearing_pinion_axial_n",
            "force_bearing_wheel_axial_n", "dte_m", "mesh_force_n", "speed_pinion_rpm", "speed_wheel_rpm",
            "tacho_pinion", "tacho_wheel")


@dataclass(frozen=True)
class Sweep:
    """A validated sweep (see the module docstring for the TOML form; SI units)."""

    name: str
    seed: int
    samples_per_class: int
    shard_size: int
    fs_hz: float
    duration_s: float
    pairs: tuple[GearPair, ...]
    channels: tuple[str, ...]
    shapes: tuple[str, ...]
    severity_bins: tuple[SeverityBin, ...]
    teeth_classes: tuple[TeethClass, ...]
    gear: str
    grid_px: tuple[int, int]
    tolerance: float | None
    depth_m: Draw
    aspect_w_to_s: Draw | None
    profile: Draw
    speed_rpm: Draw
    torque_nm: Draw
    effects: tuple[tuple[str, tuple[Draw, ...]], ...]
    drive_train: tuple[Draw, ...]
    source: Mapping  # the TOML document as read (recorded in metadata.json)
    healthy_reference: bool = False
    stiffness: StiffnessOptions = StiffnessOptions()
    #: user effect files (``[sweep] plugins``, and ``gearpit generate --plugin``): (resolved path, sha256) each
    plugins: tuple[tuple[str, str], ...] = ()

    @property
    def stored_channels(self) -> tuple[str, ...]:
        """The channels a shard stores: ``channels``, then (``healthy_reference``) their healthy twins."""
        return self.channels + (tuple(c + REFERENCE_SUFFIX for c in self.channels) if self.healthy_reference else ())

    @property
    def n_time(self) -> int:
        return int(round(self.fs_hz * self.duration_s))

    @property
    def n_samples(self) -> int:
        return len(class_grid(self)) * self.samples_per_class

    @property
    def n_shards(self) -> int:
        return -(-self.n_samples // self.shard_size)

    def pair(self, name: str) -> GearPair:
        return next(p for p in self.pairs if p.name == name)

    def tolerance_for(self, pair: GearPair) -> float:
        """Severity tolerance of the pit generator on this pair's flank grid."""
        return self.tolerance if self.tolerance is not None else default_tolerance(self.flank_grid(pair))

    def flank_grid(self, pair: GearPair):
        return pair.flank_grid(self.gear, *self.grid_px)

    @property
    def fingerprint(self) -> str:
        """sha256 of the canonical JSON of the TOML document, the format version and the simulator's mesh record
        (the record's default changed at stop 34: a dataset begun before must not be resumed with it), and the
        contents of its plugin files (a changed effect is another dataset)."""
        doc = {"format_version": FORMAT_VERSION, "config": self.source, "stiffness": self.stiffness.to_dict()}
        if self.plugins:        # the effects' code, by content (a sweep without plugins keeps its fingerprint)
            doc["plugins_sha256"] = sorted(sha for _, sha in self.plugins)
        text = json.dumps(doc, sort_keys=True)
        return hashlib.sha256(text.encode()).hexdigest()


# ---------------------------------------------------------------------- reading
def load_sweep(path: str | Path, *, plugins: tuple[str | Path, ...] = ()) -> Sweep:
    """Read and validate a sweep TOML file (raises :class:`InputError` on anything wrong). Its ``[sweep] plugins``
    are paths relative to the file; ``plugins``: further effect files (``gearpit generate --plugin``)."""
    return sweep_from_dict(read_toml(path), base_dir=Path(path).resolve().parent, plugins=plugins)


def sweep_from_dict(doc: Mapping, *, base_dir: str | Path | None = None,
                    plugins: tuple[str | Path, ...] = ()) -> Sweep:
    """Validate a sweep document (the parsed TOML) and build the :class:`Sweep`. ``base_dir``: where the
    document's ``[sweep] plugins`` paths start (default: the working directory); ``plugins``: further effect
    files. Every plugin is loaded before the effects are read, so its effects are names of the sweep."""
    require(isinstance(doc, Mapping), "sweep file", type(doc).__name__, "a TOML document")
    check_keys(dict(doc), _TOP, "", required={"sweep", "classes", "operating"})
    sw = _table(doc, "sweep")
    check_keys(sw, _SWEEP, "sweep", required={"seed", "samples_per_class", "fs_hz", "duration_s", "pairs"})
    seed = read_int(sw, "seed", "sweep", 0)
    n_per = read_int(sw, "samples_per_class", "sweep", 1)
    shard = read_int(sw, "shard_size", "sweep", 1) if "shard_size" in sw else 32
    fs = read_number(sw["fs_hz"], "sweep.fs_hz", positive=True)
    dur = read_number(sw["duration_s"], "sweep.duration_s", positive=True)
    require(round(fs * dur) >= 16, "sweep.duration_s", dur, f"at least 16 samples at fs_hz = {fs:g}")
    pairs = _pairs(sw["pairs"])
    channels = read_names(sw.get("channels", ["acc_pinion_loa_m_s2"]), "sweep.channels", CHANNELS)
    twin = sw.get("healthy_reference", False)
    require(isinstance(twin, bool), "sweep.healthy_reference", twin, "true or false")

    cl = _table(doc, "classes")
    check_keys(cl, _CLASSES, "classes", required={"severity_bins"})
    bins = read_severity_bins(cl["severity_bins"])
    has_healthy = any(b.healthy for b in bins)
    has_pitted = any(not b.healthy for b in bins)
    shapes = read_names(cl.get("shapes", ["ellipse"]), "classes.shapes", SHAPES) if has_pitted else ()
    pits = _table(doc, "pits") if "pits" in doc else {}
    check_keys(pits, _PITS, "pits")
    gear = pits.get("gear", "pinion")
    require(gear in ("pinion", "wheel"), "pits.gear", gear, "one of: pinion, wheel")
    z_min = min(p._gear(gear).teeth for p in pairs)
    teeth = read_teeth_classes(cl, has_healthy, has_pitted, z_min)

    grid_px = pits.get("grid_px", [73, 200])
    require(isinstance(grid_px, list) and len(grid_px) == 2 and all(is_int(v) and 8 <= v <= 4000 for v in grid_px),
            "pits.grid_px", grid_px, "[n_profile, n_face], integers in [8, 4000]")
    tol = None
    if "tolerance" in pits:
        tol = read_number(pits["tolerance"], "pits.tolerance", positive=True)
        require(tol <= 0.05, "pits.tolerance", tol, "a number in (0, 0.05]")
    depth = read_draw(pits.get("depth_mm", 0.2), "pits.depth_mm", "depth_m", "m", DEPTH_RANGE_M, scale=1e-3)
    aspect = read_draw(pits["aspect_w_to_s"], "pits.aspect_w_to_s", "aspect_w_to_s", "-", (0.05, 50.0)) \
        if "aspect_w_to_s" in pits else None
    profile = read_draw(pits.get("profiles", ["flat"]), "pits.profiles", "profile", "-", choices=DEPTH_PROFILES)

    op = _table(doc, "operating")
    check_keys(op, _OPERATING, "operating", required=_OPERATING)
    speed = read_draw(op["speed_rpm"], "operating.speed_rpm", "speed_rpm", "rpm", (1.0, 1e5))
    torque = read_draw(op["torque_nm"], "operating.torque_nm", "torque_nm", "N m", TORQUE_RANGE_NM)
    loaded = _plugins(sw.get("plugins", []), base_dir, plugins)
    effects = _effects(doc.get("effects", {}))
    drive = _drive_train(doc.get("drive_train", {}))
    stiffness = options_from_table(StiffnessOptions, dict(_table(doc, "stiffness")), "stiffness") \
        if "stiffness" in doc else StiffnessOptions()
    name = sw.get("name", "sweep")
    require(isinstance(name, str) and re.fullmatch(r"[A-Za-z0-9_.-]{1,64}", name) is not None, "sweep.name", name,
            "1-64 letters, digits, '_', '.', '-'")
    sweep = Sweep(name=name, seed=seed, samples_per_class=n_per, shard_size=shard, fs_hz=float(fs),
                  duration_s=float(dur), pairs=pairs, channels=channels, shapes=shapes, severity_bins=bins,
                  teeth_classes=teeth, gear=gear, grid_px=(int(grid_px[0]), int(grid_px[1])), tolerance=tol,
                  depth_m=depth, aspect_w_to_s=aspect, profile=profile, speed_rpm=speed, torque_nm=torque,
                  effects=effects, drive_train=drive, source=json.loads(json.dumps(doc)), healthy_reference=twin,
                  stiffness=stiffness, plugins=loaded)
    _check_feasible(sweep)
    return sweep


def _table(doc, key) -> dict:
    v = doc[key]
    require(isinstance(v, Mapping), key, v, "a table")
    return dict(v)


def _pairs(v) -> tuple[GearPair, ...]:
    require(isinstance(v, list) and len(v) > 0, "sweep.pairs", v, "a non-empty list of preset names or pair tables")
    out = []
    for i, item in enumerate(v):
        out.append(preset(item) if isinstance(item, str) else pair_from_dict(item, where=f"sweep.pairs[{i}]"))
    names = [p.name for p in out]
    require(len(set(names)) == len(names), "sweep.pairs", names, "pairs with distinct names (set name = ...)")
    return tuple(out)


def _field_bounds(f) -> tuple:
    return f.metadata.get("bounds", (-math.inf, math.inf))


def _plugins(listed, base_dir, extra) -> tuple[tuple[str, str], ...]:
    """Load the sweep's plugin files (``[sweep] plugins``, relative to ``base_dir``) and ``extra`` ones;
    ``(resolved path, sha256)`` each, in order, without repeats."""
    from datagen.effects.registry import ensure_plugin

    require(isinstance(listed, list) and all(isinstance(p, str) for p in listed), "sweep.plugins", listed,
            "a list of .py file paths (relative to the sweep file)")
    base = Path(base_dir) if base_dir is not None else Path.cwd()
    out: dict[str, str] = {}
    for p in [base / q for q in listed] + [Path(q) for q in extra]:
        path, sha = ensure_plugin(p)
        out[path] = sha
    return tuple(out.items())


def _effects(table) -> tuple:
    from datagen.effects import get

    require(isinstance(table, Mapping), "effects", table, "a table of [effects.NAME] tables")
    out = []
    for name in sorted(table):
        params = table[name]
        require(isinstance(params, Mapping), f"effects.{name}", params, "a table of parameter values or ranges")
        cls = get(name)
        known = {f.name: f for f in fields(cls)}
        check_keys(dict(params), set(known), f"effects.{name}")
        draws = []
        for key in sorted(params):
            f = known[key]
            where = f"effects.{name}.{key}"
            if "choices" in f.metadata:
                draws.append(read_draw(params[key], where, key, "-", choices=tuple(f.metadata["choices"])))
            else:
                draws.append(read_draw(params[key], where, key, f.metadata.get("unit", "-"), _field_bounds(f),
                                   integer=f.type in ("int", int)))
        out.append((name, tuple(draws)))
    return tuple(out)


#: unit of a DriveTrain field from its name's suffix (first match)
_DRIVE_UNITS = (("_kg_m2", "kg m^2"), ("_nm_per_rad", "N m/rad"), ("_n_per_m", "N/m"), ("_hz", "Hz"),
                ("_ratio", "-"), ("", "-"))


def _drive_train(table) -> tuple[Draw, ...]:
    require(isinstance(table, Mapping), "drive_train", table, "a table of DriveTrain fields")
    known = {f.name: f for f in fields(DriveTrain)}
    check_keys(dict(table), set(known), "drive_train")
    out = []
    for key in sorted(table):
        bounds = (0.0, 2.0) if key.endswith("damping_ratio") else (1e-12, 1e15)
        unit = next(u for suffix, u in _DRIVE_UNITS if key.endswith(suffix))
        d = read_draw(table[key], f"drive_train.{key}", key, unit, bounds)
        for v in d.span:  # DriveTrain's own checks, before any work
            DriveTrain(**{key: v})
        out.append(d)
    return tuple(out)


def _check_feasible(sweep: Sweep) -> None:
    """Every severity bin must be reachable by every shape on every pair's flank grid."""
    for pair in sweep.pairs:
        grid = sweep.flank_grid(pair)
        tol = sweep.tolerance_for(pair)
        aspects = sweep.aspect_w_to_s.span if sweep.aspect_w_to_s is not None else (None,)
        for b in sweep.severity_bins:
            if b.healthy:
                continue
            where = f"classes.severity_bins.{b.name}"
            require(b.max_fraction - b.min_fraction > 2.2 * tol, where, [b.min_fraction, b.max_fraction],
                    f"a bin wider than 2.2 x the severity tolerance {tol:.4g} of the {sweep.grid_px[0]}x"
                    f"{sweep.grid_px[1]} flank grid (labels must stay inside their bin); this bin is empty")
            for shape in sweep.shapes:
                top = min(max_severity(grid, shape, a) for a in aspects)
                require(b.max_fraction - 1.1 * tol <= top, where, [b.min_fraction, b.max_fraction],
                        f"severities a {shape} pit can reach on the {pair.name} {sweep.gear} flank "
                        f"(<= {top:.4f} with this aspect ratio)")
                if shape == "rectangle":
                    _check_rectangle_resolution(grid, b, tol, aspects, where)
    from datagen.effects import get
    from datagen.simulate import Case, OperatingPoint

    for name, draws in sweep.effects:
        cls = get(name)
        for d in draws:  # every corner value builds (bounds are checked by the effect itself)
            for v in d.span:
                cls(**{d.name: v})
    from datagen.pits import PitSpec

    # the most pitted teeth a sample gets: the stiffness record must fit its budget with them
    worst = max((tc.high for tc in sweep.teeth_classes), default=0)
    pits = PitSpec(shape="ellipse", teeth=tuple(range(worst)), severity=0.1) if worst else None
    for pair in sweep.pairs:  # the simulation's own checks (fs vs mesh frequency, duration >= 1 rev, stiffness)
        axial = [c for c in sweep.channels if "axial" in c]
        require(pair.is_helical or not axial, "sweep.channels", axial, f"no axial channels (pair {pair.name} is spur)")
        for speed in sweep.speed_rpm.span:
            for torque in sweep.torque_nm.span:
                Case(pair=pair, operating=OperatingPoint(speed, torque), duration_s=sweep.duration_s,
                     fs_hz=sweep.fs_hz, stiffness=sweep.stiffness, pits=pits, pit_gear=sweep.gear,
                     pit_grid=sweep.grid_px)


def _check_rectangle_resolution(grid, b: SeverityBin, tol: float, aspects, where: str) -> None:
    """A rectangle of whole pixels lands within ``tol`` when half its row count is <= tol * pixels."""
    n_pix = grid.n_active_pixels        # the active flank (the contact band; every column with equal face widths)
    for a in aspects:
        band = grid.face_width_m if grid.n_active_cols == grid.n_face else grid.n_active_cols * grid.dw_m
        a = band / grid.profile_length_m if a is None else a
        rows = math.sqrt(b.max_fraction * n_pix * grid.pixel_area_m2 / a) / grid.ds_m
        rows = min(grid.n_profile, math.ceil(rows))
        require(rows / 2 <= tol * n_pix, where, [b.min_fraction, b.max_fraction],
                f"a flank grid fine enough for rectangles within tolerance {tol:.4g} (need more face pixels "
                f"than {grid.n_active_cols} in the contact band or a larger pits.tolerance)")
