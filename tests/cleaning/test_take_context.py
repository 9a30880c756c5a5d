"""A take too coarse for self-similarity reads no context: a folder named for it is neither built nor cached."""

import dataclasses

import numpy as np

import mocapkit
from mocapkit.cleaning.take_context import unread_context

SNEAK = mocapkit.samples.path("HDM_bk_sneak2StepsLStart_004_120.amc")


def context_folder(tmp_path):
    """A folder of one real take (its ASF beside it), as ``--context`` names one."""
    folder = tmp_path / "ctx"
    folder.mkdir()
    for p in (SNEAK, SNEAK.with_name("HDM_bk.asf")):
        (folder / p.name).write_bytes(p.read_bytes())
    return folder


def built(cache):
    return sorted(p.name for p in (cache / "contexts").iterdir()) if (cache / "contexts").exists() else []


def test_a_take_under_12_fps_builds_no_context_and_says_why(tmp_path, monkeypatch):
    """At 10 fps detect and repair do not run; the folder given as the context was built all the same (each clip
    resampled to 24 fps and cached). Now nothing is built, the take comes back bit-identical and one note says why."""
    cache = tmp_path / "cache"
    monkeypatch.setenv("MOCAPKIT_CACHE_DIR", str(cache))
    folder = context_folder(tmp_path)
    take = mocapkit.load(SNEAK.with_name("HDM_bk_sneak2StepsLStart_005_120.amc")).resample(10)
    res = mocapkit.clean(take, [folder], steps="detect,repair")
    assert built(cache) == []
    assert res.detection is None
    assert np.array_equal(res.motion.rotations, take.rotations)
    line = ("the context given was neither built nor read: at 10 fps detect and repair do not run "
            "(self-similarity judges takes of 12 fps or more)")
    assert line in res.summary()[-1] or any(line in s for s in res.summary())


def test_the_context_is_read_from_the_lowest_judged_rate_up(tmp_path, monkeypatch):
    take = mocapkit.load(SNEAK)
    assert unread_context(take.resample(12), ["folder"]) is None
    assert unread_context(dataclasses.replace(take, fps=11.9), ["folder"]).startswith("the context given was neither")
    assert unread_context(dataclasses.replace(take, fps=5.0), None) == ""  # the default context: nothing to say
    assert unread_context(dataclasses.replace(take, fps=5.0), "none") == ""
    cache = tmp_path / "cache"
    monkeypatch.setenv("MOCAPKIT_CACHE_DIR", str(cache))
    mocapkit.clean(take.resample(12), [context_folder(tmp_path)], steps="detect")
    assert len(built(cache)) == 1  # at 12 fps detection runs, against the folder
