"""Many takes: rigfit.run_batch and rigfit.run_take (the command line's code), and
rigfit.cluster on a local Dask cluster of two worker processes started by the test. Twelve
real takes (pose, track, surface), two broken on purpose."""

import json
import os
import sys
from pathlib import Path

import batch_takes
import pytest
import rigfit
from conftest import asset, no_temporaries


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    return batch_takes.make_inputs(asset, tmp_path_factory.mktemp("inputs"))


def check_report(report: dict, attempts_of_failed: int = 1):
    assert report["done"] == 10 and report["failed"] == 2, report
    assert len(report["takes"]) == 12
    for entry in report["takes"]:
        broken = entry["name"] in batch_takes.BROKEN
        assert entry["status"] == ("failed" if broken else "done"), entry
        if broken:
            assert "\n" not in entry["error"]
            assert entry["attempts"] == attempts_of_failed
    errors = {e["name"]: e.get("error") for e in report["takes"]}
    assert "no-such-strokes.json" in errors["broken-strokes"]
    assert "broken_0000.ply" in errors["broken-frame"]


@pytest.fixture(scope="module")
def local_run(inputs, tmp_path_factory):
    """The batch run locally on two threads: its folder and report."""
    folder = tmp_path_factory.mktemp("local")
    jobs = batch_takes.write_jobs(folder / "jobs.json", batch_takes.takes(asset, inputs, "out"))
    (folder / "out").mkdir()
    report = rigfit.run_batch(jobs, workers=2, report=folder / "report.json")
    return folder, report


def test_a_local_batch_runs_every_take_and_reports_the_broken_ones(local_run, capfd):
    folder, report = local_run
    check_report(report)
    assert json.loads((folder / "report.json").read_text())["failed"] == 2
    written = batch_takes.files(folder / "out")
    # Nothing of the broken takes; the good takes' outputs all there.
    assert not any(name.startswith("broken") for name in written)
    assert {"bcn.glb", "bcn.json", "cmu.bvh", "hand.glb", "bcn-arms.json", "track.bvh", "track.json",
            "track.glb", "track-paper.json", "bunny.json"} <= set(written)
    assert sum(name.startswith("bunny/frame_") for name in written) == 3
    assert sum(name.startswith("bunny-pattern/frame_") for name in written) == 3
    no_temporaries(folder)


def test_each_take_alone_writes_the_same_files(local_run, inputs, tmp_path):
    folder, _ = local_run
    (tmp_path / "out").mkdir()
    for take in batch_takes.takes(asset, inputs, "out"):
        if take["name"] in batch_takes.BROKEN:
            with pytest.raises(rigfit.RigfitError, match=f"take '{take['name']}': "):
                rigfit.run_take(take, tmp_path)
        else:
            result = rigfit.run_take(take, tmp_path)
            assert result["status"] == "done" and result["name"] == take["name"]
    assert batch_takes.files(tmp_path / "out") == batch_takes.files(folder / "out")


def test_bad_job_files_and_takes_raise_one_line(tmp_path):
    jobs = tmp_path / "jobs.json"
    jobs.write_text('{"takes": [{"command": "paint"}]}')
    with pytest.raises(rigfit.RigfitError, match=r"jobs.json: takes\[0\]: command: 'paint'"):
        rigfit.run_batch(jobs)
    with pytest.raises(rigfit.RigfitError, match=r"jobs.json: takes\[0\]: command: 'paint'"):
        rigfit.read_jobs(jobs)
    with pytest.raises(rigfit.RigfitError, match="missing.json"):
        rigfit.run_batch(tmp_path / "missing.json")
    with pytest.raises(rigfit.RigfitError, match="workers: expected 1 to 256"):
        rigfit.run_batch(jobs, workers=0)
    with pytest.raises(rigfit.RigfitError, match="take: command: missing"):
        rigfit.run_take({"rig": "a.glb"})
    with pytest.raises(rigfit.RigfitError, match="unexpected argument '--colour'"):
        rigfit.run_take({"command": "pose", "rig": "a.glb", "strokes": "s.json", "colour": "red"})
    with pytest.raises(rigfit.RigfitError, match="take: not JSON data"):
        rigfit.run_take({"command": "pose", "rig": object()})


# ---- Dask -----------------------------------------------------------------------------

distributed = pytest.importorskip("distributed", reason="rigfit.cluster needs distributed==2026.8.0")


def die_on_first_attempt(take, base_dir):
    """A task whose worker dies the first time it runs a take (a crash, an OOM kill)."""
    marker = Path(base_dir) / f"died-{take['name']}"
    if not marker.exists():
        marker.write_text("")
        os._exit(1)
    from rigfit.cluster import run_take_task

    return run_take_task(take, base_dir)


def always_die(take, base_dir):
    os._exit(1)


@pytest.fixture(scope="module")
def cluster():
    """Two worker processes, one thread each; the scheduler gives up on a task the first
    time its worker dies (rigfit.cluster retries it once itself)."""
    import cloudpickle
    import dask

    # The test's own task functions travel by value (the workers cannot import this file).
    cloudpickle.register_pickle_by_value(sys.modules[__name__])
    with dask.config.set({"distributed.scheduler.allowed-failures": 0}):
        with distributed.LocalCluster(
            n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
        ) as cluster, distributed.Client(cluster) as client:
            yield client


def test_the_batch_on_a_local_dask_cluster_matches_the_local_run(cluster, local_run, inputs, tmp_path):
    from rigfit import cluster as rigfit_cluster

    folder, _ = local_run
    jobs = batch_takes.write_jobs(tmp_path / "jobs.json", batch_takes.takes(asset, inputs, "out"))
    (tmp_path / "out").mkdir()
    report = rigfit_cluster.run_batch(jobs, cluster, report=tmp_path / "report.json", progress=False)
    # The broken takes were tried twice and reported with their one line.
    check_report(report, attempts_of_failed=2)
    assert report["workers"] == 2
    workers = {e["worker"] for e in report["takes"] if e["status"] == "done"}
    assert len(workers) == 2, workers
    assert json.loads((tmp_path / "report.json").read_text())["done"] == 10
    assert batch_takes.files(tmp_path / "out") == batch_takes.files(folder / "out")
    no_temporaries(tmp_path)


def test_a_take_whose_worker_dies_is_run_again_once_then_reported(cluster, inputs, tmp_path):
    from rigfit import cluster as rigfit_cluster

    # One take at a time: a worker that dies takes the tasks queued on it down too.
    takes = [t for t in batch_takes.takes(asset, inputs, "out") if t["name"] in ("pose-bcn", "pose-cmu")]
    jobs = batch_takes.write_jobs(tmp_path / "jobs.json", takes)
    one = batch_takes.write_jobs(tmp_path / "one.json", takes[:1])
    (tmp_path / "out").mkdir()
    report = rigfit_cluster.run_batch(one, cluster, progress=False, task=die_on_first_attempt)
    assert report["done"] == 1, report
    assert report["takes"][0]["attempts"] == 2
    assert (tmp_path / "out" / "bcn.glb").is_file() and (tmp_path / "out" / "bcn.json").is_file()

    report = rigfit_cluster.run_batch(jobs, cluster, progress=False, task=always_die)
    assert report["failed"] == 2
    for entry in report["takes"]:
        assert entry["attempts"] == 2 and entry["error"] == "the worker running it died", entry
