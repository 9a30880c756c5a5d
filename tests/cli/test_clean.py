"""`mocapkit clean` and `mocapkit clean-batch`: outputs, records, resumption, failures, Dask, interrupts."""

from __future__ import annotations

import dataclasses
import hashlib
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import threading
from pathlib import Path

import numpy as np
import pytest

import mocapkit
from mocapkit import corrupt, samples
from tests.cleaning.ssa.helpers import twin_of
from tests.cli import helpers
from mocapkit.cleaning.decisions import changes
from mocapkit.cleaning.pipeline import CleanResult
from mocapkit.cleaning.ssa.cues import CAUSES
from mocapkit.cli import main
from mocapkit.motion import concatenate


def _hash(p: Path) -> str:
    return hashlib.sha256(p.read_bytes()).hexdigest()


def _tree(d: Path) -> dict:
    return {str(p.relative_to(d)): _hash(p) for p in sorted(d.rglob("*")) if p.is_file()}


@pytest.fixture(scope="module")
def takes(tmp_path_factory):
    d = tmp_path_factory.mktemp("takes")
    m = mocapkit.load(samples.path("12_walk.amc"))
    bad, _, _ = corrupt.real_errors(m, n_errors=3, seed=11)
    gappy, _ = corrupt.gaps(bad, seed=12)
    mocapkit.save(gappy, d / "walk_bad.npz")
    mocapkit.save(m, d / "walk_ref.npz")
    return d


def test_clean_writes_output_and_record(takes, tmp_path, capsys):
    inp = takes / "walk_bad.npz"
    before = _hash(inp)
    out = tmp_path / "walk.bvh"
    rc = main(["clean", str(inp), "-o", str(out), "--reference", str(takes / "walk_ref.npz"), "--png", str(tmp_path / "s.png")])
    text = capsys.readouterr().out
    assert rc == 0, text
    assert _hash(inp) == before
    cleaned = mocapkit.load(out)
    rec = CleanResult.load(tmp_path / "walk.clean.npz", motion=cleaned)
    assert [s.name for s in rec.steps] == ["fill", "detect", "repair", "denoise"]
    assert rec.filled.sum() == mocapkit.load(inp).missing().sum() > 0
    assert not cleaned.missing().any() and cleaned.num_frames == rec.num_frames
    assert (tmp_path / "s.png").read_bytes()[:4] == b"\x89PNG"
    assert f"wrote {out}, {tmp_path / 'walk.clean.npz'} and {tmp_path / 's.png'}: " in text  # was "A and B and C"
    assert "fill" in text and "EBD's gap prior (shipped)" in text and "flagged" in text
    # the error before and after is printed; the pose error after is far lower. (The joint positions are held to a
    # looser bound, 4.65 -> 3.83 cm now: the take's 0.9 s gap in the right upper arm is filled no better by the gap
    # prior than by the linear fill the "before" figure uses, 29 vs 28 deg, and that one arm weighs on them most;
    # before the prior read its clips' mirror images it was 33 deg and the positions 4.83 cm; docs/models.md.)
    found = re.search(r"pose error ([\d.]+) -> ([\d.]+) per frame \(Aristidou et al\. 2018 eq\. 2.*?\); positions of "
                      r"joints and end sites ([\d.]+) -> ([\d.]+) cm", text, re.S)
    assert found, text
    e0, e1, c0, c1 = map(float, found.groups())
    assert e1 < 0.5 * e0 and 0 < c1 < 2 * c0, found.group(0)
    assert not list(tmp_path.glob(".*.part"))


def test_clean_refuses_bad_requests(takes, tmp_path, capsys):
    inp = takes / "walk_bad.npz"
    before = _hash(inp)
    assert main(["clean", str(inp), "-o", str(inp)]) == 2
    assert "refusing to write over an input" in capsys.readouterr().err
    assert _hash(inp) == before
    assert main(["clean", str(inp), "-o", str(tmp_path / "x.bvh"), "--steps", "detect,repair"]) == 2
    err = capsys.readouterr().err
    assert "add the fill step" in err and len(err.strip().splitlines()) == 1
    assert main(["clean", str(inp), "-o", str(tmp_path / "x.bvh"), "--steps", "fill,shine"]) == 2
    err = capsys.readouterr().err
    assert "unknown step(s) shine; steps are fill, detect, repair, denoise" in err, err  # not a Python list ['shine']
    bogus = tmp_path / "bogus.bvh"
    bogus.write_text("HIERARCHY\nROOT Hips\n{\n")
    assert main(["clean", str(bogus), "-o", str(tmp_path / "y.bvh")]) == 2
    assert "bogus.bvh" in capsys.readouterr().err
    assert main(["clean", str(tmp_path / "missing.bvh"), "-o", str(tmp_path / "z.bvh")]) == 2
    assert not [p.name for p in tmp_path.iterdir() if p.name not in ("bogus.bvh",)]


def test_clean_report(takes, tmp_path):
    pytest.importorskip("mocapkit.report.html")
    out = tmp_path / "walk.npz"
    assert main(["clean", str(takes / "walk_bad.npz"), "-o", str(out), "--report", str(tmp_path / "r.html")]) == 0
    html = (tmp_path / "r.html").read_text(encoding="utf-8")
    assert "<html" in html.lower() and "http://" not in html.split("<body", 1)[0].lower().replace("http://www.w3.org", "")


def _corpus(d: Path) -> Path:
    """Three short real takes in sub-folders and one broken file."""
    src = d / "in"
    (src / "cmu").mkdir(parents=True)
    (src / "hdm" / "bk").mkdir(parents=True)
    walk = mocapkit.load(samples.path("12_walk.amc"))
    mocapkit.save(corrupt.real_errors(walk, n_errors=2, seed=1)[0], src / "cmu" / "walk.npz")
    mocapkit.save(mocapkit.load(samples.path("131_01.bvh"))[:150], src / "cmu" / "131_01.bvh")
    sneak = mocapkit.load(samples.path("HDM_bk_sneak2StepsLStart_004_120.amc"))[:200]
    mocapkit.save(sneak, src / "hdm" / "bk" / "sneak.npz")
    (src / "hdm" / "broken.bvh").write_text("HIERARCHY\nROOT\n")
    return src


