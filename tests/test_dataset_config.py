"""Sweep files: validation before any work, class grid, per-sample draws (no simulation here)."""
from __future__ import annotations

import copy
from pathlib import Path

import numpy as np
import pytest

from datagen.class_grid import class_grid
from datagen.pits import max_severity
from datagen.sampling import build_pit_map, draw_sample, sample_row
from datagen.sweep import load_sweep, sweep_from_dict
from gearpit.errors import InputError

REPO = Path(__file__).resolve().parents[1]

BASE = {
    "sweep": {"name": "t", "seed": 3, "samples_per_class": 2, "shard_size": 4, "fs_hz": 4096.0, "duration_s": 0.1,
              "pairs": ["spur-gds"], "channels": ["acc_pinion_loa_m_s2", "tacho_pinion"]},
    "classes": {"shapes": ["ellipse", "cluster"], "teeth": ["0", "1", "2+"], "max_pitted_teeth": 3,
                "severity_bins": {"healthy": [0.0, 0.0], "minor": [0.03, 0.08], "severe": [0.15, 0.25]}},
    "pits": {"grid_px": [30, 60], "depth_mm": [0.1, 0.3]},
    "operating": {"speed_rpm": [1150.0, 1250.0], "torque_nm": [20.0, 40.0]},
    "effects": {"noise": {"snr_db": [20.0, 30.0]}, "transmission_path": {"housing_frequency_hz": 1500.0}},
}


def base(**changes):
    doc = copy.deepcopy(BASE)
    for path, value in changes.items():
        *head, last = path.split("__")
        t = doc
        for h in head:
            t = t[h]
        if value is None:
            del t[last]
        else:
            t[last] = value
    return doc


def test_class_grid_and_counts():
    """Class grid = per pair: healthy (teeth "0", no shape) + pitted bins x pitted teeth classes x shapes.

    Source: issue 4 ("severity bins x number of pitted teeth x shape families"); exact counts.
    """
    sweep = sweep_from_dict(BASE)
    grid = class_grid(sweep)
    assert len(grid) == 1 + 2 * 2 * 2
    assert grid[0].severity_class == "healthy" and grid[0].teeth_class == "0" and grid[0].shape == "none"
    assert sweep.n_samples == 9 * 2 and sweep.n_shards == 5
    assert {(k.severity_class, k.teeth_class, k.shape) for k in grid[1:]} == {
        (b, t, s) for b in ("minor", "severe") for t in ("1", "2+") for s in ("ellipse", "cluster")}


@pytest.mark.parametrize("doc, field", [
    (base(sweep__sampels_per_class=3), "sweep.sampels_per_class"),                       # unknown key (typo)
    (base(pits__depth_m=0.2), "pits.depth_m"),                                            # unit missing in key
    (base(effects={"noise": {"snr": 20.0}}), "effects.noise.snr"),                       # unknown effect parameter
    (base(effects={"nosie": {}}), "effects.name"),                                        # unknown effect
    (base(classes__severity_bins={"healthy": [0.0, 0.0], "minor": [0.08, 0.03]}),
     "classes.severity_bins.minor"),                                                      # empty bin (min > max)
    (base(classes__severity_bins={"healthy": [0.0, 0.0], "minor": [0.03, 0.031]}),
     "classes.severity_bins.minor"),                                                      # narrower than tolerance
    (base(classes__teeth=["1", "2+"]), "classes.teeth"),                                  # healthy bin, no "0" class
    (base(classes__teeth=["0"]), "classes.teeth"),                                        # pitted bins, no teeth
    (base(classes__teeth=["0", "1", "5+"]), "classes.max_pitted_teeth"),                  # "5+" empty (max 3)
    (base(sweep__samples_per_class=0), "sweep.samples_per_class"),                        # no samples per class
    (base(classes__shapes=[]), "classes.shapes"),                                         # no shape families
    (base(classes__severity_bins={"healthy": [0.0, 0.0], "minor": [0.03, 0.10], "severe": [0.08, 0.2]}),
     "classes.severity_bins.severe"),                                                     # overlapping bins
    (base(classes__severity_bins={"severe": [0.15, 0.25], "minor": [0.03, 0.08]}, classes__teeth=["1"]),
     "classes.severity_bins.minor"),                                                      # unsorted bins
    (base(classes__severity_bins={"healthy": [0.0, 0.0], "huge": [0.5, 0.9]}),
     "classes.severity_bins.huge"),                                                       # impossible for the flank
    (base(classes__teeth=["0", "1", "40+"], classes__max_pitted_teeth=40), "classes.max_pitted_teeth"),
    (base(operating__speed_rpm=[1150.0, 9000.0]), "fs_hz"),                               # mesh above 0.4 fs
    (base(sweep__channels=["acc_pinion_axial_m_s2"]), "sweep.channels"),                 # axial on a spur pair
    (base(drive_train={"mesh_damping_ratio": [0.05, 3.0]}), "drive_train.mesh_damping_ratio"),
    (base(stiffness={"edges": "boxy"}), "stiffness.edges"),                               # no such record
    (base(stiffness={"positions_per_cycle": 2}), "stiffness.positions_per_cycle"),       # too coarse
    (base(stiffness={"positions": 64}), "stiffness.positions"),                           # unknown key
])
def test_bad_config_names_the_field(doc, field):
    """Every bad sweep is an InputError naming the offending field (issue 4, "must show" 3)."""
    with pytest.raises(InputError) as exc:
        sweep_from_dict(doc)
    assert exc.value.field == field, str(exc.value)


