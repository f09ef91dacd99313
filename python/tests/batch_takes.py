"""A job file of real takes for the batch tests and the batch bench: pose, track and
surface jobs made from the assets in RIGFIT_DATA, two of them broken on purpose."""

import json
from pathlib import Path

import numpy as np
import rigfit

BROKEN = {"broken-strokes", "broken-frame"}


def rotation_y(angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def make_inputs(asset, folder: Path, frames: int = 3) -> dict[str, object]:
    """Strokes for three rigs, a BCN point-cloud sequence, a moving bunny: files in
    ``folder``; returns what the takes need."""
    folder.mkdir(parents=True, exist_ok=True)
    strokes = {}
    for name, rel in [("bcn", "assimp/BCN_Epileptic.glb"), ("cmu", "cmu/01_01.bvh"), ("hand", "webxr_hand/left.glb")]:
        rig = rigfit.load_rig(asset(rel))
        rotations, translations = rig.sample(rig.animation_range()[1] * 0.5) if rig.animations else (None, None)
        drawn, _ = rigfit.draw_strokes(rig.skeleton, rotations, translations, noise=0.01, seed=3)
        path = folder / f"strokes-{name}.json"
        path.write_text(json.dumps({"strokes": [{"points": s.tolist()} for s in drawn]}))
        strokes[name] = path
    bcn = rigfit.load_rig(asset("assimp/BCN_Epileptic.glb"))
    track_frames = []
    for k in range(frames):
        rotations, translations = bcn.sample(1.5 + k / 30)
        cloud = rigfit.Tracker(bcn, rotations, translations).surface_points()
        path = folder / f"bcn_{k:04d}.ply"
        rigfit.save_mesh(path, cloud)
        track_frames.append(path)
    bunny, _ = rigfit.load_mesh(asset("bunny/bunny.ply"))
    rng = np.random.default_rng(5)
    surface_frames = []
    for k in range(frames):
        moved = (bunny - bunny.mean(0)) @ rotation_y(0.02 * (k + 1)).T + bunny.mean(0)
        moved += rng.normal(scale=1e-4, size=moved.shape)
        path = folder / f"bunny_{k:04d}.ply"
        rigfit.save_mesh(path, moved)
        surface_frames.append(path)
    broken = folder / "broken_0000.ply"
    broken.write_text("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nend_header\n1\n")
    return {"strokes": strokes, "track_frames": track_frames, "surface_frames": surface_frames, "broken": broken}


def takes(asset, inputs: dict, out: str) -> list[dict]:
    """Twelve takes writing under ``out`` (relative to the job file's folder): four pose,
    three track, three surface, two broken."""
    bcn, cmu, hand = asset("assimp/BCN_Epileptic.glb"), asset("cmu/01_01.bvh"), asset("webxr_hand/left.glb")
    s = inputs["strokes"]
    track = [str(p) for p in inputs["track_frames"]]
    surface = [str(p) for p in inputs["surface_frames"]]
    pattern = str(inputs["surface_frames"][0].with_name("bunny_*.ply"))
    bunny = str(asset("bunny/bunny.ply"))
    return [
        {"name": "pose-bcn", "command": "pose", "rig": str(bcn), "strokes": str(s["bcn"]), "output": f"{out}/bcn.glb", "report": f"{out}/bcn.json"},
        {"name": "pose-cmu", "command": "pose", "rig": str(cmu), "strokes": str(s["cmu"]), "output": f"{out}/cmu.bvh", "start_frame": "rest"},
        {"name": "pose-hand-paper", "command": "pose", "rig": str(hand), "strokes": str(s["hand"]), "output": f"{out}/hand.glb", "method": "paper"},
        {"name": "pose-bcn-arms", "command": "pose", "rig": str(bcn), "strokes": str(s["bcn"]), "report": f"{out}/bcn-arms.json", "bones": ["B_UpperArm_Left", "B_ForeArm_Left", "B_UpperArm_Right", "B_ForeArm_Right"]},
        {"name": "broken-strokes", "command": "pose", "rig": str(bcn), "strokes": "no-such-strokes.json", "output": f"{out}/broken.glb"},
        {"name": "track-bcn", "command": "track", "rig": str(bcn), "frames": track, "output": f"{out}/track.bvh", "report": f"{out}/track.json"},
        {"name": "track-bcn-glb", "command": "track", "rig": str(bcn), "frames": track, "output": f"{out}/track.glb", "noise": 0.02},
        {"name": "track-bcn-paper", "command": "track", "rig": str(bcn), "frames": track[:2], "report": f"{out}/track-paper.json", "method": "paper"},
        {"name": "broken-frame", "command": "track", "rig": str(bcn), "frames": [str(inputs["broken"]), track[0]], "report": f"{out}/broken.json"},
        {"name": "surface-bunny", "command": "surface", "mesh": bunny, "frames": surface, "output": f"{out}/bunny", "report": f"{out}/bunny.json"},
        {"name": "surface-bunny-pattern", "command": "surface", "mesh": bunny, "frames": pattern, "output": f"{out}/bunny-pattern", "iterations": 8},
        {"name": "surface-bunny-stiff", "command": "surface", "mesh": bunny, "frames": surface, "output": f"{out}/bunny-stiff", "rigidity": 5.0, "coarse": 1},
    ]


def write_jobs(path: Path, takes: list[dict]) -> Path:
    path.write_text(json.dumps({"takes": takes}, indent=1))
    return path


def untimed(value):
    """A report without its timings, workers and summaries (they differ run to run), its
    numbers to 12 significant digits: the surface tracker's rms and sigma are sums taken in
    parallel, whose last bits depend on how the threads split the work (its meshes do
    not)."""
    if isinstance(value, dict):
        return {k: untimed(v) for k, v in value.items() if k not in ("seconds", "summary", "worker", "workers", "jobs")}
    if isinstance(value, list):
        return [untimed(v) for v in value]
    if isinstance(value, float):
        return float(f"{value:.12g}")
    return value


def files(folder: Path) -> dict[str, bytes]:
    """Every file under ``folder`` by relative path (JSON reports without timings)."""
    out = {}
    for path in sorted(p for p in folder.rglob("*") if p.is_file()):
        data = path.read_bytes()
        if path.suffix == ".json":
            data = json.dumps(untimed(json.loads(data)), sort_keys=True).encode()
        out[str(path.relative_to(folder))] = data
    return out