@pytest.fixture(scope="module")
def serial_batch(tmp_path_factory):
    """The corpus cleaned once by a serial ``clean-batch --steps fill,denoise``: the run the serial test checks and
    resumes (on a copy of its outputs) and the reference the Dask run must equal. ``(in folder, its files' hashes
    before the run, out folder, exit status, stdout)``."""
    d = tmp_path_factory.mktemp("batch")
    src = _corpus(d)
    inputs = _tree(src)
    rc, text, _ = helpers.run("clean-batch", src, d / "out", "--executor", "serial", "--steps", "fill,denoise")
    return src, inputs, d / "out", rc, text


def test_clean_batch_serial_resume_and_failure(serial_batch, tmp_path, capsys):
    src, inputs, first, rc, text = serial_batch
    out = tmp_path / "out"
    shutil.copytree(first, out)  # the resume below changes it; copy2 keeps the time stamps the resume is judged by
    assert rc == 1, text  # one take failed
    assert "failed" in text and "broken.bvh" in text and "3 cleaned" in text
    # one line per take: what was found and fixed, or why it failed
    lines = text.splitlines()
    assert sum(ln.startswith(("cleaned ", "failed ", "skipped ")) for ln in lines) == 4, text
    walk_line = next(ln for ln in lines if ln.startswith("cleaned ") and "walk.npz" in ln)
    assert "denoised" in walk_line or "nothing to change" in walk_line
    assert any(ln.startswith("failed ") and "broken.bvh" in ln for ln in lines)
    for rel in ("cmu/walk.npz", "cmu/131_01.bvh", "hdm/bk/sneak.npz"):
        assert (out / rel).is_file(), rel
        stem = rel.rsplit(".", 1)[0]
        assert (out / f"{stem}.clean.npz").is_file()
    assert not (out / "hdm" / "broken.bvh").exists() and not list(out.rglob(".*.part"))
    assert _tree(src) == inputs
    stamp = (out / "cmu" / "walk.clean.npz").stat().st_mtime_ns
    # resume: complete takes are skipped; a take not done yet (no output, no record) is done
    (out / "hdm" / "bk" / "sneak.clean.npz").unlink()
    (out / "hdm" / "bk" / "sneak.npz").unlink()
    rc = main(["clean-batch", str(src), str(out), "--executor", "serial", "--steps", "fill,denoise"])
    text = capsys.readouterr().out
    assert rc == 1 and "1 cleaned, 2 already complete, 1 failed" in text, text
    assert (out / "cmu" / "walk.clean.npz").stat().st_mtime_ns == stamp
    assert (out / "hdm" / "bk" / "sneak.clean.npz").is_file()
    # only the pattern's files
    out2 = tmp_path / "out2"
    assert main(["clean-batch", str(src), str(out2), "--executor", "serial", "--steps", "fill", "--pattern", "*.bvh"]) == 1
    assert sorted(p.name for p in out2.rglob("*") if p.is_file()) == [".mocapkit-batch.json", "131_01.bvh", "131_01.clean.npz"]
    # a take made with another request: refused in the command line's words (the library's say overwrite=True)
    code, _, err = helpers.run("clean-batch", str(src), str(out2), "--executor", "serial", "--steps", "fill",
                               "--pattern", "*.bvh", "--threshold", "0.7")
    assert code == 2 and helpers.one_error_line(err) and "use --overwrite to clean it again" in " ".join(err.split()), err


def test_a_failed_batch_row_names_the_input_once(tmp_path, capsys):
    """A reader's reason names the file already ("PATH:LINE: ..."): the failed line says the path once."""
    src = tmp_path / "in"
    src.mkdir()
    good = Path(samples.path("131_01.bvh")).read_bytes()
    (src / "good.bvh").write_bytes(good)
    (src / "bad.bvh").write_bytes(good[:3000])  # truncated inside the hierarchy
    rc = main(["clean-batch", str(src), str(tmp_path / "out"), "--executor", "serial", "--steps", "fill"])
    text = capsys.readouterr().out
    assert rc == 1, text
    failed = [ln for ln in text.splitlines() if ln.startswith("failed ")]
    bad = str(src / "bad.bvh")
    assert len(failed) == 1 and failed[0].count(bad) == 1, failed
    assert re.match(rf"failed  {re.escape(bad)}:\d+: truncated file", failed[0]), failed


def test_clean_batch_on_local_dask_cluster(serial_batch, tmp_path, capsys):
    distributed = pytest.importorskip("distributed")
    src = _corpus(tmp_path)
    (src / "hdm" / "broken.bvh").unlink()
    out = tmp_path / "out"
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        rc = main(["clean-batch", str(src), str(out), "--executor", cluster.scheduler_address, "--steps", "fill,denoise"])
    text = capsys.readouterr().out
    assert rc == 0, text
    assert "3 cleaned" in text and "dask" in text
    # each take's line as it finished, counted (stdout is no terminal here), then the totals
    assert [(ln[:len("cleaned ")], ln[-len(" [k/3]"):]) for ln in text.splitlines()[:3]] == \
        [("cleaned ", f" [{k}/3]") for k in (1, 2, 3)]
    serial = serial_batch[2]  # the same takes cleaned by the serial executor
    for rel in ("cmu/walk.npz", "cmu/131_01.bvh", "hdm/bk/sneak.npz"):
        a, b = mocapkit.load(out / rel), mocapkit.load(serial / rel)
        assert np.allclose(a.rotations, b.rotations, atol=1e-6), rel  # same result wherever it ran


