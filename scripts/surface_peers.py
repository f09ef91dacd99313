#!/usr/bin/env python3
"""Surface tracking side by side: the PyPI tools a user would otherwise pick, run frame to
frame on the same scans as rigfit and scored the same way.

Usage: surface_peers.py SEQUENCE_DIR RIGFIT_OUT_DIR RIGFIT_REPORT FRAMES

SEQUENCE_DIR is written by `cargo run --release -p rigfit-testkit --example surface_sequence`
(reference.ply, scan_NNNN.ply, truth_NNNN.ply, sequence.json); RIGFIT_OUT_DIR holds
`rigfit surface`'s frame_NNNNN.ply for the same scans and RIGFIT_REPORT its JSON report.
Prints one markdown row per method: mean and 95th percentile of the per-vertex error (as a
percentage of the reference's bounding-box diagonal) over the first FRAMES frames, and the
milliseconds per frame (with RUNS=N, the median of N runs of every tool taken in turns, and
each run's figure; RIGFIT_RERUN is then the shell command that runs rigfit again).

Each peer tracks frame to frame: frame f starts from its own result at frame f - 1 (the
reference at frame 0) and moves the reference's vertices onto the scan's points.
Settings follow ../shared/peers.md: CPD starts from a small variance (2% of the diagonal,
squared) instead of the whole-cloud default, with an outlier weight equal to the scans'
outlier ratio; trimesh's nricp_amberg runs on the point cloud without faces or normals and
with a 1e-5 jitter of the source.
"""

import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import trimesh


def load_points(path):
    geometry = trimesh.load(path, process=False)
    return np.asarray(geometry.vertices, dtype=np.float64)


def load_mesh(path):
    mesh = trimesh.load(path, process=False)
    return np.asarray(mesh.vertices, dtype=np.float64), np.asarray(mesh.faces)


def score(fitted, truths, diagonal):
    errors = np.concatenate(
        [np.linalg.norm(f - t, axis=1) / diagonal for f, t in zip(fitted, truths)]
    )
    return 100.0 * errors.mean(), 100.0 * np.percentile(errors, 95)


def track_rustcpd(reference, faces, scans, diagonal, outliers):
    import rustcpd

    current = reference.copy()
    out = []
    for scan in scans:
        result = rustcpd.register_deformable(
            scan,
            current,
            alpha=2.0,
            beta=0.1 * diagonal,
            low_rank=300,
            low_rank_method="pivoted_cholesky",
            sigma2=(0.02 * diagonal) ** 2,
            max_iterations=50,
            tolerance=1e-4,
            outlier_weight=outliers,
        )
        current = np.asarray(result.points, dtype=np.float64)
        out.append(current)
    return out


def track_cycpd_small_sigma(reference, faces, scans, diagonal, outliers):
    from cycpd import deformable_registration
    import cycpd.expectation_maximization_registration as em

    class Patched:
        def __getattr__(self, name):
            if name == "initialize_sigma2":
                return lambda x, y: (0.02 * diagonal) ** 2
            return getattr(original_module, name)

    original_module = em.cy
    em.cy = Patched()
    try:
        current = reference.copy()
        out = []
        for scan in scans:
            reg = deformable_registration(
                X=scan,
                Y=current,
                alpha=2.0,
                beta=0.1 * diagonal,
                low_rank=True,
                num_eig=100,
                max_iterations=20,
                tolerance=1e-4,
                w=outliers,
                verbose=False,
                print_reg_params=False,
            )
            ty, _ = reg.register()
            current = np.asarray(ty, dtype=np.float64)
            out.append(current)
        return out
    finally:
        em.cy = original_module


def track_pycpd(reference, faces, scans, diagonal, outliers):
    # pycpd keeps the full M x N matrix (about 0.25 GB at 3,000 x 10,000): fine here.
    from pycpd import DeformableRegistration

    current = reference.copy()
    out = []
    for scan in scans:
        reg = DeformableRegistration(
            X=scan,
            Y=current,
            alpha=2.0,
            beta=0.1 * diagonal,
            sigma2=(0.02 * diagonal) ** 2,
            max_iterations=20,
            tolerance=1e-4,
            w=outliers,
        )
        ty, _ = reg.register()
        current = np.asarray(ty, dtype=np.float64)
        out.append(current)
    return out


