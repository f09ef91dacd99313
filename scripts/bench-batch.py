#!/usr/bin/env python3
"""Batch throughput, 1 worker against 2: the twelve real takes of the batch tests (ten good,
two broken), with longer sequences, run by rigfit.run_batch (threads in one process) and by
rigfit.cluster on a local Dask cluster (worker processes). Each take's solver uses one
thread (RAYON_NUM_THREADS=1), so the workers are the only parallelism.

    RIGFIT_DATA=../shared/data target/py-venv/bin/python scripts/bench-batch.py [FRAMES] [ROUNDS]
"""

import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

os.environ["RAYON_NUM_THREADS"] = "1"
REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "python" / "tests"))

import batch_takes  # noqa: E402
import rigfit  # noqa: E402


def asset(rel: str) -> Path:
    return Path(os.environ.get("RIGFIT_DATA", REPO.parent / "shared" / "data")) / rel


def main() -> None:
    frames = int(sys.argv[1]) if len(sys.argv) > 1 else 20
    rounds = int(sys.argv[2]) if len(sys.argv) > 2 else 3
    work = Path(tempfile.mkdtemp(prefix="rigfit-bench-batch-"))
    inputs = batch_takes.make_inputs(asset, work / "inputs", frames=frames)
    jobs = batch_takes.write_jobs(work / "jobs.json", batch_takes.takes(asset, inputs, "out"))
    (work / "out").mkdir()
    print(f"{len(batch_takes.takes(asset, inputs, 'out'))} takes, {frames} frames per sequence, {rounds} rounds, "
          f"{os.cpu_count()} cores")

    def local(workers: int) -> float:
        t0 = time.perf_counter()
        report = rigfit.run_batch(jobs, workers=workers)
        assert report["done"] == 10, report
        return time.perf_counter() - t0

    rows = []
    for workers in (1, 2):
        times = [local(workers) for _ in range(rounds)]
        rows.append((f"rigfit.run_batch, {workers} thread(s)", times))

    import dask
    import distributed
    from rigfit import cluster

    for workers in (1, 2):
        with dask.config.set({"distributed.scheduler.allowed-failures": 0}):
            with distributed.LocalCluster(
                n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None
            ) as c, distributed.Client(c) as client:
                # Warm the workers (their first import of rigfit).
                client.run(lambda: __import__("rigfit") and None)
                times = []
                for _ in range(rounds):
                    t0 = time.perf_counter()
                    report = cluster.run_batch(jobs, client, progress=False)
                    assert report["done"] == 10, report
                    times.append(time.perf_counter() - t0)
        rows.append((f"rigfit.cluster, local Dask, {workers} worker process(es)", times))

    print(f"{'runner':<52} {'median s':>9} {'takes/min':>10}  rounds")
    for name, times in rows:
        median = statistics.median(times)
        print(f"{name:<52} {median:9.2f} {12 / median * 60:10.1f}  " + " ".join(f"{t:.2f}" for t in times))


if __name__ == "__main__":
    main()
