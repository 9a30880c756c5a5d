"""What a take's own frames can show under the analysis rate: the break and hold cues at 12-23 fps.

Motion words are matched at the analysis rate (:attr:`~mocapkit.cleaning.ssa.params.SSAParams.analysis_fps`,
24 fps), but the cues that confirm a digression as an error (:mod:`~mocapkit.cleaning.ssa.cues`,
:mod:`~mocapkit.cleaning.ssa.backed`) are judged on the take's own frames. Under the analysis rate two of them
read real motion as an error, because the motion between the take's frames is not seen:

- a held joint (:func:`~mocapkit.cleaning.ssa.cues.held_joints`) needs only two equal frames (one still step)
  at 24 fps and under. At 12 fps those frames are 83 ms apart, and a joint that turns out and back between
  them (an elbow or a toe at the end of its swing) comes back within 0.04 deg of where it was: CMU 131_02
  cut to every 10th frame had its right toe (frames 82-83) and right elbow (122-123) "held". A frozen channel
  repeats its value over many frames, so under the analysis rate a hold needs :data:`COARSE_HOLD_FRAMES`
  frames (two still steps in a row);
- a backed offset (:func:`~mocapkit.cleaning.ssa.backed.backed_offsets`) pairs two breaks of a joint around a
  stretch that digresses from the neighbour words. Under the analysis rate the take's texture is upsampled to
  24 fps by slerp between frames up to 83 ms apart, so a fast joint's own flick (a toe turning 38-63 deg
  between two frames at 15 fps) is smeared and digresses from the neighbour words by 20-50 deg where it merely
  moves: CMU 131_02 cut to every 8th frame had 19 cells of its toes repaired, by up to 48 deg. Under the
  analysis rate backed offsets are not added; the transient offsets that step back
  (:func:`~mocapkit.cleaning.ssa.cues.offsets_from_residuals`), the spikes, the swaps and the breaks over the
  joint's own level still confirm errors there.

At the analysis rate and over, nothing here changes a cue. Measured on clean real takes cut to every k-th
frame (CMU BVH 131_01-03, CMU AMC 01_01 and charleston1, HDM05 bd_depositFloorR_001 at 20, 15 and 12 fps;
two Bandai Namco takes at 15 fps), the cells ``clean`` changed fell from 14, 45 and 22 to 11, 5 and 1 (the
rest: breaks over the joints' own level, on right arms and hands). What it costs: on 18 corrupted takes
at 15 fps (six of those takes, ``corrupt.real_errors`` seeds 0-2) the left/right swaps that only a backed
offset confirmed are left, and the mean error of the corrupted cells after ``clean`` is 20.7 deg instead
of 18.0 (44.7 before cleaning), while the clean cells it changed fell from 147 to 31. Raising the backed
offsets' break threshold with the rate instead (``jump_deg * (24 / fps) ** 2``) kept more of those swaps
(18.7 deg) but changed more clean cells at 20 and 12 fps than before (CMU 131_03 at 12 fps: 0 -> 11).
What is left at 12-20 fps (every 6th, 8th and 10th frame of the CMU and every 20th HDM05 take, every 2nd frame
of the Bandai Namco secondary takes and slerp at 20 and 12 fps), read against the 120 fps files: most changed
runs repair a glitch of the capture (HDM05 bd_throwBasketball_002's right hand, lambada's and backflip's hands
turning 19-155 deg in one 1/120 s frame; 11_01's left hand jumping 11 deg in one frame between steps of 1-2);
CMU 131_01's right shoulder at its throw (15 and 12 fps), its right hip (20 fps), 131_02's right shoulder
(20 fps) and Bandai slash_normal_001's left forearm are smooth motion. A margin over the joint's own level
does not tell them apart: those breaks pass the level by 1.01-1.65 times, and the breaks of
``corrupt.real_errors`` on held-out CMU and HDM05 takes at 12-20 fps by 1.01 times and more (16 % of them
under 1.25, 8 % under 1.1).
Cues of this library, not of the paper (Aristidou et al. 2018).
"""

from __future__ import annotations

__all__ = ["COARSE_HOLD_FRAMES", "RATE_TOLERANCE", "under_rate", "hold_min_frames", "backs_offsets"]

#: the fewest frames a held joint needs under the analysis rate (two still steps in a row)
COARSE_HOLD_FRAMES = 3


#: how far under a rate a take's rate may lie and count as it: 23.976 fps NTSC film is 24 fps, and a Frame Time
#: written rounded up (0.0833334 s) is 12 fps
RATE_TOLERANCE = 1e-3


def under_rate(fps: float, rate: float) -> bool:
    """Whether a take at ``fps`` (frames per second) is coarser than ``rate``; a rate within
    :data:`RATE_TOLERANCE` (0.1 %) under it counts as it. The one comparison of the rate lines of self-similarity
    (:func:`~mocapkit.cleaning.ssa.texture.too_coarse`), of these cues and of the noise rule
    (:func:`mocapkit.cleaning.noise_rate.noise_too_coarse`)."""
    return float(fps) < float(rate) * (1.0 - RATE_TOLERANCE)


def hold_min_frames(fps: float, analysis_fps: float) -> int:
    """The fewest frames of a held joint (:func:`~mocapkit.cleaning.ssa.cues.held_joints`' ``min_frames``): 2 at
    the analysis rate and over, :data:`COARSE_HOLD_FRAMES` under it (module docstring)."""
    return COARSE_HOLD_FRAMES if under_rate(fps, analysis_fps) else 2


def backs_offsets(fps: float, analysis_fps: float) -> bool:
    """Whether backed offsets (:func:`~mocapkit.cleaning.ssa.backed.backed_offsets`) confirm errors at ``fps``:
    at the analysis rate and over only (module docstring)."""
    return not under_rate(fps, analysis_fps)