def test_impossible_severity_matches_flank_limit():
    """An ellipse bin ending just above max_severity (pi/4 at the flank's aspect) is refused, just below accepted.

    Source: datagen.pits.max_severity (largest whole ellipse); tolerance margin 1.1 tol.
    """
    sweep = sweep_from_dict(BASE)
    top = max_severity(sweep.flank_grid(sweep.pairs[0]), "ellipse")
    assert top == pytest.approx(np.pi / 4, rel=1e-9)
    ok = base(classes__shapes=["ellipse"], classes__severity_bins={"healthy": [0.0, 0.0], "big": [0.6, top]})
    sweep_from_dict(ok)
    bad = base(classes__shapes=["ellipse"], classes__severity_bins={"healthy": [0.0, 0.0], "big": [0.6, top + 0.01]})
    with pytest.raises(InputError, match="ellipse pit can reach"):
        sweep_from_dict(bad)


def test_bad_config_cli_writes_nothing(tmp_path, capsys):
    """`gearpit generate` on a bad sweep exits 2 with one line naming the field, and creates no --out.

    Source: issue 4 ("a clear error before any work, nothing written").
    """
    from gearpit.cli import main

    text = (REPO / "experiments/sweeps/demo.toml").read_text()
    cases = {"pits.shpae": text.replace("[pits]", "[pits]\nshpae = 'x'"),
             "classes.severity_bins.severe": text.replace("severe = [0.15, 0.25]", "severe = [0.05, 0.25]"),
             "classes.severity_bins.severe ": text.replace("severe = [0.15, 0.25]", "severe = [0.15, 0.95]")}
    for i, (field, bad_text) in enumerate(cases.items()):
        bad = tmp_path / f"bad{i}.toml"
        bad.write_text(bad_text)
        out = tmp_path / f"out{i}"
        assert main(["generate", str(bad), "--out", str(out)]) == 2
        err = capsys.readouterr().err
        assert field.strip() + ":" in err and err.count("\n") == 1, err
        assert not out.exists()


def test_sample_draws_are_pure_and_inside_their_bins():
    """draw_sample is a pure function of (sweep, index); labels follow the class; achieved severities in bin.

    Source: issue 4 (reproducible from (config, seed, index)); bins [min, max) and the 1.1 tol margin.
    """
    sweep = sweep_from_dict(BASE)
    other = sweep_from_dict(base(sweep__seed=4))
    grid = class_grid(sweep)
    for i in range(sweep.n_samples):
        a, b = draw_sample(sweep, i), draw_sample(sweep, i)
        assert a == b
        assert a.key == grid[i % len(grid)]
        pm = build_pit_map(sweep, a)
        row = sample_row(sweep, a, pm)
        bin_ = sweep.severity_bins[row["severity_class_index"]]
        assert bin_.name == row["severity_class"] and bin_.contains(row["severity"])
        assert all(bin_.contains(s) for s in row["severity_by_tooth"])
        assert pm.pitted_teeth == list(a.teeth) and row["n_pitted_teeth"] == len(a.teeth)
        assert 1150.0 <= row["speed_rpm"] <= 1250.0 and 20.0 <= row["snr_db"] <= 30.0
    assert draw_sample(sweep, 5).speed_rpm != draw_sample(other, 5).speed_rpm


