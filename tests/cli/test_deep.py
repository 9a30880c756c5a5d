"""`mocapkit denoise`, `mocapkit fill` and `mocapkit train` on real clips, and their one-line errors; the models
`clean` and `clean-batch` use."""

import dataclasses
import re
from pathlib import Path

import numpy as np
import pytest

import mocapkit
from mocapkit import corrupt, metrics
from mocapkit.errors import SkeletonError
from mocapkit.motion import concatenate
from tests.cli.helpers import SAMPLE, one_error_line, run, run_process
from tests.shared import unknown_rig, unnamed

WALK = mocapkit.samples.path("12_walk.amc")
BVH = mocapkit.samples.path("131_01.bvh")  # the Acclaim skeleton spelled as CMU's 3dsMax-friendly BVH
BANDAI = Path(__file__).resolve().parents[1] / "data" / "dataset-1_dash_normal_001.bvh"  # the Bandai models serve it


def _gappy(motion, path, seed=2):
    gapped, _ = corrupt.gaps(motion, seed=seed, start_prob=0.01)
    mocapkit.save(gapped, path)
    return gapped


def test_the_three_commands_agree_on_a_rig_the_networks_do_not_serve(tmp_path):
    """denoise, fill and clean on a rig nothing ships for: the same fallbacks, the same message, exit 0."""
    odd = tmp_path / "odd.bvh"
    take = unknown_rig(odd)
    gin = tmp_path / "gaps.npz"
    gapped = _gappy(take, gin)
    code, out_d, err = run("denoise", str(odd), "-o", str(tmp_path / "d.bvh"))
    assert code == 0, err
    text = " ".join(out_d.split())
    assert f"warning: {odd}: Savitzky-Golay: the shipped EBF does not serve this rig" in text
    assert "Savitzky-Golay (0.1 s)" in text and (tmp_path / "d.bvh").is_file()
    code, out_f, err = run("fill", str(gin), "-o", str(tmp_path / "f.npz"))
    assert code == 0, err
    text = " ".join(out_f.split())
    assert f"warning: {gin}: cubic spline: the shipped EBD does not serve this rig" in text
    filled = mocapkit.load(tmp_path / "f.npz")
    obs = ~gapped.missing()
    assert not filled.missing().any() and np.array_equal(filled.rotations[obs], gapped.rotations[obs])
    code, out_c, err = run("clean", str(gin), "-o", str(tmp_path / "c.npz"), "--steps", "fill,denoise")
    assert code == 0, err
    text = " ".join(out_c.split())
    assert "cubic spline: the shipped EBD does not serve this rig" in text
    # the reason is the same words in all three
    why = text.split("does not serve this rig (")[1].split(")")[0]
    assert why in " ".join(out_f.split()) and why in " ".join(out_d.split())
    code, _, err = run("fill", str(gin), "-o", str(tmp_path / "g.npz"), "--no-fallback")
    assert code == 2 and one_error_line(err) and str(gin) in err and why in " ".join(err.split())
    assert not (tmp_path / "g.npz").exists()


def test_fill_without_gaps_says_so(tmp_path):
    for take in (BVH, BANDAI):  # whichever the rig, "no gaps" comes first
        out = tmp_path / f"{take.stem}.bvh"
        code, stdout, err = run("fill", str(take), "-o", str(out))
        assert code == 0, err
        assert f"no gaps in {take}; nothing to fill" in " ".join(stdout.split()) and not out.exists()
    code, stdout, err = run("fill", str(BVH), "-o", str(tmp_path / "w.npz"), "--always-write")
    assert code == 0, err
    assert np.array_equal(mocapkit.load(tmp_path / "w.npz").rotations, mocapkit.load(BVH).rotations)


def test_the_networks_serve_the_cmu_bvh_spelling(tmp_path):
    from tests.shared import motionbuilder_spelling

    take = motionbuilder_spelling(mocapkit.load(WALK))  # the walk as the CMU MotionBuilder-release BVH spells it
    noisy, _ = corrupt.angular_noise(take, 0.5, seed=4)
    inp, out = tmp_path / "noisy.bvh", tmp_path / "den.bvh"
    mocapkit.save(noisy, inp)
    code, stdout, err = run("denoise", str(inp), "-o", str(out))
    assert code == 0, err
    assert "EBF (shipped, via the cmu_bvh_motionbuilder joint map)" in " ".join(stdout.split())
    assert [ln for ln in stdout.splitlines() if "warning" in ln and "research use only" not in ln] == []  # HDM05's terms only
    den = mocapkit.load(out)
    assert metrics.joint_angle_rms(take, den, include_root=False) < 0.6 * metrics.joint_angle_rms(
        take, noisy, include_root=False)
    gin, gout = tmp_path / "gaps.npz", tmp_path / "filled.npz"
    gapped = _gappy(take, gin)
    code, stdout, err = run("fill", str(gin), "-o", str(gout))
    assert code == 0, err
    assert "EBD's gap prior (shipped, via the cmu_bvh_motionbuilder joint map)" in " ".join(stdout.split())
    filled = mocapkit.load(gout)
    obs = ~gapped.missing()
    assert not filled.missing().any() and np.array_equal(filled.rotations[obs], gapped.rotations[obs])


def test_denoise_and_fill_commands(tmp_path):
    clean = mocapkit.load(WALK)
    noisy, _ = corrupt.angular_noise(clean, 0.5, seed=4)
    inp = tmp_path / "noisy.npz"
    mocapkit.save(noisy, inp)
    out = tmp_path / "clean.npz"
    code, stdout, err = run("denoise", str(inp), "-o", str(out), "--reference", str(WALK))
    assert code == 0, err
    assert "denoised" in stdout and "joint-angle RMS against 12_walk.amc" in " ".join(stdout.split())
    den = mocapkit.load(out)
    assert den.num_frames == clean.num_frames
    assert np.array_equal(den.root_positions, clean.root_positions)
    assert metrics.joint_angle_rms(clean, den, include_root=False) < 0.6 * metrics.joint_angle_rms(
        clean, noisy, include_root=False
    )
    gapped, _ = corrupt.gaps(clean, seed=2, start_prob=0.01)
    gin, gout = tmp_path / "gaps.npz", tmp_path / "filled.npz"
    mocapkit.save(gapped, gin)
    code, stdout, err = run("fill", str(gin), "-o", str(gout), "--reference", str(WALK))
    assert code == 0, err
    assert "mean rotation error of the filled joints" in " ".join(stdout.split())
    filled = mocapkit.load(gout)
    assert not filled.missing().any() and "filled" in stdout
    obs = ~gapped.missing()
    assert np.array_equal(filled.rotations[obs], gapped.rotations[obs])


def test_deep_commands_fail_in_one_line(tmp_path):
    odd = tmp_path / "odd.bvh"
    unknown_rig(odd)
    code, _, err = run_process("denoise", str(odd), "-o", str(tmp_path / "x.bvh"), "--no-fallback")  # the real entry point
    assert code == 2 and one_error_line(err) and "does not serve this rig" in err and odd.name in err
    assert not (tmp_path / "x.bvh").exists()
    bad = tmp_path / "model.pt"
    bad.write_bytes(b"not a model")
    code, _, err = run("denoise", str(WALK), "-o", str(tmp_path / "y.bvh"), "--model", str(bad))
    assert code == 2 and one_error_line(err) and "model.pt" in err
    code, _, err = run("fill", str(WALK), "-o", str(WALK))
    assert code == 2 and one_error_line(err) and "refusing to write over an input" in err
    short = tmp_path / "short.npz"
    mocapkit.save(mocapkit.load(WALK)[:100], short)
    code, _, err = run("denoise", str(WALK), "-o", str(tmp_path / "z.npz"), "--reference", str(short))
    assert code == 2 and one_error_line(err) and "short.npz" in err and "343 frames (it has 100 frames)" in err
    assert not (tmp_path / "z.npz").exists()
    code, _, err = run("train", "nonsense", str(WALK), "-o", str(tmp_path / "m"))
    assert code == 2 and one_error_line(err)
    code, _, err = run("train", "denoiser", str(WALK), "-o", str(tmp_path / "m"), "--noise", "wobble:1")
    assert code == 2 and one_error_line(err) and "unknown noise setting 'wobble:1'" in err
    code, _, err = run("train", "denoiser", str(WALK), "-o", str(tmp_path / "m"), "--speed", "1.4", "0.7")
    assert code == 2 and one_error_line(err) and "speed_range needs 0 < lo <= hi, got (1.4, 0.7)" in err
    code, _, err = run("train", "denoiser", str(WALK), "-o", str(tmp_path / "m"), "--patchy", "1.5")
    assert code == 2 and one_error_line(err) and "patchy must be in [0, 1], got 1.5" in err
    assert not (tmp_path / "m").exists()


