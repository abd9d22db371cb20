"""Run a sweep: compute shards (in-process, on a local process pool or on Dask) and store them.

A shard is a pure function of (sweep, shard index) (:func:`compute_shard`);
workers only compute and return arrays, and this process writes every file,
so Dask workers need no shared file system and a killed worker never leaves a
half-written file. A restarted run skips the finished shards
(:func:`datagen.dataset.open_for_writing`). Each shard's samples go to the
orchestrator :func:`datagen.simulate.simulate` in one call, which batches
cases that share a time grid.

BLAS threads are limited to one per worker (``threadpoolctl``): the cores are
used by the workers, and the bytes do not depend on the thread count.
"""
from __future__ import annotations

import multiprocessing
import sys
import threading
import time
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from datagen import dataset
from datagen.sampling import build_pit_map, draw_sample, healthy_twin, sample_row
from datagen.sweep import Sweep
from gearpit.errors import require


#: index column: the codes of the sample's simulation warnings (:mod:`datagen.plausibility`), comma-separated;
#: "" for a plausible record
WARNINGS_COLUMN = "simulation_warnings"


@dataclass(frozen=True)
class ShardResult:
    """What a worker returns: signals (n, n_channels, n_time) float32, index rows, mask rows, timings (s)."""

    shard: int
    signals: np.ndarray
    rows: list
    masks: list
    seconds: float
    cpu_seconds: float


def simulate_batch(cases: list, channels=None) -> list:
    """The one call into the simulator (:func:`datagen.simulate.simulate`), vectorised over ``cases``; only
    ``channels`` are made (each the same to the bit as among all)."""
    from datagen.simulate import simulate

    return simulate(cases, channels=channels)


def build_case(sweep: Sweep, spec, pit_map):
    """The :class:`datagen.simulate.Case` of one sample."""
    from datagen.effects import get
    from datagen.lumped_model import DriveTrain
    from datagen.simulate import Case, OperatingPoint

    effects = tuple(get(name)(**dict(values)) for name, values in spec.effects)
    return Case(pair=sweep.pair(spec.key.pair), operating=OperatingPoint(spec.speed_rpm, spec.torque_nm),
                duration_s=sweep.duration_s, fs_hz=sweep.fs_hz, pits=pit_map if spec.teeth else None,
                pit_gear=sweep.gear, pit_grid=sweep.grid_px, effects=effects, seed=spec.simulation_seed,
                drivetrain=DriveTrain(**dict(spec.drive_train)), stiffness=sweep.stiffness)


def shard_samples(sweep: Sweep, shard: int) -> range:
    return range(shard * sweep.shard_size, min((shard + 1) * sweep.shard_size, sweep.n_samples))


def compute_shard(sweep: Sweep, shard: int) -> ShardResult:
    """Draw, build and simulate every sample of one shard (pure: same inputs, same bytes). The sweep's plugin files
    are loaded first where this process has not loaded them (a ``forkserver`` or Dask worker), checked against the
    digests the run began with."""
    from threadpoolctl import threadpool_limits

    from datagen.effects.registry import ensure_plugin

    for path, sha in sweep.plugins:
        ensure_plugin(path, sha)
    t0, c0 = time.perf_counter(), time.process_time()
    with threadpool_limits(1):
        specs = [draw_sample(sweep, i) for i in shard_samples(sweep, shard)]
        maps = [build_pit_map(sweep, s) for s in specs]
        signals = simulate_batch([build_case(sweep, s, m) for s, m in zip(specs, maps)], sweep.channels)
        if sweep.healthy_reference:
            # each sample's healthy twin, in a batch of their own: a batch shares its solver passes (they stop
            # when every case of the batch has converged), so with the twins beside them the records would move
            # (~1e-3 of their RMS) from what the sweep without twins stores
            signals += simulate_batch([build_case(sweep, healthy_twin(sweep, s), None) for s in specs], sweep.channels)
    n_ch = len(sweep.channels)
    out = np.empty((len(specs), len(sweep.stored_channels), sweep.n_time), np.float32)
    for k, sig in enumerate(signals):
        j, twin = k % len(specs), k // len(specs)
        for c, name in enumerate(sweep.channels):
            x = sig.channels[name]
            require(x.size == sweep.n_time, f"sample {specs[j].index} {name}", x.size, f"{sweep.n_time} samples")
            out[j, c + twin * n_ch] = x
    bad = ~np.isfinite(out).all(axis=(1, 2))
    require(not bad.any(), "samples", [specs[j].index for j in np.nonzero(bad)[0]],
            "finite signals (the simulation of these samples diverged)")
    rows = [sample_row(sweep, s, m) for s, m in zip(specs, maps)]
    for row, sig in zip(rows, signals):   # the sample's own record (not its healthy twin's)
        row[WARNINGS_COLUMN] = ",".join(sorted({w["code"] for w in sig.metadata["warnings"]}))
    masks = [{"sample_index": s.index, "tooth": t, "rows": sweep.grid_px[0], "cols": sweep.grid_px[1],
              "mask_packbits_zlib": dataset.encode_mask(m.mask(t))} for s, m in zip(specs, maps) for t in s.teeth]
    return ShardResult(shard, out, rows, masks, time.perf_counter() - t0, time.process_time() - c0)


