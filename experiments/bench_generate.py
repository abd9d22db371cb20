"""Dataset generation throughput: signals per second with 1 and 2 local workers.

Generates ``experiments/sweeps/bench.toml`` (one-second signals at 12.8 kHz,
every class family, nuisance effects, 112 samples in 4 shards) into a
temporary directory, once on a 2-process pool and once in-process (1 worker),
checks that both runs wrote identical bytes, and reports the rates. The pool
runs first, from a parent that has run no simulation yet (as ``gearpit
generate`` does: its compiled kernels are loaded by the workers, not inherited).
The reference is the 1-worker rate measured in the same run (ratio = parallel
speed-up). Target (issue 4): >= 20 signals/s on 2 cores.

Run: ``python3 experiments/bench_generate.py [--sweep FILE]``; the last line is JSON.
"""
from __future__ import annotations

import argparse
import hashlib
import json
import os
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
TARGET = 20.0


def digest(path: Path) -> str:
    h = hashlib.sha256()
    for p in sorted(path.rglob("*")):
        if p.is_file():
            h.update(str(p.relative_to(path)).encode())
            h.update(p.read_bytes())
    return h.hexdigest()


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sweep", type=Path, default=HERE / "sweeps" / "bench.toml")
    args = ap.parse_args()
    from datagen.generate import generate
    from datagen.sweep import load_sweep

    sweep = load_sweep(args.sweep)
    load = os.getloadavg()[0]
    rates, cpu_rates, digests = {}, {}, {}
    with tempfile.TemporaryDirectory() as tmp:
        for workers in (2, 1):
            out = Path(tmp) / f"w{workers}"
            t0 = time.perf_counter()
            report = generate(sweep, out, workers=workers, progress=False)
            dt = time.perf_counter() - t0
            rates[workers] = sweep.n_samples / dt
            cpu_rates[workers] = sweep.n_samples / report.cpu_seconds
            digests[workers] = digest(out)
            print(f"{workers} worker(s): {sweep.n_samples} signals of {sweep.duration_s:g} s at {sweep.fs_hz:g} Hz "
                  f"in {dt:.1f} s wall = {rates[workers]:.2f} signals/s; {report.cpu_seconds:.1f} s worker CPU = "
                  f"{cpu_rates[workers]:.2f} signals per CPU-second", flush=True)
    identical = digests[1] == digests[2]
    ratio = rates[2] / rates[1]
    per_core = sweep.n_samples * 2 / (sweep.n_samples / cpu_rates[1] + sweep.n_samples / cpu_rates[2])
    print(f"2 workers / 1 worker (wall) = {ratio:.2f}x; identical bytes: {identical}; cores: {os.cpu_count()}, "
          f"load average at start {load:.1f}")
    print(f"compute-bound estimate for 2 idle cores: {2 * per_core:.2f} signals/s; target >= {TARGET:g} on 2 cores: "
          f"{'met' if rates[2] >= TARGET else 'NOT met'} (measured wall rate)")
    print(json.dumps({"signals_per_second": round(rates[2], 3), "signals_per_second_1_worker": round(rates[1], 3),
                      "ratio_2_to_1_workers": round(ratio, 3), "signals_per_cpu_second": round(per_core, 3),
                      "estimate_2_idle_cores": round(2 * per_core, 3), "load_average_at_start": round(load, 2),
                      "n_signals": sweep.n_samples, "duration_s": sweep.duration_s, "fs_hz": sweep.fs_hz,
                      "identical_bytes": identical, "target_signals_per_second": TARGET,
                      "target_met": rates[2] >= TARGET}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