def test_train_command_writes_a_loadable_model(tmp_path):
    from mocapkit.cleaning import deep

    out = tmp_path / "ebf"
    code, stdout, err = run("train", "denoiser", str(WALK), "-o", str(out), "--epochs", "2", "--steps", "2",
                            "--hidden", "8", "--executor", "serial", "--noise-input", "--patchy", "0.5")
    assert code == 0, err
    model = deep.load_model(out / "model.pt")
    assert model.kind == "ebf" and len(model.meta["history"]) == 2 and model.net.noise_input
    assert model.meta["config"]["patchy"] == 0.5
    clean = mocapkit.load(WALK)
    den = deep.denoise(clean, model)
    assert den.num_frames == clean.num_frames


def test_train_refuses_a_holdout_name_no_clip_has(tmp_path):
    # a typo trained on everything and reported a "best training RMS", with no validation at all
    out = tmp_path / "ebf"
    code, _, err = run("train", "denoiser", str(WALK), "-o", str(out), "--epochs", "1", "--steps", "1",
                       "--hidden", "8", "--executor", "serial", "--holdout", "actor_x")
    assert code == 2 and one_error_line(err) and "--holdout actor_x: no clip's name contains it" in err
    assert not out.exists()


def test_train_says_when_a_holdout_count_leaves_one_clip(tmp_path):
    # --holdout 10 of 2 clips held out 1 and trained on 1 without a word
    out = tmp_path / "ebf"
    code, stdout, err = run("train", "denoiser", str(WALK), str(WALK), "-o", str(out), "--epochs", "1", "--steps", "1",
                            "--hidden", "8", "--executor", "serial", "--holdout", "10", "--noise", "angular:0.5")
    assert code == 0, err
    assert "note: --holdout 10 of 2 clips: 1 held out, 1 to train on" in " ".join(stdout.split())


def test_train_on_two_rigs_says_so_and_leaves_no_folder(tmp_path):
    # it said "the model was trained on a skeleton with 56 euler channels ... train a model on this rig with
    # `mocapkit train`" (no model yet, and the user was running train) and left the empty output folder
    out = tmp_path / "ebf"
    code, _, err = run("train", "denoiser", str(WALK), SAMPLE, "-o", str(out), "--epochs", "1", "--steps", "1",
                       "--hidden", "8", "--executor", "serial")
    text = " ".join(err.split())
    assert code == 2 and one_error_line(err) and "another rig than the first clip's" in text
    assert "train one rig at a time" in text and not out.exists()
    # each count beside its own clip: the second clip's channels, then the first clip's name and its count
    assert re.search(r"131_01: another rig than the first clip's \(\d+ euler channels; 12_walk has \d+\)", text), text


def test_train_mirror_adds_each_training_clip_mirror_image(tmp_path):
    """--mirror trains on the clips and their mirror images (the validation clips as they are); a rig whose names
    pair no left and right joints is refused in one line, nothing written."""
    from mocapkit.cleaning import deep

    clips = [str(mocapkit.samples.path(n)) for n in ("12_walk.amc", "HDM_bk_sneak2StepsLStart_004_120.amc")]
    out = tmp_path / "m"
    code, stdout, err = run("train", "gapfiller", *clips, "-o", str(out), "--holdout", "12_walk", "--mirror",
                            "--epochs", "1", "--steps", "1", "--hidden", "4", "--executor", "serial",
                            "--noise", "angular:0.5")
    assert code == 0, err
    meta = deep.load_model(out / "model.pt").meta
    assert sorted(meta["train_clips"]) == ["HDM_bk_sneak2StepsLStart_004_120", "HDM_bk_sneak2StepsLStart_004_120_mirror"]
    assert meta["validation_clips"] == ["12_walk"]
    assert "2 clips" in " ".join(stdout.split())
    odd = tmp_path / "odd.bvh"
    unknown_rig(odd)
    code, _, err = run("train", "denoiser", str(odd), "-o", str(tmp_path / "n"), "--mirror", "--epochs", "1")
    assert code == 2 and one_error_line(err) and "train --mirror" in err and "no left/right joint pairs" in err
    assert not (tmp_path / "n").exists()


def test_train_command_cross_validates_on_folds(tmp_path):
    clips = [str(mocapkit.samples.path(n)) for n in ("12_walk.amc", "HDM_bd_jogLeftCircle4StepsRstart_001_120.amc",
                                                      "HDM_bk_sneak2StepsLStart_004_120.amc")]
    out = tmp_path / "cv"
    code, stdout, err = run("train", "gapfiller", *clips, "-o", str(out), "--folds", "2", "--holdout", "1",
                            "--epochs", "1", "--steps", "1", "--hidden", "4", "--executor", "serial",
                            "--noise", "angular:0.5")
    assert code == 0, err
    assert (out / "fold_1" / "model.pt").is_file() and (out / "fold_2" / "model.pt").is_file()
    assert "2 holdouts: validation RMS" in stdout
    code, _, err = run("train", "gapfiller", *clips, "-o", str(out), "--folds", "3", "--holdout", "1")
    assert code == 2 and one_error_line(err) and "need more than" in err


def test_train_refuses_a_model_it_did_not_write_before_any_work(tmp_path):
    """Finding 6: an OUT/model.pt without a checkpoint of the same training was replaced after the first epoch."""
    out = tmp_path / "m"
    out.mkdir()
    (out / "model.pt").write_bytes(b"a model from elsewhere")
    args = ("train", "denoiser", str(WALK), "-o", str(out), "--epochs", "1", "--steps", "1", "--hidden", "4",
            "--noise", "angular:0.5", "--executor", "serial")
    code, stdout, err = run(*args)
    assert code == 2 and one_error_line(err), err
    assert "model.pt already exists (no checkpoint of this training beside it); --restart or --overwrite" in err
    assert sorted(p.name for p in out.iterdir()) == ["model.pt"] and "noisy pairs" not in stdout
    assert (out / "model.pt").read_bytes() == b"a model from elsewhere"
    code, _, err = run(*args, "--overwrite")
    assert code == 0, err
    code, stdout, err = run(*args[:6], "2", *args[7:])  # the same training, one more epoch: resumed
    assert code == 0 and "2 epochs" in " ".join(stdout.split()), err
    # with folds: every fold's folder is checked before the first fold trains
    clips = [str(mocapkit.samples.path(n)) for n in ("12_walk.amc", "HDM_bd_jogLeftCircle4StepsRstart_001_120.amc",
                                                      "HDM_bk_sneak2StepsLStart_004_120.amc")]
    cv = tmp_path / "cv"
    (cv / "fold_2").mkdir(parents=True)
    (cv / "fold_2" / "model.pt").write_bytes(b"x")
    code, _, err = run("train", "gapfiller", *clips, "-o", str(cv), "--folds", "2", "--holdout", "1",
                       "--epochs", "1", "--steps", "1", "--hidden", "4", "--executor", "serial")
    assert code == 2 and one_error_line(err) and "fold_2/model.pt already exists" in err
    assert sorted(str(p.relative_to(cv)) for p in cv.rglob("*")) == ["fold_2", "fold_2/model.pt"]


def test_train_help_documents_overwrite_and_restart():
    code, stdout, _ = run("train", "--help")
    text = " ".join(stdout.split())
    assert code == 0 and "--overwrite" in text and "--restart" in text


