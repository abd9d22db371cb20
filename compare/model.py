"""The comparison model: a TOML file the user edits (or extends with ``--add``).

It is a simulation case file (:mod:`datagen.simulate`) without what the
measurement fixes - pair, operating point, duration, sampling rate - plus three
keys of its own::

    description = "rig A, first guess"     # free text, shown in the ledger
    sensor = "acc_pinion_loa_m_s2"          # simulated channel compared with the measured sensor
    plugins = ["my_effects.py"]             # user effect files (relative to this file), loaded first
    [drivetrain]                            # optional: datagen.lumped_model.DriveTrain fields (SI)
    mesh_damping_ratio = 0.07
    [solver]                                # optional: omega_dt, method, transient_s
    [stiffness]                             # optional: positions_per_cycle, n_slices, pit_model, edges
    [pits]                                  # optional: pits of the model (datagen.pits.PitSpec keys, gear, grid)
    [[effects]]                             # optional, repeatable: name + parameters (SI)
    name = "eccentricity_pinion"
    amplitude_m = 2e-05
    [calibration]                           # optional: nuisance calibration (compare.calibration)
    enabled = "auto"                        # default "auto"; true: always first; false: never
    parameters = ["mesh_damping_ratio", "bearing_n_per_m", "bearing_damping_ratio"]

With ``[calibration] enabled = true`` (or ``gearpit compare --calibrate``) the
drive-train nuisances named there are fitted to the measurement before the
attribution (:mod:`compare.calibration`), starting from the ``[drivetrain]``
values (or the defaults); with ``"auto"`` (the default) only when the model as
written leaves the mismatch unexplained (:mod:`compare.escalation` says why);
the fitted values are reported and recorded in the ledger, not written back
into this file.

A missing model file means the baseline: no effects, default drive train,
sensor ``acc_pinion_loa_m_s2``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from pathlib import Path

from datagen.effects import EffectSpec, build_effects, load_plugin
from gearpit.atomic import atomic_path
from gearpit.errors import InputError, require
from gearpit.tomlio import check_keys, read_toml

MODEL_KEYS = {"description", "sensor", "plugins", "drivetrain", "solver", "stiffness", "pits", "effects", "calibration"}
CALIBRATION_KEYS = {"enabled", "parameters"}
DEFAULT_SENSOR = "acc_pinion_loa_m_s2"


@dataclass(frozen=True)
class ComparisonModel:
    """The model side of a comparison (module docstring); ``effects`` are built :class:`Effect` instances."""

    effects: tuple = ()
    sensor: str = DEFAULT_SENSOR
    description: str = ""
    plugins: tuple = ()
    tables: dict = field(default_factory=dict)   # drivetrain / solver / stiffness / pits, as in a case file
    calibration: dict = field(default_factory=dict)   # [calibration]: enabled, parameters
    path: Path | None = None

    @classmethod
    def from_dict(cls, d: dict, *, path: Path | None = None) -> "ComparisonModel":
        """From the TOML form; plugins are loaded before the effects are checked."""
        require(isinstance(d, dict), "model", d, "a table")
        check_keys(d, MODEL_KEYS, "model")
        sensor = d.get("sensor", DEFAULT_SENSOR)
        require(isinstance(sensor, str) and sensor, "model.sensor", sensor, "a simulated channel name")
        desc = d.get("description", "")
        require(isinstance(desc, str), "model.description", desc, "a string")
        plugins = d.get("plugins", [])
        require(isinstance(plugins, list) and all(isinstance(p, str) for p in plugins), "model.plugins", plugins,
                "a list of .py file paths")
        base = path.parent if path is not None else Path(".")
        for p in plugins:
            load_plugin(Path(p) if Path(p).is_absolute() else base / p)
        effects = d.get("effects", [])
        require(isinstance(effects, list), "model.effects", effects, "an array of tables [[effects]]")
        built = build_effects(effects)
        tables = {k: d[k] for k in ("drivetrain", "solver", "stiffness", "pits") if k in d}
        for k, v in tables.items():
            require(isinstance(v, dict), f"model.{k}", v, "a table")
        cal = d.get("calibration", {})
        require(isinstance(cal, dict), "model.calibration", cal, "a table")
        check_keys(cal, CALIBRATION_KEYS, "model.calibration")
        require(cal.get("enabled", True) in (True, False, "auto"), "model.calibration.enabled", cal.get("enabled"),
                "true, false or \"auto\"")
        if "parameters" in cal:
            from compare.calibration import CalibrationSettings

            ps = cal["parameters"]
            require(isinstance(ps, list) and all(isinstance(p, str) for p in ps), "model.calibration.parameters", ps,
                    "a list of drive-train field names")
            CalibrationSettings(parameters=tuple(ps))  # validates the names
        model = cls(effects=built, sensor=sensor, description=desc, plugins=tuple(plugins), tables=tables,
                    calibration=dict(cal), path=path)
        _check_unique(model.effects)
        return model

    @classmethod
    def load(cls, path: str | Path) -> "ComparisonModel":
        p = Path(path)
        if not p.exists():
            return cls(path=p)
        return cls.from_dict(read_toml(p), path=p)

    # ------------------------------------------------------------------ edits
    def with_effect(self, effect) -> "ComparisonModel":
        """The model with ``effect`` added (replacing one of the same name)."""
        kept = tuple(e for e in self.effects if e.name != effect.name)
        out = replace(self, effects=kept + (effect,))
        build_effects(out.effects)  # at most one nonlinear mesh law
        return out

    def with_plugin(self, plugin: str) -> "ComparisonModel":
        """The model with ``plugin`` in its plugins list (once), stored relative to the model file when it lies
        under the model's folder (moving the folder keeps the model working), else absolute."""
        entry = self._plugin_entry(plugin)
        have = {self._resolve_plugin(p) for p in self.plugins}
        return self if self._resolve_plugin(entry) in have else replace(self, plugins=self.plugins + (entry,))

    def _plugin_entry(self, plugin: str) -> str:
        """How ``plugin`` is written into the model file: relative to its folder when under it."""
        if self.path is None:
            return str(plugin)
        base = self.path.resolve().parent
        try:
            return Path(plugin).resolve().relative_to(base).as_posix()
        except ValueError:      # outside the model's folder
            return str(Path(plugin).resolve())

    def _resolve_plugin(self, entry: str) -> Path:
        """A plugins entry as a path: relative entries against the model file's folder (as :meth:`from_dict`)."""
        p = Path(entry)
        base = self.path.parent if self.path is not None else Path(".")
        return (p if p.is_absolute() else base / p).resolve()

    @property
    def effect_names(self) -> tuple:
        return tuple(e.name for e in self.effects)

    def describe(self) -> str:
        """One line: ``baseline`` or ``eccentricity_pinion(amplitude_m=2e-05) + ...``."""
        if not self.effects:
            return "baseline"
        parts = []
        for e in self.effects:
            ps = ", ".join(f"{k}={_fmt(v)}" for k, v in e.params().items())
            parts.append(f"{e.name}({ps})")
        return " + ".join(parts)

    def to_dict(self) -> dict:
        d: dict = {}
        if self.description:
            d["description"] = self.description
        d["sensor"] = self.sensor
        if self.plugins:
            d["plugins"] = list(self.plugins)
        d.update(self.tables)
        if self.calibration:
            d["calibration"] = dict(self.calibration)
        d["effects"] = [e.to_dict() for e in self.effects]
        return d

    @property
    def calibration_mode(self):
        """``[calibration] enabled``: True (calibrate first), False (never) or "auto" (only when the model as
        written leaves the mismatch unexplained: :mod:`compare.escalation`); default
        :data:`compare.calibration.CALIBRATE_BY_DEFAULT`."""
        from compare.calibration import CALIBRATE_BY_DEFAULT

        return self.calibration.get("enabled", CALIBRATE_BY_DEFAULT)

    @property
    def calibrates(self) -> bool:
        """Whether a single comparison calibrates the drive-train nuisances first: only when the mode is True
        ("auto" decides after an attribution, :mod:`compare.escalation`)."""
        return self.calibration_mode is True

    def calibration_settings(self, seed: int = 0):
        """The :class:`compare.calibration.CalibrationSettings` of this model."""
        from compare.calibration import CalibrationSettings

        ps = self.calibration.get("parameters")
        return CalibrationSettings(seed=seed) if ps is None else CalibrationSettings(parameters=tuple(ps), seed=seed)

    def with_drivetrain(self, values: dict) -> "ComparisonModel":
        """The model with ``values`` (drive-train fields, SI) in its ``[drivetrain]`` table."""
        tables = dict(self.tables)
        tables["drivetrain"] = {**tables.get("drivetrain", {}), **{k: float(v) for k, v in values.items()}}
        return replace(self, tables=tables)

    def save(self, path: str | Path | None = None) -> Path:
        """Write the TOML form atomically (to ``path`` or where it was loaded from)."""
        p = Path(path) if path is not None else self.path
        require(p is not None, "model path", None, "a file to write the model to")
        text = None
        if self.path is not None and p.exists() and p.resolve() == Path(self.path).resolve():
            text = _merged_text(p, self.to_dict())      # the user's file, comments and layout kept
        if text is None:
            text = "# gearpit comparison model (gearpit compare --model); edit freely\n" + to_toml(self.to_dict())
        with atomic_path(p) as tmp:
            tmp.write_text(text, encoding="utf-8")
        return p

    # ------------------------------------------------------------------ simulation
    def case(self, pair, *, speed_rpm: float, torque_nm: float, duration_s: float, fs_hz: float, seed: int = 0,
             extra_effects: tuple = (), solver: dict | None = None):
        """The :class:`datagen.simulate.Case` of this model at an operating point, plus extra effects."""
        from datagen.simulate import Case

        d = {"duration_s": float(duration_s), "fs_hz": float(fs_hz), "seed": int(seed), "pair": pair.to_dict(),
             "operating": {"speed_rpm": float(speed_rpm), "torque_nm": float(torque_nm)}}
        d.update({k: v for k, v in self.tables.items()})
        if solver:
            d["solver"] = {**d.get("solver", {}), **solver}
        case = Case.from_dict(d)
        extra_names = {e.name for e in extra_effects}
        effects = tuple(e for e in self.effects if e.name not in extra_names) + tuple(extra_effects)
        # the measurement's pair itself, not its file form read back: mm and degrees round-trip to within an ulp
        # (2.1 mm -> 0.0021000000000000003 m), and a model must simulate the very gears it is compared with
        return replace(case, pair=pair, effects=effects)