@dataclass(frozen=True)
class RunReport:
    """What a run did: shards computed now and earlier, samples, wall time and the workers' CPU time (s), and
    the samples computed now whose simulation warned (:data:`WARNINGS_COLUMN`): ``flagged`` of
    ``computed_samples``, ``warnings`` per code."""

    out: Path
    n_shards: int
    computed: int
    skipped: int
    n_samples: int
    seconds: float
    cpu_seconds: float
    computed_samples: int = 0
    flagged: int = 0
    warnings: dict = field(default_factory=dict)


class Progress:
    """Progress line with rate and ETA on stderr (redrawn on a terminal, every ``every_s`` otherwise)."""

    def __init__(self, total: int, done: int = 0, *, enabled: bool = True, every_s: float = 5.0, stream=None):
        self.total, self.done, self.start_done = total, done, done
        self.enabled, self.every_s = enabled, every_s
        self.stream = stream or sys.stderr
        self.t0 = self.last = time.monotonic()
        self.tty = hasattr(self.stream, "isatty") and self.stream.isatty()

    def update(self, n: int) -> None:
        self.done += n
        now = time.monotonic()
        if self.enabled and (self.tty or now - self.last >= self.every_s or self.done == self.total):
            self.last = now
            rate = (self.done - self.start_done) / max(now - self.t0, 1e-9)
            eta = (self.total - self.done) / rate if rate > 0 else float("inf")
            eta_s = time.strftime("%H:%M:%S", time.gmtime(eta)) if np.isfinite(eta) else "--:--:--"
            bar = "#" * int(30 * self.done / max(self.total, 1))
            line = f"generate [{bar:<30}] {self.done}/{self.total} samples  {rate:.1f}/s  ETA {eta_s}"
            print(("\r" + line) if self.tty else line, end="" if self.tty else "\n", file=self.stream, flush=True)

    def close(self) -> None:
        if self.enabled and self.tty:
            print(file=self.stream)


def generate(sweep: Sweep, out: str | Path, *, workers: int = 1, dask_address: str | None = None,
             dask_local_workers: int | None = None, progress: bool = True, max_shards: int | None = None) -> RunReport:
    """Generate (or resume) the dataset of ``sweep`` in directory ``out``.

    Parameters
    ----------
    sweep : Sweep
    out : str or Path
        Dataset directory (created; an existing run of the same sweep is resumed).
    workers : int
        Local worker processes (1: in this process).
    dask_address : str, optional
        Scheduler address (``tcp://host:8786``): run the shards on that Dask cluster.
    dask_local_workers : int, optional
        Start a Dask ``LocalCluster`` with this many single-threaded worker processes.
    progress : bool
        Progress line with ETA on stderr.
    max_shards : int, optional
        Stop after computing this many shards (the dataset stays resumable).

    Returns
    -------
    RunReport

    Examples
    --------
    >>> from datagen.sweep_examples import demo_sweep
    >>> generate(demo_sweep(), "gearpit_out/dataset", workers=2).n_samples     # doctest: +SKIP
    12
    """
    require(isinstance(workers, int) and workers >= 1, "--workers", workers, "an integer >= 1")
    require(dask_address is None or dask_local_workers is None, "--dask/--dask-local", (dask_address,
            dask_local_workers), "at most one of them")
    if dask_local_workers is not None:
        require(isinstance(dask_local_workers, int) and dask_local_workers >= 1, "--dask-local",
                dask_local_workers, "an integer >= 1")
    t0 = time.monotonic()
    done = dataset.open_for_writing(out, sweep)
    todo = [k for k in range(sweep.n_shards) if k not in done]
    if max_shards is not None:
        todo = todo[:max_shards]
    already = sum(len(shard_samples(sweep, k)) for k in done)
    bar = Progress(sweep.n_samples, already, enabled=progress)
    if dask_address is not None or dask_local_workers is not None:
        results = _run_dask(sweep, todo, dask_address, dask_local_workers)
    elif workers == 1 or len(todo) <= 1:
        results = (compute_shard(sweep, k) for k in todo)
    else:
        results = _run_pool(sweep, todo, workers)
    computed, cpu, n_rows, flagged, warnings = 0, 0.0, 0, 0, {}
    try:
        for res in results:
            dataset.write_shard(out, res.shard, res.signals, res.rows, res.masks)
            computed += 1
            cpu += res.cpu_seconds
            n_rows += len(res.rows)
            for row in res.rows:
                codes = [c for c in row[WARNINGS_COLUMN].split(",") if c]
                flagged += bool(codes)
                for c in codes:
                    warnings[c] = warnings.get(c, 0) + 1
            bar.update(len(res.rows))
    finally:  # stopped while writing a shard: stop the workers now, not when the traceback is freed
        if hasattr(results, "close"):
            results.close()
        bar.close()
    if len(dataset.finished_shards(out)) == sweep.n_shards:
        dataset.finalize(out)
    return RunReport(Path(out), sweep.n_shards, computed, len(done), sweep.n_samples, time.monotonic() - t0, cpu,
                     n_rows, flagged, dict(sorted(warnings.items())))


