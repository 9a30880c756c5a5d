"""Control signals for reconstruction: marker trajectories from a marker file or a motion, in a database's units.

The reconstruction methods take marker positions ``(F, M, 3)`` in the
database's length units and coordinate frame, plus the joint (or end-site)
name each marker sits on. Real files differ in both:

* a **marker file** (C3D, or a mocapkit marker ``.npz``) has labels such as
  ``LFHD`` and millimetres, usually with Z up; ``use`` maps its labels to
  joints (``"LFHD=head,LWRA=lhand"``) and the positions are converted to the
  database skeleton's unit (:func:`~mocapkit.motion.unit_scale_cm`) and
  turned from the file's up axis to the skeleton's;
* a **motion** (BVH, ASF/AMC, npz) gives simulated markers: the global
  positions of the named joints, converted from its skeleton's unit. This is
  how the benchmarks and the demo make a control signal from a clean take.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from ..features import parse_up_axis, detect_up_axis, virtual_markers
from ..io.c3d import MarkerSet
from ..motion import Motion, Skeleton, unit_scale_cm

__all__ = ["parse_use", "up_rotation", "control_markers", "marker_residuals", "far_from_markers", "FAR_CM", "upsampled_note", "warn_unseen",
           "up_axis_note"]

#: a markers fit that ends this far (cm) further from a seen marker than its usual distance has not passed through it
FAR_CM = 10.0


def parse_use(text: str | Sequence[str]) -> list[tuple[str, str]]:
    """``"LFHD=head,lhand"`` -> ``[("LFHD", "head"), ("lhand", "lhand")]``: marker label and the joint it sits on.

    >>> parse_use("LFHD=head, lhand")
    [('LFHD', 'head'), ('lhand', 'lhand')]
    """
    items = text.split(",") if isinstance(text, str) else list(text)
    out = []
    for item in items:
        item = item.strip()
        if not item:
            continue
        label, _, joint = item.partition("=")
        label, joint = label.strip(), (joint.strip() or label.strip())
        if not label:
            raise ValueError(f"empty marker label in {item!r}; write LABEL or LABEL=JOINT")
        out.append((label, joint))
    if not out:
        raise ValueError("no markers named; write LABEL[=JOINT],...")
    labels = [a for a, _ in out]
    dup = sorted({a for a in labels if labels.count(a) > 1})
    if dup:
        raise ValueError(f"marker label(s) named twice: {', '.join(dup)}")
    return out


def up_rotation(source_up, target_up) -> np.ndarray:
    """The proper rotation matrix (3, 3) taking axis ``source_up`` to ``target_up`` by a cyclic axis permutation.

    Both are axis specs as in :func:`mocapkit.features.root_frame` (``"z"``,
    ``"-y"``, 1, ...). A cyclic permutation keeps the frame right-handed and
    maps the horizontal axes onto horizontal axes (Z-up ``(x, y, z)`` ->
    Y-up ``(y, z, x)``); a sign flip of the up axis turns about the first
    horizontal axis.

    >>> up_rotation("z", "y") @ np.array([0.0, 0.0, 1.0])
    array([0., 1., 0.])
    """
    s = parse_up_axis(source_up)
    t = parse_up_axis(target_up)
    ks, kt = int(np.argmax(np.abs(s))), int(np.argmax(np.abs(t)))
    shift = (kt - ks) % 3
    P = np.roll(np.eye(3), shift, axis=0)  # P @ e_ks = e_kt
    if np.sign(s[ks]) != np.sign(t[kt]):
        # half turn about a horizontal axis of the target flips up to down, staying right-handed
        h = (kt + 1) % 3
        flip = -np.eye(3)
        flip[h, h] = 1.0
        P = flip @ P
    return P


def control_markers(
    source: MarkerSet | Motion,
    use: str | Sequence[str],
    skeleton: Skeleton,
    up_axis=None,
    *,
    option: str = "up_axis",
) -> tuple[np.ndarray, list[str], float]:
    """Marker trajectories of ``source`` for the joints named in ``use``, in ``skeleton``'s units and frame.

    Parameters
    ----------
    source : MarkerSet or Motion
        A marker file's trajectories, or a motion whose joints become markers.
    use : str or sequence of str
        ``LABEL[=JOINT]`` items (:func:`parse_use`). For a motion the label is
        the joint or end-site name itself; in a marker file a bare label also
        names the one label that ends in ``:LABEL`` (Vicon Nexus writes
        ``Subject:LFHD``).
    skeleton : Skeleton
        The database skeleton: its unit (:func:`unit_scale_cm`) and vertical
        axis (:func:`detect_up_axis`) are the output's.
    up_axis : optional
        The marker file's vertical axis; ``"z"`` (the C3D convention) when
        None. Ignored for motions, whose own up axis is detected. Where a marker
        file's markers stand along another axis (:func:`up_axis_note`: an
        OpenSim TRC is Y-up, and read as Z-up its body is reconstructed lying on
        its side), a ``UserWarning`` says so and which axis to pass, in the
        words ``mocapkit reconstruct`` prints as a note.
    option : str
        How the note names the argument to pass: ``"up_axis"`` (Python:
        ``pass up_axis='y'``) or ``"--up-axis"`` (the command line).

    Returns
    -------
    positions : float array (F, M, 3)
        In ``skeleton``'s length units; NaN where a marker was not seen.
    joints : list of str (M,)
    fps : float
    """
    pairs = parse_use(use)
    to_unit = 1.0 / unit_scale_cm(skeleton)
    target_up = detect_up_axis(skeleton)
    joints = [j for _, j in pairs]
    known = set(skeleton.joint_names) | set(skeleton.end_site_names)
    unknown = [j for j in joints if j not in known]
    if unknown:
        raise ValueError(f"unknown joint(s) {', '.join(unknown)} on the database skeleton")
    if isinstance(source, Motion):
        msk = source.skeleton
        names = set(msk.joint_names) | set(msk.end_site_names)
        missing = [a for a, _ in pairs if a not in names]
        if missing:
            raise ValueError(f"the motion has no joint(s) {', '.join(missing)}")
        pos = virtual_markers(source, [a for a, _ in pairs]) * (unit_scale_cm(msk) * to_unit)
        P = up_rotation(detect_up_axis(msk), target_up)
        return pos @ P.T, joints, float(source.fps)
    if not isinstance(source, MarkerSet):
        raise TypeError(f"source must be a MarkerSet or Motion, got {type(source).__name__}")
    index = {label: i for i, label in enumerate(source.labels)}
    by_bare: dict[str, list[str]] = {}  # Vicon Nexus prefixes each label with its subject: "Bastian:LFHD"
    for label in source.labels:
        if ":" in label:
            by_bare.setdefault(label.rsplit(":", 1)[1], []).append(label)
    for a, _ in pairs:
        if a not in index and len(by_bare.get(a, ())) > 1:
            raise ValueError(f"marker {a} is {' or '.join(by_bare[a])} in the file; give the full label")
    found = {a: index[a] if a in index else index[by_bare[a][0]] for a, _ in pairs if a in index or a in by_bare}
    missing = [a for a, _ in pairs if a not in found]
    if missing:
        shown = ", ".join(source.labels[:20]) + (" ..." if source.num_markers > 20 else "")
        raise ValueError(f"no marker(s) {', '.join(missing)} in the file; it has {shown}")
    pos = source.positions[:, [found[a] for a, _ in pairs]] * (source.unit_cm * to_unit)
    P = up_rotation("z" if up_axis is None else up_axis, target_up)
    pos = pos @ P.T
    note = up_axis_note(pos, joints, skeleton, up_axis, option=option)
    if note:
        import warnings

        warnings.warn(note, UserWarning, stacklevel=2)
    return pos, joints, float(source.fps)


def up_axis_note(pos: np.ndarray, joints: Sequence[str], skeleton: Skeleton, up_axis=None,
                 option: str = "--up-axis") -> str:
    """A note where a marker file's trajectories do not stand along the vertical axis they were read with; "".

    ``pos`` (F, M, 3): :func:`control_markers`' output for a marker file read with ``up_axis`` (None: ``"z"``,
    the C3D convention), in ``skeleton``'s frame and units; ``joints`` (M): the joints or end sites they sit on;
    ``option``: the argument the note says to pass (``"--up-axis"``: ``pass --up-axis y``; ``"up_axis"``: ``pass
    up_axis='y'``). :func:`control_markers` warns with it, which is how the command gets it too.
    In each frame with 3 or more markers seen off the arms (which reach above the head), their coordinates along
    each axis are regressed on their joints' heights in ``skeleton``'s rest pose (head above hips above feet):
    along the vertical the slope is near 1 (0.76-1.12 on CMU 85_02, 85_12, 135_02, HDM05 bd_05-01, and the
    shared data's Y-up T.trc and ballet_reduced.trc read with --up-axis y), along a horizontal axis near 0
    (under 0.15). Where the median
    slope over frames is under 0.3 along the vertical and over 0.5 in size along another axis (or under -0.5
    along the vertical), the file's vertical is that axis: an OpenSim TRC is Y-up, and read as Z-up its body
    was reconstructed lying on its side, without a word (Krüger 2010 and Tautges 2011 take the control
    signals in the database's frame). A take lying down for most of its frames stands along no axis and gets no
    note.
    """
    from ..joints import find_joint

    names = list(skeleton.joint_names) + list(skeleton.end_site_names)
    owner = list(range(skeleton.num_joints)) + [int(p) for p in skeleton.end_site_parents]  # an end site's joint
    arms = set()  # arms reach above the head or out to the sides: no height to expect
    for role in ("left_shoulder", "right_shoulder"):
        try:
            arms.add(find_joint(skeleton, role))
        except KeyError:
            pass

    def on_arm(j: int) -> bool:
        while j >= 0 and j not in arms:
            j = int(skeleton.parents[j])
        return j >= 0

    keep = [m for m, j in enumerate(joints) if not on_arm(owner[names.index(j)])]
    up = detect_up_axis(skeleton)
    heights = skeleton.rest_positions(end_sites=True)[[names.index(joints[m]) for m in keep]] @ up
    x = np.asarray(pos, dtype=np.float64)[:, keep]
    seen = ~np.isnan(x).any(axis=-1)
    if len(keep) < 3 or np.ptp(heights) <= 0:
        return ""
    slope = np.full((x.shape[0], 3), np.nan)
    for f in np.flatnonzero(seen.sum(axis=1) >= 3):
        h = heights[seen[f]] - heights[seen[f]].mean()
        for a in range(3):
            v = x[f, seen[f], a] - x[f, seen[f], a].mean()
            slope[f, a] = v @ h / (h @ h) if h @ h > 0 else np.nan
    if np.isnan(slope).all():
        return ""
    med = np.nanmedian(slope, axis=0)
    k_up = int(np.argmax(np.abs(up)))
    k = int(np.argmax(np.abs(med)))  # the file's vertical: a horizontal axis, or the vertical upside down
    if not (med[k_up] * np.sign(up[k_up]) < 0.3 and abs(med[k]) > 0.5):
        return ""
    given = "z" if up_axis is None else str(up_axis)
    target = np.zeros(3)
    target[k] = np.sign(med[k])
    v = up_rotation(given, up).T @ target  # back into the file's axes
    a = int(np.argmax(np.abs(v)))
    axis = ("-" if v[a] < 0 else "") + "xyz"[a]
    default = " (the default, the C3D convention)" if up_axis is None else ""
    how = "upside down" if k == k_up else "lying on its side"
    fix = f"{option} {axis}" if option.startswith("-") else f"{option}={axis!r}"
    return (f"the markers stand along the file's {axis} axis, not {given}{default}: the body was reconstructed "
            f"{how}; pass {fix}")


def marker_residuals(motion: Motion, markers: np.ndarray, joints: Sequence[str]) -> np.ndarray:
    """Distances (F, M) in cm between a motion's markers and the given ones (NaN where a marker is missing).

    How closely a reconstruction passes through the markers the user gave, per frame: the fit residual of
    :func:`~mocapkit.reconstruct.markers.reconstruct`, and for :func:`~mocapkit.reconstruct.ssg.reconstruct`
    (which plays back database motion and fits no marker) the check that the result follows them at all.
    ``motion``: the result; ``markers`` (F, M, 3) in its skeleton's units and frame; ``joints`` (M) the joints
    or end sites they sit on.
    """
    p = virtual_markers(motion, list(joints))
    x = np.asarray(markers, dtype=np.float64)
    if x.shape != p.shape:
        raise ValueError(f"markers: expected shape {p.shape}, got {x.shape}")
    return np.linalg.norm(p - x, axis=-1) * unit_scale_cm(motion.skeleton)


def far_from_markers(result: Motion, pos, joints: Sequence[str], pos_unit_cm: float, labels: Sequence[str],
                     over_cm: float = FAR_CM) -> dict:
    """Where a reconstruction ends over ``over_cm`` further from a seen marker than usual: frames, the worst marker
    and frame.

    The markers fit is a least-squares compromise with a pose prior, a smoothness and a joint-range term, and in
    single frames it can end tens of centimetres from a marker (a hand missed when the local model cannot reach
    it). The subsequence graph plays database motion back and fits no marker: where the database lacks the
    performer's motion it follows other motion for seconds (a standing T-pose played as hop apexes, the body
    30 cm above the floor).
    ``pos`` (F, M, 3): the markers as the fit saw them, in units of ``pos_unit_cm`` centimetres (the database's)
    and its frame, NaN where unseen; ``joints`` (M): the joint each sits on; ``labels`` (M): the markers' names.
    The result's markers are taken on its own skeleton, in its unit. A skin marker sits centimetres off its joint
    (LFHD on the forehead, not the head joint), so its usual distance, the median over the take, is no miss.

    Returns ``{"over_cm", "frames"}`` (frames with any marker over), and where there are some ``"worst_marker"``
    (``"LABEL (joint)"``), ``"worst_cm"`` (beyond the marker's median distance), ``"worst_frame"`` and
    ``"ranges"``: the runs of such frames, ``[first, last]`` each (0-based, inclusive), in order.
    """
    fitted = virtual_markers(result, list(joints)) * unit_scale_cm(result.skeleton)
    d = np.linalg.norm(fitted - np.asarray(pos) * pos_unit_cm, axis=-1)  # (F, M) cm, NaN unseen
    d = d - np.nanmedian(d, axis=0)
    over = np.nan_to_num(d, nan=0.0) > over_cm
    if not over.any():
        return {"over_cm": over_cm, "frames": 0}
    f, m = np.unravel_index(int(np.nanargmax(np.where(over, d, -1.0))), d.shape)
    bad = np.concatenate([[False], over.any(axis=1), [False]]).astype(np.int8)
    edges = np.flatnonzero(np.diff(bad))
    ranges = [[int(a), int(b) - 1] for a, b in zip(edges[::2], edges[1::2])]
    return {"over_cm": over_cm, "frames": int(over.any(axis=1).sum()), "worst_marker": f"{labels[m]} ({joints[m]})",
            "worst_cm": round(float(d[f, m]), 2), "worst_frame": int(f), "ranges": ranges}


def warn_unseen(markers, joints: Sequence[str], stacklevel: int = 2) -> list[str]:
    """Warn (``UserWarning``) naming the markers (F, M, 3) NaN in every frame, and return their joints.

    Such a marker says nothing and the fit goes on without it, carried by the others; counted as used it would
    claim a fit that was not made, and a mislabelled marker shows up here. The command line says the same in a
    note (and leaves the marker out before the reconstruction, so this stays silent there). ``stacklevel``: as
    :func:`warnings.warn`'s, counted from the caller of this function (2: its caller's caller).
    """
    import warnings

    seen = np.isfinite(np.asarray(markers, dtype=np.float64)).all(axis=-1).any(axis=0)
    unseen = [str(j) for j, ok in zip(joints, seen) if not ok]
    if unseen and seen.any():
        warnings.warn(f"marker(s) on {', '.join(unseen)} never seen in any frame: left out (the other markers "
                      "carry the fit)", UserWarning, stacklevel=stacklevel + 1)
    return unseen


def upsampled_note(fps: float, db_fps: float, what: str = "the control signals") -> str:
    """One line saying that control signals at ``fps`` coarser than the database's ``db_fps`` were interpolated up
    to it for the reconstruction and the result resampled back, or "" when they were not upsampled.

    Every method reconstructs at the database's rate (:mod:`~mocapkit.reconstruct.markers`,
    :mod:`~mocapkit.reconstruct.ssg`: markers linearly, :mod:`~mocapkit.reconstruct.accelerometers`: readings on the
    database's grid) and writes the input's rate and frame count; at 5 fps against a 30 fps database five of every
    six frames the method matches are made up between the recorded ones, which the output's own rate hides."""
    fps, db_fps = float(fps), float(db_fps)
    if not fps < db_fps * (1 - 1e-6):
        return ""
    return (f"{what} at {fps:g} fps were interpolated up to the database's {db_fps:g} fps ({db_fps / fps:.3g} frames "
            f"for each one recorded) to be reconstructed there, and the result resampled back to {fps:g} fps")