def test_a_bandai_take_is_denoised_by_the_bandai_ebf_with_its_licence_line(tmp_path):
    """The rig family picks the shipped model; its licence (CC BY-NC) is said where it is used; --model overrides."""
    noisy, _ = corrupt.angular_noise(mocapkit.load(BANDAI), 0.5, seed=3)
    src = tmp_path / "noisy.bvh"
    mocapkit.save(noisy, src)
    code, out, err = run("denoise", str(src), "-o", str(tmp_path / "d.bvh"))
    assert code == 0, err
    text = " ".join(out.split())
    assert "denoised by EBF (shipped, bandai_namco)" in text and "CC BY-NC 4.0" in text and "--model" in text
    assert "--model picks another: no shipped model" in text and "clean-batch" not in text and "--ebf" not in text
    acclaim = Path(mocapkit.__file__).parent / "models" / "ebf.pt"
    code, out, err = run("denoise", str(src), "-o", str(tmp_path / "e.bvh"), "--model", str(acclaim))
    assert code == 0, err
    text = " ".join(out.split())  # the Acclaim EBF serves the game rig through its joint map
    assert "EBF (given, via the bandai_namco joint map)" in text and "used: CC BY-NC" not in text and "used: research use only" in text
    # the shipped model by its name, as the licence line suggests, from any folder
    code, out, err = run("denoise", str(src), "-o", str(tmp_path / "f.bvh"), "--model", "ebf.pt", cwd=tmp_path)
    assert code == 0, err
    assert "used: CC BY-NC" not in out
    assert np.array_equal(mocapkit.load(tmp_path / "f.bvh").rotations, mocapkit.load(tmp_path / "e.bvh").rotations)
    code, _, err = run("denoise", str(src), "-o", str(tmp_path / "g.bvh"), "--model", "ebd.pt", cwd=tmp_path)
    assert code == 2 and one_error_line(err) and "ebd.pt: an EBD model, but this needs an EBF" in " ".join(err.split())
    assert not (tmp_path / "g.bvh").exists()


def test_clean_and_clean_batch_take_their_models_and_say_the_licence(tmp_path):
    """clean and clean-batch use the Bandai models on a Bandai take and say their licence (clean-batch under the
    take's line); --ebf / --ebd pick others, by file or by a shipped model's name; a wrong kind is one line."""
    noisy, _ = corrupt.angular_noise(mocapkit.load(BANDAI), 0.5, seed=3)
    (tmp_path / "in").mkdir()
    src = tmp_path / "in" / "noisy.bvh"
    mocapkit.save(noisy, src)
    code, out, err = run("clean", str(src), "-o", str(tmp_path / "a.bvh"))
    assert code == 0, err
    text = " ".join(out.split())
    assert "EBF (shipped, bandai_namco)" in text and f"warning: {src}: licence of the EBF used: CC BY-NC 4.0" in text
    code, out, err = run("clean", str(src), "-o", str(tmp_path / "b.bvh"), "--ebf", "ebf.pt", cwd=tmp_path)
    assert code == 0, err
    text = " ".join(out.split())
    assert "EBF (ebf.pt, via the bandai_namco joint map)" in text and "used: CC BY-NC" not in text and "used: research use only" in text
    code, _, err = run("clean", str(src), "-o", str(tmp_path / "c.bvh"), "--ebf", "ebd.pt", cwd=tmp_path)
    assert code == 2 and one_error_line(err) and "ebd.pt: an EBD model, but this needs an EBF" in " ".join(err.split())
    assert not (tmp_path / "c.bvh").exists() and not (tmp_path / "c.clean.npz").exists()
    code, out, err = run("clean-batch", str(tmp_path / "in"), str(tmp_path / "out"), "--executor", "serial")
    assert code == 0, err
    lines = out.splitlines()
    at = next(i for i, line in enumerate(lines) if line.startswith("cleaned "))
    assert lines[at + 1].startswith(f"warning: {src}: licence of the EBF used: CC BY-NC 4.0")
    code, out, err = run("clean-batch", str(tmp_path / "in"), str(tmp_path / "out2"), "--executor", "serial",
                         "--ebf", "ebf.pt", cwd=tmp_path)
    assert code == 0, err
    assert "used: CC BY-NC" not in out
    assert np.array_equal(mocapkit.load(tmp_path / "out2" / "noisy.bvh").rotations,
                          mocapkit.load(tmp_path / "b.bvh").rotations)


def test_a_given_ebd_is_smoothed_by_its_own_pair(tmp_path):
    """The EBF smooths the EBD's channels: a given Acclaim EBD on a Bandai take gets the Acclaim EBF (not the rig's
    own, which reads other channels), in fill and clean; two models of different rigs are one line, not a
    fallback."""
    gin = tmp_path / "gaps.npz"
    _gappy(mocapkit.load(BANDAI.with_name("dataset-1_dash_chimpira_001.bvh")), gin, seed=2)
    code, out, err = run("fill", str(gin), "-o", str(tmp_path / "f.npz"), "--model", "ebd.pt", cwd=tmp_path)
    assert code == 0, err
    assert "EBD's gap prior (given, via the bandai_namco joint map)" in " ".join(out.split())
    code, out, err = run("clean", str(gin), "-o", str(tmp_path / "c.npz"), "--ebd", "ebd.pt", cwd=tmp_path)
    assert code == 0, err
    text = " ".join(out.split())
    assert "EBD's gap prior (ebd.pt, via the bandai_namco joint map)" in text and "cubic" not in text
    code, _, err = run("fill", str(gin), "-o", str(tmp_path / "g.npz"), "--model", "ebd.pt", "--denoiser",
                       "ebf_bandai.pt", cwd=tmp_path)
    assert code == 2 and one_error_line(err) and "not a pair" in err and not (tmp_path / "g.npz").exists()


def test_fill_by_the_network_or_the_prior(tmp_path):
    """--by picks what fills the gaps; a model without a prior asked for one is an error, not a fallback."""
    import dataclasses

    from mocapkit.cleaning import deep

    gin = tmp_path / "gaps.npz"
    gapped = _gappy(mocapkit.load(WALK), gin)
    outs = {}
    for by, name in (("ebd", "EBD (shipped) + EBF"), ("prior", "EBD's gap prior (shipped)")):
        outs[by] = tmp_path / f"{by}.npz"
        code, stdout, err = run("fill", str(gin), "-o", str(outs[by]), "--by", by)
        assert code == 0, err
        assert f"filled by {name}" in " ".join(stdout.split())
    a, b = mocapkit.load(outs["ebd"]), mocapkit.load(outs["prior"])
    obs = ~gapped.missing()
    assert np.array_equal(a.rotations[obs], b.rotations[obs]) and not np.array_equal(a.rotations, b.rotations)
    bare = tmp_path / "bare.pt"
    deep.save_model(dataclasses.replace(deep.shipped_model("ebd"), prior=None), bare)
    out = tmp_path / "x.npz"
    code, _, err = run("fill", str(gin), "-o", str(out), "--model", str(bare), "--by", "prior")
    assert code != 0 and one_error_line(err) and "no gap prior" in err and not out.exists()
    code, _, err = run("fill", str(gin), "-o", str(out), "--by", "spline")
    assert code != 0 and one_error_line(err) and "--by" in err and not out.exists()


def test_the_licence_line_names_each_command_own_option(tmp_path):
    """The licence line says which option picks another model in the command that prints it: fill --model (EBD) and
    --denoiser (EBF) (denoise's --model: the test above); clean and clean-batch keep --ebf / --ebd."""
    gin = tmp_path / "gaps.npz"
    _gappy(mocapkit.load(BANDAI), gin, seed=2)
    code, out, err = run("fill", str(gin), "-o", str(tmp_path / "f.bvh"))
    assert code == 0, err
    text = " ".join(out.split())
    assert "licence of the EBD and EBF used: CC BY-NC 4.0" in text and text.count("licence of the") == 1
    assert "--model, --denoiser pick others: no shipped model" in text
    assert "clean-batch" not in text and "--ebf" not in text and "--ebd" not in text


