"""The pair check of ``gearpit compare`` (:mod:`compare.pair_check`) on every simulated rig the project has.

Each rig is described by its own pair: the hidden-effect rigs (:data:`compare.synthetic.HIDDEN_EXAMPLES`) on the
test rig and on the two other drive trains of :data:`compare.synthetic.OTHER_RIGS`, the independent simulator's
cases (``experiments/foreign_rig_check.py``) and the unseen rigs (``experiments/unseen_rigs_check.py``). Printed
per rig: questioned (no mesh line where the comparison reads it), other_family (a decisive sideband comb at a count
that is no shaft of the pair), the mesh-line score (dB) and the comb's count and contrast, and the speed drift
read from the mesh phase when the tachometer is left out (:func:`compare.speed_track.drift_track`). None should be
questioned and none tracked (their mean speed is constant); other_family marks the rigs whose fluctuation (or
rattle) makes a comb of its own.

Run: ``python experiments/pair_check_scan.py`` (~1 min); the last line is JSON.
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "tests"), str(ROOT / "experiments")]

from compare.pair_check import check_pair  # noqa: E402
from compare.speed import refine_speed  # noqa: E402
from compare.synthetic import HIDDEN_EXAMPLES, OTHER_RIGS, hidden_effect_measurement, rig_measurement  # noqa: E402


def measurements():
    from foreign_rig import ForeignRig, foreign_measurement
    from foreign_rig_check import FOREIGN_CASES
    from unseen_rigs_check import CASES

    for name, ex in HIDDEN_EXAMPLES.items():
        yield f"test rig {name}", hidden_effect_measurement(name)[0]
        for rig, (base, less_db) in OTHER_RIGS.items():
            rig_kw = {**base, "snr_db": ex.snr_db - less_db}
            yield f"{rig} {name}", hidden_effect_measurement(name, seed=11, **rig_kw)[0]
    for name, (over, _, _) in FOREIGN_CASES.items():
        yield f"foreign {name}", foreign_measurement(ForeignRig(seed=5, **over))
    for name, (kw, _) in CASES.items():
        kw = dict(kw)
        yield f"unseen {name}", rig_measurement(kw.pop("effects", ()), **kw)


def without_tacho(m):
    """The measurement without its tachometer channel (the speed then comes from the spectrum, and its drift from
    the mesh phase: compare.speed_track.drift_track)."""
    import dataclasses

    from compare.measurement import measurement_from_arrays

    if m.tacho is None:
        return m
    sc = dataclasses.replace(m.sidecar, tacho=None)
    return measurement_from_arrays({k: v for k, v in m.channels.items() if k != m.tacho}, sc, source=m.source)


def main() -> int:
    rows = []
    for tag, m in measurements():
        c = check_pair(m, refine_speed(m))
        free = without_tacho(m)
        sp = refine_speed(free)
        rows.append({"rig": tag, **{k: c[k] for k in ("questioned", "other_family", "mesh_family_db", "z_measured",
                                                      "score_db")}, "drift_rad": sp.drift_rad, "tracked": sp.tracked})
        sc = "-" if c["score_db"] is None else f"{c['score_db']:.1f}"
        print(f"{tag:48s} questioned={c['questioned']!s:5} other_family={c['other_family']!s:5} "
              f"mesh line {c['mesh_family_db']:5.1f} dB  comb z={c['z_measured']} ({sc} dB)  "
              f"drift {sp.drift_rad:.3f} rad tracked={sp.tracked}", flush=True)
    summary = {"rigs": len(rows), "questioned": sum(r["questioned"] for r in rows),
               "other_family": sum(r["other_family"] for r in rows),
               "min_mesh_line_db": min(r["mesh_family_db"] for r in rows),
               "tracked_without_tacho": sum(r["tracked"] for r in rows)}
    print(json.dumps(summary))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
