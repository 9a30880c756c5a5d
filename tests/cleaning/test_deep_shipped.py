"""The shipped EBF and EBD (docs/models.md) on real clips they never saw: CMU subject 12's walk; the Bandai Namco pair on the game rig."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
from scipy.ndimage import gaussian_filter1d

import mocapkit
from mocapkit import corrupt, metrics
from mocapkit.cleaning import deep
from mocapkit.cleaning.deep.channels import decode, encode


@pytest.fixture(scope="module")
def walk():
    return mocapkit.load(mocapkit.samples.path("12_walk.amc"))


def _wrapped_rms(a, b, mask=None):
    d = (a - b + 180.0) % 360.0 - 180.0
    return float(np.sqrt(np.mean(d[mask] ** 2 if mask is not None else d**2)))


def test_shipped_models_are_held_out_and_documented():
    for kind in ("ebf", "ebd"):
        m = deep.shipped_model(kind)
        assert m.kind == kind and m.fps == 120.0
        train = m.meta["train_clips"]
        assert len(train) > 100
        # the test clips of the benchmarks: HDM05 actor mm, CMU 12 walk, charleston2, 11_01
        assert not any(n.startswith("HDM_mm_") or n in ("12_from_examples_02_01", "charleston2", "11_01") for n in train)
        assert all(n.startswith("HDM_tr_") for n in m.meta["validation_clips"])


def test_models_md_states_each_shipped_gap_priors_fit_as_its_file_records_it():
    # docs/models.md gives the command that fits each shipped gap prior with its clips, frames and time: the figures
    # the model file keeps (gap_prior), not a time from an older fit.
    text = (Path(__file__).resolve().parents[2] / "docs" / "models.md").read_text()
    for rig, name in (("", "ebd.pt"), ("--rig bandai ", "ebd_bandai.pt")):
        line = next(ln for ln in text.splitlines()
                    if ln.lstrip().startswith(f"python scripts/train_shipped.py {rig}--kind ebd --prior-only"))
        said = line.split("#", 1)[1]
        fit = deep.load_model(Path(deep.__file__).resolve().parents[2] / "models" / name).meta["gap_prior"]
        assert said.lstrip().startswith(f"{fit['train_clips']:,} "), (name, said)
        assert f"{fit['frames']:,} frames" in said, (name, said)
        assert said.rstrip().endswith(f" {fit['fit_seconds']} s"), (name, said, fit["fit_seconds"])


def _gaussian_errors(walk, noisy):
    lay = deep.shipped_model("ebf").layout
    x, _ = encode(noisy, lay)
    return [
        metrics.joint_angle_rms(walk, decode(gaussian_filter1d(x, s * 120, axis=0, mode="nearest"), noisy, lay),
                                include_root=False)
        for s in (0.058, 0.125)
    ]


def test_shipped_ebf_denoises_angular_noise(walk):
    noisy, _ = corrupt.angular_noise(walk, 0.5, seed=0)
    out = deep.denoise(noisy)
    assert out.skeleton is walk.skeleton and out.num_frames == walk.num_frames and out.fps == walk.fps
    assert np.array_equal(out.root_positions, noisy.root_positions)
    assert np.array_equal(out.rotations[:, 0], noisy.rotations[:, 0])
    ebf = metrics.joint_angle_rms(walk, out, include_root=False)
    assert ebf < 0.45 * metrics.joint_angle_rms(walk, noisy, include_root=False)  # measured 1.51 vs 3.93
    # on this held-out walk the shipped EBF is only as good as the 58 ms Gaussian (1.51 vs 1.49; docs/models.md)
    assert ebf < 1.1 * min(_gaussian_errors(walk, noisy))


def test_shipped_ebf_beats_the_gaussians_on_spatial_noise(walk):
    noisy, _ = corrupt.spatial_noise(walk, std_cm=0.5, seed=0)
    ebf = metrics.joint_angle_rms(walk, deep.denoise(noisy), include_root=False)
    assert ebf < 0.9 * min(_gaussian_errors(walk, noisy))  # measured 1.69 vs 1.98 (58 ms)


def test_shipped_ebf_at_another_frame_rate(walk):
    w30 = walk.resample(30)
    noisy, _ = corrupt.angular_noise(w30, 0.5, seed=1)
    out = deep.denoise(noisy)
    assert out.fps == 30 and out.num_frames == w30.num_frames
    assert metrics.joint_angle_rms(w30, out, include_root=False) < 0.7 * metrics.joint_angle_rms(
        w30, noisy, include_root=False
    )


def test_shipped_ebd_fills_a_long_gap_better_than_lerp(walk):
    ebf, ebd = deep.shipped_model("ebf"), deep.shipped_model("ebd")
    noisy, _ = corrupt.angular_noise(walk, 0.5, seed=2)
    y, _ = encode(walk, ebf.layout)
    x, ctx = encode(noisy, ebf.layout)
    c = list(ebf.layout.names).index("ltibia.Xrotation")  # the left knee, as Mall's Fig. 10
    xg = x.copy()
    xg[60:240, c] = np.nan  # 1.5 s
    gap = np.isnan(xg)
    lerp_gauss = gaussian_filter1d(deep.lerp_fill(xg), 0.058 * 120, axis=0, mode="nearest")
    filled = deep.fill_channels(xg, ctx, ebd, smooth=False, method="ebd")  # the network (the prior: test_prior.py)
    assert np.array_equal(filled[~gap], xg[~gap])  # observed entries bit-identical
    ours = deep.denoise_channels(filled, ctx, ebf)
    assert _wrapped_rms(ours, y, gap) < 0.8 * _wrapped_rms(lerp_gauss, y, gap)  # measured 19.1 vs 26.8 deg


def test_shipped_fill_gaps_on_a_motion(walk):
    gapped, mask = corrupt.gaps(walk, seed=3, start_prob=0.01)
    assert mask.any()
    out = deep.fill_gaps(gapped)
    assert out.skeleton is walk.skeleton and out.num_frames == walk.num_frames
    assert not out.missing().any()
    obs = ~gapped.missing()
    assert np.array_equal(out.rotations[obs], gapped.rotations[obs])
    assert np.array_equal(out.root_positions, walk.root_positions)
    # the filled joints are close to the truth: mean rotation error on the gap cells well under 10 degrees
    err = np.degrees(metrics.geodesic_pose_distance(walk, out))[mask]
    assert err.mean() < 10.0


# -- the Bandai Namco game rig's own models (ebf_bandai.pt, ebd_bandai.pt) ---------------------------------

BANDAI_DATA = Path(__file__).resolve().parents[1] / "data"
HELD_OUT_STYLES = ("_elderly_", "_old_", "_sad_", "_proud_")  # scripts/train_shipped.py BANDAI_TEST


@pytest.fixture(scope="module")
def dance():
    """60 frames (2 s, 30 fps) of a dataset-1 dance take: the game rig, 22 joints, Hips carrying the translation."""
    return mocapkit.load(BANDAI_DATA / "bandai_dance-short_normal_001_first60.bvh")


def test_a_bandai_take_gets_the_bandai_models_held_out_by_style_and_non_commercial(dance, walk):
    for kind in ("ebf", "ebd"):
        m = deep.shipped_model(kind, dance)
        assert m.fps == 30.0 and m.meta["rig"] == "bandai_namco" and "CC BY-NC 4.0" in m.meta["licence"]
        assert not isinstance(deep.served_by(dance, m), str)
        train, val = m.meta["train_clips"], m.meta["validation_clips"]
        assert len(train) > 1000 and len(val) > 10
        assert not any(s in n for n in train + val for s in HELD_OUT_STYLES)  # whole styles kept for the test
        assert all("_tired_" in n or "_childish_" in n for n in val) and not set(val) & set(train)
        assert deep.shipped_model(kind, walk) is deep.shipped_model(kind)  # the Acclaim take keeps the Acclaim model


def test_bandai_ebf_denoises_and_its_note_names_the_licence(dance):
    noisy, _ = corrupt.angular_noise(dance, 0.5, seed=7)
    out, method, note = deep.denoise_or_fallback(noisy)
    assert method == "EBF (shipped, bandai_namco)" and "CC BY-NC 4.0" in note and "--ebf (clean, clean-batch; models= in Python)" in note
    before = metrics.joint_angle_rms(dance, noisy, include_root=False)
    assert metrics.joint_angle_rms(dance, out, include_root=False) < 0.75 * before
    assert np.array_equal(out.rotations[:, 0], noisy.rotations[:, 0])  # joint_Root untouched
    # --model picks another: the Acclaim EBF, through its joint map (the game rig retargeted, its palms, fingers,
    # thumbs, middle spine and upper neck held at the model's means)
    acclaim, method, note = deep.denoise_or_fallback(noisy, deep.shipped_model("ebf"), label="given")
    assert method == "EBF (given, via the bandai_namco joint map)" and "used: CC BY-NC" not in note and "used: research use only" in note
    assert metrics.joint_angle_rms(dance, acclaim, include_root=False) < 0.75 * before


def test_bandai_ebf_denoises_the_hip_whose_channels_wrapped_in_training_as_the_other_hip():
    # UpperLeg_R's Y channel swings 149..180..-170 in a walk; the model's training std for it is 174 deg (its
    # takes sat 360 deg apart), which hid its noise from the network: its width was 4x too wide (7.58 -> 7.22 deg
    # while UpperLeg_L went 7.16 -> 3.42). Its width is now the least estimated risk's (sure.wrapped_channels).
    walk = mocapkit.load(BANDAI_DATA / "dataset-2_walk_normal_001_first120.bvh")
    noisy, _ = corrupt.angular_noise(walk, 0.5, seed=1)
    out = deep.denoise(noisy)
    sk = walk.skeleton

    def rms(a, b, joint):
        j = sk.index(joint)
        d = np.abs(np.sum(a.rotations[:, j] * b.rotations[:, j], axis=-1)).clip(0.0, 1.0)
        return float(np.sqrt(np.mean(np.degrees(2.0 * np.arccos(d)) ** 2)))

    for joint in ("UpperLeg_L", "UpperLeg_R"):
        assert rms(walk, out, joint) < 0.6 * rms(walk, noisy, joint), joint
    assert rms(walk, out, "UpperLeg_R") < 1.3 * rms(walk, out, "UpperLeg_L")
    # at 60 fps (resampled to the model's 30) the network's width made the hip worse than its input (8.09 -> 8.66
    # deg on the whole take); the wrapped channels are calibrated at any rate
    walk60 = walk.resample(60)
    noisy60, _ = corrupt.angular_noise(walk60, 0.5, seed=1)
    out60 = deep.denoise(noisy60)
    for joint in ("UpperLeg_L", "UpperLeg_R"):
        assert rms(walk60, out60, joint) < 0.6 * rms(walk60, noisy60, joint), joint


def test_bandai_ebd_fills_a_whole_joint_gap_and_keeps_the_observed_cells(dance):
    rot = np.array(dance.rotations)
    j = dance.skeleton.joint_names.index("LowerLeg_L")
    rot[15:45, j] = np.nan  # a 1 s gap of the knee
    gapped = dataclasses.replace(dance, rotations=rot)
    out, method, note = deep.fill_or_fallback(gapped)
    assert method == "EBD's gap prior (shipped, bandai_namco) + EBF" and "CC BY-NC 4.0" in note
    assert not out.missing().any()
    obs = ~gapped.missing()
    assert np.array_equal(out.rotations[obs], gapped.rotations[obs])
    err = np.degrees(mocapkit.rotations.geodesic_angle(out.rotations[15:45, j], dance.rotations[15:45, j]))
    assert float(np.sqrt(np.mean(err**2))) < 20.0


def test_denoise_and_fill_gaps_warn_of_the_non_commercial_models_they_pick(dance):
    """deep.denoise and deep.fill_gaps used the CC BY-NC Bandai models on a Bandai take without a word (the CLI and
    clean's summary say it): a LicenceWarning naming the licence and the argument that picks another model."""
    import warnings

    from mocapkit.errors import LicenceWarning

    noisy, _ = corrupt.angular_noise(dance, 0.5, seed=7)
    with pytest.warns(LicenceWarning, match="licence of the EBF used: CC BY-NC 4.0.*model= picks another"):
        deep.denoise(noisy)
    rot = np.array(dance.rotations)
    rot[15:45, dance.skeleton.joint_names.index("LowerLeg_L")] = np.nan
    with pytest.warns(LicenceWarning, match="licence of the EB[DF] used: CC BY-NC 4.0") as said:
        deep.fill_gaps(dataclasses.replace(dance, rotations=rot))
    assert any("denoiser= picks another" in str(w.message) for w in said)  # its EBF smooths the fill
    with pytest.warns(LicenceWarning, match="licence of the EBF used: research use only"):  # HDM05's terms
        deep.denoise(noisy, deep.shipped_model("ebf"))
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # clean's path (its summary says it) warns of nothing
        deep.denoise_or_fallback(noisy)


def test_the_streaming_denoiser_warns_of_the_non_commercial_model_it_picks(dance, walk):
    """deep.Denoiser and deep.denoise_rows picked the CC BY-NC Bandai EBF for a Bandai take without a word, where
    deep.denoise warns: the same LicenceWarning; the Acclaim model streaming an Acclaim take warns of HDM05's terms."""

    from mocapkit.errors import LicenceWarning

    with pytest.warns(LicenceWarning, match="licence of the EBF used: CC BY-NC 4.0.*model= picks another"):
        deep.Denoiser(dance.skeleton, dance.fps)
    with pytest.warns(LicenceWarning, match="licence of the EBF used: CC BY-NC 4.0"):
        deep.denoise_rows(dance.skeleton, dance.channel_values()[:40], dance.fps)
    with pytest.warns(LicenceWarning, match="research use only"):  # the Acclaim model: HDM05's terms
        deep.Denoiser(walk.skeleton, walk.fps)
    with pytest.warns(LicenceWarning, match="research use only"):
        deep.denoise_rows(walk.skeleton, walk.channel_values()[:40], walk.fps)


@pytest.mark.parametrize("method", ["auto", "ebd"])
@pytest.mark.parametrize("rotation_too", [True, False])
def test_a_lost_bandai_pelvis_position_is_filled_as_the_root_position_is(dance, method, rotation_too):
    """Trial A, finding 1: on this rig joint_Root stands still and Hips' animated offset carries the path; its gap
    was left NaN by the EBD's fill (prior and network), so ``clean`` stopped at detect's complete-frames check."""
    j = dance.skeleton.index("Hips")
    rot, tr = np.array(dance.rotations), np.array(dance.translations)
    tr[20:35, j] = np.nan
    if rotation_too:
        rot[20:35, j] = np.nan
    gapped = dataclasses.replace(dance, rotations=rot, translations=tr)
    out, _, _ = deep.fill_or_fallback(gapped, method=method)
    assert not out.missing().any() and not np.isnan(out.translations).any()
    assert np.array_equal(out.translations[~np.isnan(tr)], tr[~np.isnan(tr)])  # observed offsets bit-identical
    t = (np.arange(20, 35) - 19) / 16.0  # the line between the frames either side
    line = (1 - t)[:, None] * dance.translations[19, j] + t[:, None] * dance.translations[35, j]
    if rotation_too:  # a filled rotation would swing the feet: no stretch of 60 frames to judge by, the line
        assert np.allclose(out.translations[20:35, j], line)
    else:  # the feet's contacts (root_gaps.fill_pelvis): 0.07 -> 0.01 cm RMS off on this near-still stretch
        off = np.sqrt(np.mean(np.sum((out.translations[20:35, j] - dance.translations[20:35, j]) ** 2, axis=-1)))
        assert off < 0.03
    if method == "auto":
        res = mocapkit.clean(gapped)  # fill is a default step: no "detect needs complete frames" any more
        assert not res.motion.missing().any()


def _with_joint(motion, name: str, parent: str, offset, angle_deg, inserted: bool = False):
    """``motion`` with a joint ``name`` (3 rotation channels, ZXY as the rig's, turning ``angle_deg`` (F,) about
    its z) hung from ``parent``: a weapon bone beside the rig's joints, or with ``inserted`` a helper bone placed
    between ``parent`` and its children (which then hang from it, their motion the same)."""
    from mocapkit.motion import Motion, Skeleton

    sk = motion.skeleton
    p = sk.index(parent)
    order = list(range(p + 1)) + [-1] + list(range(p + 1, sk.num_joints))  # the new joint right after its parent
    new = {j: k for k, j in enumerate(order)}
    parents = []
    for j in order:
        q = p if j == -1 else int(sk.parents[j])
        parents.append(-1 if q < 0 else new[-1] if inserted and j != -1 and q == p else new[q])
    offsets = np.array([offset if j == -1 else sk.offsets[j] for j in order], dtype=np.float64)
    channels = tuple(("Zrotation", "Xrotation", "Yrotation") if j == -1 else sk.channels[j] for j in order)
    names = tuple(name if j == -1 else sk.joint_names[j] for j in order)
    ends = np.array([new[int(e)] for e in sk.end_site_parents], dtype=np.int64)
    skel = Skeleton(names, np.array(parents), offsets, ends, sk.end_site_offsets, channels=channels)
    F = motion.num_frames
    turn = mocapkit.rotations.quaternion_from_axis_angle(np.array([0.0, 0.0, 1.0]), np.radians(angle_deg))
    rot = np.concatenate([motion.rotations[:, : p + 1], turn[:, None], motion.rotations[:, p + 1:]], axis=1)
    tr = None
    if motion.translations is not None:
        tr = np.concatenate([motion.translations[:, : p + 1], np.broadcast_to(offsets[p + 1], (F, 1, 3)),
                             motion.translations[:, p + 1:]], axis=1)
    return Motion(skeleton=skel, rotations=rot, root_positions=motion.root_positions, fps=motion.fps,
                  name=motion.name, translations=tr)


def test_a_bandai_take_with_a_weapon_bone_keeps_the_bandai_models_on_its_own_joints(dance):
    """Issue 4: one weapon bone under the right hand switched a Bandai take to the Acclaim models through a joint
    map. The take has every channel of the Bandai models, so they serve it directly: the rig's joints come out
    as from the plain take, bit for bit, and the weapon gets the fallback's filter."""
    noisy, _ = corrupt.angular_noise(dance, 0.5, seed=7)
    swing = 40.0 * np.sin(np.arange(dance.num_frames) / 4.0) + np.random.default_rng(3).normal(0, 2.0, dance.num_frames)
    armed = _with_joint(noisy, "weapon_r", "Hand_R", (-8.0, 0.0, 2.0), swing)
    w = armed.skeleton.index("weapon_r")
    assert mocapkit.rigs.rig_family(armed.skeleton) == "bandai_namco"
    for kind in ("ebf", "ebd"):
        m = deep.shipped_model(kind, armed)
        assert m.meta["rig"] == "bandai_namco"
        sv = deep.served_by(armed, m)
        assert sv.direct and sv.others == (w,) and armed.skeleton.joint_names[sv.joints[0]] == "Hips"
    plain, _m, _n = deep.denoise_or_fallback(noisy)
    out, method, note = deep.denoise_or_fallback(armed)
    assert method == "EBF (shipped, bandai_namco; weapon_r beside its joints by the fallback)"
    assert "CC BY-NC 4.0" in note and "not used" not in note
    ids = [armed.skeleton.index(n) for n in dance.skeleton.joint_names]
    assert np.allclose(out.rotations[:, ids], plain.rotations, rtol=0, atol=1e-12)
    smooth = mocapkit.cleaning.filters.savgol_smooth(armed, window_s=0.1, polyorder=2, joints=[w], root=False)
    assert np.array_equal(out.rotations[:, w], smooth.rotations[:, w])
    assert not np.array_equal(out.rotations[:, w], armed.rotations[:, w])
    # a gap of the knee is filled by the Bandai EBD as on the plain take; the weapon's gap by interpolation
    rot = np.array(armed.rotations)
    k = armed.skeleton.index("LowerLeg_L")
    rot[15:45, k] = np.nan
    rot[20:30, w] = np.nan
    filled, method, _note = deep.fill_or_fallback(dataclasses.replace(armed, rotations=rot))
    assert method == "EBD's gap prior (shipped, bandai_namco; weapon_r beside its joints by the fallback) + EBF"
    assert not filled.missing().any()
    seen = ~np.isnan(rot).any(axis=-1)
    assert np.array_equal(filled.rotations[seen], armed.rotations[seen])
    with pytest.raises(mocapkit.errors.SkeletonError, match="streaming needs exactly the model's channels; this "
                       "bandai_namco rig has joints the model does not know"):
        deep.Denoiser(armed.skeleton, armed.fps)  # streaming reads every file channel: offline only


def test_a_bandai_take_the_bandai_models_cannot_serve_says_why(dance):
    """Issue 4: a helper bone inserted between the right forearm and hand changes what the hand's channels mean
    (its rotation is now relative to the helper), so the Bandai models do not serve the take; the Acclaim model's
    joint map does, and the output says why the rig's own model was not used, naming the joint."""
    helper = _with_joint(dance, "wrist_helper_r", "LowerArm_R", (-11.0, 0.0, 0.0), np.zeros(dance.num_frames),
                         inserted=True)
    assert helper.skeleton.joint_names[int(helper.skeleton.parents[helper.skeleton.index("Hand_R")])] == "wrist_helper_r"
    assert deep.shipped_model("ebf", helper).meta.get("rig", "acclaim") != "bandai_namco"
    noisy, _ = corrupt.angular_noise(helper, 0.5, seed=7)
    _out, method, note = deep.denoise_or_fallback(noisy)
    assert method == "EBF (shipped, via the bandai_namco joint map)"
    assert note.startswith("the bandai_namco EBF (ebf_bandai.pt) was not used: ")
    assert "its Hand_R hangs below wrist_helper_r, which the model has no channels for" in note
    assert "\n" not in note


@pytest.mark.parametrize("namespace", ["", "Character1:"])
def test_joints_named_by_their_dag_paths_change_neither_the_model_nor_the_result(namespace):
    """Every joint named by its full Maya DAG path (`|joint_Root|Hips|Spine`, `|Character1:joint_Root|Character1:Hips`)
    made the Bandai take of no known family: the Acclaim model through a joint map, under HDM05's licence. Read by
    the last part of each path, it gets the Bandai EBF and the same cleaned arrays, bit for bit; the output keeps the
    file's names."""
    take = mocapkit.load(Path(__file__).parents[1] / "data" / "dataset-2_walk-turn-left_exhausted_005.bvh")
    bad = corrupt.corrupt(take, kind="noise", seed=1, amount=0.3)[0]
    base = mocapkit.clean(bad)
    paths: list[str] = []
    for j, n in enumerate(bad.skeleton.joint_names):
        p = int(bad.skeleton.parents[j])
        paths.append(("" if p < 0 else paths[p]) + "|" + namespace + n)
    sk = dataclasses.replace(bad.skeleton, joint_names=tuple(paths))
    out = mocapkit.clean(dataclasses.replace(bad, skeleton=sk))
    assert out.motion.skeleton.joint_names == sk.joint_names and sk.joint_names[2] == f"|{namespace}joint_Root|{namespace}Hips|{namespace}Spine"
    denoise = [line for line in out.summary() if line.startswith("denoise")]
    assert denoise and "EBF (shipped, bandai_namco)" in denoise[0] and "CC BY-NC 4.0" in denoise[0]
    np.testing.assert_array_equal(out.motion.rotations, base.motion.rotations)
    np.testing.assert_array_equal(out.motion.root_positions, base.motion.root_positions)


@pytest.mark.parametrize("kind, prefixes", [("noise", ("mixamorig:", "Character1_")), ("gaps", ("rig|",))])
def test_a_namespace_before_the_joint_names_changes_neither_the_model_nor_the_result(kind, prefixes):
    """A user trial: a Bandai Namco take exported with `mixamorig:` (or `Character1_`, `rig|`) before every joint
    name was cleaned by the Acclaim model through a joint map, under HDM05's research-only licence, 2.63 -> 1.94 cm
    where the bare names gave the Bandai pair (CC BY-NC) and 1.73 cm. The namespace is set aside for the family and
    the model's joints (mocapkit.rigs.family_names): the same model, licence line and cleaned arrays, bit for bit,
    the file's names kept in the output and the summary."""
    import re

    take = mocapkit.load(Path(__file__).parents[1] / "data" / "dataset-2_walk-turn-left_exhausted_005.bvh")
    bad = corrupt.corrupt(take, kind=kind, seed=1, **({"amount": 0.3} if kind == "noise" else {}))[0]
    base = mocapkit.clean(bad)
    said = [re.sub(r"\(\d+\.\d+ s\)", "", line) for line in base.summary()]
    step = "denoise" if kind == "noise" else "fill"
    assert any(line.startswith(step) and "(shipped, bandai_namco)" in line and "CC BY-NC 4.0" in line for line in said)
    for prefix in prefixes:
        sk = dataclasses.replace(bad.skeleton, joint_names=tuple(prefix + n for n in bad.skeleton.joint_names))
        out = mocapkit.clean(dataclasses.replace(bad, skeleton=sk))
        assert out.motion.skeleton.joint_names == sk.joint_names
        np.testing.assert_array_equal(out.motion.rotations, base.motion.rotations)
        np.testing.assert_array_equal(out.motion.root_positions, base.motion.root_positions)
        assert [re.sub(r"\(\d+\.\d+ s\)", "", line).replace(prefix, "") for line in out.summary()] == said


UNREAL_NAMES = {"joint_Root": "root", "Hips": "pelvis", "Spine": "spine_01", "Chest": "spine_02", "Neck": "neck_01",
                "Head": "head", "Shoulder": "clavicle", "UpperArm": "upperarm", "LowerArm": "lowerarm", "Hand": "hand",
                "UpperLeg": "thigh", "LowerLeg": "calf", "Foot": "foot", "Toes": "ball"}


def _unreal_named(motion, rename=UNREAL_NAMES):
    """The take on the same rig, its joints spelled as Unreal's mannequin (``UpperLeg_L`` -> ``thigh_l``)."""
    def ue(name):
        base, _, side = name.partition("_") if name.endswith(("_L", "_R")) else (name, "", "")
        return rename.get(base, base) + (f"_{side.lower()}" if side else "")
    names = tuple(ue(n) for n in motion.skeleton.joint_names)
    return dataclasses.replace(motion, skeleton=dataclasses.replace(motion.skeleton, joint_names=names))


def test_the_bandai_pair_serves_the_bandai_rig_under_unreal_names_by_role_bit_identically(dance):
    # Trial G, finding 4: the Bandai pair refused the same rig spelled with Unreal names ("trained on a skeleton
    # with 63 euler channels and this one has 63 (no joint Hips ...)") while the Acclaim pair served it by role.
    noisy, _ = corrupt.angular_noise(dance, 0.5, seed=7)
    ue = _unreal_named(noisy)
    assert mocapkit.rigs.rig_family(ue.skeleton) == "unreal"
    ebf, ebd = deep.load_model("ebf_bandai.pt"), deep.load_model("ebd_bandai.pt")
    for m in (ebf, ebd):
        s = deep.served_by(ue, m)
        assert s.direct and s.by_role
        # unasked, an Unreal take keeps the Acclaim pair (never silently the non-commercial one)
        assert deep.shipped_model(m.kind, ue) is deep.shipped_model(m.kind)
    out, method, _ = deep.denoise_or_fallback(ue, ebf, label="given")
    assert method == "EBF (given, the unreal rig's joints read by role as bandai_namco's)"
    same, _, _ = deep.denoise_or_fallback(noisy, ebf, label="given")
    assert np.array_equal(out.rotations, same.rotations) and out.skeleton.joint_names == ue.skeleton.joint_names
    rot = np.array(noisy.rotations)
    rot[20:40, noisy.skeleton.index("LowerArm_L")] = np.nan
    gappy = dataclasses.replace(noisy, rotations=rot)
    filled, _, _ = deep.fill_or_fallback(_unreal_named(gappy), ebd, ebf, label="given")
    assert np.array_equal(filled.rotations, deep.fill_or_fallback(gappy, ebd, ebf, label="given")[0].rotations)


def test_a_rig_whose_joint_names_differ_is_refused_for_its_names_not_its_channel_count(dance):
    odd = _unreal_named(dance, {**UNREAL_NAMES, "Shoulder": "collar"})  # no Unreal clavicle: no role for Shoulder_L
    why = deep.served_by(odd, deep.load_model("ebf_bandai.pt"))
    assert isinstance(why, str) and why.startswith("the model's joint names differ from this rig's (no joint Hips")
    assert "63" not in why and "Shoulder_L" in why
