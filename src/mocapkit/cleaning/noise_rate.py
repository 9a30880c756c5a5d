"""The lowest frame rate at which the noise rule of ``clean`` can tell capture noise from motion.

:func:`mocapkit.cleaning.pipeline.noisy_cells` calls a joint noisy where what a
cubic Savitzky-Golay fit over ``NOISE_FIT_MIN`` (7) frames leaves over is large
and its frame-to-frame steps turn back on each other. Both tests read the
highest frequencies the rate holds. A cubic fit of 7 points passes frequencies
up to about 0.4 x the frame rate (its -3 dB edge: 0.8 of the Nyquist frequency,
Schafer 2011, "What is a Savitzky-Golay filter?", IEEE Signal Processing
Magazine 28(4)), so the residual holds what lies above 12 Hz at 30 fps, where
human limb motion has little power, but above 8 Hz at 20 fps, 6 Hz at 15 fps and
4 Hz at 10 fps, where the feet, hands and knees of a walk, a hop or a dance move: there the
residual of clean motion is as large as jitter, and motion near half the frame
rate reverses at every frame as white noise does.

The line is measured on clean real takes cut to lower rates (every k-th frame
of the 120 fps CMU and HDM05 captures; every 2nd, 3rd or 6th frame of 30 fps
Bandai Namco takes and BVH files other projects ship, slerp for 24, 20 and 12
fps): at 30 fps the rule marks no cell of them; at 24 fps 164 of 57,939 cells
of the CMU AMC takes (charleston2's toes and elbow, backflip's knee and right
hand), none of the other rigs'; at 20 fps the torso and neck of CMU backflip
and the knee of CMU 131_02; at 15 fps takes of three rigs of five, at 12 fps
every rig, and at 5 fps 10-25 % of the cells. Mall's noise on three joints is
found at 24 fps as at 30 fps. Below :data:`NOISE_MIN_FPS` the rule does not
run: the take is left as it is, and the summary says why in one line.

What the 164 cells at 24 fps are, read against the 120 fps files: backflip's
right hand and thumb (frames 18-50) hold a glitch of the capture itself (the
hand turns 18-66 deg in one 1/120 s frame, which ``clean`` repairs at 120 fps
too); charleston2's left toes carry CMU's toe jitter (steps of 3-10 deg that
reverse at 120 fps); backflip's left knee (both knees swing 40-50 deg at about
7 Hz in the flip) and charleston2's right elbow (steps of 2.3 deg or less at
120 fps) are smooth motion the rate aliases. The tests of one track measured
do not tell those two from Mall's noise: over their runs the mean cosine of
steps two frames apart (-0.22 to 0.16), the share of steps that reverse
(0.52-0.63 on the one-channel knee, elbow and toe) and the median step over the
median level (1.0-2.2) lie within what Mall's 0.1-0.5 noise on three joints of
CMU and HDM05 takes at 24 fps gives (-0.13 to 0.48; 0.51-0.70; 1.1-1.9, its 5th
percentile 1.14), and a 5-frame fit instead of 7 leaves 163 of the 164 cells.
"""

from __future__ import annotations

from .ssa.coarse_cues import under_rate

__all__ = ["NOISE_MIN_FPS", "noise_too_coarse"]

#: frames per second under which the noise rule cannot hold jitter apart from motion (module docstring)
NOISE_MIN_FPS = 24.0


def noise_too_coarse(fps: float) -> str:
    """One line saying why a take at ``fps`` (frames per second) is too coarse for the noise rule, or "" when it
    is not. A rate within 0.1 % of :data:`NOISE_MIN_FPS` counts as it (23.976 fps NTSC film; a Frame Time written
    rounded up)."""
    if not under_rate(fps, NOISE_MIN_FPS):
        return ""
    return (f"{fps:g} fps is too coarse to tell capture noise from motion: a 7-frame fit spans {7 / fps:.2f} s and "
            f"passes motion up to about {0.4 * fps:.0f} Hz, where feet and hands move; the noise rule judges takes "
            f"of {NOISE_MIN_FPS:g} fps or more")