# -- interrupts -------------------------------------------------------------------------


def _run_and_signal(args, sig, ready, tmp_path, timeout=600.0):
    """Start the CLI, wait until ``ready(stderr_so_far)`` is true (a readiness signal, not a sleep), then send ``sig``.

    The timeout only bounds a hung run; nothing depends on how long a step takes.
    """
    env = dict(os.environ, PYTHONUNBUFFERED="1", MOCAPKIT_PROGRESS="1")  # its bars, though stderr is a pipe
    # a shell runs background jobs with SIGINT ignored and children inherit that; give the CLI the default, as a terminal does
    proc = subprocess.Popen([sys.executable, "-m", "mocapkit.cli", *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            env=env, cwd=tmp_path, preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    chunks: list[bytes] = []
    reader = threading.Thread(target=lambda: chunks.extend(iter(lambda: proc.stderr.read1(4096), b"")), daemon=True)
    reader.start()
    seen = threading.Event()

    def watch():
        while proc.poll() is None and not ready(b"".join(chunks).decode(errors="replace")):
            seen.wait(0.05)
        seen.set()

    watcher = threading.Thread(target=watch, daemon=True)
    watcher.start()
    assert seen.wait(timeout), "no readiness signal"
    assert proc.poll() is None, "finished before the signal; make the take longer"
    proc.send_signal(sig)
    proc.wait(timeout=timeout)
    reader.join(timeout)
    return proc.returncode, b"".join(chunks).decode(errors="replace")


@pytest.fixture(scope="module")
def long_take(tmp_path_factory):
    d = tmp_path_factory.mktemp("long")
    m = mocapkit.load(samples.path("12_walk.amc"))
    long = concatenate([m] * 8, name="walk_x8")  # 23 s
    gappy, _ = corrupt.gaps(long, seed=3)
    mocapkit.save(gappy, d / "long.npz")
    return d / "long.npz"


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
def test_interrupted_clean_leaves_no_output(long_take, tmp_path, sig):
    before = _hash(long_take)
    out = tmp_path / "o" / "clean.bvh"
    # ready: detection has started (its progress bar), i.e. the gaps are filled and nothing is written yet
    rc, err = _run_and_signal(["clean", str(long_take), "-o", str(out), "--png", str(tmp_path / "o" / "s.png")], sig,
                              lambda err: "ssa walk_x8" in err, tmp_path)
    assert rc == 128 + sig, err  # 130 after Ctrl-C, 143 after SIGTERM (made a KeyboardInterrupt, as a shell reports it)
    assert not out.exists() and not (tmp_path / "o" / "clean.clean.npz").exists()
    assert not list(tmp_path.rglob(".*.part"))
    assert _hash(long_take) == before


@pytest.mark.slow  # ~60 s: the workers finish the take they are on before the batch exits
def test_interrupted_batch_leaves_only_complete_takes(long_take, tmp_path):
    src = tmp_path / "in"
    src.mkdir()
    for k in range(3):
        (src / f"t{k}.npz").write_bytes(long_take.read_bytes())
    inputs = _tree(src)
    out = tmp_path / "out"
    # ready: the first take is complete, the others are under way
    rc, err = _run_and_signal(["clean-batch", str(src), str(out)], signal.SIGTERM,
                              lambda err: any(out.rglob("*.clean.npz")) if out.is_dir() else False, tmp_path)
    assert rc == 143, err
    assert _tree(src) == inputs
    assert not list(tmp_path.rglob(".*.part"))
    for k in range(3):  # each take is either complete (output + record) or absent
        assert (out / f"t{k}.npz").exists() == (out / f"t{k}.clean.npz").exists()


# -- checked before any work, nothing left behind ------------------------------------------------


def test_reference_of_another_length_is_refused_before_anything_is_written(takes, tmp_path, capsys):
    short = tmp_path / "ref" / "short.npz"
    mocapkit.save(mocapkit.load(takes / "walk_ref.npz")[:50], short)
    before = _tree(tmp_path)
    out = tmp_path / "o" / "walk.bvh"
    argv = ["clean", str(takes / "walk_bad.npz"), "-o", str(out), "--reference", str(short),
            "--report", str(tmp_path / "o" / "r.html"), "--png", str(tmp_path / "o" / "s.png")]
    assert main(argv) == 2
    captured = capsys.readouterr()
    assert "short.npz: the reference must have the input's joints and 343 frames (it has 50 frames)" in captured.err
    assert "ssa" not in captured.err  # refused before detection started
    assert _tree(tmp_path) == before and not (tmp_path / "o").exists()
    other_rig = tmp_path / "ref" / "other.npz"
    mocapkit.save(mocapkit.load(samples.path("131_01.bvh"))[:343], other_rig)
    argv[argv.index(str(short))] = str(other_rig)
    assert main(argv) == 2
    assert "its joints differ" in capsys.readouterr().err and not (tmp_path / "o").exists()


def test_a_run_that_fails_while_writing_leaves_no_report(takes, tmp_path, monkeypatch, capsys):
    import errno

    import mocapkit.io as mio

    def disk_full(*args, **kwargs):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(mio, "save", disk_full)  # the take itself cannot be written, after the report and png were
    keep = tmp_path / "o" / "s.png"
    keep.parent.mkdir()
    keep.write_bytes(b"an earlier figure")
    out = tmp_path / "o" / "walk.bvh"
    argv = ["clean", str(takes / "walk_bad.npz"), "-o", str(out), "--steps", "fill", "--report", str(tmp_path / "o" / "r.html"),
            "--png", str(keep), "--overwrite"]
    assert main(argv) == 2
    assert "no space left on the device" in capsys.readouterr().err
    # what this run created is gone; what existed before (replaced with --overwrite) is not deleted
    assert sorted(p.name for p in (tmp_path / "o").iterdir()) == ["s.png"]


def test_clean_overwrite_and_asf(takes, tmp_path, capsys):
    import shutil

    amc = tmp_path / "in" / "walk.amc"
    amc.parent.mkdir()
    shutil.copy(samples.path("12_walk.amc"), amc)
    asf = tmp_path / "subject12.asf"
    shutil.copy(samples.path("12.asf"), asf)
    out = tmp_path / "new" / "walk.npz"  # a missing parent folder is created
    argv = ["clean", str(amc), "--asf", str(asf), "-o", str(out), "--steps", "fill"]
    assert main(argv) == 0
    assert out.is_file() and "walk.clean.npz" in capsys.readouterr().out
    record = tmp_path / "new" / "walk.clean.npz"
    stamp = record.stat().st_mtime_ns
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "already exists; pass --overwrite" in err and record.stat().st_mtime_ns == stamp
    assert main(argv + ["--overwrite"]) == 0
    np.testing.assert_array_equal(mocapkit.load(out).rotations, mocapkit.load(samples.path("12_walk.amc")).rotations)


def test_asf_serves_clean_batch_and_the_reference(tmp_path, capsys):
    """AMC takes whose ASF is elsewhere: clean-batch --asf cleans them, clean --asf also reads an AMC reference."""
    src = tmp_path / "amc"
    src.mkdir()
    amc = samples.path("12_walk.amc")
    (src / "walk.amc").write_bytes(amc.read_bytes())  # no ASF beside it
    asf = samples.path("12.asf")
    assert main(["clean-batch", str(src), str(tmp_path / "no_asf"), "--executor", "serial", "--steps", "detect"]) == 1
    assert "failed" in capsys.readouterr().out
    rc = main(["clean-batch", str(src), str(tmp_path / "out"), "--executor", "serial", "--steps", "detect", "--asf", str(asf)])
    text = capsys.readouterr().out
    assert rc == 0, text
    assert any(ln.startswith("reviewed ") and "walk.amc" in ln for ln in text.splitlines()), text  # --steps detect
    assert (tmp_path / "out" / "walk.bvh").is_file()
    m = mocapkit.load(amc)
    bad, _, _ = corrupt.real_errors(m, n_errors=2, seed=5)
    mocapkit.save(bad, tmp_path / "bad.npz")
    rc = main(["clean", str(tmp_path / "bad.npz"), "-o", str(tmp_path / "c.npz"), "--reference", str(src / "walk.amc"),
               "--asf", str(asf), "--steps", "detect,repair"])
    text = capsys.readouterr().out
    assert rc == 0, text
    assert "error against walk.amc" in text


def test_review_mode_gives_a_bvh_take_back_byte_for_byte(tmp_path):
    """``--steps detect`` changes nothing, so the written BVH is the input file, byte for byte (the 3dsMax CMU
    conversion and a Bandai Namco take: values the writer would otherwise reformat and unwrap)."""
    bandai = Path(__file__).resolve().parents[1] / "data" / "bandai_dance-short_normal_001_first60.bvh"
    for src in (Path(mocapkit.__file__).parent / "data" / "131_01.bvh", bandai):
        out = tmp_path / f"{src.stem}_review.bvh"
        assert main(["clean", str(src), "-o", str(out), "--steps", "detect", "--context", "none"]) == 0
        assert out.read_bytes() == src.read_bytes()


def test_clean_amc_to_amc_keeps_every_unchanged_frame_as_the_input_has_it(tmp_path, capsys):
    """An AMC cleaned into an AMC (read back with the same ASF): frames with no change are the input's lines."""
    from mocapkit.cleaning.pipeline import clean_path
    from mocapkit.io.asfamc import read_amc

    amc, asf = samples.path("12_walk.amc"), samples.path("12.asf")
    m = mocapkit.load(amc)
    bad, _, _ = corrupt.real_errors(m, n_errors=3, seed=11)
    src = tmp_path / "walk_bad.amc"
    mocapkit.save(bad, src)
    out = tmp_path / "walk_clean.amc"
    assert main(["clean", str(src), "--asf", str(asf), "-o", str(out)]) == 0
    given = read_amc(src, asf)
    res = CleanResult.load(clean_path(out))
    assert res.changed.any() and not res.changed.all(axis=1).any()

    def frames(p):
        blocks, cur = [], None
        for ln in p.read_text().splitlines():
            if ln.strip().isdigit():
                cur = [ln]
                blocks.append(cur)
            elif cur is not None:
                cur.append(ln)
        return blocks

    a, b = frames(src), frames(out)
    assert len(a) == len(b) == m.num_frames
    same = ~res.changed.any(axis=1)
    assert all((a[f] == b[f]) == bool(same[f]) for f in range(m.num_frames))
    back = read_amc(out, asf)
    np.testing.assert_array_equal(back.rotations[same], given.rotations[same])
    # the cleaned cells as the record holds them, on the bones' dofs (a blend of two rotations a bone can
    # make may leave its dofs by a few thousandths of a degree, which the AMC cannot hold)
    assert np.degrees(mocapkit.rotations.geodesic_angle(back.rotations[res.changed], res.samples["rotations"])).max() < 0.05
    capsys.readouterr()
    before = sorted(p.name for p in tmp_path.iterdir())
    assert main(["denoise", str(samples.path("131_01.bvh")), "-o", str(tmp_path / "walk.amc")]) == 2
    assert "ASF" in capsys.readouterr().err and sorted(p.name for p in tmp_path.iterdir()) == before


def test_clean_batch_drifts_flags_a_smooth_drift_only_when_asked(tmp_path, capsys):
    """clean-batch --drifts passes the smooth-drift rule to every take, as clean --drifts does: a 35 degree knee
    drift with no break, the clean take as context, is flagged and repaired with it and left alone without it."""
    m = mocapkit.load(samples.path("HDM_bk_sneak2StepsLStart_004_120.amc"))
    bad, mask, _ = corrupt.smooth_drifts(m, n_drifts=1, duration_s=(1.0, 1.0), seed=0, joints=["ltibia"])
    j = m.skeleton.index("ltibia")
    src, ctx = tmp_path / "in", tmp_path / "ctx.npz"
    src.mkdir()
    mocapkit.save(bad, src / "sneak.npz")
    mocapkit.save(twin_of(m), ctx)  # another take of the same motion (not of the take's length: not the input itself)
    records = {}
    for name, extra in (("off", []), ("on", ["--drifts"])):
        out = tmp_path / name
        rc = main(["clean-batch", str(src), str(out), "--executor", "serial", "--steps", "detect,repair",
                   "--context", str(ctx), *extra])
        assert rc == 0, capsys.readouterr().out
        records[name] = CleanResult.load(out / "sneak.clean.npz")
    assert not records["off"].flags[:, j].any()
    seen = mask[:, j] & (np.degrees(mocapkit.rotations.geodesic_angle(bad.rotations[:, j], m.rotations[:, j])) >= 5.0)
    assert records["on"].flags[seen, j].all()  # every cell the drift moved visibly; its faint ends need not be
    # the record says which rule flagged each cell, and the change list says it in words
    drift = 1 << [name for name, _ in CAUSES].index("drift")
    on = records["on"]
    assert np.array_equal(on.causes != 0, on.flags) and (on.causes[mask[:, j] & on.flags[:, j], j] & drift).all()
    assert not (records["off"].causes & drift).any()
    reasons = [c.reason for c in changes(on, bad) if c.joint == "ltibia"]
    assert reasons and all("smooth drift" in r for r in reasons)


def test_a_model_licence_is_said_once_naming_cleans_own_option(tmp_path, capsys):
    """The Bandai Namco EBD's non-commercial licence: one line in clean's output, naming --ebd, not a --model clean lacks."""
    take = mocapkit.load(Path(__file__).resolve().parents[1] / "data" / "bandai_dance-short_normal_001_first60.bvh")
    rot = take.rotations.copy()
    rot[20:30, take.skeleton.joint_names.index("LowerArm_L")] = np.nan
    mocapkit.save(dataclasses.replace(take, rotations=rot), tmp_path / "gappy.npz")
    assert main(["clean", str(tmp_path / "gappy.npz"), "-o", str(tmp_path / "out.npz"), "--steps", "fill",
                 "--context", "none"]) == 0
    out = capsys.readouterr().out
    # the EBD and the EBF that smooths its fill, of one licence: one statement (U2: two repeated ~400 characters
    # word for word on every Bandai take with gaps)
    assert out.count("licence of the EBD and EBF used: CC BY-NC") == 1 and "licence of the EBF used" not in out, out
    assert "warning: " in out and "fill (" in out  # a warning line, as denoise and fill print it, not in the step's
    assert "--ebd, --ebf (clean, clean-batch; models= in Python) pick others: no shipped model" in " ".join(out.split())


def test_rejected_fills_written_as_bvh_say_the_decisions_left_the_gaps(tmp_path, capsys):
    """A BVH holds no gaps: with fill changes rejected the hint is to accept them, not to add a fill step that ran."""
    import json

    from mocapkit.cleaning import decisions as dec

    take = mocapkit.load(samples.path("12_walk.amc"))[:120]
    rot = take.rotations.copy()
    rot[40:50, 5] = np.nan
    gappy = dataclasses.replace(take, rotations=rot)
    mocapkit.save(gappy, tmp_path / "gappy.npz")
    assert main(["clean", str(tmp_path / "gappy.npz"), "-o", str(tmp_path / "out.npz"), "--steps", "fill"]) == 0
    res = CleanResult.load(tmp_path / "out.clean.npz")
    found = changes(res, gappy)
    doc = dec.template(gappy, found, decisions={c.id: "reject" for c in found if c.step == "fill"})
    (tmp_path / "d.json").write_text(json.dumps(doc))
    capsys.readouterr()
    assert main(["clean", str(tmp_path / "gappy.npz"), "-o", str(tmp_path / "out.bvh"), "--record",
                 str(tmp_path / "out.clean.npz"), "--decisions", str(tmp_path / "d.json")]) == 2
    err = capsys.readouterr().err
    assert "the decisions reject fill changes: accept them or write .npz" in err and "add the fill step" not in err
    assert not (tmp_path / "out.bvh").exists()


def test_output_suffix_and_record_clashes_are_named_first(tmp_path, capsys):
    """A wrong OUT suffix is said before an existing record asks for --overwrite; a record landing on the input says so."""
    (tmp_path / "x.clean.npz").write_bytes(b"an earlier record")
    assert main(["clean", str(samples.path("131_01.bvh")), "-o", str(tmp_path / "x.c3d")]) == 2
    assert "unknown suffix '.c3d' for writing" in capsys.readouterr().err
    mocapkit.save(mocapkit.load(samples.path("12_walk.amc"))[:60], tmp_path / "a.clean.npz")
    assert main(["clean", str(tmp_path / "a.clean.npz"), "-o", str(tmp_path / "a.npz")]) == 2
    assert "the record of" in capsys.readouterr().err and not (tmp_path / "a.npz").exists()


def test_an_interrupted_batch_says_its_finished_takes_are_kept(tmp_path, monkeypatch):
    import mocapkit.batch

    out = tmp_path / "out"

    def interrupted(in_dir, out_dir, **kwargs):
        (Path(out_dir) / "done.clean.npz").parent.mkdir(parents=True, exist_ok=True)
        (Path(out_dir) / "done.clean.npz").write_bytes(b"a finished take's record")
        raise KeyboardInterrupt

    monkeypatch.setattr(mocapkit.batch, "clean_batch", interrupted)
    (tmp_path / "in").mkdir()
    code, text, err = helpers.run("clean-batch", tmp_path / "in", out)
    assert code == 130 and "the takes finished in" in " ".join(text.split()) and "resumes the others" in text


def test_clean_batch_writes_a_cmu_trial_numbered_30_at_120_fps(shared_data, tmp_path):
    """CMU's SS_TT.amc: trial 30 is no 30 fps take. The BVH clean-batch writes plays at the take's 120 fps, and
    --amc-fps gives the rate of every AMC of the batch."""
    src = tmp_path / "in"
    src.mkdir()
    (src / "86.asf").write_bytes((shared_data / "cmu_asfamc" / "11.asf").read_bytes())
    (src / "86_30.amc").write_bytes((shared_data / "cmu_asfamc" / "11_01.amc").read_bytes())
    code, out, err = helpers.run("clean-batch", src, tmp_path / "out", "--steps", "fill", "--context", "none")
    assert code == 0, (out, err)
    bvh = mocapkit.load(tmp_path / "out" / "86_30.bvh")
    assert bvh.fps == 120.0 and bvh.num_frames == 597
    assert "Frame Time: 0.008333" in (tmp_path / "out" / "86_30.bvh").read_text()
    code, out, err = helpers.run("clean-batch", src, tmp_path / "out60", "--steps", "fill", "--context", "none",
                         "--amc-fps", "60")
    assert code == 0, (out, err)
    assert mocapkit.load(tmp_path / "out60" / "86_30.bvh").fps == 60.0


def test_noise_deg_sets_the_level_a_joint_is_denoised_over(shared_data, tmp_path, capsys):
    """CMU 01_01 delivered at 30 fps (every fourth frame): its toes' and fingers' own wobble is left, the body being
    smooth (docs/guide/cleaning.md); with Mall's 0.1 noise on every channel the take is denoised (the denoise step
    alone), and --noise-deg 10 leaves it bit-identical and says the level; a level that is not a positive number of degrees is refused in
    one line, nothing written."""
    clean = tmp_path / "01_01_30fps.bvh"
    mocapkit.save(mocapkit.load(shared_data / "cmu_bvh" / "01_01.bvh")[::4], clean)
    assert main(["clean", str(clean), "-o", str(tmp_path / "a0.bvh")]) == 0
    assert CleanResult.load(tmp_path / "a0.clean.npz").denoised.sum() == 0
    take = tmp_path / "01_01_30fps_noisy.bvh"
    assert main(["corrupt", str(clean), str(take), "--kind", "noise", "--amount", "0.1", "--seed", "7"]) == 0
    assert main(["clean", str(take), "-o", str(tmp_path / "a.bvh"), "--steps", "denoise"]) == 0
    assert CleanResult.load(tmp_path / "a.clean.npz").denoised.sum() > 100
    capsys.readouterr()
    assert main(["clean", str(take), "-o", str(tmp_path / "b.bvh"), "--steps", "denoise", "--noise-deg", "10"]) == 0
    text = capsys.readouterr().out
    assert "level > 10 deg" in text and (tmp_path / "b.bvh").read_bytes() == take.read_bytes()
    assert CleanResult.load_params(tmp_path / "b.clean.npz")["request"]["noise_deg"] == 10.0
    for bad in ("0", "-1", "nan"):
        assert main(["clean", str(take), "-o", str(tmp_path / "c.bvh"), "--noise-deg", bad]) == 2
        err = capsys.readouterr().err
        assert "--noise-deg must be a positive number" in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "c.bvh").exists()


def test_clean_batch_names_a_renamed_take_and_what_an_npz_output_leaves_out(tmp_path, capsys):
    """take.bvh (with a prop root) and take.npz in one folder: each is named after its format and the command
    says so; the npz output of the BVH keeps the file's text, prop included (a BVH written from it has the prop
    back), so nothing is said to be left out."""
    from tests.io.prop_files import with_prop

    src = tmp_path / "in"
    src.mkdir()
    with_prop(samples.path("131_01.bvh"), src / "take.bvh", frames=40)
    mocapkit.save(mocapkit.load(samples.path("131_01.bvh"))[:40], src / "take.npz")
    out = tmp_path / "out"
    rc = main(["clean-batch", str(src), str(out), "--executor", "serial", "--steps", "fill", "--format", "npz"])
    text = capsys.readouterr().out
    assert rc == 0, text
    assert sorted(p.name for p in out.iterdir() if not p.name.startswith(".")) == [
        "take-bvh.clean.npz", "take-bvh.npz", "take-npz.clean.npz", "take-npz.npz"]
    lines = text.splitlines()
    for name in ("take.bvh", "take.npz"):
        assert sum(ln.startswith(f"note: {src / name}: its files are named after its format") for ln in lines) == 1, text
    assert not [ln for ln in lines if "not written" in ln], text
    assert main(["convert", str(out / "take-bvh.npz"), str(tmp_path / "back.bvh")]) == 0
    assert (tmp_path / "back.bvh").read_bytes() == (src / "take.bvh").read_bytes()  # the prop's root and channels too


# -- a batch's log --------------------------------------------------------------------------------


def test_a_batch_logged_to_a_file_says_each_take_as_it_finishes_and_keeps_it_when_interrupted(tmp_path):
    """Trial 25: `clean-batch IN OUT > log` printed its per-take lines only when the batch returned, so a log had
    none of the 53 takes written before Ctrl-C. Each line is in the file as soon as its take is done, with how
    far the batch is, since no progress bar is drawn there; a take written whose row the interrupt cut off is
    said from its record (a later trial: complete on disk, missing from the log)."""
    src, out = tmp_path / "in", tmp_path / "out"
    src.mkdir()
    short = src / "t000.bvh"
    mocapkit.save(mocapkit.load(samples.path("131_01.bvh"))[:40], short)
    for k in range(1, 120):
        (src / f"t{k:03d}.bvh").write_bytes(short.read_bytes())
    log = tmp_path / "log"
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONUNBUFFERED", "MOCAPKIT_PROGRESS")}
    with open(log, "wb") as fh:  # stdout to a file: block-buffered, no terminal
        proc = subprocess.Popen([sys.executable, "-m", "mocapkit.cli", "clean-batch", str(src), str(out),
                                 "--steps", "fill", "--context", "none", "--executor", "serial"],
                                stdout=fh, stderr=subprocess.PIPE, env=env, cwd=tmp_path,
                                preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
        try:
            # ready: two takes' lines are in the log (on the code that printed at the end, never before it ends)
            while proc.poll() is None and log.read_text().count("\ncleaned ") < 1:
                threading.Event().wait(0.05)
            assert proc.poll() is None, "the batch ended before a line reached its log"
            proc.send_signal(signal.SIGINT)
            _, err = proc.communicate(timeout=600)
        finally:
            if proc.poll() is None:
                proc.kill()
    assert proc.returncode == 130, err
    lines = log.read_text().splitlines()
    cleaned = [ln for ln in lines if ln.startswith("cleaned ")]
    complete = sorted(p.name for p in out.glob("*.clean.npz"))
    assert 2 <= len(cleaned) < 120
    assert len(cleaned) == len(complete)  # a take written as the interrupt came is said too, from its record
    for n, line in enumerate(cleaned, 1):
        found = re.fullmatch(rf"cleaned {re.escape(str(src))}/(t\d+)\.bvh -> .* \[{n}/120\]", line)
        assert found, line
        assert f"{found[1]}.clean.npz" in complete
    assert lines[-1].startswith("note: the takes finished in")


def test_a_full_disk_stops_clean_batch_in_one_line(tmp_path, monkeypatch):
    """Trial 25: a full output folder failed every later take the same way; the batch stops and says how to go
    on (a rerun resumes), after the lines of the takes it did."""
    import errno

    import mocapkit.batch as batch

    src = tmp_path / "in"
    src.mkdir()
    for k in range(4):
        mocapkit.save(mocapkit.load(samples.path("131_01.bvh"))[:40], src / f"t{k}.bvh")
    real = batch.clean_file
    tried = []

    def fills_up(inp, staged, **kwargs):
        tried.append(inp)
        if len(tried) > 1:
            raise OSError(errno.ENOSPC, "No space left on device", str(staged))
        return real(inp, staged, **kwargs)

    monkeypatch.setattr(batch, "clean_file", fills_up)
    code, text, err = helpers.run("clean-batch", src, tmp_path / "out", "--steps", "fill", "--context", "none",
                                  "--executor", "serial")
    assert code == 2 and helpers.one_error_line(err), err
    assert len(tried) == 2
    assert "no space left on the device; stopped: 1 of 4 takes complete, 2 not started; the same command " \
           "resumes the rest" in err
    lines = text.splitlines()
    assert lines[0].startswith("cleaned ") and lines[0].endswith(" [1/4]")
    assert lines[1].startswith("failed ") and lines[1].endswith(" [2/4]")
    assert lines[2].endswith("1 cleaned, 0 already complete, 1 failed, 2 not started")


def test_clean_gives_a_take_too_coarse_for_a_word_back_bit_identical_and_says_it_was_not_judged(tmp_path):
    """A BVH whose Frame Time is 1 s: detection was a slow search of interpolated words; clean now leaves the take
    as it came and says what it did not judge."""
    inp, out = tmp_path / "coarse.bvh", tmp_path / "out.bvh"
    mocapkit.save(dataclasses.replace(mocapkit.load(helpers.SAMPLE)[:40], fps=1.0), inp)
    code, text, err = helpers.run("clean", inp, "-o", out)
    assert code == 0, err
    assert out.read_bytes() == inp.read_bytes()
    said = text + err
    assert "detect and repair skipped: 1 fps is too coarse for motion words" in said and ": not judged" in said
    assert re.search(r"^  detect \([0-9.]+ s\): skipped$", text, re.M)


def test_clean_batch_says_in_a_log_when_it_builds_the_context_before_the_first_take(tmp_path, monkeypatch):
    """A user trial: with stdout a log, `clean-batch --context FOLDER` said nothing while it built the folder into
    a database before the first take (a minute on a real folder); one line on stderr as it starts, one as it ends
    (clips, seconds), and none when the cache already holds it."""
    import shutil

    monkeypatch.setenv("MOCAPKIT_CACHE_DIR", str(tmp_path / "cache"))
    ctx, src = tmp_path / "ctx", tmp_path / "takes"
    ctx.mkdir()
    src.mkdir()
    for name in ("HDM_bk.asf", "HDM_bd.asf", "HDM_bk_sneak2StepsLStart_005_120.amc",
                 "HDM_bd_jogLeftCircle4StepsRstart_001_120.amc"):  # real HDM05 takes of two actors
        shutil.copy(samples.path(name), ctx / name)
    for name in ("HDM_bk.asf", "HDM_bk_sneak2StepsLStart_004_120.amc"):
        shutil.copy(samples.path(name), src / name)
    code, out, err = helpers.run("clean-batch", src, tmp_path / "out", "--steps", "fill", "--context", ctx)
    assert code == 0, err
    lines = [ln for ln in err.splitlines() if "context" in ln]
    assert lines[0] == f"building context the takes of {ctx}: 2 files, once (cached for the next run)", err
    assert re.fullmatch(rf"built context the takes of {re.escape(str(ctx))}: 2 clips of 2 files \(\d+\.\d s\)",
                        lines[1]), err
    assert "cleaned " in out
    code, out, err = helpers.run("clean-batch", src, tmp_path / "out2", "--steps", "fill", "--context", ctx)
    assert code == 0 and "context" not in err, err  # opened from the cache: nothing built, nothing said


def test_a_context_of_bandai_takes_says_their_licence_once(tmp_path, capsys):
    """clean --context <a database of Bandai Namco takes>: a repair draws its motion from CC BY-NC takes, said in
    one line and kept in the record's notes; a context of unknown terms says nothing of a licence."""
    bandai = Path(__file__).resolve().parents[1] / "data" / "bandai_dance-short_normal_001_first60.bvh"
    db = tmp_path / "db"
    assert main(["db", "build", str(db), str(bandai), "--fps", "24", "--executor", "serial"]) == 0
    capsys.readouterr()
    assert main(["clean", str(bandai), "-o", str(tmp_path / "out.bvh"), "--steps", "detect,repair",
                 "--context", str(db)]) == 0
    said = [ln for ln in capsys.readouterr().out.splitlines() if "CC BY-NC 4.0" in ln]
    assert len(said) == 1 and "a repair draws its motion from them" in said[0], said
    assert sum("CC BY-NC 4.0" in n for n in CleanResult.load(tmp_path / "out.clean.npz").notes) == 1
    assert main(["clean", str(bandai), "-o", str(tmp_path / "self.bvh"), "--steps", "detect,repair",
                 "--context", "none"]) == 0
    assert "CC BY-NC" not in capsys.readouterr().out


def test_clean_and_detect_take_a_joint_map_for_a_context_of_a_rig_whose_names_say_no_roles(tmp_path, monkeypatch):
    """One --joint-map file, as db build takes it, lets a folder of such a rig's takes be the context."""
    from tests.shared import unnamed

    data = Path(__file__).resolve().parents[1] / "data"
    folder = tmp_path / "kt"
    folder.mkdir()
    for n in ("dataset-1_dash_normal_001", "dataset-2_run_active_049"):
        m = mocapkit.load(data / f"{n}.bvh")
        mocapkit.save(unnamed(m), folder / f"{n}.bvh")
    jm = tmp_path / "map.json"
    jm.write_text(json.dumps({f"bone{j}": n for j, n in enumerate(m.skeleton.joint_names)}))
    take = tmp_path / "take.bvh"
    mocapkit.save(unnamed(mocapkit.load(data / "dataset-1_run_masculinity_001.bvh")), take)
    monkeypatch.setenv("MOCAPKIT_CACHE_DIR", str(tmp_path / "cache"))
    out = tmp_path / "out.bvh"
    code, _, err = helpers.run("clean", str(take), "-o", str(out), "--context", str(folder))
    assert code == 2 and helpers.one_error_line(err) and "dataset-1_dash_normal_001.bvh: " in err and "--joint-map" in err
    assert not out.exists()
    code, stdout, err = helpers.run("clean", str(take), "-o", str(out), "--context", str(folder), "--joint-map", str(jm))
    assert code == 0, err
    assert "joints named by its joint map" in " ".join(stdout.split())
    assert np.array_equal(mocapkit.load(out).rotations, mocapkit.load(take).rotations)  # a clean take untouched
    code, _, err = helpers.run("detect", str(take), "-o", str(tmp_path / "d.npz"), "--context", str(folder), "--joint-map", str(jm))
    assert code == 0, err


def test_clean_batch_refuses_an_amc_rate_for_bvh_takes_naming_the_flag(tmp_path):
    """--amc-fps with no .amc among the batch's takes: one line naming the flag the user typed (not the library's
    keyword), exit 2, nothing written."""
    src = tmp_path / "in"
    src.mkdir()
    (src / "131_01.bvh").write_bytes(samples.path("131_01.bvh").read_bytes())
    code, out, err = helpers.run("clean-batch", src, tmp_path / "out", "--amc-fps", "60")
    assert code == 2 and "--amc-fps" in err and "amc_fps=" not in err, err
    assert not (tmp_path / "out").exists()


def test_clean_batch_in_review_mode_says_reviewed(tmp_path, capsys):
    """--steps detect changes nothing: each take's line and the totals say "reviewed", not "cleaned"."""
    src = tmp_path / "src"
    src.mkdir()
    mocapkit.save(mocapkit.load(samples.path("12_walk.amc")), src / "walk.npz")
    rc = main(["clean-batch", str(src), str(tmp_path / "out"), "--executor", "serial", "--steps", "detect"])
    text = capsys.readouterr().out
    assert rc == 0, text
    lines = text.splitlines()
    assert any(ln.startswith(f"reviewed {src / 'walk.npz'} -> ") for ln in lines), text
    totals = next(ln for ln in lines if ln.startswith("1 take on "))
    assert not any(ln.startswith("cleaned ") for ln in lines) and "1 reviewed," in totals, text


def test_a_take_clean_refuses_is_named_once_by_its_file(tmp_path):
    """The library names the take by its stem; the command's line named both ('one.bvh: one: 1 frame(s)')."""
    one = tmp_path / "one.bvh"
    mocapkit.save(mocapkit.load(helpers.SAMPLE)[:1], one)
    code, _, err = helpers.run("clean", one, "-o", tmp_path / "c.bvh")
    assert code == 2 and helpers.one_error_line(err), err
    assert f"error: {one}: 1 frame(s); cleaning compares frames" in " ".join(err.split())
    assert not (tmp_path / "c.bvh").exists()


def test_a_batch_that_finds_no_take_says_so(tmp_path):
    """A mistyped --pattern or folder printed only '0 takes ... 0 cleaned' and exit 0: now a warning line says why."""
    src = tmp_path / "in"
    src.mkdir()
    mocapkit.save(mocapkit.load(helpers.SAMPLE)[:20], src / "walk.bvh")
    code, out, err = helpers.run("clean-batch", src, tmp_path / "out", "--pattern", "*.bhv")
    assert code == 0, err
    assert "0 takes on" in out
    assert f"warning: {src}: no file matches --pattern *.bhv (searched recursively); nothing cleaned" in " ".join(err.split())
    assert not (tmp_path / "out").exists()