def track_nricp(reference, faces, scans, diagonal, outliers):
    from trimesh.registration import nricp_amberg

    rng = np.random.default_rng(0)
    current = reference.copy()
    out = []
    for scan in scans:
        source = trimesh.Trimesh(
            current + rng.normal(scale=1e-5 * diagonal, size=current.shape),
            faces,
            process=False,
        )
        try:
            moved = nricp_amberg(
                source,
                scan,
                distance_threshold=0.1 * diagonal,
                use_faces=False,
                use_vertex_normals=False,
            )
            current = np.asarray(moved, dtype=np.float64)
        except Exception as e:  # "Factor is exactly singular": keep the previous frame.
            print(f"  nricp_amberg failed on a frame: {e}", file=sys.stderr)
        out.append(current.copy())
    return out


def main():
    seq_dir, rigfit_dir, rigfit_report, frames = (
        Path(sys.argv[1]),
        Path(sys.argv[2]),
        Path(sys.argv[3]),
        int(sys.argv[4]),
    )
    meta = json.loads((seq_dir / "sequence.json").read_text())
    diagonal = meta["diagonal"]
    outliers = meta["outlier_ratio"]
    reference, faces = load_mesh(seq_dir / "reference.ply")
    scans = [load_points(seq_dir / f"scan_{f:04d}.ply") for f in range(frames)]
    truths = [load_mesh(seq_dir / f"truth_{f:04d}.ply")[0] for f in range(frames)]
    name = Path(meta['asset']).name
    if meta.get('clip'):
        name += f" ({meta['clip']})"

    # RUNS > 1: every tool runs that many times, rigfit and the peers taking turns (rigfit
    # again through the RIGFIT_RERUN command), and the time shown is the median with every
    # run's figure: this machine's speed drifts by tens of percent within minutes.
    runs = max(1, int(os.environ.get("RUNS", "1")))
    rerun = os.environ.get("RIGFIT_RERUN")
    if runs > 1 and not rerun:
        sys.exit("surface_peers.py: RUNS > 1 needs RIGFIT_RERUN, the command that runs rigfit again")
    peers = [
        ("rustcpd 4.0.0 non-rigid (low_rank=300)", track_rustcpd),
        ("cycpd 0.28 non-rigid (low_rank, 20 iterations)", track_cycpd_small_sigma),
        ("trimesh 5.2.0 nricp_amberg", track_nricp),
        ("pycpd 2.0.0 non-rigid (20 iterations)", track_pycpd),
    ]
    only = set(a for a in sys.argv[5:])
    peers = [(label, track) for label, track in peers if not only or any(o in label for o in only)]
    scores = {}
    times = {label: [] for label in ["rigfit surface"] + [label for label, _ in peers]}
    failed = {}
    for run in range(runs):
        if run > 0:
            subprocess.run(rerun, shell=True, check=True, stdout=subprocess.DEVNULL)
        report = json.loads(Path(rigfit_report).read_text())
        times["rigfit surface"].append(
            sum(fr["seconds"] for fr in report["frames"][:frames]) / frames
        )
        if run == 0:
            rigfit = [load_mesh(rigfit_dir / f"frame_{f:05d}.ply")[0] for f in range(frames)]
            scores["rigfit surface"] = score(rigfit, truths, diagonal)
        for label, track in peers:
            if label in failed:
                continue
            t0 = time.perf_counter()
            try:
                fitted = track(reference, faces, scans, diagonal, outliers)
            except (KeyboardInterrupt, SystemExit):
                raise
            except BaseException as e:
                # A peer's own panic (a Rust extension's PanicException is not an
                # Exception) fails that peer on this object, not the comparison.
                reason = str(e).splitlines()[0] if str(e) else type(e).__name__
                print(f"{label} failed: {reason}", file=sys.stderr)
                failed[label] = reason
                continue
            times[label].append((time.perf_counter() - t0) / frames)
            if run == 0:
                scores[label] = score(fitted, truths, diagonal)

    def shown(label):
        median = statistics.median(times[label]) * 1000
        if len(times[label]) == 1:
            return f"{median:.1f}"
        return f"{median:.1f} ({' / '.join(f'{x * 1000:.1f}' for x in times[label])})"

    stay = [reference] * frames
    rows = [("rigfit surface", *scores["rigfit surface"], shown("rigfit surface"))]
    rows.append(("(reference, not moved)", *score(stay, truths, diagonal), "0.0"))
    for label, _ in peers:
        if label in scores:
            rows.append((label, *scores[label], shown(label)))
    for label, mean, p95, ms in rows:
        print(f"| {name} | {label} | {mean:.3f} | {p95:.3f} | {ms} |")
    for label, reason in failed.items():
        print(f"| {name} | {label} | failed: {reason[:80]} | - | - |")
    sys.stdout.flush()


if __name__ == "__main__":
    main()
