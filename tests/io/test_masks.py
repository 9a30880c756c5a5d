"""mocapkit.io.masks: the ground truth of a corruption, written and read back."""

import json

import numpy as np
import pytest

import mocapkit
from mocapkit import corrupt
from mocapkit.errors import MocapFormatError
from mocapkit.io.masks import error_record, mask_path_for, read_mask, write_mask


def test_round_trip_with_error_records(tmp_path):
    walk = mocapkit.load(mocapkit.samples.path("12_walk.amc"))
    bad, mask, records = corrupt.real_errors(walk, n_errors=2, seed=3)
    path = tmp_path / "sub" / "bad.mask.npz"  # the parent folder is created
    write_mask(path, mask, walk.skeleton.joint_names, kind="errors", seed=3, params={"n": 2}, records=records)
    np.testing.assert_array_equal(read_mask(path, frames=walk.num_frames), mask)
    with np.load(path) as z:
        assert z["joint_names"].tolist() == list(walk.skeleton.joint_names)
        assert str(z["kind"]) == "errors" and int(z["seed"]) == 3 and json.loads(str(z["params"])) == {"n": 2}
        errors = json.loads(str(z["errors"]))
    assert len(errors) == len(records) > 0 and errors[0] == json.loads(json.dumps(error_record(records[0]), default=str))


def test_refusals_name_the_file(tmp_path):
    path = tmp_path / "m.mask.npz"
    write_mask(path, np.zeros((4, 2), bool), ["a", "b"], kind="noise", seed=0)
    with pytest.raises(MocapFormatError, match="the mask has 4 frames and the take 5"):
        read_mask(path, frames=5)
    junk = tmp_path / "junk.mask.npz"
    junk.write_bytes(b"not a zip")
    with pytest.raises(MocapFormatError, match="not a readable .npz file") as err:
        read_mask(junk)
    assert "junk.mask.npz" in str(err.value)


def test_mask_path_for():
    assert mask_path_for("a/noisy.bvh").as_posix() == "a/noisy.mask.npz"
    assert mask_path_for("noisy").as_posix() == "noisy.mask.npz"
    assert error_record({"joint": "x"}) == {"joint": "x"}
