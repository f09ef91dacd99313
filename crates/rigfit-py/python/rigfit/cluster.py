"""Run a job file's takes on a Dask distributed cluster, one task per take.

Each take runs on a worker through ``rigfit.run_take`` (the command line's own code), so
its inputs are read where the worker runs and its outputs are written there, atomically.
Workers need the rigfit wheel installed and must see the job file's paths (a shared file
system). A take that fails, or whose worker dies, is run once more; a take that fails
again is reported with its one-line error and never dropped silently.

Start a scheduler and workers (``dask scheduler``; ``dask worker tcp://HOST:8786
--nthreads 1`` on each machine), then::

    from rigfit.cluster import run_batch
    report = run_batch("takes.json", "tcp://HOST:8786", report="takes-report.json")

Pinned engine: ``distributed==2026.8.0`` (``pip install "distributed==2026.8.0"``).
"""

from __future__ import annotations

import json
import os
import sys
import tempfile
import time
import uuid
from collections.abc import Callable
from pathlib import Path
from typing import Any

import rigfit

__all__ = ["run_batch", "run_take_task"]

#: How many times a take runs at most: once, and once more if it fails or its worker dies.
ATTEMPTS = 2


def run_take_task(take: dict[str, Any], base_dir: str) -> dict[str, Any]:
    """The task a worker runs for one take: ``rigfit.run_take`` plus where it ran."""
    import socket

    result = rigfit.run_take(take, base_dir)
    result["worker"] = f"{socket.gethostname()}:{os.getpid()}"
    return result


def _one_line(error: BaseException) -> str:
    """A task's failure as one line: rigfit's own message, or what befell the worker."""
    name = type(error).__name__
    if name == "KilledWorker":
        text = "the worker running it died"
    elif isinstance(error, rigfit.RigfitError):
        text = str(error)
        # run_take prefixes the take's name; the report has it already.
        if text.startswith("take '") and "': " in text:
            text = text.split("': ", 1)[1]
    else:
        text = f"{name}: {error}"
    return " ".join(text.split())


def _write_atomic(path: Path, text: str) -> None:
    """Writes ``text`` to ``path`` through a temporary file renamed into place."""
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent or ".")
    try:
        with os.fdopen(fd, "w") as f:
            f.write(text)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def run_batch(
    jobs: str | os.PathLike[str],
    client: Any,
    *,
    report: str | os.PathLike[str] | None = None,
    progress: bool = True,
    task: Callable[[dict[str, Any], str], dict[str, Any]] | None = None,
) -> dict[str, Any]:
    """Runs every take of the job file ``jobs`` on a Dask cluster and returns the summary
    report (the same fields as ``rigfit batch --report``, plus each take's ``attempts``
    and ``worker``). ``client``: a ``distributed.Client`` or a scheduler address.
    ``report``: also write the report there (atomically). ``progress``: a line on stderr
    per finished take. ``task``: what a worker runs per take (default
    ``run_take_task``; it must be importable on the workers). The job file is checked
    before anything runs (``RigfitError`` for a bad one); a failed take never raises."""
    from distributed import Client, as_completed

    takes, base_dir = rigfit.read_jobs(jobs)
    base_dir = str(Path(base_dir).resolve())  # "" (a job file in the current folder) is it
    if report is not None:
        report = Path(report)
        if not report.parent.is_dir():
            raise rigfit.RigfitError(f"{report}: the folder does not exist")
    own_client = not isinstance(client, Client)
    if own_client:
        client = Client(client)
    workers = len(client.scheduler_info().get("workers", {}))
    task = task or run_take_task
    batch = uuid.uuid4().hex[:8]
    started = time.perf_counter()
    results: list[dict[str, Any] | None] = [None] * len(takes)
    attempts = [0] * len(takes)
    index_of: dict[str, int] = {}

    def submit(i: int):
        attempts[i] += 1
        key = f"rigfit-{batch}-{i}-{attempts[i]}"
        index_of[key] = i
        # retries=0: rigfit retries a failed take itself, once, whatever the failure.
        return client.submit(task, takes[i], base_dir, key=key, pure=False, retries=0)

    try:
        pending = as_completed([submit(i) for i in range(len(takes))])
        finished = 0
        for future in pending:
            i = index_of[future.key]
            take = takes[i]
            if future.status == "finished":
                entry = dict(future.result())
                entry.update(status="done", attempts=attempts[i])
            else:
                try:
                    error = future.exception()
                except BaseException as cancelled:  # a cancelled future raises here
                    error = cancelled
                if attempts[i] < ATTEMPTS:
                    pending.add(submit(i))
                    continue
                entry = {
                    "name": take["name"],
                    "command": take["command"],
                    "status": "failed",
                    "error": _one_line(error),
                    "attempts": attempts[i],
                }
                print(
                    f"rigfit: take '{take['name']}' ({take['command']}) failed: {entry['error']}",
                    file=sys.stderr,
                )
            results[i] = entry
            finished += 1
            if progress:
                print(f"rigfit: {finished}/{len(takes)} takes ({entry['name']}: {entry['status']})", file=sys.stderr)
    finally:
        if own_client:
            client.close()
    failed = sum(1 for r in results if r is not None and r["status"] == "failed")
    summary = {
        "jobs": str(jobs),
        "workers": workers,
        "done": len(takes) - failed,
        "failed": failed,
        "seconds": time.perf_counter() - started,
        "takes": results,
    }
    if report is not None:
        _write_atomic(report, json.dumps(summary, indent=2) + "\n")
    return summary
