"""The effect registry and effect specs: effects by name, as case files and the command line give them.

- :func:`register` (a class decorator), :func:`unregister`, :func:`get`, :func:`names`: the registry of
  :class:`~datagen.effects.base.Effect` subclasses by their ``name``; :func:`load_plugin` imports a user's file
  whose ``@register`` decorators add to it;
- :class:`EffectSpec`: an effect by name plus parameters, from a TOML table or ``name:key=value,...``, validated
  before any work; :func:`build_effects` turns a mixed sequence into effect instances.

Everything here is also importable from :mod:`datagen.effects.base` (the plugin API of its docstring).
"""
from __future__ import annotations

import dataclasses
import hashlib
import importlib.util
import sys
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any

from datagen.effects.base import Effect
from gearpit.errors import InputError

_REGISTRY: dict[str, type[Effect]] = {}


def register(effect_cls: type[Effect]) -> type[Effect]:
    """Class decorator: add an :class:`Effect` subclass to the registry under its ``name``."""
    if not (isinstance(effect_cls, type) and issubclass(effect_cls, Effect)):
        raise InputError("effect", effect_cls, "a subclass of datagen.effects.base.Effect")
    if not dataclasses.is_dataclass(effect_cls) or not effect_cls.__dataclass_params__.frozen:
        raise InputError(f"effect {effect_cls.__name__}", "not a frozen dataclass", "@dataclass(frozen=True)")
    name = effect_cls.name
    if not (isinstance(name, str) and name.replace("_", "").isalnum() and name == name.lower()):
        raise InputError(f"effect {effect_cls.__name__}.name", name, "a short lower-case identifier")
    if not effect_cls.signature:
        raise InputError(f"effect {name}.signature", "", "one line describing the signature it leaves")
    for f in fields(effect_cls):
        if f.default is dataclasses.MISSING:
            raise InputError(f"effect {name}.{f.name}", "no default", "every parameter needs a default")
        if "unit" not in f.metadata or ("bounds" not in f.metadata and "choices" not in f.metadata):
            raise InputError(f"effect {name}.{f.name}", dict(f.metadata), "metadata with 'unit' and 'bounds' (or 'choices')")
    effect_cls.fit_declaration()  # a bad fit declaration is refused at registration, not mid-comparison
    old = _REGISTRY.get(name)
    if old is not None and (old.__module__, old.__qualname__) != (effect_cls.__module__, effect_cls.__qualname__):
        raise InputError("effect name", name, f"a name not yet taken (by {old.__module__}.{old.__qualname__})")
    _REGISTRY[name] = effect_cls
    return effect_cls


def unregister(name: str) -> None:
    """Remove an effect from the registry (tests, or reloading a user's plugin)."""
    _REGISTRY.pop(name, None)


def get(name: str) -> type[Effect]:
    """The effect class registered under ``name``."""
    if name not in _REGISTRY:
        raise InputError("effects.name", name, f"one of: {', '.join(names())}")
    return _REGISTRY[name]


def names() -> list[str]:
    """All registered effect names, sorted."""
    return sorted(_REGISTRY)


#: plugin files loaded in this process: resolved path -> sha256 of the bytes loaded
_LOADED_PLUGINS: dict[str, str] = {}


def plugin_digest(path: str | Path) -> str:
    """sha256 of a plugin file's bytes (what a dataset records and a worker checks)."""
    p = Path(path)
    if not p.is_file() or p.suffix != ".py":
        raise InputError("plugin", str(p), "an existing .py file")
    return hashlib.sha256(p.read_bytes()).hexdigest()


def ensure_plugin(path: str | Path, sha256: str | None = None) -> tuple[str, str]:
    """Load a plugin file once per process (:func:`load_plugin`); ``(resolved path, sha256)``.

    A worker process of a dataset run calls it for every plugin of the sweep: a forked worker finds it loaded, a
    fresh one (``forkserver``, a Dask worker) loads it. ``sha256``: the digest the run recorded; a file that changed
    since is refused (the dataset would mix two versions of the effect)."""
    p = Path(path).resolve()
    digest = plugin_digest(p)
    if sha256 is not None and digest != sha256:
        raise InputError("plugin", str(p), f"the file the run began with (sha256 {sha256[:12]}...; it changed to "
                                           f"{digest[:12]}...)")
    key = str(p)
    if key in _LOADED_PLUGINS:
        if _LOADED_PLUGINS[key] != digest:
            raise InputError("plugin", key, f"the version loaded earlier in this process (sha256 "
                                           f"{_LOADED_PLUGINS[key][:12]}...)")
        return key, digest
    load_plugin(p)
    _LOADED_PLUGINS[key] = digest
    return key, digest


