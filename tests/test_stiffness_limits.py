"""Limits of the stiffness record, checked before any work: enough slices for a helical pair's stagger, and a
record that fits its memory budget to compute."""
from __future__ import annotations

import tracemalloc

import numpy as np
import pytest

import datagen.stiffness as st
from datagen.geometry import helical_pair_example, spur_pair_example
from datagen.pits import make_pit_map
from datagen.simulate import Case, OperatingPoint, StiffnessOptions
from gearpit.cli import main
from gearpit.errors import InputError

HEL, SPUR = helical_pair_example(), spur_pair_example()


# ------------------------------------------------------------------ slices (defect: 1 slice for a helical pair)
def test_min_slices_follow_the_overlap_ratio():
    """Neighbouring slices at most 0.1 base pitch apart: ceil(eps_beta / 0.1); spur pairs need one."""
    assert st.min_n_slices(HEL) == int(np.ceil(HEL.contact_ratio_overlap / 0.1)) == 13
    assert st.min_n_slices(SPUR) == 1
    st.mesh_stiffness(SPUR, n_slices=1)            # a spur pair's slices share one contact position


def test_min_slices_are_close_to_converged_and_one_is_not():
    """Invariant: the record converges with the slices. Against 2000 slices (64 positions, box edges): the
    minimum count within 2.5 % RMS of the mean (measured 1.4 %), one slice off by more than 20 % (31 %)."""
    ref = st.mesh_stiffness(HEL, n_slices=2000).k_n_per_m

    def rms(n):
        return float(np.sqrt(np.mean((st.mesh_stiffness(HEL, n_slices=n).k_n_per_m - ref) ** 2)) / ref.mean())

    assert rms(st.min_n_slices(HEL)) < 0.025
    with pytest.raises(InputError):
        st.mesh_stiffness(HEL, n_slices=1)
    assert rms(2000) == 0.0


def test_one_slice_refused_for_helical_pair_on_cli_and_case(tmp_path, capsys):
    """`--n-slices 1` on helical-dct gave min stiffness 0 with pits (total contact ratio 2.7); now refused."""
    out = tmp_path / "o"
    assert main(["stiffness", "--preset", "helical-dct", "--n-slices", "1", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "--n-slices: got 1; allowed: an integer in [13, 20000] for the helical pair helical-dct" in err
    assert not out.exists()
    with pytest.raises(InputError) as exc:
        Case(pair=HEL, operating=OperatingPoint(1500.0, 50.0), duration_s=0.1, fs_hz=12800.0,
             stiffness=StiffnessOptions(n_slices=4))
    assert exc.value.field == "stiffness.n_slices" and exc.value.value == 4


def test_default_slices_of_a_narrow_pit_map_reach_the_minimum():
    """A pit map of 8 face columns on a helical flank is sampled by 13 slices (it gave 8)."""
    pits = make_pit_map(HEL.flank_grid("pinion", 16, 8), shape="ellipse", severity=0.2, teeth=[0])
    assert st.mesh_stiffness(HEL, pits=pits, positions_per_cycle=16).n_slices == 13


# ------------------------------------------------------------------ memory (defect: 100000 positions -> OOM killer)
@pytest.mark.parametrize("pair, n_slices, teeth, gear", [
    (HEL, 100, (), "pinion"), (HEL, 200, (0, 7), "pinion"), (HEL, 60, (0, 3, 7, 9), "pinion"),
    (SPUR, 1, (), "pinion"), (SPUR, 120, (0, 5), "wheel")])
def test_record_bytes_bounds_the_measured_peak(pair, n_slices, teeth, gear):
    """The estimate is above the peak that tracemalloc measures (numpy reports its arrays to it), and within a
    factor 2.5 of it (it must not refuse what fits)."""
    pits = None
    if teeth:
        grid = pair.flank_grid(gear, 32, n_slices)
        pits = make_pit_map(grid, shape="ellipse", severity=0.2, teeth=list(teeth), gear=gear)
    st._HEALTHY.clear()
    tracemalloc.start()
    try:
        st.mesh_stiffness(pair, pits=pits, positions_per_cycle=512, n_slices=n_slices)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    est = st.record_bytes(pair, 512, n_slices, {gear: len(teeth)})
    assert peak < est < 2.5 * peak, (peak, est)


def test_largest_count_is_accepted_and_one_more_refused():
    """The count the error names fits the budget; one more does not (the estimate is linear in positions)."""
    pitted = {"pinion": 2}
    per_position = st.record_bytes(HEL, 1, 1000, pitted) - st.RECORD_FIXED_BYTES
    top = int((st.STIFFNESS_BUDGET_BYTES - st.RECORD_FIXED_BYTES) // per_position)
    st.require_record_fits(HEL, top, 1000, pitted)
    with pytest.raises(InputError, match=f"an integer in \\[4, {top}\\]"):
        st.require_record_fits(HEL, top + 1, 1000, pitted)
    st.require_record_fits(SPUR, 4096, 1)      # the band's largest automatic count, spur: 11 MB


def test_too_many_positions_refused_before_work_with_the_largest_that_fits(tmp_path, capsys, monkeypatch):
    """`--positions-per-cycle 100000` with pits allocated 24 GB; now refused, naming the largest count that fits
    the 2 GB budget, on the CLI and in a case file."""
    calls = []
    monkeypatch.setattr(st, "_mesh_stiffness", lambda *a, **k: calls.append(a))
    pits = tmp_path / "pits.toml"
    pits.write_text('[pits]\nshape = "ellipse"\nteeth = [0, 7]\nseverity = 0.2\n')
    out = tmp_path / "o"
    assert main(["stiffness", "--preset", "helical-dct", "--pits", str(pits), "--positions-per-cycle", "100000",
                 "--out", str(out)]) == 2
    err = capsys.readouterr().err
    per_position = st.record_bytes(HEL, 1, 1000, {"pinion": 2}) - st.RECORD_FIXED_BYTES
    top = int((st.STIFFNESS_BUDGET_BYTES - 2 * st.RECORD_FIXED_BYTES) // (2 * per_position))
    assert f"--positions-per-cycle: got 100000; allowed: an integer in [4, {top}]" in err and "budget 2 GB" in err
    assert not out.exists() and not calls
    with pytest.raises(InputError) as exc:
        Case.from_dict({"duration_s": 0.1, "fs_hz": 12800.0, "pair": {"preset": "helical-dct"},
                        "operating": {"speed_rpm": 1500.0, "torque_nm": 50.0},
                        "stiffness": {"positions_per_cycle": 100000},
                        "pits": {"grid": [64, 1000], "shape": "ellipse", "teeth": [0], "severity": 0.2}})
    assert exc.value.field == "stiffness.positions_per_cycle" and exc.value.value == 100000
    per_position = st.record_bytes(HEL, 1, 1000, {"pinion": 1}) - st.RECORD_FIXED_BYTES
    top = int((st.STIFFNESS_BUDGET_BYTES - st.RECORD_FIXED_BYTES) // per_position)
    assert exc.value.allowed.startswith(f"an integer in [4, {top}]")
    with pytest.raises(InputError, match="positions_per_cycle"):
        st.mesh_stiffness(HEL, positions_per_cycle=100000, n_slices=2000)
