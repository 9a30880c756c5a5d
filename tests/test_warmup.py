"""Tests of mocapkit.warmup: every step of clean runs, and afterwards a clean (a search, a reconstruction) compiles nothing."""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest

from mocapkit import samples
from mocapkit.warmup import low_rate_kernels, main, reconstruct_kernels, search_kernels, warm_up


def test_warm_up_runs_every_step_of_clean(monkeypatch):
    # in this process alone: the install's warm-up (make install / make test) runs the two-process split every time,
    # and test_after_warm_up_a_clean_compiles_nothing checks what it caches.
    # search_kernels and reconstruct_kernels have tests of their own below (reconstruct_kernels ~6 s of CPU a run):
    # here they are only counted, so the module runs each once
    from mocapkit import warmup

    called = []
    for name in ("search_kernels", "reconstruct_kernels", "low_rate_kernels"):
        monkeypatch.setattr(warmup, name, lambda name=name: called.append(name))
    out = warm_up(processes=1)
    assert called == ["search_kernels", "reconstruct_kernels", "low_rate_kernels"]
    assert list(out["steps"]) == ["fill", "detect", "repair", "denoise"]
    cells = out["steps"]  # detect changes no cell; repair changes only what detect flagged
    assert cells["fill"] > 0 and cells["repair"] > 0 and cells["denoise"] > 0, cells  # each step had work: its kernels ran


def test_search_kernels_compile_what_search_and_reconstruct_call(small_db):
    """After search_kernels, a search of another database by both methods, the Tautges search on a cost matrix
    (mocapkit.reconstruct.ssg) and global DTW both ways (mocapkit.reconstruct.multilinear) add no kernel signature."""
    from numba.core.registry import CPUDispatcher

    from mocapkit.search import dtw, lng

    search_kernels()
    kernels = {f"{mod.__name__}.{n}": k for mod in (dtw, lng) for n, k in vars(mod).items()
               if isinstance(k, CPUDispatcher)}
    before = {n: set(k.signatures) for n, k in kernels.items()}
    query = small_db.clip(2)[5:40]
    for method in ("lng", "dtw"):
        assert small_db.search(query, k=3, method=method)
    x = small_db.features["F15"]
    cost = dtw.local_cost_matrix(x[:20], x)
    dtw.subsequence_dtw(None, None, small_db.clip_ids, k=3, steps="tautges", cost=cost, max_overlap=10)
    y = np.array(x)  # writable, as tests/search/test_dtw.py's arrays
    for steps in dtw.STEPS:
        dtw.dtw(x[:30], x[40:75], steps=steps)
        dtw.dtw(y[:30], y[40:75], steps=steps)
        dtw.subsequence_dtw(y[:20], y, small_db.clip_ids, k=3, steps=steps)
        dtw.accumulated_cost(y[:20], y[:50], steps=steps)
    assert {n: set(k.signatures) for n, k in kernels.items()} == before


def test_main_refuses_arguments():
    with pytest.raises(SystemExit) as e:
        main(["--bogus"])
    assert e.value.code == 2


@pytest.mark.slow
def test_after_warm_up_a_clean_compiles_nothing(tmp_path):
    """With numba's cache in an empty folder, warm up, then clean a take, with the self-similarity kernels' serial
    twins (a short take's) and their parallel twins (a long take's), against the default context and alone: numba
    saves no new machine code."""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "cache"), "NUMBA_DEBUG_CACHE": "1"}
    subprocess.run([sys.executable, "-m", "mocapkit.warmup"], env=env, check=True, capture_output=True)
    code = ("import mocapkit; from mocapkit import corrupt; "
            f"m = mocapkit.load({str(samples.path('12_walk.amc'))!r}); "
            "from mocapkit.cleaning.ssa.twins import forced; "
            "b = corrupt.real_errors(m, n_errors=3, seed=1)[0]; mocapkit.clean(b); mocapkit.clean(b, context=False)\n"
            "with forced('parallel'): mocapkit.clean(b); mocapkit.clean(b, context=False)")
    out = subprocess.run([sys.executable, "-c", code], env=env, check=True, capture_output=True, text=True)
    assert "data loaded" in out.stdout
    assert "data saved" not in out.stdout