def _check_unique(effects) -> None:
    seen = set()
    for e in effects:
        require(e.name not in seen, "model.effects", e.name, "each effect at most once")
        seen.add(e.name)


def parse_add(text: str):
    """``EFFECT[:key=value,...]`` -> (name, params dict or None when no parameters were given)."""
    name, sep, rest = text.partition(":")
    if not sep or not rest.strip():
        EffectSpec.from_dict({"name": name.strip()})  # validates the name
        return name.strip(), None
    spec = EffectSpec.from_string(text)
    return spec.name, dict(spec.params)


# ---------------------------------------------------------------------- rewriting the user's file
def _merged_text(path: Path, new: dict) -> str | None:
    """The model file at ``path`` with its values brought to ``new`` (the model's TOML form), its comments, key
    order and layout kept: an ``--add`` rewrites the file the user edits, and must not throw away their notes.
    Tables are merged key by key, ``[[effects]]`` entries by effect name. ``None`` when the file cannot be read
    as TOML (the caller then writes it afresh)."""
    import tomlkit

    try:
        doc = tomlkit.parse(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, tomlkit.exceptions.TOMLKitError):
        return None
    _merge_table(doc, new)
    return tomlkit.dumps(doc)


def _is_table_array(v) -> bool:
    return isinstance(v, list) and bool(v) and all(isinstance(x, dict) for x in v)


