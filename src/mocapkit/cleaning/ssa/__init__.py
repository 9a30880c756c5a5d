"""Self-similarity analysis for motion-capture cleaning (Aristidou, Cohen-Or, Hodgins, Shamir 2018).

The package, by step of the method:

- :mod:`~mocapkit.cleaning.ssa.params`: :class:`SSAParams`, every parameter and its default;
- :mod:`~mocapkit.cleaning.ssa.texture`: the motion texture, and :func:`prepare`, which prepares a
  take once (an :class:`Analysis`: joints, textures, groups, words) for detection and repair;
- :mod:`~mocapkit.cleaning.ssa.neighbours`: nearest neighbour words and the mean motion texture,
  on the word-DTW kernels of :mod:`~mocapkit.cleaning.ssa.word_dtw`;
- :mod:`~mocapkit.cleaning.ssa.cues`: discontinuities, held joints, side swaps, transient offsets;
- :mod:`~mocapkit.cleaning.ssa.drifts`: smooth drifts, flagged with no break where a chosen context
  repeats the motion;
- :mod:`~mocapkit.cleaning.ssa.detect`: the movement digression map and the flags;
- :mod:`~mocapkit.cleaning.ssa.repair`: the flagged cells replaced by their neighbour words;
- :mod:`~mocapkit.cleaning.ssa.undo`: a transient offset's offset taken away instead;
- :mod:`~mocapkit.cleaning.ssa.swap_exchange`: a side swap exchanged back with mirrored rotations instead;
- :mod:`~mocapkit.cleaning.ssa.freeze_bounds`: a frozen channel's flags bounded to its frozen frames;
- :mod:`~mocapkit.cleaning.ssa.turning_holds`: a joint still for one step where it turns back is not held.

A clip's joint rotations over time form a *motion texture* (section 3.1):
resampled to the analysis rate (24 fps), one row per joint, the root's heading removed so global
pose does not matter. *Motion words* are windows of it on groups of joints
(whole body, upper, lower, left, right): source words of 15 frames every 5
frames, target words of 20 frames at every frame. Each source word is compared
with every target word of a context (the clip itself, or related clips) by the
constrained DTW of the appendix over the pose distance of eq. 1
(:mod:`mocapkit.cleaning.ssa.word_dtw`); its K = 5 nearest neighbours are the K
smallest local minima of that distance function (section 3.3). The matched
part of each neighbour is resampled to the source word's length with a
polyphase filter, the neighbours are averaged into a *mean motion word*, and
overlapping mean words into the *mean motion texture*. Where a joint digresses
from it, the *movement digression map* (MDM, section 3.4) is high: that is an
error, or a motion the context has never seen.

:func:`detect` returns the MDM and the flags (MDM above a threshold) at the
input's frame rate; :func:`repair` replaces only flagged joints in flagged
frames by the median (medoid) of their neighbour words, blended with a
quadratic Savitzky-Golay filter (section 4).

Departures from the paper, and why:

- The MDM compares the input at its own frame rate with the mean texture
  upsampled from 24 fps, so a one-frame spike at 120 fps is seen even though
  the words are matched at 24 fps.
- A joint's digression is the rotation angle between the input and the mean
  texture; with several groups a joint belongs to, the group that explains it
  best (smallest digression) counts, so a motion that only a sub-group of the
  context repeats is not called an error (section 3.1's reason for groups).
- Row normalisation: the paper divides each joint's row by its mean, which
  puts every row's mean at the kernel's knee (``1 - e^-1 = 0.63 > 0.5``), so a
  clean clip would be flagged everywhere at the paper's own threshold. Rows
  are divided by ``row_scale`` times the row's median digression instead (the
  median is not pulled up by the errors themselves), with a floor of
  ``floor_deg`` so a joint that barely moves is not flagged for a
  fraction of a degree. ``normalization="mean"`` gives the paper's rule.
- Timing tolerance: a joint's digression at a frame is its smallest angle
  from the mean texture within ``shift_s`` (0.02 s) of that frame. The
  neighbours are time-warped on the whole group, so a fast joint (a knee in
  mid-swing) that leads or lags its group by a frame or two digresses by tens
  of degrees without being wrong; on the detection benchmark most false flags
  sat in the fastest quarter of each joint's motion. Spikes, flips and swaps
  are not explained by a 0.02 s shift.
- Confirmation (``confirm=True``, the default): a digression is flagged as an
  error only where the joint's own trajectory also breaks
  (:func:`discontinuities`: a step or one-frame spike no smooth motion makes)
  within ``confirm_margin_s`` of it. Without it the flags are the paper's,
  ``MDM > threshold``, and they also fire on every motion the context does
  not repeat (a gesture made once): on the detection benchmark, 79-87 % of
  its (word, joint) flags without a large context. A confirmed run is the
  connected cells of ``MDM > threshold / 2`` that reach ``threshold`` and
  hold a break, so the repair covers the error's whole extent; a run with
  two breaks or more is cut to the first and last of them, since beyond
  them the digression is the error's wake in the neighbour words, and a run
  whose breaks are all spikes is flagged on the spikes' own frames
  (:mod:`~mocapkit.cleaning.ssa.run_extent`). The price: an error that
  grows smoothly out of the motion and back (no step anywhere) is left
  unflagged; ``confirm=False`` finds it, with the false flags above.
  Confirmation also flags held joints (:func:`held_joints`): a joint held
  bit-still while its mean motion texture travels 10 degrees, a frozen
  channel whose digression is still small where it starts; and left/right
  label swaps (:func:`side_swaps`): a joint and its mirror partner breaking
  at the same frame and again within a second, which a swapped limb in a
  plausible pose shows though it hardly digresses; and transient offsets
  (:func:`transient_offsets`): a joint that steps off its own path and back
  by the opposite step within a second, a drift or flip between its two
  steps, flagged even where the context holds poses like the wrong ones (a
  drifted shoulder in a walk full of shoulder motion digressed under the
  threshold).
- "Median of the KNN": the medoid word (the neighbour closest to the others on
  the flagged joints), an actual motion, as the paper requires.
- A transient offset is not replaced by neighbour words: the offset it steps off by,
  measured at its two steps, is taken away (:mod:`~mocapkit.cleaning.ssa.undo`), which keeps
  the joint's own motion under the error.
- One preparation: :func:`detect` keeps the prepared take in its result
  (:attr:`Detection.analysis`) and :func:`repair` reuses it, so the take and
  its context are resampled to the analysis rate once.

Examples
--------
>>> import mocapkit
>>> from mocapkit import corrupt
>>> from mocapkit.cleaning import ssa
>>> walk = mocapkit.load(mocapkit.samples.path("131_01.bvh"))
>>> bad, mask, records = corrupt.real_errors(walk, kinds=("flip",), n_errors=1, seed=3)
>>> det = ssa.detect(bad)
>>> det.mdm.shape == det.flags.shape == (walk.num_frames, walk.num_joints)
True
>>> j = walk.skeleton.index(records[0].joint)
>>> bool(det.flags[records[0].start : records[0].end, j].any())
True
>>> fixed = ssa.repair(bad, det, foot_skate=False)   # foot_skate=True may also adjust planted legs
>>> bool((fixed.rotations[~det.flags] == bad.rotations[~det.flags]).all())
True
"""

