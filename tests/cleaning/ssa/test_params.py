"""SSAParams is the one source of the self-similarity defaults, and a detection records the ones it used."""

import dataclasses
import inspect
import json

import numpy as np
import pytest

import mocapkit
from mocapkit.cleaning import pipeline, ssa
from mocapkit.cleaning.ssa import SSAParams, cues, neighbours, texture
from mocapkit.reconstruct.sparse import reconstruct_sparse

D = SSAParams()


def _default(fn, name):
    return inspect.signature(fn).parameters[name].default


@pytest.mark.parametrize("fn, arg, field", [
    (cues.discontinuities, "jump_deg", "jump_deg"),
    (cues.side_swaps, "jump_deg", "swap_jump_deg"),
    (cues.side_swaps, "max_s", "swap_max_s"),
    (cues.transient_offsets, "jump_deg", "offset_jump_deg"),
    (cues.transient_offsets, "max_s", "offset_max_s"),
    (cues.transient_offsets, "min_offset_deg", "offset_min_deg"),
    (cues.held_joints, "travel_deg", "hold_travel_deg"),
    (cues.confirm_flags, "margin_s", "confirm_margin_s"),
    (texture.motion_texture, "analysis_fps", "analysis_fps"),
    (texture.motion_words, "length", "source_length"),
    (texture.motion_words, "stride", "stride"),
    (texture.informative_joints, "count", "joints"),
    (neighbours.neighbor_words, "min_width", "min_width"),
    (ssa.movement_digression_map, "normalization", "normalization"),
    (ssa.movement_digression_map, "row_scale", "row_scale"),
    (ssa.movement_digression_map, "floor_deg", "floor_deg"),
    (ssa.movement_digression_map, "z_scale", "z_scale"),
    (reconstruct_sparse, "analysis_fps", "analysis_fps"),
    (reconstruct_sparse, "k", "k"),
    (reconstruct_sparse, "source_length", "source_length"),
    (reconstruct_sparse, "target_length", "target_length"),
])
def test_function_defaults_are_the_dataclass_defaults(fn, arg, field):
    assert _default(fn, arg) == getattr(D, field)


def test_detect_records_its_parameters():
    walk = mocapkit.load(mocapkit.samples.path("131_01.bvh"))[:300]
    det = ssa.detect(walk, k=3, confirm=False)
    assert det.params == D.replace(k=3, confirm=False, prefilter=False)  # prefilter resolved to what ran
    assert det.neighbor_pos.shape[2] == 3
    given = SSAParams(stride=10)
    det = ssa.detect(walk, params=given, max_word_angle_deg=8.0)
    assert det.params == given.replace(max_word_angle_deg=8.0, prefilter=False)
    assert np.all(np.diff(det.word_starts[:-1]) == 10)
    with pytest.raises(TypeError, match="analysis_fps"):
        ssa.detect(walk, fps=24.0)  # the analysis rate is analysis_fps


def test_clean_takes_its_analysis_from_the_dataclass(monkeypatch):
    seen = []
    real = ssa.detect
    monkeypatch.setattr(ssa, "detect", lambda *a, **k: seen.append(k["params"]) or real(*a, **k))
    walk = mocapkit.load(mocapkit.samples.path("131_01.bvh"))[:300]
    pipeline.clean(walk, steps="detect")
    assert seen == [D.replace(max_word_angle_deg=pipeline.MAX_WORD_ANGLE_DEG)]
    # a take shorter than one source word at the analysis rate is not analysed
    short = walk[: int((D.source_length - 1) * walk.fps / D.analysis_fps)]  # 14 frames at 24 fps
    res = pipeline.clean(short, steps="detect")
    assert res.steps[0].method == "skipped" and f"{D.source_length} frames at {D.analysis_fps:g} fps" in res.steps[0].note


def test_params_check_and_round_trip():
    for bad in (dict(source_length=30), dict(analysis_fps=0.0), dict(normalization="max"), dict(jump_deg=0.0),
                dict(confirm_margin_s=-1.0), dict(hold_travel_deg=float("nan")), dict(k=0), dict(drift_others=-1),
                dict(drift_others=1.5), dict(drift_return_ratio=0.0), dict(drift_return_ratio=1.5),
                dict(drift_partner_ratio=0.0), dict(drift_partner_ratio=1.5)):
        with pytest.raises(ValueError):
            SSAParams(**bad)
    with pytest.raises(TypeError, match="unknown"):
        D.replace(window=3)
    p = SSAParams(joints=["LeftKnee", 3], max_word_angle_deg=8.0)
    assert p.joints == ("LeftKnee", 3)
    assert SSAParams.from_dict(json.loads(json.dumps(p.as_dict()))) == p
    old = {k: v for k, v in D.as_dict().items() if k != "analysis_fps"} | {"fps": 30.0, "retired": 1}
    assert SSAParams.from_dict(old) == D.replace(analysis_fps=30.0)  # files written before the rename
    with pytest.raises(dataclasses.FrozenInstanceError):
        D.k = 3
    assert D.min_width == 11 and SSAParams(source_length=8, target_length=10).min_width == 8