def load_plugin(path: str | Path) -> list[str]:
    """Import a user's Python file so that its ``@register`` effects join the registry.

    Returns the names that the file added. A file that cannot be imported (a syntax error, an exception or a
    missing module at import) is refused with one line naming the file (and the line of a syntax error), and
    whatever it registered before failing is removed again; a file that registers no effect is refused too (a
    plugin without effects is always a mistake: a forgotten ``@register``).
    """
    p = Path(path)
    if not p.is_file() or p.suffix != ".py":
        raise InputError("plugin", str(p), "an existing .py file")
    before = dict(_REGISTRY)
    mod_name = f"gearpit_plugin_{p.stem}_{abs(hash(str(p.resolve()))) % 10**8}"
    spec = importlib.util.spec_from_file_location(mod_name, p)
    module = importlib.util.module_from_spec(spec)
    sys.modules[mod_name] = module
    try:
        spec.loader.exec_module(module)
    except Exception as exc:    # the user's code: any failure becomes one line naming the file
        sys.modules.pop(mod_name, None)
        _REGISTRY.clear()
        _REGISTRY.update(before)
        raise PluginError(p, exc) from None
    if not any(c.__module__ == mod_name for c in _REGISTRY.values()):
        sys.modules.pop(mod_name, None)
        raise InputError(f"plugin {p.name}", str(p), "a file that registers at least one effect (it registers no "
                                                      "effect: decorate an Effect subclass with @register)")
    return sorted(set(_REGISTRY) - set(before))


class PluginError(InputError):
    """A plugin file that failed to import: one line naming the file, the line of a syntax error, and the error."""

    def __init__(self, path: Path, exc: BaseException):
        self.path, self.exc = Path(path), exc
        self.field, self.value, self.allowed = "plugin", str(path), "a file that imports without error"
        name = self.path.name
        if isinstance(exc, InputError):          # a bad @register: its own message already says what is allowed
            text = f"plugin {name}: {exc}"
        elif isinstance(exc, SyntaxError):
            text = f"plugin {name}: line {exc.lineno}: {exc.msg}"
        else:
            text = f"plugin {name}: raised {type(exc).__name__}: {exc} while loading"
        ValueError.__init__(self, text)

    def __reduce__(self):
        return type(self), (self.path, self.exc)


@dataclass(frozen=True)
class EffectSpec:
    """An effect by name plus parameters, as read from a case file or the command line.

    Parameters
    ----------
    name : str
        Registered effect name.
    params : tuple of (str, value)
        Parameter overrides (SI units, names as the dataclass fields).
    """

    name: str
    params: tuple = ()

    @classmethod
    def from_dict(cls, d: dict, where: str = "effects") -> "EffectSpec":
        """From a TOML table ``{name = "noise", snr_db = 30.0}``; unknown names/keys raise."""
        if not isinstance(d, dict) or "name" not in d:
            raise InputError(where, d, "a table with a 'name' key")
        effect_cls = get(d["name"])
        allowed = {f.name for f in fields(effect_cls)}
        for key in d:
            if key != "name" and key not in allowed:
                raise InputError(f"{where}.{d['name']}.{key}", d[key],
                                 f"a parameter of {d['name']}: {', '.join(sorted(allowed)) or '(none)'}")
        spec = cls(name=d["name"], params=tuple(sorted((k, v) for k, v in d.items() if k != "name")))
        spec.build()  # validate now, before any work
        return spec

    @classmethod
    def from_string(cls, text: str) -> "EffectSpec":
        """From the CLI form ``name:key=value,key=value`` (values parsed as numbers when they can be: ``1.5`` and
        ``1e3`` as floats, ``3`` as an integer); a key given twice is refused, as in a TOML table."""
        name, _, rest = text.partition(":")
        d: dict[str, Any] = {"name": name.strip()}
        for item in filter(None, (s.strip() for s in rest.split(","))):
            key, eq, val = item.partition("=")
            if not eq:
                raise InputError("effect", text, "name:key=value,key=value")
            key = key.strip()
            if key in d:        # as a TOML table refuses a key given twice
                raise InputError(f"effect.{d['name']}.{key}", text, "each parameter given once")
            try:
                d[key] = float(val) if any(c in val for c in ".eE") else int(val)
            except ValueError:
                d[key] = val.strip()
        return cls.from_dict(d, where="effect")

    def build(self) -> Effect:
        """The effect instance (validates the parameters against their bounds)."""
        effect_cls = get(self.name)
        params = dict(self.params)
        for f in fields(effect_cls):  # ints from TOML for float fields are fine
            if f.name in params and f.type in ("float", float) and isinstance(params[f.name], int) \
                    and not isinstance(params[f.name], bool):
                params[f.name] = float(params[f.name])
        return effect_cls(**params)


def build_effects(items) -> tuple[Effect, ...]:
    """Effects from a sequence of :class:`Effect`, :class:`EffectSpec` or dicts; at most one nonlinear mesh law."""
    out = []
    for i, item in enumerate(items or ()):
        if isinstance(item, Effect):
            out.append(item)
        elif isinstance(item, EffectSpec):
            out.append(item.build())
        elif isinstance(item, dict):
            out.append(EffectSpec.from_dict(item, where=f"effects[{i}]").build())
        else:
            raise InputError(f"effects[{i}]", item, "an Effect, EffectSpec or {name = ..., ...} table")
    if sum(e.is_nonlinear for e in out) > 1:
        raise InputError("effects", [e.name for e in out if e.is_nonlinear], "at most one nonlinear mesh law")
    return tuple(out)


__all__ = ["EffectSpec", "register", "unregister", "get", "names", "load_plugin", "build_effects"]
