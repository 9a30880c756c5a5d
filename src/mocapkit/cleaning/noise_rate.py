"""The lowest frame rate at which the noise rule of ``clean`` can tell capture noise from motion.

:func:`mocapkit.cleaning.pipeline.noisy_cells` calls a joint noisy where what a
cubic Savitzky-Golay fit over ``NOISE_FIT_MIN`` (7) frames leaves over is large
and its frame-to-frame steps turn back on each other. Both tests read the
highest frequencies the rate holds. A cubic fit of 7 points passes frequencies
up to about 0.4 x the frame rate (its -3 dB edge: 0.8 of the Nyquist frequency,
Schafer 2011, "What is a Savitzky-Golay filter?", IEEE Signal Processing
Magazine 28(4)), so the residual holds 12-15 Hz at 30 fps, where human limb
motion has little power, but 8 Hz at 20 fps, 6 Hz at 15 fps and 4 Hz at 10 fps,
where the feet, hands and knees of a walk, a hop or a dance move: there the
residual of clean motion is as large as jitter, and motion near half the frame
rate reverses at every frame as white noise does.

The line is measured on clean real takes decimated to lower rates (every k-th
frame of the 120 fps CMU and HDM05 captures; the 30 fps Bandai Namco takes
and BVH files other projects ship): at 30 fps the rule marks no cell of them;
at 24 fps the cells it marks on CMU charleston2 are the toes' twist aliased to
half the rate, whose steps reverse exactly (:data:`NYQUIST_REVERSAL`); at 20 fps
it marks the torso and neck of CMU backflip and the knee of CMU 131_02, at 15
fps takes of three rigs of five, at 12 fps every rig, and at 5 fps a quarter
of a Bandai Namco take's cells. Below :data:`NOISE_MIN_FPS` the rule does not run:
the take is left as it is, and the summary says why in one line.
"""

from __future__ import annotations

__all__ = ["NOISE_MIN_FPS", "NYQUIST_REVERSAL", "noise_too_coarse"]

#: frames per second under which the noise rule cannot hold jitter apart from motion (module docstring)
NOISE_MIN_FPS = 24.0

#: median cosine of consecutive steps over a run below which the run is a motion at half the frame rate, not
#: white noise: independent errors give a median near -0.5 (each error enters two steps with opposite signs),
#: while a sinusoid at the Nyquist frequency (a twist faster than the rate holds, aliased there) reverses exactly,
#: cosines of -1 frame after frame
NYQUIST_REVERSAL = -0.9


def noise_too_coarse(fps: float) -> str:
    """One line saying why a take at ``fps`` (frames per second) is too coarse for the noise rule, or "" when it
    is not. A rate within 0.1 % of :data:`NOISE_MIN_FPS` counts as it (23.976 fps NTSC film; a Frame Time written
    rounded up)."""
    if fps >= NOISE_MIN_FPS * (1.0 - 1e-3):
        return ""
    return (f"{fps:g} fps is too coarse to tell capture noise from motion: a 7-frame fit spans {7 / fps:.2f} s and "
            f"passes motion up to about {0.4 * fps:.0f} Hz, where feet and hands move; the noise rule judges takes "
            f"of {NOISE_MIN_FPS:g} fps or more")
