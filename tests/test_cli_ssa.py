"""`mocapkit detect` and `mocapkit repair` on a real clip with an injected error."""

import numpy as np

import mocapkit
from mocapkit import corrupt
from mocapkit.cleaning import ssa
from tests.test_cli import one_error_line, run


def test_detect_and_repair(tmp_path):
    walk = mocapkit.load(mocapkit.samples.path("131_01.bvh"))
    bad, mask, records = corrupt.real_errors(walk, kinds=("flip",), n_errors=1, seed=1, joints=["LeftKnee"])
    inp = tmp_path / "bad.bvh"
    mocapkit.save(bad, inp)
    det_path, png = tmp_path / "det.npz", tmp_path / "mdm.png"
    code, out, err = run("detect", str(inp), "--out", str(det_path), "--png", str(png))
    assert code == 0, err
    det = ssa.Detection.load(det_path)
    r = records[0]
    assert det.flags[r.start : r.end, walk.skeleton.index("LeftKnee")].mean() > 0.9
    assert png.stat().st_size > 10_000 and "LeftKnee" in out
    fixed_path = tmp_path / "fixed.bvh"
    code, out, err = run("repair", str(inp), "-o", str(fixed_path), "--detection", str(det_path), "--no-foot-skate")
    assert code == 0, err
    fixed = mocapkit.load(fixed_path)
    again = mocapkit.load(inp)  # what a BVH round trip of the input gives
    keep = ~det.flags
    assert np.allclose(fixed.rotations[keep], again.rotations[keep], atol=1e-6) or np.allclose(
        np.abs(np.sum(fixed.rotations[keep] * again.rotations[keep], axis=-1)), 1.0, atol=1e-9
    )


def test_detect_errors_are_one_line(tmp_path):
    inp = mocapkit.samples.path("131_01.bvh")
    code, _, err = run("detect", str(inp), "--out", str(tmp_path / "d.npz"), "--context", str(mocapkit.samples.path("12_walk.amc")))
    assert code == 2 and one_error_line(err) and "joints differ" in err
    assert not (tmp_path / "d.npz").exists()
    code, _, err = run("detect", str(inp), "--out", str(tmp_path / "d.txt"))
    assert code == 2 and one_error_line(err) and ".npz" in err
    code, _, err = run("repair", str(inp), "-o", str(tmp_path / "x.bvh"), "--detection", str(inp))
    assert code == 2 and one_error_line(err) and "not a mocapkit detection file" in err


def test_detect_no_confirm_gives_the_papers_flags(tmp_path):
    walk = mocapkit.load(mocapkit.samples.path("131_01.bvh"))[:600]
    inp = tmp_path / "walk.npz"
    mocapkit.save(walk, inp)
    paths = {rule: tmp_path / f"{rule}.npz" for rule in ("confirm", "no-confirm")}
    for rule, path in paths.items():
        code, _, err = run("detect", str(inp), "--out", str(path), f"--{rule}", "--json")
        assert code == 0, err
    confirmed, paper = (ssa.Detection.load(p) for p in paths.values())
    assert np.array_equal(confirmed.mdm, paper.mdm)
    assert np.array_equal(paper.flags, paper.mdm > 0.5) and not paper.params.confirm
    assert confirmed.params.confirm and (confirmed.flags <= paper.flags | (confirmed.mdm > 0.25)).all()
    assert confirmed.flags.sum() < paper.flags.sum()  # the clean walk's unrepeated gestures are not errors
    code, _, err = run("detect", str(inp), "--out", str(tmp_path / "bad.npz"), "--jump-deg", "-1")
    assert code == 2 and one_error_line(err) and "jump_deg" in err
    assert not (tmp_path / "bad.npz").exists()