def pool_context() -> multiprocessing.context.BaseContext:
    """How the pool's workers start: ``fork`` where that is safe, else ``forkserver``.

    A forked worker has the simulator already imported (1.4 s of imports per
    pool otherwise, a quarter of a 2-worker run of ``experiments/sweeps/bench.toml``).
    Forking is safe from a Linux parent that runs no other Python thread and
    has not loaded torch (whose OpenMP pool does not survive a fork); the
    executor starts every forked worker before its own manager thread. Any
    other parent (a notebook with torch, a Dask client's threads, macOS) gets
    workers forked from a fresh server process that imports the simulator once
    (``forkserver``). Both give the same bytes (the shards are pure functions).
    """
    if sys.platform == "linux" and threading.active_count() == 1 and "torch" not in sys.modules:
        return multiprocessing.get_context("fork")
    ctx = multiprocessing.get_context("forkserver")
    ctx.set_forkserver_preload(["datagen.generate", "datagen.simulate"])
    return ctx


def _run_pool(sweep: Sweep, todo: list[int], workers: int):
    """Shards on a local process pool (:func:`pool_context`); at most ``2 * workers`` in flight (memory stays
    bounded).

    The workers ignore Ctrl-C and die with this process (:func:`gearpit.interrupt.reset_in_worker`). Stopped
    early (an error, Ctrl-C, SIGTERM under the command line, the caller closing this generator), it terminates
    the workers and drops their shards: a worker left running would block for ever writing its result into a
    pipe nobody reads (~230 MB each on ``sw2.toml``).
    """
    from gearpit.interrupt import reset_in_worker

    pool = ProcessPoolExecutor(max_workers=workers, mp_context=pool_context(), initializer=reset_in_worker)
    finished_all = False
    try:
        pending, queue = set(), list(todo)
        while queue or pending:
            while queue and len(pending) < 2 * workers:
                pending.add(pool.submit(compute_shard, sweep, queue.pop(0)))
            finished, pending = wait(pending, return_when=FIRST_COMPLETED)
            for f in sorted(finished, key=lambda f: f.result().shard):
                yield f.result()
        finished_all = True
    finally:
        if not finished_all:
            _terminate_workers(pool)
        pool.shutdown(wait=True, cancel_futures=True)


def _terminate_workers(pool: ProcessPoolExecutor) -> None:
    """SIGTERM every live worker of ``pool`` and reap it (the executor has no public call for this before
    Python 3.14's ``terminate_workers``)."""
    procs = list((getattr(pool, "_processes", None) or {}).values())
    for p in procs:
        if p.is_alive():
            p.terminate()
    for p in procs:
        p.join(timeout=5.0)
        if p.is_alive():
            p.kill()
            p.join()


def _run_dask(sweep: Sweep, todo: list[int], address: str | None, local_workers: int | None):
    """Shards on a Dask cluster (an address, or a LocalCluster started and closed here)."""
    from distributed import Client, LocalCluster, as_completed

    cluster = None
    if address is None:
        cluster = LocalCluster(n_workers=local_workers, threads_per_worker=1, processes=True,
                               dashboard_address=None)
        client = Client(cluster)
    else:
        client = Client(address)
    try:
        futures = [client.submit(compute_shard, sweep, k, pure=False) for k in todo]
        for fut in as_completed(futures):
            res = fut.result()
            fut.release()
            yield res
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
