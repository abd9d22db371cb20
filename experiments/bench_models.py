"""Benchmark of the classifiers: CNN training time on the default dataset and inference throughput.

Run: ``python experiments/bench_models.py`` (the default dataset, ``experiments/models_sweeps/default*.toml``,
is generated into ``experiments/out/models/data`` first if it is not there: ~5 min).

- training: the CNN with the protocol's configuration (a CNN variant of ``classifier_runs.VARIANTS``,
  default ``tsa``: representation and side inputs; the default :class:`models.train.TrainConfig`: at
  most 150 epochs, early stopping) on the whole default dataset; target < 5 min on 2 cores;
- inference: ``CNNClassifier.predict`` (representation + network, 1 and 3 test-time crops) on 1024
  records, with one worker thread and with two (each worker represents and classifies its own batches with
  one torch thread; the predictions are the same); target >= 500 signals/s with 3 crops on the 2 cores;
- reference measured in the same run: computing the representation alone (numpy FFTs), the floor
  of any model that uses it. Ratios are against it.

The last line is a JSON object.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from models.representations import represent  # noqa: E402
from models.train import TrainConfig, train_cnn  # noqa: E402

TRAIN_TARGET_S = 300.0
THROUGHPUT_TARGET = 500.0


sys.path.insert(0, str(ROOT / "experiments"))
from classifier_runs import VARIANTS as PROTOCOL_VARIANTS, dataset  # noqa: E402
from reference_check import VARIANTS as REFERENCE_VARIANTS  # noqa: E402
from sensor_protocol_design import SENSOR_VARIANTS  # noqa: E402

#: CNN variants of both protocols (representation + side inputs)
VARIANTS = {**PROTOCOL_VARIANTS, **SENSOR_VARIANTS, **REFERENCE_VARIANTS}


def default_dataset(data_dir: Path, channel: str | None = None, name: str = "default"):
    return dataset(name, data_dir, channel=channel)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data-dir", type=Path, default=ROOT / "experiments" / "out" / "models" / "data")
    ap.add_argument("--variant", default="tsa", choices=tuple(VARIANTS),
                    help="CNN variant of experiments/eval_protocol.py or sensor_protocol.py (representation + side "
                         "inputs; tsa_te: the transmission-error model)")
    ap.add_argument("--threads", type=int, default=1, choices=(1, 2), help="torch threads of the training")
    ap.add_argument("--dataset", default="default",
                    help="sweep of experiments/models_sweeps/ (with its _healthy part), e.g. default_pitch_ref for "
                         "the variants read against a reference (experiments/reference_check.py)")
    ap.add_argument("--channel", default=None,
                    help="stored channel of the default dataset (default: the first, the housing accelerometer; "
                         "dte_m: the transmission error, experiments/sensor_protocol.py)")
    args = ap.parse_args(argv)
    import torch

    torch.set_num_threads(args.threads)
    data = default_dataset(args.data_dir, args.channel, args.dataset)
    rep, side = VARIANTS[args.variant]
    records = (lambda d: d.paired_signals()) if rep.reference else (lambda d: d.signals)
    print(f"{args.dataset} dataset: {len(data)} records x {data.n_samples} samples at {data.fs_hz:g} Hz, channel {data.channel}")

    # reference: the representation alone, once over the training records
    t0 = time.perf_counter()
    represent(records(data), rep, fs_hz=data.fs_hz, shaft_hz=data.shaft_hz(), z_pinion=data.pair.z_pinion,
              z_wheel=data.pair.z_wheel, starts=0.5)
    t_rep = time.perf_counter() - t0

    cfg = TrainConfig(representation=rep, seed=0, threads=args.threads, operating_inputs=side)
    t0 = time.perf_counter()
    model = train_cnn(data, cfg)
    t_train = time.perf_counter() - t0
    tr = model.spec.training
    print(f"training: {t_train:.1f} s ({tr['epochs_run']} epochs, best {tr['best_epoch']}, "
          f"{tr['n_parameters']} parameters, val acc {tr['val_accuracy']:.3f}, teeth {tr['val_teeth_accuracy']:.3f}); "
          f"target < {TRAIN_TARGET_S:.0f} s")
    print(f"reference: one pass of the representation over the dataset {t_rep:.2f} s; training = {t_train / t_rep:.0f}x that")

    n = 1024
    idx = np.arange(n) % len(data)
    batch = data.subset(idx)
    model.predict(batch.subset(np.arange(32)), n_crops=1)  # warm-up
    rates = {}
    for workers in (1, 2):
        for crops in (1, 3):
            t0 = time.perf_counter()
            model.predict(batch, n_crops=crops, threads=workers)
            rates[workers, crops] = n / (time.perf_counter() - t0)
    t0 = time.perf_counter()
    represent(records(batch), rep, fs_hz=batch.fs_hz, shaft_hz=batch.shaft_hz(), z_pinion=batch.pair.z_pinion,
              z_wheel=batch.pair.z_wheel, starts=0.5)
    ref_rate = n / (time.perf_counter() - t0)
    for workers in (1, 2):
        print(f"inference, {workers} worker thread{'s' if workers > 1 else ''}: {rates[workers, 1]:.0f} signals/s "
              f"(1 crop), {rates[workers, 3]:.0f} signals/s (3 crops, the CLI default); target >= "
              f"{THROUGHPUT_TARGET:.0f} on the 2 cores")
    print(f"reference: representation alone {ref_rate:.0f} signals/s (one thread); predict (1 crop, 1 worker) runs "
          f"at {rates[1, 1] / ref_rate:.2f} of it")
    result = {"benchmark": "models", "dataset": args.dataset, "variant": args.variant, "channel": data.channel, "representation": rep.kind,
              "side_inputs": list(side), "train_threads": args.threads, "n_records": len(data),
              "train_seconds": round(t_train, 1), "epochs": tr["epochs_run"], "n_parameters": tr["n_parameters"],
              "train_target_seconds": TRAIN_TARGET_S, "train_ok": t_train < TRAIN_TARGET_S,
              "signals_per_second_1crop": round(rates[1, 1], 1), "signals_per_second_3crops": round(rates[1, 3], 1),
              "signals_per_second_1crop_2workers": round(rates[2, 1], 1),
              "signals_per_second_3crops_2workers": round(rates[2, 3], 1),
              "throughput_target": THROUGHPUT_TARGET, "throughput_ok": rates[2, 3] >= THROUGHPUT_TARGET,
              "reference_representation_seconds": round(t_rep, 2), "train_over_reference": round(t_train / t_rep, 1),
              "reference_signals_per_second": round(ref_rate, 1),
              "predict_over_reference": round(rates[1, 1] / ref_rate, 3)}
    print(json.dumps(result))
    return 0


if __name__ == "__main__":
    sys.exit(main())
