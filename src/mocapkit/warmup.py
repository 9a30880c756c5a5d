"""Compile and cache the numba kernels of ``mocapkit clean`` before the first real run.

numba compiles a kernel the first time it is called and, with ``cache=True``,
keeps the machine code on disk (beside the package's sources, or in
``NUMBA_CACHE_DIR`` when that is set). Without a warm cache the first
``mocapkit clean`` spends most of its time compiling. ``make install`` runs::

    python -m mocapkit.warmup

which cleans the bundled CMU walk (``12_walk.amc``) with gaps, capture errors
and noise, against the bundled default context and alone, so that every step
(the EBD gap filler, self-similarity detection and repair, the EBF denoiser)
runs and compiles what it needs (the serial and the parallel twin of each
self-similarity kernel; the parallel twins in a second process, beside the
rest), then writes and reads the result as BVH and npz, and searches a
database of the walk by LNG and by DTW (:func:`search_kernels`: the kernels of
``mocapkit search`` and ``reconstruct``, which ``clean`` does not call), and
reconstructs a second of a bundled take from markers and from accelerometers
(:func:`reconstruct_kernels`), and reads the noise of a second of the walk as the EBF's calibration does for a
30 fps model (:func:`low_rate_kernels`). It writes nothing but numba's cache (the files go to a temporary folder that is
removed).
"""

from __future__ import annotations

import argparse
import contextlib
import multiprocessing
import os
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

__all__ = ["warm_up", "broken_walk", "parallel_twins", "search_kernels", "reconstruct_kernels", "low_rate_kernels"]


def broken_walk(gaps: bool = True):
    """The bundled walk with gaps, capture errors and noise on two joints (a Motion with every defect ``clean`` treats);
    ``gaps=False``: the same without the gaps (nothing for the fill step, so no network is loaded)."""
    import dataclasses

    from . import corrupt, samples
    from .io import load

    walk = load(samples.path("12_walk.amc"))
    bad, _, _ = corrupt.real_errors(walk, n_errors=4, seed=7)
    gappy, gap = corrupt.gaps(bad, seed=8) if gaps else (bad, np.zeros(bad.rotations.shape[:2], dtype=bool))
    noisy, mask = corrupt.angular_noise(gappy, amount=0.5, seed=9, joints=["lfemur", "rhumerus"])
    rot = np.where((mask & ~gap)[..., None], noisy.rotations, gappy.rotations)
    return dataclasses.replace(gappy, rotations=rot)


def parallel_twins() -> None:
    """Detect and repair the broken walk with every self-similarity twin forced parallel, with and without the context.

    The bundled take alone would compile only the serial twins (a call picks a
    twin by problem size); this compiles the parallel ones, which a long take
    uses (:mod:`mocapkit.cleaning.ssa.twins`). numba compiles ``parallel=True``
    kernels slowly (about two thirds of the warm-up), so :func:`warm_up` runs
    this in a second process beside the rest. The walk has no gaps here: the
    twins are detect's and repair's, and filling (the EBD, torch) is the other
    process's work, which this one would only repeat. The pose-distance twin
    of :func:`~mocapkit.cleaning.ssa.word_dtw.group_pose_distances` runs
    only for words the take alone leaves unseen (searched again in the take
    and its context), which the walk has none of: it is called directly, with
    the argument types ``detect`` passes.
    """
    from .cleaning.pipeline import clean
    from .cleaning.ssa.twins import forced
    from .context import fit_context, resolve_context

    from .cleaning.ssa.word_dtw import group_pose_distances

    take = broken_walk(gaps=False)
    context, _ = fit_context(take, resolve_context(None))
    with forced("parallel"):
        for ctx in (context, None):
            clean(take, ctx, steps="detect,repair")
        # the words a take alone leaves unseen are searched in the take and its context, whose pose distances
        # (the take's chunk against every context frame) run this twin parallel; the walk leaves none unseen
        q = take.rotations[:4]
        group_pose_distances(q, q, np.ones((1, q.shape[1]), dtype=bool), [0])


