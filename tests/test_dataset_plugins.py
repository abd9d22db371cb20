"""A user's effect file in a dataset sweep (``[sweep] plugins``, ``gearpit generate --plugin``): the README's
promise that a plugin effect is available to datasets as to simulation and comparison.

Truth from outside: the effect's own signature (a once-per-wheel-revolution transmission error, like the README's
``runout``) must change the stored records; the bytes must not depend on how the workers start (the sweep's
other tests, issue 4: "identical bytes for 1 and 2 workers"); a changed effect file is another dataset."""
from __future__ import annotations

import copy
import hashlib
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from datagen.generate import generate
from datagen.sweep import load_sweep
from gearpit.errors import InputError
from compare.model import to_toml as toml_dumps

from test_dataset_config import BASE, REPO  # tests/ is on sys.path (conftest.py)
from test_dataset_generate import digest

PLUGIN = '''
from dataclasses import dataclass, field

import numpy as np

from datagen.effects import Effect, register


@register
@dataclass(frozen=True)
class SweepTestRunout(Effect):
    name = "sweep_test_runout"
    signature = "wheel order 1 in the transmission error"
    amplitude_m: float = field(default=5e-6, metadata={"unit": "m", "bounds": (0.0, 50e-6)})

    def deviation_period_cycles(self, ctx):
        return ctx.pair.wheel.teeth

    def angle_deviation_m(self, th1, th2, ctx):
        return self.amplitude_m * np.sin(th2)
'''


def _doc(with_effect: bool = True, listed: bool = True) -> dict:
    doc = copy.deepcopy(BASE)
    doc["sweep"]["channels"] = ["dte_m"]
    doc["sweep"]["samples_per_class"] = 1
    if listed:
        doc["sweep"]["plugins"] = ["fx/sweep_effects.py"]
    if with_effect:
        doc["effects"]["sweep_test_runout"] = {"amplitude_m": [10e-6, 20e-6]}
    return doc


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    """The plugin beside a sweep file that lists it (relative path); unregistered again after the module."""
    from datagen.effects import registry

    root = tmp_path_factory.mktemp("plugin_sweep")
    (root / "fx").mkdir()
    (root / "fx" / "sweep_effects.py").write_text(PLUGIN)
    (root / "sweep.toml").write_text(toml_dumps(_doc()))
    (root / "plain.toml").write_text(toml_dumps(_doc(with_effect=False, listed=False)))
    (root / "unlisted.toml").write_text(toml_dumps(_doc(listed=False)))
    yield root
    registry._LOADED_PLUGINS.pop(str((root / "fx" / "sweep_effects.py").resolve()), None)
    if "sweep_test_runout" in registry.names():
        registry.unregister("sweep_test_runout")


@pytest.fixture(scope="module")
def in_process(folder):
    sweep = load_sweep(folder / "sweep.toml")
    generate(sweep, folder / "ds1", progress=False)
    return sweep, folder / "ds1"


def test_the_plugin_effect_shapes_the_records_and_is_recorded(folder, in_process):
    """The effect's wheel-order line is in every stored transmission error (against the same draws without it),
    and metadata.json names the file and its sha256."""
    from models.sources import load_dataset

    sweep, ds = in_process
    generate(load_sweep(folder / "plain.toml"), folder / "plain", progress=False)
    meta = json.loads((ds / "metadata.json").read_text())
    sha = hashlib.sha256((folder / "fx" / "sweep_effects.py").read_bytes()).hexdigest()
    assert meta["plugins"] == [{"file": "sweep_effects.py", "sha256": sha}]
    with_fx, plain = load_dataset(ds, channel="dte_m"), load_dataset(folder / "plain", channel="dte_m")
    # the runout is 10-20 um at wheel order 1; the records' own transmission error is ~1 um peak to peak
    spread = np.ptp(with_fx.signals - plain.signals, axis=1)
    assert np.all(spread > 5e-6)


def test_every_worker_loads_the_plugin_and_writes_the_same_bytes(folder, in_process, tmp_path, monkeypatch):
    """A fork server's workers have not loaded the plugin; they load it themselves (checked against the run's
    sha256) and write the in-process run's bytes (forked workers inherit it loaded)."""
    import multiprocessing

    from datagen import generate as gen

    sweep, ds = in_process
    monkeypatch.setattr(gen, "pool_context", lambda: multiprocessing.get_context("forkserver"))
    generate(sweep, tmp_path / "ds", workers=2, progress=False)
    assert digest(tmp_path / "ds") == digest(ds)


def test_without_the_plugin_its_effect_is_an_unknown_name(folder):
    """In a process that has not loaded the file, the sweep that uses its effect without listing it is refused by
    name (a child process: this one has the plugin loaded)."""
    code = ("import sys; from datagen.sweep import load_sweep; from gearpit.errors import InputError\n"
            f"try:\n    load_sweep({str(folder / 'unlisted.toml')!r})\nexcept InputError as e:\n"
            "    print(e); sys.exit(2)\n")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=REPO)
    assert r.returncode == 2 and "effects.name" in r.stdout and "sweep_test_runout" in r.stdout, r.stdout + r.stderr


def _cli(*args, cwd):
    code = "import sys; from gearpit.cli import main; sys.exit(main(sys.argv[1:]))"
    return subprocess.run([sys.executable, "-c", code, *map(str, args)], capture_output=True, text=True, cwd=cwd,
                          env={**__import__("os").environ, "PYTHONPATH": str(REPO)})


def test_gearpit_generate_plugin_option_and_a_changed_plugin_on_resume(folder, in_process, tmp_path):
    """``--plugin`` gives the sweep that does not list it the same shards as the one that does; a run begun with
    one version of the file is not resumed with another (its effect would differ between shards)."""
    plugin = tmp_path / "sweep_effects.py"
    plugin.write_text(PLUGIN)
    r = _cli("generate", folder / "unlisted.toml", "--plugin", plugin, "--out", tmp_path / "ds", "--quiet",
             "--max-shards", "1", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    first = {k: v for k, v in digest(tmp_path / "ds").items() if k.startswith("shards")}
    assert len(first) >= 1 and all(digest(in_process[1])[k] == v for k, v in first.items())
    plugin.write_text(PLUGIN + "\n# edited\n")
    r = _cli("generate", folder / "unlisted.toml", "--plugin", plugin, "--out", tmp_path / "ds", "--quiet",
             cwd=tmp_path)
    assert r.returncode == 2 and "--out" in r.stderr and "Traceback" not in r.stderr, r.stderr
