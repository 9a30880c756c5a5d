"""Whose noise it is: jitter confined to the hands and toes is the capture's own motion, not noise to remove.

The noise rule of :func:`mocapkit.cleaning.pipeline.noisy_cells` judges each
joint's track alone. That cannot tell sensor or solver noise from the
high-frequency wobble a capture gives its end effectors: CMU's toes and hands
carry 2-2.5 deg RMS above 10 Hz in the files themselves. At 120 fps that
wobble keeps its direction from frame to frame and the direction test leaves
it; the same take at 30 fps (every 4th frame) samples it 3-6 times a period,
its steps reverse, and track by track it is indistinguishable from Mall et
al.'s noise: the toe of CMU 01_01 at 30 fps has the same residual RMS (2.2
deg), spectrum and residual autocorrelation with and without Mall's 0.1
angular noise added (Mall, Roberts et al. 2017, "Deep learning for
motion-capture cleaning", section 4: Gaussian noise on every channel, std a
fraction of that channel's std).

What does tell them apart is where the noise is. Noise of the capture
(markers jittering, a solver fitting them) is the capture's: it shows on the
limbs and trunk, not on the hands and toes alone (Mall's model puts it on
every channel; at 0.1 of each channel's std at 30 fps the femurs, tibias and
forearms of CMU 01_01 are noisy too). So a noisy run on an *extremity* (a
joint at or below a hand or toe role: wrist, palm, fingers, thumb, toes) is
kept only where a joint that is not an extremity is noisy at some frame of the
same run; a run on an extremity while the rest of the body is smooth is the
file's own wobble and is left as it is. Runs on every other joint are kept as
they were: the rule only ever takes cells out of the noisy set, so clean
takes can only keep more of their cells. :func:`~mocapkit.cleaning.pipeline.noisy_cells`
asks it only under 117 fps, where the fit's 7 frames span more than 0.06 s;
at 120 fps the wobble keeps its direction and is not called noise, and a
hand or toe noisy alone still is. The price, under 117 fps: noise on the
hands or toes alone, the body smooth, is left too (CMU 01_01 and charleston2
at 30 fps: the toes' level is 1.2-3.0 deg from their wobble alone, 0.10-0.37
of their channels' std; Mall's 0.5 noise on one toe gives 3.5 deg, 0.36).
"""

from __future__ import annotations

import numpy as np

from ..motion import Skeleton

__all__ = ["EXTREMITY_ROLES", "extremities", "with_body_noise"]

#: The roles whose joints, and every joint below them, are extremities (:func:`extremities`).
EXTREMITY_ROLES = ("left_hand", "right_hand", "left_toe", "right_toe")


def extremities(skeleton: Skeleton) -> np.ndarray:
    """(J,) bool: the joints at or below a hand or toe role (:data:`EXTREMITY_ROLES`, found by
    :func:`mocapkit.rigs.roles`: the rig family's names, or the tree and rest pose of an unnamed rig).

    On CMU's and HDM05's Acclaim rig: ``lwrist``, ``lhand``, ``lfingers``, ``lthumb``, ``ltoes`` and their
    right twins; on a rig whose roles show no hands or toes, none. Where the family finds a foot but not its toes
    (a name it does not know), the joints below the foot are the toes: their wobble at 30 fps was denoised as the
    body's noise (LaFAN1's ``LeftToe`` on a HumanIK rig before the family named it: 40 of 86 frames of the bundled
    12_walk at 30 fps).
    """
    from ..rigs import roles

    found = roles(skeleton)
    out = np.zeros(skeleton.num_joints, dtype=bool)
    for r in EXTREMITY_ROLES:
        if r in found:
            out[found[r]] = True
    parents = np.asarray(skeleton.parents)
    for side in ("left", "right"):  # the toes where the family does not name them: every joint below the foot
        if f"{side}_foot" in found and f"{side}_toe" not in found:
            out[parents == found[f"{side}_foot"]] = True
    for j in range(1, skeleton.num_joints):  # parents come before their children
        if parents[j] >= 0 and out[parents[j]]:
            out[j] = True
    return out


def with_body_noise(noisy: np.ndarray, skeleton: Skeleton) -> np.ndarray:
    """(F, J) bool: ``noisy`` (F, J) bool without the runs on extremities that no other joint's noise
    accompanies (module docstring).

    A run is a maximal stretch of consecutive noisy frames of one extremity joint; it stays noisy when
    any joint that is not an extremity is noisy at one of its frames at least.
    """
    from scipy import ndimage

    noisy = np.asarray(noisy, dtype=bool)
    ext = extremities(skeleton)
    if not (noisy[:, ext].any() and ext.any()):
        return noisy.copy()
    body = noisy[:, ~ext].any(axis=1)  # (F,) frames where the body itself is noisy somewhere
    out = noisy.copy()
    for j in np.flatnonzero(ext & noisy.any(axis=0)):
        labels, n = ndimage.label(noisy[:, j])
        with_body = ndimage.maximum(body, labels, index=np.arange(1, n + 1)).astype(bool)  # (n,) per run
        out[:, j] = np.concatenate([[False], with_body])[labels]
    return out