from . import word_dtw
from .cues import confirm_flags, discontinuities, held_joints, side_swaps, transient_offsets
from .drifts import body_agreement, offset_change, smooth_drift_flags
from .detect import Detection, detect, detect_prepared, movement_digression_map
from .neighbours import mean_motion_texture, nearest_words, word_distance
from .guard import LeftRun
from .params import SSAParams
from .repair import Contact, repair, repair_with_left
from .texture import (
    Analysis,
    MotionTexture,
    facing_aligned,
    informative_joints,
    joint_groups,
    left_out_joints,
    min_take_fps,
    motion_texture,
    motion_words,
    prepare,
    too_coarse,
)

__all__ = [
    "SSAParams",
    "Analysis",
    "prepare",
    "Contact",
    "Detection",
    "MotionTexture",
    "detect",
    "detect_prepared",
    "repair",
    "repair_with_left",
    "LeftRun",
    "motion_texture",
    "motion_words",
    "min_take_fps",
    "too_coarse",
    "joint_groups",
    "informative_joints",
    "left_out_joints",
    "facing_aligned",
    "word_distance",
    "nearest_words",
    "mean_motion_texture",
    "movement_digression_map",
    "discontinuities",
    "confirm_flags",
    "held_joints",
    "side_swaps",
    "transient_offsets",
    "body_agreement",
    "offset_change",
    "smooth_drift_flags",
    "word_dtw",
]