def search_kernels() -> None:
    """Search a database of the bundled walk for a piece of it, by LNG and by subsequence DTW (classic and Tautges).

    ``mocapkit search`` and ``reconstruct`` run these kernels, ``clean`` does
    not: :func:`mocapkit.database.MotionDatabase.search` (``method="lng"``:
    the lazy neighbourhood graph of Krüger et al. 2010, sec. 4.1; ``"dtw"``:
    Müller's subsequence DTW), the Tautges eq. 4.2 search of
    :mod:`mocapkit.reconstruct.ssg` on a precomputed cost matrix and the global
    DTW of :mod:`mocapkit.reconstruct.multilinear`, each with the
    argument types those commands pass: a database's features are read-only
    (memory-mapped), a caller's own arrays writable, two signatures of each
    DTW kernel. They compile in a few seconds, while the
    parallel twins still compile in the second process.
    """
    from . import samples
    from .database import MotionDatabase
    from .search.dtw import dtw, local_cost_matrix, subsequence_dtw

    db = MotionDatabase.build([samples.path("12_walk.amc")], fps=30, executor="serial", progress=False)
    with warnings.catch_warnings():  # compiling the kernels, not searching: no note on fewer matches
        warnings.simplefilter("ignore", UserWarning)
        for method in ("lng", "dtw"):  # the database's features are read-only, a type of their own to numba
            db.search(db.features["F15"][10:40], k=2, method=method)
    features = np.array(db.features["F15"])  # writable, as a caller's own arrays
    query = features[10:40]
    cost = local_cost_matrix(query, features)
    subsequence_dtw(None, None, clip_ids=db.clip_ids, k=2, steps="tautges", cost=cost, max_overlap=15)
    for steps in ("classic", "tautges"):
        subsequence_dtw(query, features, db.clip_ids, k=2, steps=steps)
        dtw(query[:8], query[:12], steps=steps)  # global DTW, as the multilinear reconstruction aligns takes


def reconstruct_kernels() -> None:
    """Reconstruct a second of the bundled HDM05 sneak from six of its joints' markers and from four accelerometers.

    ``mocapkit reconstruct --markers`` (Krüger et al. 2010, sec. 5.2: the
    forward kinematics of the local pose model) and ``--accelerometers``
    (Tautges 2012, ch. 3: online LNG, the mean pose of the best paths, and
    ``--synthesis energy``, the minimisation of eq. 3.4 with the kernel prior)
    run kernels that ``clean`` and ``search`` do not. A one-clip database at
    25 fps and 30 frames of another take fix their argument types, both as
    built in memory (a caller's own database) and as ``reconstruct`` opens one
    from disk (read-only arrays, a type of their own to numba); they compile
    in seconds, in this process while the parallel twins compile in the other.
    """
    from . import samples
    from .database import MotionDatabase
    from .features import virtual_accelerometers, virtual_markers
    from .io import load
    from .reconstruct import accelerometers, markers

    db = MotionDatabase.build([samples.path("HDM_bk_sneak2StepsLStart_004_120.amc")], fps=25, executor="serial",
                              progress=False)
    take = load(samples.path("HDM_bk_sneak2StepsLStart_005_120.amc")).resample(25)[:30]
    readings = virtual_accelerometers(take)
    for synthesis in ("mean", "energy"):
        accelerometers.reconstruct(readings, db, take.fps, synthesis=synthesis, progress=False)
    joints = ["lhand", "rhand", "lfoot", "rfoot", "head", "root"]
    with tempfile.TemporaryDirectory() as tmp:
        opened = MotionDatabase.open(db.save(Path(tmp) / "db"))
        accelerometers.reconstruct(readings, opened, take.fps, progress=False)
        for base in (db, opened):
            markers.reconstruct(virtual_markers(take, joints), joints, base, take.fps, progress=False)


