"""A joint the file gives partly ``nan`` (one rotation channel of a Bandai Namco Hips written ``nan`` over 40 frames,
the other two measured; one dof of an HDM05 AMC bone) is filled conditioned on its measured channels: the fill's estimate reads them
(measured.measured_rotations, deep.channels.with_measured), so the rotation it returns carries the file's measured
angles as they are, not a made-up whole rotation that the put-back (measured.keep_measured) must then bend to them."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

from mocapkit import rotations as R
from mocapkit import samples
from mocapkit.cleaning import deep
from mocapkit.cleaning.deep.channels import euler_values, with_measured
from mocapkit.cleaning.measured import measured_rotations
from mocapkit.io.asfamc import read_amc
from mocapkit.io.bvh import read_bvh

DANCE = Path(__file__).resolve().parents[1] / "data" / "bandai_dance-short_normal_001_first240.bvh"
GAP = range(100, 140)
HIPS = slice(9, 12)  # Hips: Xposition Yposition Zposition, then Zrotation Xrotation Yrotation


def _with_nan(out: Path, column: int) -> np.ndarray:
    """The dance with its ``column``-th number written ``nan`` over :data:`GAP`; the file's numbers (F, C)."""
    lines = DANCE.read_text().split("\n")
    at = next(i for i, t in enumerate(lines) if t.startswith("Frame Time")) + 1
    for f in GAP:
        tokens = lines[at + f].split()
        tokens[column] = "nan"
        lines[at + f] = " ".join(tokens)
    out.write_text("\n".join(lines))
    return np.array([[float(x) for x in lines[at + f].split()] for f in range(240)])


@pytest.mark.parametrize("column", [9, 10, 11])
def test_the_fill_of_a_partly_missing_hips_carries_its_measured_angles(tmp_path, column):
    numbers = _with_nan(tmp_path / "hips.bvh", column)
    gappy = read_bvh(tmp_path / "hips.bvh")
    hips = gappy.skeleton.index("Hips")
    assert gappy.missing()[GAP.start:GAP.stop, hips].all()  # the whole joint reads as missing
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the Bandai models' non-commercial notice
        filled = deep.fill_gaps(gappy)
    own = numbers[GAP.start:GAP.stop, HIPS]
    q = filled.rotations[GAP.start:GAP.stop, hips]
    angles = R.nearest_euler(R.quaternion_to_euler(q, "ZXY"), np.where(np.isnan(own), 0.0, own), "ZXY")
    measured = ~np.isnan(own)
    assert np.abs(angles[measured] - own[measured]).max() < 1e-6  # the fill's rotation: the measured angles as written
    other = np.ones(filled.num_joints, dtype=bool)
    other[hips] = False
    assert np.array_equal(filled.rotations[:, other], gappy.rotations[:, other])  # every observed cell bit for bit


def test_measured_angles_go_in_on_the_encoding_branch(tmp_path):
    """Near the rig's gimbal lock the file's numbers and the encoded channels can lie on the two branches of the
    same rotation; the measured angles go in on the encoding's (the clean take's own channels there)."""
    numbers = _with_nan(tmp_path / "hips.bvh", 9)
    gappy = read_bvh(tmp_path / "hips.bvh")
    clean = read_bvh(DANCE)
    values = euler_values(gappy.channel_values(), gappy.skeleton)
    placed = with_measured(values, measured_rotations(gappy), gappy.skeleton)
    truth = euler_values(clean.channel_values(), clean.skeleton)
    assert np.isnan(values[GAP.start:GAP.stop, :3]).all()
    assert np.isnan(placed[GAP.start:GAP.stop, 0]).all()  # Zrotation: still for the fill to make
    assert np.allclose(placed[GAP.start:GAP.stop, 1:3], truth[GAP.start:GAP.stop, 1:3], atol=1e-9)
    assert np.array_equal(np.isnan(placed[:GAP.start]), np.isnan(values[:GAP.start]))
    assert numbers.shape == gappy.channel_values().shape