def _merge_table(table, new: dict) -> None:
    import tomlkit

    for key in [k for k in table if k not in new]:
        del table[key]
    for key, value in new.items():
        old = table.get(key)
        if key == "effects" and not value:
            if old is not None:
                del table[key]
            continue
        if old is not None and isinstance(value, dict) and isinstance(old, dict):
            _merge_table(old, value)
        elif old is not None and _is_table_array(value) and isinstance(old, list) and all(isinstance(x, dict) for x in old):
            by_name = {x.get("name"): x for x in old}
            aot = tomlkit.aot()
            for item in value:
                kept = by_name.get(item.get("name"))
                if kept is None:
                    kept = tomlkit.table()
                _merge_table(kept, item)
                aot.append(kept)
            table[key] = aot
        elif old is None or _plain(old) != value:
            table[key] = value


def _plain(v):
    return v.unwrap() if hasattr(v, "unwrap") else v


# ---------------------------------------------------------------------- TOML writing (the subset we emit)
def _fmt(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if not math.isfinite(v):
            raise InputError("model value", v, "a finite number")
        return repr(v)
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_fmt(x) for x in v) + "]"
    raise InputError("model value", v, "a number, string, boolean or list")


def to_toml(d: dict, prefix: str = "") -> str:
    """Scalars first, then sub-tables, then arrays of tables (enough for models and sidecars)."""
    lines = []
    for k, v in d.items():
        if not isinstance(v, dict) and not (isinstance(v, list) and v and all(isinstance(x, dict) for x in v)):
            if isinstance(v, list) and not v and k == "effects":
                continue
            lines.append(f"{k} = {_fmt(v)}")
    for k, v in d.items():
        if isinstance(v, dict):
            lines.append(f"\n[{prefix}{k}]")
            lines.append(to_toml(v, prefix=f"{prefix}{k}.").rstrip("\n"))
    for k, v in d.items():
        if isinstance(v, list) and v and all(isinstance(x, dict) for x in v):
            for item in v:
                lines.append(f"\n[[{prefix}{k}]]")
                lines.append(to_toml(item, prefix=f"{prefix}{k}.").rstrip("\n"))
    return "\n".join(x for x in lines if x != "") + "\n"
