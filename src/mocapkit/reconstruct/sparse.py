"""Full-body motion from a few joints' rotations by self-similarity (Aristidou et al. 2018, section 4, Fig. 8).

The sparse take's motion words, matched on the known joints against a context
of full-body clips with the word DTW of :mod:`mocapkit.cleaning.ssa`, are
chained into a full-body texture: each word the neighbour that continues the
previous one best.
"""

from __future__ import annotations

import dataclasses
from typing import Sequence

import numpy as np
from scipy.signal import savgol_filter

from .. import rotations as R
from ..cleaning.filters import window_frames
from ..cleaning.ssa.neighbours import dropped_terms, nearest_words, neighbor_words
from ..cleaning.ssa.params import SSAParams
from ..cleaning.ssa.texture import context_motions, motion_texture, upsample_quaternions
from ..features import detect_up_axis
from ..metrics import motion_word_starts
from ..motion import Motion
from ..words import plural

__all__ = ["reconstruct_sparse"]

_D = SSAParams()


def reconstruct_sparse(
    sparse: Motion,
    joints: Sequence,
    context,
    *,
    analysis_fps: float = _D.analysis_fps,
    k: int = _D.k,
    source_length: int = _D.source_length,
    target_length: int = _D.target_length,
    blend_s: float = 0.25,
    progress: bool = False,
) -> Motion:
    """Full-body motion from a few joints' rotations and a context of full-body clips (section 4, Fig. 8).

    ``sparse`` holds the skeleton and the rotations of ``joints`` (names or
    indices; the other joints' values are ignored and may be NaN). Its words
    (non-overlapping, ``source_length`` frames) are matched on those joints
    against ``context`` (list of Motions or a MotionDatabase, same joints);
    the first output word is the nearest neighbour of the first input word,
    and each next one is the candidate among the next word's K neighbours
    whose first frame is closest (eq. 1, all joints) to the last frame of the
    word chosen before. The chain is upsampled to the input's frame rate,
    its transitions smoothed with a quadratic Savitzky-Golay filter, and the
    given joints keep their input values exactly. The root trajectory is the
    input's where it is finite. Words are matched at ``analysis_fps``: a take
    at another rate is resampled to it by slerp (at 5 fps a word of 0.625 s
    spans about 3 of the take's frames, the rest interpolated), and the result
    has the input's rate and frame count.
    """
    from tqdm.auto import tqdm
    from ..progress import bar_disabled, bar_size

    sk = sparse.skeleton
    known = np.array(sorted({sk.index(j) if isinstance(j, str) else int(j) for j in joints}), dtype=np.int64)
    if len(known) < 2:
        raise ValueError("sparse reconstruction needs at least two known joints")
    if not np.all(np.isfinite(sparse.rotations[:, known])):
        raise ValueError(f"{sparse.name or 'motion'}: the known joints have missing rotations; fill the gaps first")
    ctx, _ = context_motions(sparse, context)
    if not ctx:
        raise ValueError("sparse reconstruction needs a context of full-body clips")
    N, M = int(source_length), int(target_length)
    up = detect_up_axis(sk)
    all_rows = np.arange(sk.num_joints)
    filled = np.array(sparse.rotations)
    filled[:, np.setdiff1d(all_rows, known)] = R.identity()
    src = motion_texture(dataclasses.replace(sparse, rotations=filled), analysis_fps, all_rows, up)
    full = motion_texture(ctx, analysis_fps, all_rows, up)
    if src.num_frames < N:
        raise ValueError(f"a clip of {plural(src.num_frames, 'frame')} at {analysis_fps:g} fps is shorter than one motion word")
    words = motion_word_starts(src.num_frames, N, N)
    nb = nearest_words(src, full, [known], words, k=k, source_length=N, target_length=M, min_width=min(11, N), self_clip=None)
    drop = dropped_terms(known)
    out = np.array(src.values)
    prev_last = None
    wi, ki = np.nonzero(nb.pos[0] >= 0)
    nws, ok = neighbor_words(src.values, full, known, drop, words[wi], nb.pos[0][wi, ki], N, M, min(11, N), out_rows=all_rows)
    bar = tqdm(words, desc="sparse reconstruction", disable=bar_disabled(progress), **bar_size(), unit="word")
    for w, s in enumerate(bar):
        cands = [(float(nb.dist[0, w, ki[q]]), nws[q]) for q in np.flatnonzero((wi == w) & ok)]
        if not cands:
            continue
        if prev_last is None:
            choice = min(cands, key=lambda c: c[0])[1]
        else:
            choice = min(cands, key=lambda c: float(np.sum(R.geodesic_angle(c[1][0], prev_last) ** 2)))[1]
        # a last word flush with the end overlaps the one before: keep what is already placed
        a = s if w == 0 else max(s, int(words[w - 1]) + N)
        out[a : s + N] = choice[a - s :]
        prev_last = choice[-1]
    rot = upsample_quaternions(R.quaternion_continuity(out, axis=0), analysis_fps, sparse.num_frames, sparse.fps)
    window = window_frames(blend_s, sparse.fps, 2)
    if sparse.num_frames >= window:
        rot = R.quaternion_normalize(savgol_filter(R.quaternion_continuity(rot, axis=0), window, 2, axis=0, mode="interp"))
    if 0 in known:
        rot[:, 0] = R.quaternion_multiply(R.quaternion_twist(sparse.rotations[:, 0], up), rot[:, 0])
    rot[:, known] = sparse.rotations[:, known]
    root = np.where(np.isfinite(sparse.root_positions), sparse.root_positions, 0.0)
    return dataclasses.replace(sparse, rotations=rot, root_positions=root, name=(sparse.name or "motion") + "_reconstructed")