def _jog_with_nan(out: Path, bone: str, dof: int, frames: range) -> np.ndarray:
    """HDM_bd_jog (mocapkit.samples, 120 fps; HDM_bd.asf beside it at ``out``) with ``bone``'s ``dof``-th dof (0-based,
    after the name) written ``nan`` in ``frames`` (0-based); the bone's numbers as the file gave them (F, dofs)."""
    import shutil

    lines = samples.path("HDM_bd_jogLeftCircle4StepsRstart_001_120.amc").read_text(encoding="latin-1").split("\n")
    shutil.copy(samples.path("HDM_bd.asf"), out.parent / "HDM_bd.asf")
    frame, own = -1, []
    for i, line in enumerate(lines):
        tokens = line.split(" ")
        if len(tokens) == 1 and tokens[0].isdigit():
            frame += 1
        elif frame >= 0 and tokens[0] == bone:
            own.append([float(x) for x in tokens[1:]])
            if frame in frames:
                tokens[1 + dof] = "nan"
                lines[i] = " ".join(tokens)
    out.write_text("\n".join(lines), encoding="latin-1")
    return np.array(own)


def test_a_partly_missing_amc_bone_with_two_dofs_is_filled_conditioned_on_its_measured_dof(tmp_path):
    """HDM05's lfoot has two dofs (``rx rz``; its skeleton channels Zrotation, Xrotation: the other order): its ``rz``
    written ``nan`` over frames 40-99, the measured ``rx`` goes to the Xrotation column (measured_rotations) and the
    fill's rotation carries it as the file writes it, as a BVH's measured channels are carried."""
    path = tmp_path / "HDM_bd_jogLeftCircle4StepsRstart_001_120.amc"
    gap = range(40, 100)
    own = _jog_with_nan(path, "lfoot", 1, gap)
    gappy = read_amc(path)
    sk = gappy.skeleton
    j = sk.index("lfoot")
    assert sk.joint_channels(j) == ("Zrotation", "Xrotation")
    assert gappy.missing()[gap.start:gap.stop, j].all()
    measured = measured_rotations(gappy)
    at = sum(len(sk.joint_channels(k)) for k in range(j))
    assert measured is not None
    assert np.array_equal(measured[gap.start:gap.stop, at + 1], own[gap.start:gap.stop, 0])  # rx: Xrotation's column
    assert np.isnan(measured[gap.start:gap.stop, at]).all()  # rz: for the fill to make
    assert np.isnan(np.delete(measured, [at, at + 1], axis=1)).all()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        filled = deep.fill_gaps(gappy)
    q = filled.rotations[gap.start:gap.stop, j]
    c = np.broadcast_to(sk.axes[j], q.shape)
    dofs = R.quaternion_to_euler(R.quaternion_multiply(R.quaternion_multiply(R.quaternion_conjugate(c), q), c), "xz")
    rx = own[gap.start:gap.stop, 0]
    assert np.abs((dofs[:, 0] - rx + 180.0) % 360.0 - 180.0).max() < 1e-6  # the measured rx, as the file writes it
    assert np.array_equal(filled.rotations[:gap.start], gappy.rotations[:gap.start])


def test_an_npz_of_a_take_with_gaps_cut_in_gives_no_measured_channels_in_its_gaps(tmp_path):
    """An .npz keeps its source file's numbers (mocapkit.io.kept_channels), whole, in the cells a gap was cut into
    (``mocapkit corrupt take.bvh g.npz``): they are the numbers taken out, not channels the gap left measured, and
    the fill must not read them (it gave the Bandai dash's 9 cut cells back exactly, 0 deg, as if it knew them)."""
    import mocapkit
    from mocapkit import corrupt

    clean = read_bvh(DANCE.parent / "dataset-1_dash_normal_001.bvh")
    gapped, _ = corrupt.gaps(clean, seed=2, start_prob=0.01)
    mocapkit.save(gapped, tmp_path / "gaps.npz")
    gappy = mocapkit.load(tmp_path / "gaps.npz")
    gone = gappy.missing()
    assert gone.any()
    assert measured_rotations(gappy) is None
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        filled = deep.fill_gaps(gappy)
    off = np.degrees(R.geodesic_angle(filled.rotations[gone], clean.rotations[gone]))
    assert off.max() > 1.0  # an estimate, not the numbers cut out