def low_rate_kernels() -> None:
    """Read the noise of the bundled walk's first second through the symmetric interpolator of the EBF's calibration.

    At a model rate up to :data:`~mocapkit.cleaning.deep.sure.PREDICTOR_MAX_FPS` (the Bandai Namco models, 30 fps)
    the SURE calibration of the EBF's widths (:mod:`mocapkit.cleaning.deep.sure`) reads the noise through
    :func:`~mocapkit.cleaning.deep.noise_predictor.predictor_noise_std` as well as through second differences; the
    bundled walk is denoised at 120 fps, where it is not called, so ``clean`` of the first 30 fps take compiled it
    (about 6 s of CPU). Its wrapper casts every argument (float64 channels, bool mask, int64 block edges), so any
    channels fix the kernel's types: here the walk's (F, J) quaternion w components, in two blocks.
    """
    from . import samples
    from .cleaning.deep.noise_predictor import predictor_noise_std
    from .cleaning.deep.sure import block_edges
    from .io import load

    walk = load(samples.path("12_walk.amc"))
    x = walk.rotations[: int(walk.fps), :, 0]
    predictor_noise_std(x, np.ones(x.shape, dtype=bool), block_edges(len(x), len(x) // 2))


def warm_up(processes: int | None = None) -> dict:
    """Run every step of :func:`mocapkit.clean` on a bundled take (and on a short piece of it) once.

    The take is cleaned against the bundled default context, as ``mocapkit
    clean`` does, and against itself alone (``--context none``), which calls
    other kernels (the self-distance matrix of one clip against the pose
    distances of the clip against a database).

    Returns a dict ``{"seconds": float, "steps": {step name: cells it changed}}``;
    fill, repair and denoise all change cells (repair only those detect
    flagged), so every step ran its kernels.
    The self-similarity kernels are compiled twice, serial and parallel
    (:mod:`mocapkit.cleaning.ssa.twins`), and a call takes one or the other by
    problem size: the bundled take alone would compile only the serial twins,
    so detect and repair run again with every twin forced parallel
    (:func:`parallel_twins`: what a long take uses, and any take once the
    parallel twins are cached), and on a short piece (its shorter word lists
    compile nothing new but check the small sizes run). ``processes`` (default:
    2 where the machine has two cores or more, else 1): with 2 the parallel
    twins compile in a second process (spawned, so it shares nothing but the
    disk cache, which numba writes file by file under temporary names) while
    this one compiles the rest, which halves the wall time on two cores.
    """
    from concurrent.futures import ProcessPoolExecutor

    from .io import load, save
    from .cleaning.pipeline import clean
    from .context import fit_context, resolve_context

    if processes is None:
        processes = 2 if (os.cpu_count() or 1) >= 2 else 1
    t = time.perf_counter()
    with contextlib.ExitStack() as stack:
        twins = None
        if processes >= 2:
            pool = stack.enter_context(ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("spawn")))
            twins = pool.submit(parallel_twins)
        take = broken_walk()
        context, _ = fit_context(take, resolve_context(None))  # what `mocapkit clean` compares with by default
        result = clean(take, context)
        clean(take, steps="fill,detect,repair")  # the clip alone (context "none"): other kernels
        if twins is None:
            parallel_twins()
        clean(take[: int(2 * take.fps)], context, steps="fill,detect,repair")
        search_kernels()
        reconstruct_kernels()
        low_rate_kernels()
        with tempfile.TemporaryDirectory() as tmp:
            for suffix in (".bvh", ".npz"):
                path = save(result.motion, Path(tmp) / f"walk{suffix}")
                load(path)
        if twins is not None:
            twins.result()
    return {"seconds": time.perf_counter() - t, "steps": {s.name: s.cells for s in result.steps}}


def main(argv=None) -> int:
    """``python -m mocapkit.warmup``: compile and cache the kernels, print how long it took."""
    argparse.ArgumentParser(prog="python -m mocapkit.warmup", description=__doc__.splitlines()[0]).parse_args(argv)
    out = warm_up()
    print(f"mocapkit: numba kernels compiled and cached in {out['seconds']:.1f} s ({', '.join(out['steps'])})")
    return 0


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
