"""A joint the file gives partly ``nan`` (one rotation channel of a Bandai Namco Hips written ``nan`` over 40 frames,
the other two measured) is filled conditioned on its measured channels: the fill's estimate reads them
(measured.measured_rotations, deep.channels.with_measured), so the rotation it returns carries the file's measured
angles as they are, not a made-up whole rotation that the put-back (measured.keep_measured) must then bend to them."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

from mocapkit import rotations as R
from mocapkit.cleaning import deep
from mocapkit.cleaning.deep.channels import euler_values, with_measured
from mocapkit.cleaning.measured import measured_rotations
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