def test_marker_files_are_sent_to_clean(tmp_path):
    """denoise and fill on a marker capture (.c3d, or a marker .npz) say that `mocapkit clean` cleans it, whatever
    OUT's suffix: one line naming IN, exit 2, nothing written; a motion to a marker suffix is still OUT's error."""
    from mocapkit.io import load_markers, save_markers

    c3d = mocapkit.samples.path("Eb015pr.c3d")
    npz = tmp_path / "markers.npz"
    save_markers(load_markers(c3d), npz)
    for inp in (c3d, npz):
        for command in ("denoise", "fill"):
            for suffix in (".c3d", ".npz", ".bvh"):
                out = tmp_path / f"x{suffix}"
                code, _, err = run(command, str(inp), "-o", str(out))
                text = " ".join(err.split())
                assert code == 2 and one_error_line(err), (command, inp, suffix, err)
                assert f"{inp}: a marker capture; {command} works on skeletal takes" in text, text
                assert "`mocapkit clean` cleans marker files (fills gaps, removes spikes, undoes swaps)" in text
                assert "unknown suffix" not in text and "solve it to a skeleton" not in text
    code, _, err = run("denoise", str(WALK), "-o", str(tmp_path / "x.c3d"))
    assert code == 2 and one_error_line(err) and "x.c3d: unknown suffix '.c3d' for writing" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["markers.npz"]


def test_commands_writing_an_amc_elsewhere_copy_its_asf(tmp_path):
    """repair, denoise, fill and corrupt, as convert and clean: an AMC output reads back (it said 'no skeleton')."""
    amc = mocapkit.samples.path("HDM_bk_sneak2StepsLStart_004_120.amc")
    for k, argv in enumerate((["denoise", str(amc), "-o"], ["fill", str(amc), "--always-write", "-o"],
                              ["corrupt", str(amc), "--kind", "spike", "--seed", "1"])):
        out = tmp_path / f"o{k}" / "take.amc"
        code, stdout, err = run(*argv, str(out)) if argv[0] != "corrupt" else run(*argv[:2], str(out), *argv[2:])
        assert code == 0, (argv, err)
        assert (out.parent / "take.asf").read_bytes() == mocapkit.samples.path("HDM_bk.asf").read_bytes(), argv
        assert mocapkit.load(out).num_frames == mocapkit.load(amc).num_frames
    code, _, err = run("reconstruct", "--db", str(tmp_path / "o0"), "--accelerometers", str(amc), "-o", str(tmp_path / "r" / "r.amc"))
    assert code == 2 and "not a motion database" in err and not (tmp_path / "r").exists()