def test_reconstruct_kernels_compile_what_reconstruct_calls(tmp_path):
    """After reconstruct_kernels, reconstructions from markers and from accelerometers (mean pose and energy
    synthesis) on other databases, built in memory or opened from disk as ``mocapkit reconstruct`` does, add no
    kernel signature."""
    from numba.core.registry import CPUDispatcher

    from mocapkit import load, samples
    from mocapkit.database import MotionDatabase
    from mocapkit.features import virtual_accelerometers, virtual_markers
    from mocapkit.reconstruct import accelerometers, markers, model_kinematics
    from mocapkit.reconstruct.accelerometers import kernels as acc_kernels
    from mocapkit.search import lng

    reconstruct_kernels()
    found = {f"{mod.__name__}.{n}": k for mod in (acc_kernels, lng, markers, model_kinematics) for n, k in vars(mod).items()
             if isinstance(k, CPUDispatcher)}
    before = {n: set(k.signatures) for n, k in found.items()}
    db = MotionDatabase.build([samples.path("HDM_bd_jogLeftCircle4StepsRstart_001_120.amc")], fps=30, mirror=True,
                              executor="serial", progress=False)
    take = load(samples.path("HDM_bk_sneak2StepsLStart_004_120.amc")).resample(30)[10:18]  # 8 frames call what 20 do
    readings = virtual_accelerometers(take)
    for synthesis in ("mean", "energy"):
        accelerometers.reconstruct(readings, db, take.fps, synthesis=synthesis, progress=False)
    opened = MotionDatabase.open(db.save(tmp_path / "db"))
    accelerometers.reconstruct(readings, opened, take.fps, synthesis="energy", progress=False)
    joints = ["lhand", "rhand", "lfoot", "rfoot", "head", "root"]
    for base in (db, opened):
        markers.reconstruct(virtual_markers(take, joints), joints, base, take.fps, progress=False)
    assert {n: set(k.signatures) for n, k in found.items()} == before


@pytest.mark.filterwarnings("ignore::mocapkit.errors.LicenceWarning")  # said by test_deep_shipped.py
def test_low_rate_kernels_compile_what_a_30fps_models_calibration_calls():
    """After low_rate_kernels, the SURE-calibrated EBF of the Bandai Namco rig (30 fps) on a Bandai take, as clean
    denoises it, adds no kernel signature to the noise predictor's."""
    from pathlib import Path

    from numba.core.registry import CPUDispatcher

    import mocapkit
    from mocapkit.cleaning import deep
    from mocapkit.cleaning.deep import noise_predictor
    from mocapkit.cleaning.deep.channels import encode

    low_rate_kernels()
    found = {n: k for n, k in vars(noise_predictor).items() if isinstance(k, CPUDispatcher)}
    before = {n: set(k.signatures) for n, k in found.items()}
    assert any(before.values())  # the kernel the wrapper calls (its helper is compiled into it)
    take = mocapkit.load(Path(__file__).parent / "data" / "dataset-2_run_active_049.bvh")
    ebf = deep.shipped_model("ebf", take)
    assert ebf.fps == 30.0
    x, ctx = encode(take, ebf.layout)
    deep.denoise_channels(x, ctx, ebf, fps=take.fps)
    assert {n: set(k.signatures) for n, k in found.items()} == before


def test_parallel_twins_compile_the_pose_distances_of_unseen_words(monkeypatch):
    """The words a take alone leaves unseen are searched again in the take and its context (nearest_words against
    the whole texture: group_pose_distances, the parallel twin on a long take). The bundled walk leaves none, so
    parallel_twins calls that twin itself, with the argument types that search passes (read-only textures)."""
    import dataclasses

    from numba import typeof

    from mocapkit import load, warmup
    from mocapkit.cleaning import pipeline, ssa
    from mocapkit.cleaning.ssa import neighbours, word_dtw
    from mocapkit.cleaning.ssa.twins import forced

    twin = word_dtw._group_pose_distances
    kernel, seen = twin.parallel, []

    def spy(*args):
        seen.append(tuple(typeof(a) for a in args))
        return kernel(*args)

    monkeypatch.setattr(twin, "parallel", spy)
    monkeypatch.setattr(pipeline, "clean", lambda *args, **kwargs: None)  # the twin alone: detect's others are cached
    warmup.parallel_twins()
    assert len(seen) == 1
    walk = load(samples.path("12_walk.amc"))
    an = ssa.prepare(walk[:240], [dataclasses.replace(walk[240:], name="rest")])
    with forced("parallel"):
        neighbours.nearest_words(an.source, an.texture, list(an.group_rows), an.words[:2], self_clip=0)
    assert len(seen) == 2 and seen[1] == seen[0]
