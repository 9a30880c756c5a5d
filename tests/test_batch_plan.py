"""Which takes a batch cleans and which files each writes (mocapkit.batch_plan): mirrored names, the inputs found,
takes of one folder that would share a file."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

import mocapkit
from mocapkit import samples
from mocapkit.batch import BatchSummary, clean_batch, find_inputs, output_for
from mocapkit.errors import MocapFormatError

from .test_batch import STEPS, file_tree, visible_files, short_bvh, twins  # noqa: F401  (fixtures)

# -- names -------------------------------------------------------------------------------


def test_output_for_mirrors_folders_and_picks_the_suffix():
    i, o = Path("in"), Path("out")
    assert output_for(i / "a" / "b" / "walk.amc", i, o) == o / "a" / "b" / "walk.bvh"
    assert output_for(i / "walk.NPZ", i, o) == o / "walk.npz"
    assert output_for(i / "walk.bvh", i, o, fmt="npz") == o / "walk.npz"
    assert output_for(i / "walk.v2.bvh", i, o, fmt="npz", keep_suffix=True) == o / "walk.v2-bvh.npz"


def test_find_inputs_patterns_records_hidden_and_excluded(tmp_path):
    for rel in ("a/walk.bvh", "a/walk.clean.npz", "a/walk.mask.npz", "a/.hidden.bvh", "b/run.amc", "b/run.asf",
                "notes.txt", "out/old.bvh", "c/x.npz"):
        (tmp_path / rel).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / rel).write_text("x")
    names = [p.relative_to(tmp_path).as_posix() for p in find_inputs(tmp_path, exclude=tmp_path / "out")]
    assert names == ["a/walk.bvh", "b/run.amc", "c/x.npz"]
    assert [p.name for p in find_inputs(tmp_path, ["*.BVH"])] == ["walk.bvh", "old.bvh"]


# -- item 4: colliding takes ---------------------------------------------------------------


def test_takes_sharing_a_name_keep_their_suffix_and_resume(twins, tmp_path):
    out = tmp_path / "out"
    s = clean_batch(twins, out, steps=STEPS, executor="serial", progress=False)
    assert isinstance(s, BatchSummary) and s.count("done") == 2 and not s.failed, s.rows
    assert sorted(Path(p).name for p in s.renamed) == ["take.amc", "take.bvh"]
    assert visible_files(out) == ["take-amc.bvh", "take-amc.clean.npz", "take-bvh.bvh", "take-bvh.clean.npz"]
    a, b = mocapkit.load(out / "take-amc.bvh"), mocapkit.load(out / "take-bvh.bvh")
    assert (a.num_frames, b.num_frames) == (30, 40)  # each output is its own take's
    before = file_tree(out)
    again = clean_batch(twins, out, steps=STEPS, executor="serial", progress=False)
    assert again.count("skipped") == 2 and again.count("done") == 0
    assert file_tree(out) == before


def test_bvh_and_npz_of_one_name_share_the_record_so_both_keep_their_suffix(tmp_path, short_bvh):
    src = tmp_path / "in"
    src.mkdir()
    shutil.copy(short_bvh, src / "take.bvh")
    mocapkit.save(mocapkit.load(short_bvh), src / "take.npz")
    shutil.copy(short_bvh, src / "other.bvh")
    s = clean_batch(src, tmp_path / "out", steps=STEPS, executor="serial", progress=False)
    assert s.count("done") == 3
    assert visible_files(tmp_path / "out") == ["other.bvh", "other.clean.npz", "take-bvh.bvh", "take-bvh.clean.npz",
                                          "take-npz.clean.npz", "take-npz.npz"]


def test_a_bvh_and_a_c3d_of_one_name_are_named_after_their_format_never_a_doubled_suffix(tmp_path, short_bvh):
    """take.bvh and take.c3d in one folder share only the record take.clean.npz: they were written as
    take.bvh.bvh and take.c3d.c3d. Each is named after its format instead, with its own record, and the
    summary lists both."""
    src = tmp_path / "in"
    src.mkdir()
    shutil.copy(short_bvh, src / "take.bvh")
    shutil.copy(samples.path("Eb015pr.c3d"), src / "take.c3d")
    s = clean_batch(src, tmp_path / "out", steps=STEPS, executor="serial", progress=False)
    assert sorted(Path(p).name for p in s.renamed) == ["take.bvh", "take.c3d"]
    assert sorted(Path(r["output"]).name for r in s.rows) == ["take-bvh.bvh", "take-c3d.c3d"]
    assert all(".bvh.bvh" not in name and ".c3d.c3d" not in name for name in visible_files(tmp_path / "out"))


def test_takes_that_still_collide_refuse_the_batch(twins, tmp_path):
    (twins / "take-amc.bvh").write_text("not read: the batch is refused first")
    out = tmp_path / "out"
    with pytest.raises(MocapFormatError, match=r"take[-.]amc.*would write .*take-amc\.bvh, as .*take[-.]amc(\.bvh)? does; rename one"):
        clean_batch(twins, out, steps=STEPS, executor="serial", progress=False)
    assert not out.exists()