def test_an_interrupted_train_says_its_checkpoint_resumes(tmp_path):
    import os
    import signal
    import subprocess
    import sys
    import time

    out = tmp_path / "m"
    p = subprocess.Popen([sys.executable, "-m", "mocapkit.cli", "train", "denoiser", str(WALK), "-o", str(out),
                          "--epochs", "500", "--steps", "1", "--hidden", "8", "--noise", "angular:0.5",
                          "--executor", "serial"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                         env=dict(os.environ, OMP_NUM_THREADS="1"),  # one torch thread, beside the busy test workers
                         preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    # readiness, not speed: an epoch's model and checkpoint set has ended whole. checkpoint.pt appearing is not that:
    # it is published inside its epoch's removed_on_failure block, and an interrupt landing before the block ends
    # rightly removes it again (no message then). A second version replacing the first means the next epoch's block
    # has begun, so the first ended whole; an interrupt from then on keeps a checkpoint (put back, or the latest).
    def version():
        try:
            st = os.stat(out / "checkpoint.pt")
        except FileNotFoundError:
            return None
        return st.st_ino, st.st_mtime_ns, st.st_size

    first, deadline = None, time.monotonic() + 300
    while p.poll() is None and time.monotonic() < deadline:
        now = version()
        if first is not None and now is not None and now != first:
            break
        first = first or now
        time.sleep(0.05)
    assert p.poll() is None, "the training ended before a second epoch's checkpoint"
    p.send_signal(signal.SIGINT)
    stdout, stderr = p.communicate(timeout=300)
    assert p.returncode == 130, stderr
    assert f"{out / 'checkpoint.pt'} keeps the last finished epoch; the same command resumes" in " ".join(stdout.split())
    assert (out / "checkpoint.pt").is_file()


def test_denoise_refuses_a_take_too_short_to_tell_noise_by(tmp_path):
    short = tmp_path / "short.bvh"
    mocapkit.save(mocapkit.load(SAMPLE)[:5], short)
    code, _, err = run("denoise", short, "-o", tmp_path / "d.bvh")
    assert code == 2 and one_error_line(err) and "5 frames is shorter than the noise criterion's fit (7 frames)" in err
    assert not (tmp_path / "d.bvh").exists()


def test_info_describes_a_training_checkpoint(tmp_path):
    out = tmp_path / "m"
    code, _, err = run("train", "denoiser", WALK, "-o", out, "--epochs", "1", "--steps", "2", "--hidden", "8",
                       "--noise", "angular:0.5", "--executor", "serial")
    assert code == 0, err
    code, text, err = run("info", out / "checkpoint.pt")
    assert code == 0, err  # it said "malformed mocapkit model"
    assert "training checkpoint (EBF" in text and "digests kept" in text


def test_train_reads_amc_files_with_asf_and_amc_fps(tmp_path):
    """Docs trial: train had no --asf or --amc-fps, so AMC clips in a folder of several ASFs could not be trained on."""
    import shutil

    from mocapkit.cleaning import deep

    folder = tmp_path / "takes"
    folder.mkdir()
    shutil.copy(WALK, folder / "walk.amc")
    for asf in ("12.asf", "HDM_bd.asf"):
        shutil.copy(mocapkit.samples.path(asf), folder / asf)
    code, _, err = run("train", "denoiser", str(folder), "-o", str(tmp_path / "refused"), "--epochs", "1")
    assert code == 2 and one_error_line(err) and "--asf" in err
    out = tmp_path / "ebf"
    code, _, err = run("train", "denoiser", str(folder), "-o", str(out), "--epochs", "1", "--steps", "1",
                       "--hidden", "8", "--executor", "serial", "--asf", str(folder / "12.asf"), "--amc-fps", "60",
                       "--noise", "angular:0.5")
    assert code == 0, err
    assert deep.load_model(out / "model.pt").fps == 60


def test_fill_fills_a_lost_bandai_pelvis_position_and_says_how(tmp_path):
    """A Bandai take's Hips (whose animated offset carries the path) lost over half a second, rotation included: its
    positions are filled (the line or the spline: the rotation is a fill too, so not the feet's contacts), and
    said so."""
    import dataclasses

    take = mocapkit.load(Path(__file__).resolve().parents[1] / "data" / "bandai_dance-short_normal_001_first60.bvh")
    j = take.skeleton.index("Hips")
    rot, tr = np.array(take.rotations), np.array(take.translations)
    rot[20:35, j] = tr[20:35, j] = np.nan
    gin, gout = tmp_path / "hips.npz", tmp_path / "out.npz"
    mocapkit.save(dataclasses.replace(take, rotations=rot, translations=tr), gin)
    code, out, err = run("fill", gin, "-o", gout)
    assert code == 0, err
    text = " ".join(out.split())
    assert "15 missing joint samples filled by EBD's gap prior" in text
    assert ("the 15 missing Hips position(s) among them from the feet's contacts, a cubic spline or the line between"
            " the gap's ends, whichever refills the take's measured stretches best") in text
    assert "interpolated linearly" not in text
    assert not np.isnan(mocapkit.load(gout).translations).any()


def test_fill_fills_a_bandai_pelvis_path_written_nan_from_the_feet(tmp_path):
    """A Bandai walk's Hips position channels written ``nan`` for 1.3 s (frames 40-79), its rotation measured:
    `fill` wrote the line between the gap's ends, 4.7 cm RMS off; now the feet's contacts carry the path, within
    1 cm, and every measured number of the file is written as it was."""
    from mocapkit.joints import unit_scale_cm

    src = Path(__file__).resolve().parents[1] / "data" / "dataset-2_walk_normal_001_first120.bvh"
    lines = src.read_text().splitlines()
    first = next(i for i, s in enumerate(lines) if s.startswith("Frame Time")) + 1
    for i in range(first + 40, first + 80):
        row = lines[i].split()
        row[6:9] = ["nan"] * 3  # Hips: Xposition Yposition Zposition
        lines[i] = " ".join(row)
    gin, gout = tmp_path / "hips.bvh", tmp_path / "out.bvh"
    gin.write_text("\n".join(lines) + "\n")
    code, out, err = run("fill", gin, "-o", gout)
    assert code == 0, err
    assert "the 40 missing Hips position(s) among them from the feet's contacts" in " ".join(out.split())
    truth, got = mocapkit.load(src), mocapkit.load(gout)
    d = got.translations[40:80, 1] - truth.translations[40:80, 1]
    assert np.sqrt(np.mean(np.sum(d ** 2, axis=-1))) * unit_scale_cm(truth.skeleton) < 1.0
    written = gout.read_text().splitlines()
    at = next(i for i, s in enumerate(written) if s.startswith("Frame Time")) + 1
    for i in range(120):
        keep = [k for k, _ in enumerate(lines[first + i].split()) if not 40 <= i < 80 or k not in (6, 7, 8)]
        assert [written[at + i].split()[k] for k in keep] == [lines[first + i].split()[k] for k in keep]


def test_fill_fills_channels_written_as_zero_as_clean_does(tmp_path):
    """A real take whose hip reads 0 for 100 frames and whose frame 504 is all 0 (an exporter's dropouts): `fill`
    said "no gaps" and wrote nothing; it fills them by clean's fill step, names them in clean's words, and OUT is
    clean --steps fill's byte for byte; every other sample is the input's."""
    from tests.cleaning.test_zeros import _zeroed_bvh

    inp = _zeroed_bvh(BVH, tmp_path / "zeroed.bvh", {("LeftHip", None): range(100, 200), (None, None): [504]})
    out, ref = tmp_path / "f.bvh", tmp_path / "c.bvh"
    code, said, err = run("fill", str(inp), "-o", str(out))
    assert code == 0, err
    text = " ".join(said.split())
    assert "no gaps" not in text and "(131 of them written as 0 where the capture lost data)" in text
    assert "frame 504: every channel written as 0, the root's position too (a dropout), filled" in text
    assert "LeftHip frames 100-199: channels written as 0 (a dropout), filled" in text
    code, _, err = run("clean", str(inp), "-o", str(ref), "--steps", "fill")
    assert code == 0, err
    assert out.read_bytes() == ref.read_bytes()
    bad, filled, truth = mocapkit.load(inp), mocapkit.load(out), mocapkit.load(BVH)
    hip = bad.skeleton.index("LeftHip")
    lost = np.zeros((bad.num_frames, bad.num_joints), dtype=bool)
    lost[100:200, hip] = True
    lost[504] = True
    assert np.array_equal(filled.rotations[~lost], bad.rotations[~lost])
    err_deg = np.degrees(mocapkit.rotations.geodesic_angle(filled.rotations[100:200, hip], truth.rotations[100:200, hip]))
    assert err_deg.mean() < 10.0  # 0 was tens of degrees off


def test_denoise_leaves_channels_written_as_zero_and_the_frames_beside_them(tmp_path):
    """A real take whose hip reads 0 for 100 frames: the EBF read the dropout as motion and spread its jumps into
    the good frames beside it; `denoise` takes clean's denoise path, the run left as written, named in clean's
    words, and out of what the filter reads."""
    from tests.cleaning.test_zeros import _zeroed_bvh

    inp = _zeroed_bvh(BVH, tmp_path / "zeroed.bvh", {("LeftHip", None): range(100, 200)})
    out = tmp_path / "d.bvh"
    code, said, err = run("denoise", str(inp), "-o", str(out))
    assert code == 0, err
    assert ("LeftHip frames 100-199: channels written as 0 (a dropout), left as written (the fill step did not run)"
            in " ".join(said.split()))
    bad, den, truth = mocapkit.load(inp), mocapkit.load(out), mocapkit.load(BVH)
    hip = bad.skeleton.index("LeftHip")
    assert np.array_equal(den.rotations[100:200, hip], bad.rotations[100:200, hip])
    near = np.r_[90:100, 200:210]  # the good frames beside the run move as the rest of the take does
    moved = np.degrees(mocapkit.rotations.geodesic_angle(den.rotations[near, hip], truth.rotations[near, hip]))
    assert moved.max() < 3.0


def test_a_model_trained_on_bandai_takes_says_its_rig_data_and_licence_wherever_it_is_used(tmp_path, shared_data):
    """A user trial: `train` on Bandai Namco takes (CC BY-NC 4.0) wrote a model that `info` called `rig acclaim`,
    `licence none stated`, and that denoise used without a licence line."""
    import shutil

    takes = tmp_path / "takes"
    takes.mkdir()
    for name in ("kick_normal_001", "punch_normal_001", "walk_tired_001"):
        shutil.copy(shared_data / "secondary_bandai_namco_CC-BY-NC" / f"dataset-1_{name}.bvh", takes)
    out = tmp_path / "out"
    code, _, err = run("train", "denoiser", str(takes), "-o", str(out), "--holdout", "tired", "--epochs", "1",
                       "--steps", "1", "--hidden", "4", "--executor", "serial")
    assert code == 0, err
    code, said, err = run("info", str(out / "model.pt"))
    assert code == 0, err
    text = " ".join(said.split())
    assert "rig bandai_namco" in text and "acclaim" not in text
    assert "trained on 2 takes, 582 frames" in text and f"from {takes}" in text
    assert "held out 1 take, 247 frames (--holdout tired)" in text
    assert "licence CC BY-NC 4.0: trained on the Bandai Namco Research Motiondataset" in text
    code, said, err = run("denoise", str(BANDAI), "-o", str(tmp_path / "d.bvh"), "--model", str(out / "model.pt"))
    assert code == 0, err
    assert f"warning: {BANDAI}: licence of the EBF used: CC BY-NC 4.0" in " ".join(said.split()) and "--model picks" in said
    noisy, _ = corrupt.angular_noise(mocapkit.load(BANDAI), 0.5, seed=3)  # clean denoises a noisy take only
    mocapkit.save(noisy, tmp_path / "noisy.bvh")
    code, said, err = run("clean", str(tmp_path / "noisy.bvh"), "-o", str(tmp_path / "c.bvh"), "--ebf",
                          str(out / "model.pt"))
    assert code == 0, err
    text = " ".join(said.split())
    assert "EBF (model.pt, bandai_namco)" in text and "licence of the EBF used: CC BY-NC 4.0" in text and "--ebf (clean" in text


def test_train_licence_states_a_model_licence_and_an_unknown_one_is_not_stated(tmp_path):
    from mocapkit.cleaning import deep

    args = ("train", "denoiser", str(WALK), "--epochs", "1", "--steps", "1", "--hidden", "4", "--executor", "serial",
            "--noise", "angular:0.5")
    code, _, err = run(*args, "-o", str(tmp_path / "a"), "--licence", "CC BY 4.0, our own takes")
    assert code == 0, err
    code, said, err = run("info", str(tmp_path / "a" / "model.pt"))
    text = " ".join(said.split())
    assert code == 0 and "licence CC BY 4.0, our own takes" in text and "rig acclaim" in text
    code, _, err = run(*args, "-o", str(tmp_path / "b"))
    assert code == 0, err
    code, said, err = run("info", str(tmp_path / "b" / "model.pt"))
    assert code == 0 and "licence not stated" in " ".join(said.split())
    # a model file that keeps no rig (written before models kept one), of the game rig: not called acclaim
    bandai = deep.shipped_model("ebf", mocapkit.load(BANDAI))
    deep.save_model(dataclasses.replace(bandai, meta={}), tmp_path / "old.pt")
    code, said, err = run("info", str(tmp_path / "old.pt"))
    assert code == 0, err
    assert "rig not stated" in " ".join(said.split()) and "acclaim" not in said


def test_info_says_the_shipped_bandai_models_rig_as_denoise_does(tmp_path):
    """A user trial: `info ebf_bandai.pt` said `rig bandai`, `denoise` on a Bandai take `(shipped, bandai_namco)`."""
    for name in ("ebf_bandai.pt", "ebd_bandai.pt"):
        code, said, err = run("info", Path(mocapkit.__file__).parent / "models" / name)
        assert code == 0, err
        assert re.search(r"^rig +bandai_namco$", said, re.MULTILINE), said
    code, said, err = run("denoise", str(BANDAI), "-o", str(tmp_path / "d.bvh"))
    assert code == 0 and "(shipped, bandai_namco)" in said, err


def test_a_model_trained_on_bandai_takes_says_their_licence_once(tmp_path):
    """train on Bandai Namco takes (CC BY-NC 4.0): the model inherits the licence, one console line says so, and
    info of the model says it once."""
    out = tmp_path / "ebf"
    from mocapkit.motion import concatenate

    bow = mocapkit.load(BANDAI.with_name("dataset-1_bow_active_001.bvh"))  # 4.3 s; twice: longer than a crop
    take = tmp_path / "bow_twice.npz"
    mocapkit.save(concatenate([bow, bow]), take)
    code, stdout, err = run("train", "denoiser", str(take), "-o", str(out), "--epochs", "1", "--steps", "1",
                            "--hidden", "8", "--executor", "serial", "--noise", "angular:0.5")
    assert code == 0, err
    said = [ln for ln in stdout.splitlines() if "CC BY-NC 4.0" in ln]
    assert len(said) == 1 and said[0].startswith("note: model.pt keeps its takes' licence"), stdout
    code, stdout, err = run("info", str(out / "model.pt"))
    assert code == 0, err
    assert [ln.split()[0] for ln in stdout.splitlines() if "CC BY-NC 4.0" in ln] == ["licence"], stdout


def test_a_model_named_that_cannot_serve_the_take_is_refused_not_replaced(tmp_path):
    """A model the user names (--model, --ebf, --ebd, models=) is used or refused: on a rig it does not serve, one
    line naming the model file and why, exit 2, nothing written; the fallback is for the shipped models chosen by
    the take's rig. clean-batch fails that take's row and goes on with the others."""
    (tmp_path / "in").mkdir()
    odd = tmp_path / "in" / "odd.bvh"
    take = unknown_rig(odd)
    gin = tmp_path / "gaps.npz"
    _gappy(take, gin)
    for args, out in ((("denoise", str(odd), "--model", "ebf.pt"), "d.bvh"),
                      (("fill", str(gin), "--model", "ebd.pt"), "f.npz"),
                      (("clean", str(odd), "--ebf", "ebf.pt"), "c.bvh"),
                      (("clean", str(gin), "--ebd", "ebd.pt", "--steps", "fill"), "e.npz")):
        code, _, err = run(*args, "-o", str(tmp_path / out), cwd=tmp_path)
        text = " ".join(err.split())
        assert code == 2 and one_error_line(err), (args, err)
        assert re.search(r"the EB[FD] eb[fd]\.pt cannot serve this take: ", text), text  # named as typed
        assert not (tmp_path / out).exists() and not (tmp_path / out).with_suffix(".clean.npz").exists()
    mocapkit.save(mocapkit.load(WALK), tmp_path / "in" / "walk.bvh")
    code, out, err = run("clean-batch", str(tmp_path / "in"), str(tmp_path / "out"), "--executor", "serial",
                         "--ebf", "ebf.pt", "--steps", "denoise", cwd=tmp_path)
    text = " ".join(out.split())
    assert code == 1 and "cannot serve this take" in text, out + err
    assert (tmp_path / "out" / "walk.bvh").is_file() and not (tmp_path / "out" / "odd.bvh").exists()
    with pytest.raises(SkeletonError, match="cannot serve this take"):
        mocapkit.clean(take, models={"ebf": "ebf.pt"}, steps="denoise")
    from mocapkit.cleaning import deep

    with pytest.raises(SkeletonError, match="the given EBF cannot serve this take"):
        deep.denoise_or_fallback(take, dataclasses.replace(deep.shipped_model("ebf"), source=""))


def test_train_refuses_clips_shorter_than_a_crop_before_any_work(tmp_path):
    """`train denoiser` on a folder with a clip shorter than a crop (150 frames by default): one line naming the file,
    exit 2, no model folder; the model card never counts a clip the training did not use."""
    (tmp_path / "clips").mkdir()
    mocapkit.save(mocapkit.load(WALK), tmp_path / "clips" / "walk.npz")
    mocapkit.save(mocapkit.load(WALK)[:100], tmp_path / "clips" / "short.npz")
    code, _, err = run("train", "denoiser", str(tmp_path / "clips"), "-o", str(tmp_path / "m"), "--epochs", "1",
                       "--steps", "1", "--hidden", "8", "--executor", "serial")
    text = " ".join(err.split())
    assert code == 2 and one_error_line(err), err
    assert "1 of 2 training clips is shorter than a crop of 150 frames" in text and "short.npz (100)" in text
    assert not (tmp_path / "m").exists()


def test_a_model_of_an_unfinished_training_says_so_in_info_and_wherever_it_is_used(tmp_path):
    """A model.pt written by an interrupted run (``finished`` False, 1 of 3 epochs) works, and says what it is:
    info shows epochs run of planned, unfinished, its best validation RMS in deg and the noise/steps/seed settings;
    denoise and fill say it in one warning line and still write their output."""
    import torch

    from mocapkit.cleaning import deep

    walk = mocapkit.load(WALK)
    lay = deep.layout_for(walk)
    cfg = {"epochs": 3, "steps_per_epoch": 7, "batch": 4, "seed": 11, "representation": "euler",
           "noise": ["angular:0.5", "uniform:0.5"]}
    history = [{"epoch": 0, "train_rmse": 2.0, "val_rmse": 4.25, "lr": 0.002, "seconds": 1.0}]
    meta = {"config": cfg, "history": history, "validation_clips": ["held"], "best_val_rmse": 4.25, "best_epoch": 0,
            "finished": False}
    torch.manual_seed(0)
    for kind, net in (("ebf", deep.EBF(lay.num_channels, hidden=8, width=16)),
                      ("ebd", deep.EBD(lay.num_channels, hidden=8, width=16))):
        deep.save_model(deep.DeepModel(kind, net, lay, walk.fps, {**meta, "config": {**cfg, "kind": kind}}),
                        tmp_path / f"{kind}.pt")
    code, out, err = run("info", str(tmp_path / "ebf.pt"))
    assert code == 0, err
    rows = {line.split("  ")[0]: line.split("  ", 1)[1].strip() for line in out.splitlines() if "  " in line}
    assert rows["epochs"].startswith("1 of 3: unfinished")
    assert rows["best validation RMS"] == "4.250 deg (epoch 1)"
    assert rows["noise"] == "angular:0.5, uniform:0.5" and rows["settings"] == "7 steps per epoch, batch 4, seed 11"
    code, out, err = run("denoise", str(WALK), "-o", str(tmp_path / "d.bvh"), "--model", str(tmp_path / "ebf.pt"))
    text = " ".join(out.split())
    assert code == 0 and (tmp_path / "d.bvh").is_file(), err
    assert f"the EBF {tmp_path / 'ebf.pt'} is from an unfinished training (1 of 3 epochs run)" in text
    gin = tmp_path / "gaps.npz"
    _gappy(walk, gin)
    code, out, err = run("fill", str(gin), "-o", str(tmp_path / "f.npz"), "--model", str(tmp_path / "ebd.pt"),
                         "--denoiser", str(tmp_path / "ebf.pt"), "--by", "ebd")
    assert code == 0 and (tmp_path / "f.npz").is_file(), err
    warned = [line for line in out.splitlines() if line.startswith("warning:")]
    assert len(warned) == 1 and "the EBD" in warned[0] and "unfinished training (1 of 3 epochs run)" in warned[0]


def test_a_finished_training_run_again_leaves_its_model_and_the_files_are_named_for_what_they_are(tmp_path):
    """The same finished train command again trains nothing and leaves model.pt as it was (bytes and mtime); a
    checkpoint given as a model is named as one; a model of no known rig family prints no "None" in its line."""
    out = tmp_path / "m"
    args = ("train", "denoiser", WALK, "-o", out, "--epochs", "1", "--steps", "2", "--hidden", "8",
            "--noise", "angular:0.5", "--executor", "serial")
    code, _, err = run(*args)
    assert code == 0, err
    before = (out / "model.pt").stat().st_mtime_ns, (out / "model.pt").read_bytes()
    code, _, err = run(*args)
    assert code == 0, err
    assert ((out / "model.pt").stat().st_mtime_ns, (out / "model.pt").read_bytes()) == before
    code, _, err = run("denoise", WALK, "-o", tmp_path / "d.bvh", "--model", out / "checkpoint.pt")
    text = " ".join(err.split())
    assert code == 2 and one_error_line(err) and "a training checkpoint" in text and "use the model.pt beside it" in text
    odd = tmp_path / "odd.bvh"
    take = unknown_rig(odd)
    from mocapkit.cleaning import deep

    lay = deep.layout_for(take)
    deep.save_model(deep.DeepModel("ebf", deep.EBF(lay.num_channels, hidden=8, width=16), lay, take.fps),
                    tmp_path / "odd_ebf.pt")
    code, said, err = run("denoise", odd, "-o", tmp_path / "o.bvh", "--model", tmp_path / "odd_ebf.pt")
    assert code == 0, err
    assert "denoised by EBF (given)" in " ".join(said.split()) and "None" not in said


def _own_rig_ebd(tmp_path):
    """A gappy take of a rig no shipped model reads (``gaps.npz``) and a small untrained EBD for its channels:
    ``(take, gappy file, layout, EBD network)``."""
    from mocapkit.cleaning import deep

    odd = tmp_path / "odd.bvh"
    take = unknown_rig(odd)
    gin = tmp_path / "gaps.npz"
    _gappy(take, gin)
    lay = deep.layout_for(take)
    x = np.nan_to_num(deep.channels.encode(take, lay)[0])
    net = deep.EBD(lay.num_channels, hidden=8, width=16)
    net.set_statistics(x.mean(0), np.maximum(x.std(0), 1.0), np.ones(3))
    return take, gin, lay, net


def test_fill_with_an_own_rig_ebd_alone_says_to_give_its_denoiser(tmp_path):
    """An EBD trained on a rig no shipped EBF reads, given alone to fill: one line naming the model and saying to
    give --denoiser (or --no-smooth), not the shipped Acclaim EBF's "not a pair"; with --no-smooth it fills."""
    from mocapkit.cleaning import deep

    take, gin, lay, net = _own_rig_ebd(tmp_path)
    deep.save_model(deep.DeepModel("ebd", net, lay, take.fps), tmp_path / "own_ebd.pt")
    code, _, err = run("fill", gin, "-o", tmp_path / "f.npz", "--model", tmp_path / "own_ebd.pt", "--by", "ebd")
    text = " ".join(err.split())
    assert code == 2 and one_error_line(err) and not (tmp_path / "f.npz").exists(), err
    assert f"the EBD {tmp_path / 'own_ebd.pt'}" in text and "fill --denoiser" in text and "not a pair" not in text
    code, _, err = run("fill", gin, "-o", tmp_path / "f.npz", "--model", tmp_path / "own_ebd.pt", "--by", "ebd",
                       "--no-smooth")
    assert code == 0 and (tmp_path / "f.npz").is_file(), err


def test_a_rig_whose_bones_do_not_tell_the_unit_is_given_it_with_unit(tmp_path):
    """train's default spatial noise (cm) and denoise/fill --reference (errors in cm) on a rig of unknown names:
    each error names --unit, and --unit serves them."""
    bow = unnamed(mocapkit.load(Path(__file__).resolve().parents[1] / "data" / "dataset-1_bow_active_001.bvh"))
    odd = tmp_path / "odd.bvh"
    mocapkit.save(concatenate([bow, bow]), odd)  # a Bandai take under names no family knows, long enough to train on
    out = tmp_path / "ebf"
    args = ("train", "denoiser", str(odd), "-o", str(out), "--epochs", "1", "--steps", "1", "--hidden", "8",
            "--executor", "serial")
    code, _, err = run(*args)
    assert code != 0 and one_error_line(err) and "--unit" in err and "--noise" in err and not out.exists()
    code, _, err = run(*args, "--unit", "cm")
    assert code == 0, err
    assert (out / "model.pt").is_file()
    for cmd in ("denoise", "fill"):
        res = tmp_path / f"{cmd}.bvh"
        code, _, err = run(cmd, str(odd), "-o", str(res), "--reference", str(odd))
        assert code == 2 and one_error_line(err) and str(odd) in err and "--unit" in err and not res.exists()
        code, _, err = run(cmd, str(odd), "-o", str(res), "--reference", str(odd), "--unit", "cm")
        assert code == 0, err


def test_fill_with_an_own_rig_ebd_takes_the_ebf_named_as_its_pair_beside_it(tmp_path):
    """An own-rig EBD given alone whose folder holds its pair by the shipped models' naming (``own_ebd.pt`` ->
    ``own_ebf.pt``) reading the same channels: fill uses that EBF and says so in one line; an EBF of that name
    that reads other channels is not its pair, and the refusal stays."""
    from mocapkit.cleaning import deep

    take, gin, lay, net = _own_rig_ebd(tmp_path)
    models = tmp_path / "models"
    models.mkdir()
    deep.save_model(deep.DeepModel("ebd", net, lay, take.fps), models / "own_ebd.pt")
    other = deep.layout_for(mocapkit.load(WALK))
    deep.save_model(deep.DeepModel("ebf", deep.EBF(other.num_channels, hidden=8, width=16), other, take.fps),
                    models / "own_ebf.pt")
    args = ("fill", gin, "-o", tmp_path / "f.npz", "--model", models / "own_ebd.pt", "--by", "ebd")
    code, _, err = run(*args)
    assert code == 2 and one_error_line(err) and "fill --denoiser" in " ".join(err.split()), err
    assert not (tmp_path / "f.npz").exists()
    deep.save_model(deep.DeepModel("ebf", deep.EBF(lay.num_channels, hidden=8, width=16), lay, take.fps),
                    models / "own_ebf.pt")
    code, out, err = run(*args)
    assert code == 0 and (tmp_path / "f.npz").is_file(), err
    said = [ln for ln in out.splitlines() if "own_ebf.pt" in ln]
    assert len(said) == 1 and said[0].startswith(f"warning: {gin}: the EBF ") and "beside" in said[0], out
    code, _, err = run(*args[:3], tmp_path / "g.npz", *args[4:], "--denoiser", models / "own_ebf.pt")
    assert code == 0, err
    assert np.array_equal(mocapkit.load(tmp_path / "f.npz").rotations, mocapkit.load(tmp_path / "g.npz").rotations)


def test_every_path_pairs_an_own_rig_ebd_with_its_ebf_in_trains_layout(tmp_path):
    """``mocapkit train -o my_ebd`` / ``-o my_ebf`` write ``my_ebd/model.pt`` and ``my_ebf/model.pt``: an EBD given
    alone there is smoothed by that EBF in fill --model, clean --ebd, mocapkit.clean(models=) and deep.fill_gaps
    alike (one rule, cleaning.deep.pairs), each the same as with the EBF named, and the CLI says which it used: fill
    and clean in one line, the same words at the same level (fill said it as a note, clean as a warning)."""
    from mocapkit.cleaning import deep

    take, gin, lay, net = _own_rig_ebd(tmp_path)
    ebd, ebf = tmp_path / "my_ebd" / "model.pt", tmp_path / "my_ebf" / "model.pt"
    ebd.parent.mkdir()
    ebf.parent.mkdir()
    deep.save_model(deep.DeepModel("ebd", net, lay, take.fps), ebd)
    deep.save_model(deep.DeepModel("ebf", deep.EBF(lay.num_channels, hidden=8, width=16), lay, take.fps), ebf)
    gappy = mocapkit.load(gin)
    named = deep.fill_gaps(gappy, model=ebd, denoiser=ebf, method="ebd")
    assert np.array_equal(deep.fill_gaps(gappy, model=ebd, method="ebd").rotations, named.rotations)
    res = mocapkit.clean(gappy, steps="fill", models={"ebd": ebd})  # no gap prior in this EBD: the network fills
    assert np.array_equal(res.motion.rotations, named.rotations)
    lines = []
    for cmd, opt in (("fill", "--model"), ("clean", "--ebd")):
        out = tmp_path / f"{cmd}.npz"
        code, said, err = run(cmd, gin, "-o", out, opt, ebd, *(("--by", "ebd") if cmd == "fill" else ("--steps", "fill")))
        assert code == 0, err
        assert np.array_equal(mocapkit.load(out).rotations, named.rotations)
        lines.append([ln for ln in (said + err).splitlines() if str(ebf) in ln])
    assert lines[0] == lines[1] and len(lines[0]) == 1 and lines[0][0] == (
        f"warning: {gin}: the EBF {ebf} smooths the fill of the EBD {ebd}: its pair beside it (by name, reading the "
        f"same {lay.num_channels} channels), as no shipped EBF reads them"), lines
    assert res.warnings == (lines[0][0].split(": ", 2)[2],)  # mocapkit.clean's warnings, word for word


def test_train_names_unit_as_the_command_line_does(tmp_path):
    """train --unit on a clip whose file states another unit said "unit= is for a file that states none": Python's
    keyword to a CLI user, and the clip's name, not its file."""
    walk = mocapkit.samples.path("12_walk.amc")
    code, _, err = run("train", "denoiser", walk, "-o", tmp_path / "ebf", "--unit", "mm", "--executor", "serial")
    assert code == 2 and one_error_line(err), err
    assert f"{walk}: the file states its length unit (5.644 cm), not mm: --unit is for a file that states none" in err
    assert "unit=" not in err and not (tmp_path / "ebf").exists()


@pytest.mark.parametrize("args", [("denoise", "--model", "ebf_bandai.pt"), ("clean", "--ebf", "ebf_bandai.pt")])
def test_a_shipped_model_refused_for_a_rig_is_named_as_typed(tmp_path, args):
    """Before 0.15.0 the refusal named the installed copy (.../site-packages/mocapkit/models/ebf_bandai.pt), not
    the name the user gave."""
    command, option, name = args
    code, _, err = run(command, SAMPLE, "-o", str(tmp_path / "d.bvh"), option, name)
    assert code == 2 and one_error_line(err) and f": the EBF {name} cannot serve this take:" in err, err
    assert "models/" not in err and not (tmp_path / "d.bvh").exists()


def test_train_crops_a_second_of_a_30_fps_game_set_and_says_the_fix_for_shorter_takes(tmp_path):
    """Trial G, finding 2: a crop of 120 + 2 x 15 frames (1.25 s at 120 fps) is 5 s at 30 fps, so `train denoiser`
    refused 147 of 221 Bandai walks and runs; the crop is now 1 s of the clips' rate, and --crop sets it."""
    import shutil

    from mocapkit.cleaning import deep

    data = Path(__file__).resolve().parents[1] / "data"
    takes = tmp_path / "takes"
    takes.mkdir()
    names = ("dataset-2_run_active_049", "dataset-1_dash_chimpira_001", "dataset-2_walk-turn-left_exhausted_005",
             "dataset-2_walk_normal_001_first120", "dataset-1_bow_active_001", "dataset-1_bye_giant_001")
    for name in names:  # 65 to 142 frames at 30 fps
        shutil.copy(data / f"{name}.bvh", takes)
    args = ("--epochs", "1", "--steps", "1", "--hidden", "4", "--executor", "serial", "--noise", "angular:0.5")
    out = tmp_path / "ebf"
    code, _, err = run("train", "denoiser", str(takes), "-o", str(out), "--holdout", "bow", *args)
    assert code == 0, err
    assert deep.load_model(out / "model.pt").meta["config"]["crop"] == 30
    shutil.copy(data / "dataset-2_raise-up-both-hands_active_061.bvh", takes)  # 46 frames: under 1 s + 2 x 15
    code, _, err = run("train", "denoiser", str(takes), "-o", str(tmp_path / "refused"), "--holdout", "bow", *args)
    assert code == 2 and one_error_line(err) and "shorter than a crop of 60 frames" in err and "--crop N" in err
    assert not (tmp_path / "refused").exists()
    code, _, err = run("train", "denoiser", str(takes), "-o", str(tmp_path / "short"), "--holdout", "bow", "--crop", "16",
                       *args)
    assert code == 0, err
    assert deep.load_model(tmp_path / "short" / "model.pt").meta["config"]["crop"] == 16


@pytest.mark.parametrize("channels,bound", [((3, 4, 5), 35.0), ((0, 1, 2), 15.0)])
def test_fill_fills_a_pelvis_root_written_nan_from_the_body(tmp_path, channels, bound):
    """CMU 131_01's root (Hips, the pelvis) with its rotation channels, or its position channels, written ``nan``
    for 1.5 s (frames 300-479): `fill` gave the line between the gap's ends, 53 deg RMS off in rotation and 44 cm
    in position; now the body fills it (the feet's contacts, the heading's spline and the body's tilt), within
    ``bound`` deg or cm, and every measured number of the file is written as it was."""
    from mocapkit import rotations as R
    from mocapkit.joints import unit_scale_cm

    src = mocapkit.samples.path("131_01.bvh")
    lines = src.read_text().splitlines()
    first = next(i for i, s in enumerate(lines) if s.startswith("Frame Time")) + 1
    for i in range(first + 300, first + 480):
        row = lines[i].split()
        for c in channels:
            row[c] = "nan"
        lines[i] = " ".join(row)
    gin, gout = tmp_path / "root.bvh", tmp_path / "out.bvh"
    gin.write_text("\n".join(lines) + "\n")
    code, out, err = run("fill", gin, "-o", gout)
    assert code == 0, err
    truth, got = mocapkit.load(src), mocapkit.load(gout)
    if channels == (3, 4, 5):
        off = np.sqrt(np.mean(np.degrees(R.geodesic_angle(got.rotations[300:480, 0], truth.rotations[300:480, 0])) ** 2))
    else:
        assert "the 180 missing root position(s) among them from the feet's contacts or a cubic spline" in " ".join(out.split())
        d = got.root_positions[300:480] - truth.root_positions[300:480]
        off = np.sqrt(np.mean(np.sum(d ** 2, axis=-1))) * unit_scale_cm(truth.skeleton)
    assert off < bound
    written = gout.read_text().splitlines()
    at = next(i for i, s in enumerate(written) if s.startswith("Frame Time")) + 1
    for i in (0, 299, 300, 479, 480, 993):  # measured channels: the file's text
        keep = [k for k in range(96) if i < 300 or i >= 480 or k not in channels]
        assert [written[at + i].split()[k] for k in keep] == [lines[first + i].split()[k] for k in keep]


def test_fill_fills_a_lost_root_from_the_body_on_a_rig_no_network_serves(tmp_path):
    """CMU 131_01 on a rig without clavicles (the networks do not serve it: the cubic spline fills its joints), its
    root position channels written ``nan`` for 1.5 s (frames 300-479): the cubic spline is 28.9 cm RMS off; the
    feet's contacts carry it within 10 cm, as where the networks serve the rig, and the output line says so."""
    from mocapkit.joints import unit_scale_cm
    from tests.shared import respelled

    truth = respelled(mocapkit.load(BVH), {}, drop=("LeftCollar", "RightCollar"))
    src = tmp_path / "nocollar.bvh"
    mocapkit.save(truth, src)
    lines = src.read_text().splitlines()
    first = next(i for i, s in enumerate(lines) if s.startswith("Frame Time")) + 1
    for i in range(first + 300, first + 480):
        row = lines[i].split()
        row[0:3] = ["nan"] * 3
        lines[i] = " ".join(row)
    gin, gout = tmp_path / "root.bvh", tmp_path / "out.bvh"
    gin.write_text("\n".join(lines) + "\n")
    code, out, err = run("fill", gin, "-o", gout)
    assert code == 0, err
    said = " ".join(out.split())
    assert "cubic spline: the shipped EBD does not serve this rig" in said
    assert "the 180 missing root position(s) among them from the feet's contacts or a cubic spline" in said
    truth, got = mocapkit.load(src), mocapkit.load(gout)
    d = got.root_positions[300:480] - truth.root_positions[300:480]
    assert np.sqrt(np.mean(np.sum(d ** 2, axis=-1))) * unit_scale_cm(truth.skeleton) < 10.0
    assert np.array_equal(got.root_positions[:300], truth.root_positions[:300])
    assert np.array_equal(got.rotations, truth.rotations)