def test_adding_an_effect_keeps_pits_and_operating_point():
    """Per-group random streams: a new nuisance effect changes neither the pits nor the operating point.

    Source: datagen.sampling (streams keyed by (index, group[, crc32(effect)])); exact equality.
    """
    a = sweep_from_dict(BASE)
    b = sweep_from_dict(base(effects={**BASE["effects"], "profile_error": {"grade": [4.0, 8.0]}}))
    for i in (1, 7, 12):
        sa, sb = draw_sample(a, i), draw_sample(b, i)
        assert (sa.teeth, sa.target_severity, sa.speed_rpm, sa.torque_nm) == \
               (sb.teeth, sb.target_severity, sb.speed_rpm, sb.torque_nm)
        assert dict(sa.effects)["noise"] == dict(sb.effects)["noise"]


def test_example_sweeps_are_valid():
    """The shipped sweeps parse; small.toml has every class family of issue 4 (28 classes)."""
    assert len(class_grid(load_sweep(REPO / "experiments/sweeps/small.toml"))) == 1 + 3 * 3 * 3
    assert len(class_grid(load_sweep(REPO / "experiments/sweeps/demo.toml"))) == 4


def test_demo_sweep_matches_shipped_file():
    """datagen.sweep_examples.DEMO_TOML is the text of experiments/sweeps/demo.toml (one demo sweep)."""
    from datagen.sweep_examples import DEMO_TOML, demo_sweep

    assert DEMO_TOML == (REPO / "experiments/sweeps/demo.toml").read_text()
    assert demo_sweep().fingerprint == load_sweep(REPO / "experiments/sweeps/demo.toml").fingerprint


def test_classifier_protocol_sweeps_are_valid():
    """Every sweep of the classifier protocols (experiments/models_sweeps/*.toml) passes the checks, and the
    default pair stores the accelerometer first (what every protocol and the benchmark read) and the
    transmission error (experiments/sensor_protocol.py), with noise on both."""
    sweeps = {p.stem: load_sweep(p) for p in sorted((REPO / "experiments/models_sweeps").glob("*.toml"))}
    assert {"default", "default_healthy", "rig", "nopath", "randomised"} <= set(sweeps)
    for name in ("default", "default_healthy"):
        assert sweeps[name].channels == ("acc_pinion_loa_m_s2", "dte_m")
        assert sweeps[name].source["effects"]["noise"]["channels"] == "all"


def test_the_sweep_picks_the_mesh_record_and_its_fingerprint_holds_it():
    """[stiffness] reaches every case (the former record, 64 point-sampled positions, reproduces datasets made before
    commit d1b9c53); absent, the case gets the default (positions chosen by the band, box edges). The fingerprint
    (what a resumed run must match) differs between the two records, and metadata.json records the record."""
    from datagen.dataset import build_metadata
    from datagen.generate import build_case

    old = sweep_from_dict(base(stiffness={"positions_per_cycle": 64, "edges": "point"}))
    new = sweep_from_dict(BASE)
    spec = draw_sample(old, 0)
    case_old = build_case(old, spec, build_pit_map(old, spec))
    case_new = build_case(new, spec, build_pit_map(new, spec))
    assert (case_old.stiffness.positions_per_cycle, case_old.stiffness.edges) == (64, "point")
    assert (case_new.stiffness.positions_per_cycle, case_new.stiffness.edges) == (None, "box")
    assert old.fingerprint != new.fingerprint
    assert build_metadata(new)["stiffness"]["positions_per_cycle"] == "auto"
