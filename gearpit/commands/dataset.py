"""``gearpit dataset info DIR``: what a generated dataset holds.

Class counts (severity class x teeth class x shape, per pair), the range of
every numeric index column with its unit, progress (finished shards) and the
size on disk.
"""
from __future__ import annotations

import json
from pathlib import Path


def register(sub) -> None:
    p = sub.add_parser("dataset", help="inspect a generated dataset (info)", description=__doc__)
    actions = p.add_subparsers(dest="action", metavar="ACTION", parser_class=type(p))
    actions.required = True
    info = actions.add_parser("info", help="class counts, parameter ranges, size on disk")
    info.add_argument("dir", type=Path, metavar="DIR", help="dataset directory")
    info.add_argument("--json", action="store_true", help="print the summary as JSON")
    info.set_defaults(func=run)


def run(args) -> int:
    from datagen.dataset import dataset_info

    info = dataset_info(args.dir)
    if args.json:
        print(json.dumps(info, indent=1))
        return 0
    print(format_info(info))
    return 0


def format_info(info: dict) -> str:
    """Human-readable form of :func:`datagen.dataset.dataset_info`."""
    lines = [f"dataset {info['path']}: sweep '{info['name']}', seed {info['seed']}, gearpit {info['software']['gearpit']}",
             f"  samples {info['n_finished']}/{info['n_samples']} ({info['finished_shards']}/{info['n_shards']} shards)"
             f", {info['n_classes']} classes x {info['samples_per_class']}",
             f"  signals: {', '.join(info['channels'])}; {info['n_time']} samples at {info['fs_hz']:g} Hz float32",
             f"  size on disk: {info['size_bytes'] / 1e6:.2f} MB"]
    for shard, damage in info.get("damaged_shards", {}).items():
        lines.append(f"  DAMAGED shard {shard}: {damage} (generate the dataset again)")
    lines += ["", "class counts (pair / severity / teeth / shape):"]
    for key, n in info["class_counts"].items():
        lines.append(f"  {key:<48} {n}")
    lines += ["", "parameter ranges:"]
    for col, r in info["ranges"].items():
        lines.append(f"  {col:<48} {r['min']:<12.6g} .. {r['max']:<12.6g} {r['unit']}")
    return "\n".join(lines)
