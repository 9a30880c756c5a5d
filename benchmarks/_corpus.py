"""The databases the search benchmarks run on: the real clips, and the same grown to a million frames.

* :func:`real_database`: the ASF/AMC clips of ``../shared/data`` (CMU and
  HDM05 share the Acclaim skeleton layout), resampled to 30 fps, except the
  held-out ones — about 18,000 frames of real motion capture.
* :func:`heldout_motions`: the clips kept out of every database, where the
  queries come from, so that no query is answered by finding itself: all
  clips of HDM05 actor ``mm`` and CMU ``charleston2`` (``charleston1``, the
  same dance, stays in).
* :func:`large_database`: the real clips, mirrored, and repeated with small
  perturbations until the target size is reached: each repeat plays every
  clip at a random speed between 0.8x and 1.25x (slerp resampling) and turns
  every joint by a fixed random rotation of about 2 degrees. Features are
  recomputed from the perturbed poses, so the database is consistent motion,
  not copied feature rows. The benchmarks say so in their output.

Both are cached (``benchmarks/.cache``, git-ignored) keyed by their
parameters, since building the large one takes a minute.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import os
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
# the real data beside the repository; $MOCAPKIT_SHARED_DATA for a checkout elsewhere (a git worktree)
DEFAULT_DATA = Path(os.environ.get("MOCAPKIT_SHARED_DATA", REPO.parent / "shared" / "data"))
CACHE = REPO / "benchmarks" / ".cache"

sys.path.insert(0, str(REPO / "src"))

from mocapkit import rotations as R  # noqa: E402
from mocapkit.database import MotionDatabase  # noqa: E402
from mocapkit.motion import Motion  # noqa: E402


def _is_heldout(p: Path) -> bool:
    return p.name.startswith("HDM_mm_") or p.name == "charleston2.amc"


def real_clip_paths(data: Path = DEFAULT_DATA, heldout: bool = False) -> list[Path]:
    """The database clips, or with ``heldout=True`` the query clips."""
    paths = sorted((data / "cmu_asfamc").glob("*.amc")) + sorted((data / "hdm05_asfamc").glob("*.amc"))
    if not paths:
        raise SystemExit(f"no ASF/AMC clips under {data}; pass --data")
    return [p for p in paths if _is_heldout(p) == heldout]


def heldout_motions(data: Path = DEFAULT_DATA, fps: float = 30.0) -> list[Motion]:
    import mocapkit

    return [mocapkit.load(p).resample(fps) for p in real_clip_paths(data, heldout=True)]


def random_windows(motions: list[Motion], length: int, count: int, rng: np.random.Generator) -> list[Motion]:
    """``count`` random windows of ``length`` frames from the motions long enough, uniform over all windows."""
    pool = [m for m in motions if m.num_frames >= length]
    if not pool:
        raise SystemExit(f"no held-out clip has {length} frames")
    weights = np.array([m.num_frames - length + 1 for m in pool], dtype=float)
    out = []
    for c in rng.choice(len(pool), size=count, p=weights / weights.sum()):
        a = int(rng.integers(0, pool[c].num_frames - length + 1))
        out.append(pool[c][a : a + length])
    return out


def _cached(key: dict, build) -> MotionDatabase:
    digest = hashlib.sha1(json.dumps(key, sort_keys=True).encode()).hexdigest()[:12]
    path = CACHE / f"{key['kind']}-{digest}"
    if (path / "database.json").is_file():
        return MotionDatabase.open(path)
    db = build()
    db.save(path, overwrite=True)
    return MotionDatabase.open(path)


def real_database(data: Path = DEFAULT_DATA, features=("F15", "F15x3"), fps: float = 30.0) -> MotionDatabase:
    paths = real_clip_paths(data)
    key = {"kind": "real", "files": [p.name for p in paths], "features": list(features), "fps": fps, "v": 2}
    return _cached(key, lambda: MotionDatabase.build(paths, fps=fps, features=features, progress=False))


def _perturbed(m: Motion, rng: np.random.Generator, fps: float) -> Motion:
    speed = float(np.exp(rng.uniform(np.log(0.8), np.log(1.25))))
    warped = dataclasses.replace(m, fps=m.fps * speed).resample(fps)
    J = m.num_joints
    axis = rng.normal(size=(J, 3))
    angle = np.radians(rng.normal(0.0, 2.0, size=J))
    turn = R.quaternion_from_axis_angle(axis / np.linalg.norm(axis, axis=1, keepdims=True), angle)
    turn[0] = R.identity()  # keep the root's facing; its turn would only rotate the whole body
    rot = R.quaternion_multiply(warped.rotations, turn[None])
    return dataclasses.replace(warped, rotations=rot, name=f"{m.name}~{speed:.3f}")


def large_database(
    target_frames: int = 1_000_000, data: Path = DEFAULT_DATA, features=("F15", "F15x3"), fps: float = 30.0, seed: int = 0
) -> MotionDatabase:
    real = real_database(data, features, fps)
    key = {
        "kind": "large",
        "target": target_frames,
        "files": [p.name for p in real_clip_paths(data)],
        "features": list(features),
        "fps": fps,
        "seed": seed,
        "v": 2,
    }

    def build() -> MotionDatabase:
        rng = np.random.default_rng(seed)
        base = [real.clip(c) for c in range(real.num_clips)]
        base = base + [m.mirror() for m in base]
        motions = list(base)
        total = sum(m.num_frames for m in motions)
        while total < target_frames:
            for m in base:
                p = _perturbed(m, rng, fps)
                motions.append(p)
                total += p.num_frames
                if total >= target_frames:
                    break
        return MotionDatabase.build(motions, fps=fps, features=features, progress=True)

    return _cached(key, build)


def describe(db: MotionDatabase, real: MotionDatabase) -> str:
    return (
        f"{db.num_frames} frames in {db.num_clips} clips: the {real.num_frames} real frames ({real.num_clips} CMU and HDM05 "
        "ASF/AMC clips at 30 fps), their mirror images, and repeats at random speeds 0.8-1.25x with every joint turned "
        "by a fixed random ~2 degree rotation; queries come from held-out real clips (HDM05 actor mm, CMU charleston2)"
    )
