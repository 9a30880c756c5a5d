"""clean_batch over folders: mirrored names, colliding takes, the output guard, overwrite, resume, and no write after the batch is gone."""

from __future__ import annotations

import dataclasses
import hashlib
import os
import shutil
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

import mocapkit
from mocapkit import samples
from mocapkit.batch import BATCH_MARK, BatchSummary, clean_batch, find_inputs, output_for
from mocapkit.errors import MocapError, MocapFormatError
from mocapkit.motion import concatenate

STEPS = ["fill"]  # the cheapest pipeline: these tests are about files, not about cleaning


def file_tree(d: Path) -> dict:
    """Every file under ``d`` (hidden ones included) -> its sha256."""
    return {str(p.relative_to(d)): hashlib.sha256(p.read_bytes()).hexdigest() for p in sorted(d.rglob("*")) if p.is_file()}


def visible_files(d: Path) -> list[str]:
    """Files under ``d`` that are not hidden temporaries or staging folders."""
    if not d.exists():
        return []
    return sorted(str(p.relative_to(d)) for p in d.rglob("*")
                  if p.is_file() and not any(part.startswith(".") for part in p.relative_to(d).parts))


@pytest.fixture(scope="module")
def short_bvh(tmp_path_factory) -> Path:
    p = tmp_path_factory.mktemp("short") / "short.bvh"
    mocapkit.save(mocapkit.load(samples.path("131_01.bvh"))[:40], p)
    return p


@pytest.fixture
def twins(tmp_path, short_bvh) -> Path:
    """IN_DIR with take.amc (+ its ASF) and take.bvh: both map to take.bvh + take.clean.npz."""
    src = tmp_path / "in"
    src.mkdir()
    shutil.copy(samples.path("12.asf"), src / "take.asf")
    lines = samples.path("12_walk.amc").read_text().splitlines(keepends=True)
    frames = [k for k, line in enumerate(lines) if line.strip().isdigit()]  # the frame-number lines
    (src / "take.amc").write_text("".join(lines[:frames[30]]))  # the header and 30 frames
    shutil.copy(short_bvh, src / "take.bvh")
    return src


@pytest.fixture
def walk_in(tmp_path, short_bvh) -> Path:
    """IN_DIR holding one take, walk.bvh."""
    src = tmp_path / "in"
    src.mkdir()
    shutil.copy(short_bvh, src / "walk.bvh")
    return src


# -- item 4: the output guard, before any take is cleaned ----------------------------------------


def test_out_dir_that_is_in_dir_through_a_link_is_refused(twins, tmp_path):
    link = tmp_path / "link"
    link.symlink_to(twins, target_is_directory=True)
    before = file_tree(twins)
    with pytest.raises(MocapFormatError, match="refusing to write into the input folder"):
        clean_batch(twins, link, steps=STEPS, executor="serial", progress=False)
    assert file_tree(twins) == before


def test_output_that_resolves_to_an_input_through_a_link_is_refused(tmp_path, short_bvh):
    src = tmp_path / "in"
    (src / "a").mkdir(parents=True)
    shutil.copy(short_bvh, src / "a" / "walk.bvh")
    shutil.copy(short_bvh, src / "first.bvh")
    out = tmp_path / "out"
    out.mkdir()
    (out / "a").symlink_to(src / "a", target_is_directory=True)  # out/a/walk.bvh is the input in/a/walk.bvh
    before = file_tree(src)
    with pytest.raises(MocapFormatError, match=r"refusing to write over an input"):
        clean_batch(src, out, steps=STEPS, executor="serial", progress=False)
    assert file_tree(src) == before and visible_files(out) == []  # refused before first.bvh (sorted first) was cleaned


def test_output_that_is_a_hard_link_of_an_input_is_refused(tmp_path, short_bvh, walk_in):
    src = walk_in
    out = tmp_path / "out"
    out.mkdir()
    os.link(src / "walk.bvh", out / "walk.bvh")
    for overwrite in (False, True):
        with pytest.raises(MocapFormatError, match="refusing to write over an input"):
            clean_batch(src, out, steps=STEPS, executor="serial", progress=False, overwrite=overwrite)
    assert (src / "walk.bvh").read_bytes() == short_bvh.read_bytes()


def test_output_inside_in_dir_is_refused_unless_under_out_dir(tmp_path, short_bvh):
    root = tmp_path / "root"
    (root / "takes" / "takes").mkdir(parents=True)
    shutil.copy(short_bvh, root / "takes" / "takes" / "x.bvh")
    with pytest.raises(MocapFormatError, match="refusing to write over an input"):  # IN_DIR inside OUT_DIR: root/takes/x.bvh
        clean_batch(root / "takes", root, steps=STEPS, executor="serial", progress=False)
    assert visible_files(root) == ["takes/takes/x.bvh"]
    s = clean_batch(root, root / "cleaned", steps=STEPS, executor="serial", progress=False)  # OUT_DIR below IN_DIR: fine
    assert s.count("done") == 1 and (root / "cleaned" / "takes" / "takes" / "x.bvh").is_file()
    again = clean_batch(root, root / "cleaned", steps=STEPS, executor="serial", progress=False)
    assert [r["status"] for r in again.rows] == ["skipped"]  # the outputs are not taken for inputs


def test_context_file_is_never_an_output(tmp_path, short_bvh, walk_in):
    src = walk_in
    out = tmp_path / "out"
    out.mkdir()
    ctx = out / "walk.bvh"  # the context clip sits where the output would go
    shutil.copy(short_bvh, ctx)
    with pytest.raises(MocapFormatError, match="refusing to write over an input"):
        clean_batch(src, out, context=[ctx], steps=STEPS, executor="serial", progress=False, overwrite=True)
    assert ctx.read_bytes() == short_bvh.read_bytes()


def test_existing_outputs_need_overwrite_but_complete_takes_resume(tmp_path, short_bvh):
    src = tmp_path / "in"
    src.mkdir()
    for name in ("a.bvh", "b.bvh", "c.bvh"):
        shutil.copy(short_bvh, src / name)
    out = tmp_path / "out"
    assert clean_batch(src, out, steps=STEPS, executor="serial", progress=False).count("done") == 3
    (out / "b.clean.npz").unlink()  # b.bvh is now an output without its record: not a complete take
    (out / "c.bvh").unlink()
    (out / "c.bvh").write_text("someone else's file")
    (out / "c.clean.npz").unlink()
    before = file_tree(out)
    with pytest.raises(MocapFormatError, match=r"b\.bvh: already exists; pass overwrite=True"):
        clean_batch(src, out, steps=STEPS, executor="serial", progress=False)
    assert file_tree(out) == before  # refused before anything was cleaned
    s = clean_batch(src, out, steps=STEPS, executor="serial", progress=False, overwrite=True)
    assert [r["status"] for r in s.rows] == ["skipped", "done", "done"]
    assert mocapkit.load(out / "c.bvh").num_frames == 40


def test_bad_arguments_are_one_line_and_write_nothing(twins, tmp_path):
    out = tmp_path / "out"
    for kwargs, msg in [({"executor": "garbage"}, "^executor='garbage': expected"), ({"fmt": "c3d"}, "format must be"),
                        ({"executor": "garbage", "flags": True}, "^--executor: expected"),
                        ({"steps": ["fill", "nope"]}, "nope")]:
        with pytest.raises(MocapError, match=msg):
            clean_batch(twins, out, **{"steps": STEPS, "executor": "serial", "progress": False, **kwargs})
    with pytest.raises(MocapFormatError, match="not a folder"):
        clean_batch(twins / "take.bvh", out, steps=STEPS, executor="serial", progress=False)
    assert not out.exists()


def test_a_failing_take_is_a_row_and_the_others_go_on(tmp_path, short_bvh):
    src = tmp_path / "in"
    src.mkdir()
    shutil.copy(short_bvh, src / "good.bvh")
    (src / "broken.bvh").write_text("HIERARCHY\nROOT\n")
    s = clean_batch(src, tmp_path / "out", steps=STEPS, executor="serial", progress=False)
    assert [(Path(r["input"]).name, r["status"]) for r in s.rows] == [("broken.bvh", "failed"), ("good.bvh", "done")]
    assert "broken.bvh" in s.failed[0]["reason"] and "\n" not in s.failed[0]["reason"]
    assert visible_files(tmp_path / "out") == ["good.bvh", "good.clean.npz"]
    assert [p.name for p in (tmp_path / "out").rglob(".*")] == [BATCH_MARK]  # no staging folder or temporary left


def test_a_failing_take_leaves_no_folder_behind(tmp_path, short_bvh):
    # the mirrored folders a failed take's output would have gone in are not left empty (OUT_DIR itself neither,
    # when every take failed); folders that were there stay
    src = tmp_path / "in"
    (src / "a" / "b").mkdir(parents=True)
    shutil.copy(short_bvh, src / "good.bvh")
    (src / "a" / "b" / "broken.bvh").write_text("HIERARCHY\nROOT\n")
    out = tmp_path / "out"
    (out / "a").mkdir(parents=True)
    s = clean_batch(src, out, steps=STEPS, executor="serial", progress=False)
    assert [r["status"] for r in s.rows] == ["failed", "done"]
    assert sorted(str(p.relative_to(out)) for p in out.rglob("*")) == [BATCH_MARK, "a", "good.bvh", "good.clean.npz"]
    (src / "good.bvh").unlink()
    clean_batch(src, tmp_path / "none", steps=STEPS, executor="serial", progress=False)
    assert not (tmp_path / "none").exists()



def test_a_take_whose_record_name_is_too_long_fails_before_cleaning_and_the_others_go_on(tmp_path, short_bvh):
    # a 250-byte take name is legal, its record's (+ .clean.npz: 256 bytes) is not: the take was cleaned, then failed
    # as its record was written (OUT_DIR new), or the whole batch died on a bare OSError (OUT_DIR there: a rerun)
    src = tmp_path / "in"
    src.mkdir()
    shutil.copy(short_bvh, src / "good.bvh")
    shutil.copy(short_bvh, src / ("a" * 246 + ".bvh"))
    out = tmp_path / "out"
    for run in range(2):
        s = clean_batch(src, out, steps=STEPS, executor="serial", progress=False)
        assert [(len(Path(r["input"]).name), r["status"]) for r in s.rows] == [(250, "failed"), (8, "done" if run == 0 else "skipped")]
        assert s.failed[0]["reason"] == ("not cleaned: its record (STEM.clean.npz) cannot be written: its name is 256 "
                                         "bytes, more than the 255 a file name may hold; shorten the take's name")
        assert s.failed[0]["seconds"] == 0.0  # refused before it was read
        assert visible_files(out) == ["good.bvh", "good.clean.npz"]
        assert [p.name for p in out.rglob(".*")] == [BATCH_MARK]

# -- item 5: no write after the batch is gone -----------------------------------------------


def test_a_take_whose_batch_is_gone_moves_nothing_into_place(tmp_path, monkeypatch, walk_in):
    """The liveness token is asked before each rename; when it turns false mid-take, what was moved is removed."""
    import mocapkit.parallel

    src = walk_in
    answers = iter([True, True, False])  # take starts, the report is moved, then the batch is gone
    monkeypatch.setattr(mocapkit.parallel, "owner_alive", lambda: next(answers))
    out = tmp_path / "out"
    s = clean_batch(src, out, steps=STEPS, executor="serial", progress=False, report=True)
    assert s.failed and "the batch that started this take is gone" in s.failed[0]["reason"]
    assert not [p for p in out.rglob("*") if p.is_file()] and not list(out.glob(".*"))


def _start_batch(src: Path, out: Path, executor: str, jobs: int | None = None) -> subprocess.Popen:
    code = textwrap.dedent(f"""
        from mocapkit.batch import clean_batch
        clean_batch({str(src)!r}, {str(out)!r}, steps=["fill", "denoise"], executor={executor!r}, jobs={jobs!r},
                    progress=False)
    """)
    return subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                            env=dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path)))


def _wait_for(predicate, what: str, proc: subprocess.Popen | None = None, limit_s: float = 600.0):
    """Poll ``predicate`` until true; fail (naming ``what``) if ``proc`` ends first or after a generous limit."""
    deadline = time.monotonic() + limit_s
    while not predicate():
        if proc is not None and proc.poll() is not None:
            pytest.fail(f"the batch ended before {what}: {proc.stderr.read().decode()[-2000:]}")
        if time.monotonic() > deadline:
            pytest.fail(f"gave up waiting for {what}")
        time.sleep(0.05)


def _staging(out: Path) -> list[Path]:
    return [p for p in out.rglob(".*.part") if p.is_dir()] if out.exists() else []


@pytest.fixture(scope="module")
def long_takes(tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp("long")
    m = mocapkit.load(samples.path("12_walk.amc"))
    long = concatenate([m] * 6, name="walk_x6")
    for k in range(3):
        mocapkit.save(long, d / f"t{k}.npz")
    return d


def _gone(pid: int) -> bool:
    psutil = pytest.importorskip("psutil")
    try:
        return psutil.Process(pid).status() == psutil.STATUS_ZOMBIE
    except psutil.NoSuchProcess:
        return True


@pytest.mark.skipif(sys.platform == "win32", reason="kill -9")
def test_kill_9_of_the_batch_takes_its_workers_and_their_writes(long_takes, tmp_path):
    psutil = pytest.importorskip("psutil")
    out = tmp_path / "out"
    # jobs=2: a pool of worker processes on any machine; left to the cores, one core cleans in the batch's own
    # process and there would be no worker whose death this test checks
    proc = _start_batch(long_takes, out, "processes", jobs=2)
    _wait_for(lambda: _staging(out), "the first take started", proc)  # readiness: a worker made its staging folder
    workers = [c.pid for c in psutil.Process(proc.pid).children(recursive=True)]
    assert workers
    proc.kill()
    proc.wait()
    _wait_for(lambda: all(_gone(pid) for pid in workers), "the workers to die")
    assert visible_files(out) == []  # nothing was moved into place, and no worker is left to do it


@pytest.mark.slow  # ~11 s each of a dask cluster starting and dying: `pytest -m slow`
@pytest.mark.skipif(sys.platform == "win32", reason="kill -9")
def test_kill_9_of_a_dask_client_writes_nothing_on_the_cluster(long_takes, tmp_path):
    distributed = pytest.importorskip("distributed")
    src = tmp_path / "in"
    src.mkdir()
    shutil.copy(long_takes / "t0.npz", src / "t0.npz")
    out = tmp_path / "out"
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        proc = _start_batch(src, out, cluster.scheduler_address)
        _wait_for(lambda: _staging(out), "the take started on the cluster", proc)
        proc.kill()
        proc.wait()
        # the worker lives on and finishes cleaning; the cancelled take then removes its staging folder
        _wait_for(lambda: not _staging(out), "the cancelled take to give up")
    assert visible_files(out) == []


@pytest.mark.slow  # ~11 s each of a dask cluster starting and dying: `pytest -m slow`
@pytest.mark.skipif(sys.platform == "win32", reason="kill -9")
def test_kill_9_of_a_batch_on_its_own_dask_cluster_takes_the_cluster(long_takes, tmp_path):
    pytest.importorskip("distributed")
    psutil = pytest.importorskip("psutil")
    out = tmp_path / "out"
    proc = _start_batch(long_takes, out, "dask")
    _wait_for(lambda: _staging(out), "the first take started on the local cluster", proc)
    workers = [c.pid for c in psutil.Process(proc.pid).children(recursive=True)]
    assert workers
    proc.kill()
    proc.wait()
    _wait_for(lambda: all(_gone(pid) for pid in workers), "the Dask workers to die")
    assert visible_files(out) == []


def test_a_complete_take_whose_output_is_an_input_is_refused_not_skipped(tmp_path, short_bvh):
    src = tmp_path / "in"
    (src / "a").mkdir(parents=True)
    shutil.copy(short_bvh, src / "a" / "walk.bvh")
    (src / "a" / "walk.clean.npz").write_bytes(b"a record from elsewhere")  # not an input (records are left out)
    out = tmp_path / "out"
    out.mkdir()
    (out / "a").symlink_to(src / "a", target_is_directory=True)  # the take looks complete: its output is its input
    with pytest.raises(MocapFormatError, match=r"walk\.bvh: refusing to write over an input"):
        clean_batch(src, out, steps=STEPS, executor="serial", progress=False)


def test_failures_name_the_output_not_the_staging_folder(tmp_path, short_bvh):
    from mocapkit import corrupt

    src = tmp_path / "in"
    src.mkdir()
    gappy, _ = corrupt.gaps(mocapkit.load(short_bvh), seed=1)
    assert gappy.missing().any()
    mocapkit.save(gappy, src / "gappy.npz")
    out = tmp_path / "out"
    s = clean_batch(src, out, steps=["denoise"], fmt="bvh", executor="serial", progress=False)  # no fill: NaN cannot go to BVH
    assert s.failed[0]["reason"].startswith(f"{out / 'gappy.bvh'}: "), s.failed[0]["reason"]
    assert not list(out.rglob("*"))


def test_a_failing_take_s_reason_names_its_input_as_given(tmp_path, monkeypatch):
    """Docs trial A: `clean-batch cap3/ out/` printed `failed  cap3/broken.bvh: /abs/.../cap3/broken.bvh:3: ...`,
    the take named twice, once by the worker's absolute path (the line names a reader's PATH:LINE once)."""
    monkeypatch.chdir(tmp_path)
    Path("cap").mkdir()
    Path("cap/broken.bvh").write_text("HIERARCHY\nROOT Hips\n{\n")
    s = clean_batch("cap", "out", steps=STEPS, executor="serial", progress=False)
    assert s.failed[0]["input"] == str(Path("cap/broken.bvh"))
    assert s.failed[0]["reason"].startswith(f"{Path('cap/broken.bvh')}:3: "), s.failed[0]["reason"]


def test_leftovers_of_a_killed_worker_are_swept_and_nothing_else(tmp_path, walk_in):
    src = walk_in
    out = tmp_path / "out"
    (out / ".walk.bvh.k1ll3d.part").mkdir(parents=True)  # a staging folder
    (out / ".walk.bvh.k1ll3d.part" / "walk.bvh").write_text("half")
    (out / ".walk.clean.npz.x_9.part").write_text("half")  # an atomic_write temporary
    (out / ".mine.bvh.a.part").write_text("not of this batch")
    (out / ".walk.bvh.bvh.b.part").write_text("not of this batch either")
    assert clean_batch(src, out, steps=STEPS, executor="serial", progress=False).count("done") == 1
    assert sorted(p.name for p in out.iterdir()) == [".mine.bvh.a.part", BATCH_MARK, ".walk.bvh.bvh.b.part", "walk.bvh",
                                                    "walk.clean.npz"]


def test_amc_outputs_get_their_asf_beside_them(tmp_path, short_bvh):
    # an AMC holds no skeleton: --format amc copies each take's ASF into its output folder, so the outputs read back;
    # a BVH take beside them, which has no ASF, stays BVH (it failed)
    src = tmp_path / "in"
    (src / "hdm").mkdir(parents=True)
    shutil.copy(short_bvh, src / "hdm" / "mixed.bvh")
    mocapkit.save(mocapkit.load(samples.path("12_walk.amc"))[:40], src / "hdm" / "walk40.npz")  # no ASF file either
    shutil.copy(samples.path("12.asf"), src / "12.asf")
    (src / "12_walk.amc").write_bytes(samples.path("12_walk.amc").read_bytes())
    shutil.copy(samples.path("HDM_bd.asf"), src / "hdm" / "HDM_bd.asf")
    amc = samples.path("HDM_bd_jogLeftCircle4StepsRstart_001_120.amc")
    (src / "hdm" / amc.name).write_bytes(amc.read_bytes())
    out = tmp_path / "out"
    s = clean_batch(src, out, steps=STEPS, fmt="amc", executor="serial", progress=False)
    assert s.count("done") == 4
    assert mocapkit.load(out / "hdm" / "mixed.bvh").num_frames == 40
    assert mocapkit.load(out / "hdm" / "walk40.npz").num_frames == 40 and not (out / "hdm" / "walk40.amc").exists()
    assert (out / "12.asf").read_bytes() == samples.path("12.asf").read_bytes()
    assert (out / "hdm" / "HDM_bd.asf").read_bytes() == samples.path("HDM_bd.asf").read_bytes()
    for inp, outp in ((src / "12_walk.amc", out / "12_walk.amc"), (src / "hdm" / amc.name, out / "hdm" / amc.name)):
        assert mocapkit.load(outp).num_frames == mocapkit.load(inp).num_frames
    # someone else's file of that name is replaced only with --overwrite, and refused before any take is cleaned
    shutil.rmtree(out)
    out.mkdir()
    (out / "12.asf").write_text("someone else's skeleton")
    with pytest.raises(MocapFormatError, match=r"12\.asf: exists and differs from the skeleton"):
        clean_batch(src, out, steps=STEPS, fmt="amc", executor="serial", progress=False)
    assert sorted(p.name for p in out.rglob("*")) == ["12.asf"]
    clean_batch(src, out, steps=STEPS, fmt="amc", executor="serial", progress=False, overwrite=True)
    assert (out / "12.asf").read_bytes() == samples.path("12.asf").read_bytes()


def test_a_take_is_complete_only_for_the_request_that_made_it(tmp_path, walk_in):
    """A review batch (steps detect) leaves takes unchanged: a later full batch must not skip them as complete."""
    src = walk_in
    out = tmp_path / "out"
    assert clean_batch(src, out, steps=["detect"], executor="serial", progress=False).count("done") == 1
    review = (out / "walk.bvh").read_bytes()
    with pytest.raises(MocapFormatError, match=r"walk.bvh: exists from an earlier run, but it was cleaned with steps="
                                               r"'detect' \(now 'fill,detect,repair,denoise'\); use overwrite=True"):
        clean_batch(src, out, executor="serial", progress=False)
    assert (out / "walk.bvh").read_bytes() == review  # refused before anything was written
    again = clean_batch(src, out, executor="serial", progress=False, overwrite=True)
    assert again.count("done") == 1
    assert clean_batch(src, out, executor="serial", progress=False).count("skipped") == 1  # now complete
    with pytest.raises(MocapFormatError, match="its png is missing"):
        clean_batch(src, out, executor="serial", progress=False, png=True)
    with pytest.raises(MocapFormatError, match=r"with threshold=0.5 \(now 0.7\)"):
        clean_batch(src, out, executor="serial", progress=False, threshold=0.7)


def test_an_earlier_batchs_outputs_inside_in_dir_are_not_inputs(tmp_path, walk_in):
    src = walk_in
    first = clean_batch(src, src / "cleaned", executor="serial", progress=False)
    assert first.count("done") == 1 and (src / "cleaned" / BATCH_MARK).is_file() and first.earlier == []
    second = clean_batch(src, tmp_path / "out2", executor="serial", progress=False)
    assert [Path(r["input"]).name for r in second.rows] == ["walk.bvh"]  # not cleaned/walk.bvh a second time
    assert second.earlier == [str(src / "cleaned")]
    assert find_inputs(src) == [src / "walk.bvh"]
    assert find_inputs(src / "cleaned") == [src / "cleaned" / "walk.bvh"]  # named itself: its takes are the inputs


def test_a_batch_that_wrote_nothing_leaves_no_mark(tmp_path):
    src = tmp_path / "in"
    src.mkdir()
    (src / "broken.bvh").write_text("HIERARCHY\nROOT x\n")
    s = clean_batch(src, tmp_path / "out", executor="serial", progress=False)
    assert s.count("failed") == 1 and not (tmp_path / "out").exists()


def test_an_earlier_batch_whose_out_dir_holds_its_in_dir_keeps_those_inputs(tmp_path, short_bvh):
    """clean-batch proj/s1/raw proj/s1, then clean-batch proj: proj/s1's outputs are left out, proj/s1/raw's takes
    (the earlier batch's own inputs, inside its OUT_DIR) are not."""
    raw = tmp_path / "proj" / "s1" / "raw"
    raw.mkdir(parents=True)
    shutil.copy(short_bvh, raw / "a.bvh")
    assert clean_batch(raw, tmp_path / "proj" / "s1", executor="serial", progress=False).count("done") == 1
    assert (tmp_path / "proj" / "s1" / "a.bvh").is_file()
    earlier: list = []
    assert find_inputs(tmp_path / "proj", earlier=earlier) == [raw / "a.bvh"]
    assert earlier == [tmp_path / "proj" / "s1"]


def test_clean_file_runs_every_step_by_default(tmp_path, short_bvh):
    from mocapkit.batch import clean_file
    from mocapkit.cleaning.pipeline import STEPS as ALL_STEPS

    _, res = clean_file(short_bvh, tmp_path / "o.bvh")  # steps left to their default (it raised TypeError)
    assert res.params["request"]["steps"] == list(ALL_STEPS) and "detect" in res.params["steps"]


def test_an_interrupted_overwrite_leaves_the_earlier_take_whole(tmp_path, monkeypatch, walk_in):
    """Interrupted while a take's new files replace an earlier run's (--overwrite): the earlier set comes back."""
    src = walk_in
    out = tmp_path / "out"
    clean_batch(src, out, steps=STEPS, executor="serial", progress=False, report=True)
    before = file_tree(out)
    real = os.replace

    def interrupted_at_the_record(a, b, *args, **kwargs):
        if Path(b) == out / "walk.clean.npz" and ".part" in str(a) and Path(a).parent != out:
            raise KeyboardInterrupt  # the report and the take are in place; the record is not
        return real(a, b, *args, **kwargs)

    monkeypatch.setattr(os, "replace", interrupted_at_the_record)
    with pytest.raises(KeyboardInterrupt):
        clean_batch(src, out, steps=["fill", "denoise"], executor="serial", progress=False, report=True,
                    overwrite=True)
    assert file_tree(out) == before  # the earlier take, report and record, and no hidden copy left


@pytest.mark.usefixtures("python_sigint")  # the second interrupt, deferred, is a real SIGINT sent again later
def test_a_second_interrupt_as_the_undo_begins_still_puts_the_earlier_take_back(tmp_path, monkeypatch, walk_in):
    """As above, and a second Ctrl-C lands at the first point Python checks for one after the first (the call that
    begins the undo): it skipped the put-back, and the clean-up then dropped the hidden links of the earlier run's
    files, which were lost. The handler installed then is called with that frame, as the interpreter would."""
    import mocapkit.batch
    import mocapkit.interrupts

    monkeypatch.setattr(mocapkit.interrupts, "RETRY_S", 0.002)
    src = walk_in
    out = tmp_path / "out"
    clean_batch(src, out, steps=STEPS, executor="serial", progress=False, report=True)
    before = file_tree(out)
    real, first = os.replace, []

    def interrupted_at_the_record(a, b, *args, **kwargs):
        if Path(b) == out / "walk.clean.npz" and ".part" in str(a) and Path(a).parent != out:
            first.append(True)
            raise KeyboardInterrupt("the first Ctrl-C")
        return real(a, b, *args, **kwargs)

    landed = []

    def profile(frame, event, arg):
        if first and not landed and event == "call" and frame.f_code.co_filename == mocapkit.batch.__file__:
            landed.append(frame.f_code.co_name)
            signal.getsignal(signal.SIGINT)(signal.SIGINT, frame)

    monkeypatch.setattr(os, "replace", interrupted_at_the_record)
    came = []
    try:
        sys.setprofile(profile)
        try:
            clean_batch(src, out, steps=["fill", "denoise"], executor="serial", progress=False, report=True,
                        overwrite=True)
        finally:
            sys.setprofile(None)
    except KeyboardInterrupt as exc:
        came.append(str(exc))
    if came and came[0] == "the first Ctrl-C":  # the second was deferred: it comes RETRY_S later
        try:
            time.sleep(60)
        except KeyboardInterrupt as exc:
            came.append(str(exc))
    assert landed and len(came) in (1, 2)
    assert file_tree(out) == before  # the earlier take, report and record, and no hidden copy left


def test_a_record_that_cannot_be_read_is_not_a_complete_take(tmp_path, walk_in):
    src = walk_in
    out = tmp_path / "out"
    clean_batch(src, out, steps=STEPS, executor="serial", progress=False)
    for junk in (b"", b"garbage", (out / "walk.clean.npz").read_bytes()[:500]):
        (out / "walk.clean.npz").write_bytes(junk)
        with pytest.raises(MocapFormatError, match=r"walk\.bvh: exists from an earlier run, but its record "
                                                   r"walk\.clean\.npz is not a readable mocapkit clean record"):
            clean_batch(src, out, steps=STEPS, executor="serial", progress=False)
    s = clean_batch(src, out, steps=STEPS, executor="serial", progress=False, overwrite=True)
    assert s.count("done") == 1
    np = pytest.importorskip("numpy")
    np.savez(out / "walk.clean.npz", something=np.zeros(3))  # another program's .npz of that name
    with pytest.raises(MocapFormatError, match="its record walk.clean.npz is not a readable mocapkit clean record"):
        clean_batch(src, out, steps=STEPS, executor="serial", progress=False)


@pytest.mark.skipif(sys.platform == "win32", reason="flock")
def test_a_second_batch_into_a_folder_in_use_is_refused(tmp_path, walk_in):
    import fcntl

    src = walk_in
    out = tmp_path / "out"
    out.mkdir()
    (out / ".walk.bvh.x1y2.part").mkdir()  # another batch's take, being staged
    fd = os.open(out, os.O_RDONLY)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)  # as the running batch holds it
        with pytest.raises(MocapFormatError, match="another clean-batch is writing into this folder"):
            clean_batch(src, out, steps=STEPS, executor="serial", progress=False)
        assert (out / ".walk.bvh.x1y2.part").is_dir()  # its staging folder was not swept away
    finally:
        os.close(fd)
    assert clean_batch(src, out, steps=STEPS, executor="serial", progress=False).count("done") == 1


def test_clean_file_writes_the_asf_before_the_amc_and_neither_on_failure(tmp_path, monkeypatch):
    from mocapkit import io
    from mocapkit.batch import clean_file
    from mocapkit.io.takes import asf_for_output

    out = tmp_path / "elsewhere" / "walk.amc"
    inp, asf = samples.path("12_walk.amc"), samples.path("12.asf")
    copy = asf_for_output(out, asf)
    real, seen = io.save, []

    def save(motion, path, **kwargs):
        seen.append(copy.is_file())
        raise KeyboardInterrupt

    monkeypatch.setattr(io, "save", save)
    with pytest.raises(KeyboardInterrupt):
        clean_file(inp, out, steps=STEPS, asf=asf, skeleton_copy=(copy, asf))
    assert seen == [True]  # the skeleton was there before the take
    assert not any(p.is_file() for p in tmp_path.rglob("*"))  # and neither is left
    monkeypatch.setattr(io, "save", real)
    clean_file(inp, out, steps=STEPS, asf=asf, skeleton_copy=(copy, asf))
    assert mocapkit.load(out).num_frames == mocapkit.load(inp, asf=asf).num_frames


def test_a_batch_hands_out_absolute_paths(tmp_path, short_bvh, monkeypatch, walk_in):
    """A remote Dask worker resolves a relative path against its own folder: every path a job carries is absolute."""
    from tests.shared import record_map_ordered

    shutil.copy(short_bvh, tmp_path / "ctx.bvh")
    seen = record_map_ordered(monkeypatch)
    monkeypatch.chdir(tmp_path)
    s = clean_batch("in", "out", context=["ctx.bvh"], steps=STEPS, executor="serial", progress=False, report=True)
    assert s.count("done") == 1 and s.rows[0]["input"] == os.path.join("in", "walk.bvh")  # said as given
    job = seen[0]
    for key in ("input", "output", "report"):
        assert os.path.isabs(job[key]), key
    assert all(os.path.isabs(c) for c in job["context"])


def test_context_none_stays_a_word(tmp_path, monkeypatch, walk_in):
    """``--context none`` (the take judged against itself) is no path: made absolute it named a folder 'none' in
    the working folder, and every take failed."""
    monkeypatch.chdir(tmp_path)
    s = clean_batch("in", "out", context=["none"], steps=["fill", "detect"], executor="serial", progress=False)
    assert s.count("done") == 1, s.rows


def test_the_context_turned_off_is_one_request_however_it_is_said(tmp_path, walk_in):
    out = tmp_path / "out"
    assert clean_batch(walk_in, out, context=["none"], steps=STEPS, executor="serial", progress=False).count("done") == 1
    for said in ("off", "NONE"):  # documented as the same: the take is complete, not 'made otherwise'
        again = clean_batch(walk_in, out, context=[said], steps=STEPS, executor="serial", progress=False)
        assert again.count("skipped") == 1


def test_two_takes_whose_outputs_resolve_to_one_file_are_refused_before_any_work(tmp_path, short_bvh):
    """OUT_DIR/a is a link to OUT_DIR/b (an earlier layout): in/a/walk.bvh and in/b/walk.bvh would write one file,
    the second take silently replacing the first's output."""
    src = tmp_path / "in"
    for sub in ("a", "b"):
        (src / sub).mkdir(parents=True)
        shutil.copy(short_bvh, src / sub / "walk.bvh")
    out = tmp_path / "out"
    (out / "b").mkdir(parents=True)
    (out / "a").symlink_to(out / "b", target_is_directory=True)
    with pytest.raises(MocapFormatError, match="given as two outputs"):
        clean_batch(src, out, steps=STEPS, executor="serial", progress=False)
    assert list((out / "b").iterdir()) == []  # refused before the first take was cleaned


def test_clean_file_removes_an_old_record_before_it_replaces_the_take_and_puts_it_back_on_failure(tmp_path, short_bvh,
                                                                                                  monkeypatch):
    """A kill -9 while the take is replaced must not leave the old record (the completion marker) beside a new take."""
    from mocapkit import io
    from mocapkit.batch import clean_file
    from mocapkit.cleaning.pipeline import clean_path

    out = tmp_path / "o.bvh"
    clean_file(short_bvh, out, steps=STEPS)
    record = clean_path(out)
    old = record.read_bytes()
    seen = []

    def save(motion, path, **kwargs):
        seen.append(record.exists())
        raise KeyboardInterrupt

    monkeypatch.setattr(io, "save", save)
    with pytest.raises(KeyboardInterrupt):
        clean_file(short_bvh, out, steps=STEPS, overwrite=True)
    assert seen == [False]  # gone while the take was written
    assert record.read_bytes() == old  # and back after the failure


def test_a_rerun_cleans_again_a_take_whose_input_was_replaced_and_says_so(tmp_path, short_bvh):
    """Trial 20: a new version of a take kept the old version's output ("skipped: complete")."""
    src, out = tmp_path / "in", tmp_path / "out"
    src.mkdir()
    shutil.copy(short_bvh, src / "a.bvh")
    shutil.copy(short_bvh, src / "b.bvh")
    assert clean_batch(src, out, steps=STEPS, executor="serial", progress=False).count("done") == 2
    mocapkit.save(mocapkit.load(short_bvh)[:30], src / "a.bvh")  # the new version: 30 frames
    s = clean_batch(src, out, steps=STEPS, executor="serial", progress=False)
    assert [(r["status"], r["reason"]) for r in s.rows] == [
        ("done", "cleaned again: its input changed since it was cleaned"), ("skipped", "complete")]
    assert mocapkit.load(out / "a.bvh").num_frames == 30
    assert clean_batch(src, out, steps=STEPS, executor="serial", progress=False).count("skipped") == 2


def test_a_second_batch_of_another_folder_does_not_replace_a_take_of_the_same_name(tmp_path, short_bvh):
    """Docs trial A: two batches of two folders into one OUT_DIR, each holding a take.bvh. The second took the
    first's cleaned take.bvh for its own, "cleaned again: its input changed since it was cleaned", and replaced
    it and its record unasked. It is now refused until overwrite; a resumed batch of a
    folder moved since (the same bytes) still skips its takes."""
    first, second, out = tmp_path / "first", tmp_path / "second", tmp_path / "out"
    first.mkdir(), second.mkdir()
    shutil.copy(short_bvh, first / "take.bvh")
    mocapkit.save(mocapkit.load(short_bvh)[:30], second / "take.bvh")  # another take of the same name
    assert clean_batch(first, out, steps=STEPS, executor="serial", progress=False).count("done") == 1
    before = file_tree(out)
    with pytest.raises(MocapFormatError, match=r"take\.bvh: exists from an earlier run, but it was cleaned from another "
                                               r"file of the same name; use overwrite=True"):
        clean_batch(second, out, steps=STEPS, executor="serial", progress=False)
    assert file_tree(out) == before
    moved = tmp_path / "moved"
    first.rename(moved)
    assert clean_batch(moved, out, steps=STEPS, executor="serial", progress=False).count("skipped") == 1
    s = clean_batch(second, out, steps=STEPS, executor="serial", progress=False, overwrite=True)
    assert s.count("done") == 1 and mocapkit.load(out / "take.bvh").num_frames == 30


@pytest.mark.parametrize("damage", ["truncate", "same size"])
def test_an_output_changed_outside_mocapkit_is_not_complete(tmp_path, short_bvh, damage):
    """Trial 20: an output cut short outside mocapkit counted as complete. It is now refused, naming it, until
    --overwrite cleans it again (it is not the batch's to replace unasked: someone changed it)."""
    src, out = tmp_path / "in", tmp_path / "out"
    src.mkdir()
    shutil.copy(short_bvh, src / "a.bvh")
    clean_batch(src, out, steps=STEPS, executor="serial", progress=False)
    data = (out / "a.bvh").read_bytes()
    (out / "a.bvh").write_bytes(data[:1000] if damage == "truncate" else data[:-2] + b"9\n")
    before = file_tree(out)
    with pytest.raises(MocapFormatError, match=r"a\.bvh: exists from an earlier run, but its output was changed since "
                                               r"that run wrote it.*use overwrite=True"):
        clean_batch(src, out, steps=STEPS, executor="serial", progress=False)
    assert file_tree(out) == before
    s = clean_batch(src, out, steps=STEPS, executor="serial", progress=False, overwrite=True)
    assert s.count("done") == 1 and (out / "a.bvh").read_bytes() == data


def test_a_marker_capture_s_record_keeps_what_it_read_and_wrote(tmp_path):
    src, out = tmp_path / "in", tmp_path / "out"
    src.mkdir()
    shutil.copy(samples.path("Eb015pr.c3d"), src / "e.c3d")
    clean_batch(src, out, executor="serial", progress=False)
    with open(out / "e.c3d", "r+b") as fh:
        fh.truncate(100_000)
    with pytest.raises(MocapFormatError, match=r"e\.c3d: exists from an earlier run, but its output was changed"):
        clean_batch(src, out, executor="serial", progress=False)


def test_a_take_that_cannot_be_written_fails_in_one_line_naming_its_output(tmp_path, short_bvh, monkeypatch):
    """Trial 20: rows said "OSError: [Errno 28] No space left on device: '...'" and, for a folder without write
    permission, named the hidden staging folder '.a.bvh.RANDOM.part'."""
    import errno
    import tempfile

    import mocapkit.batch as batch

    monkeypatch.chdir(tmp_path)
    src, out = Path("in"), Path("out")  # named as given, not as the worker's absolute paths
    src.mkdir()
    shutil.copy(short_bvh, src / "a.bvh")

    def full(inp, staged, **kwargs):  # the staged output's write fills the disk
        raise OSError(errno.ENOSPC, "No space left on device", str(staged.parent / ".a.bvh.k2j4.part"))

    monkeypatch.setattr(batch, "clean_file", full)
    s = clean_batch(src, out, steps=STEPS, executor="serial", progress=False)
    assert s.rows[0]["reason"] == f"{out / 'a.bvh'}: no space left on the device"
    monkeypatch.undo()

    def denied(prefix="", suffix="", dir=None):
        raise PermissionError(errno.EACCES, "Permission denied", os.path.join(dir, f"{prefix}q7w2{suffix}"))

    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(tempfile, "mkdtemp", denied)
    s = clean_batch(src, out, steps=STEPS, executor="serial", progress=False)
    assert s.rows[0]["reason"] == f"{out / 'a.bvh'}: Permission denied"


def test_the_noise_level_is_part_of_the_request_and_an_earlier_record_without_it_reads_as_the_default(tmp_path,
                                                                                                      walk_in):
    """--noise-deg changes what denoise touches, so a take cleaned at another level is not this run's to skip; a
    record written before the request kept the level (or the AMC rate and unit) was made at the defaults."""
    from mocapkit.cleaning.pipeline import NOISE_DEG, CleanResult

    from mocapkit.batch import REQUEST_DEFAULTS

    assert REQUEST_DEFAULTS["noise_deg"] == NOISE_DEG
    out = tmp_path / "out"
    assert clean_batch(walk_in, out, steps=["fill", "denoise"], executor="serial", progress=False).count("done") == 1
    record = out / "walk.clean.npz"
    assert CleanResult.load_params(record)["request"]["noise_deg"] == NOISE_DEG
    with pytest.raises(MocapFormatError, match=r"with noise_deg=1 \(now 3\)"):
        clean_batch(walk_in, out, steps=["fill", "denoise"], executor="serial", progress=False, noise_deg=3.0)
    with pytest.raises(MocapError, match="noise_deg must be a positive number"):
        clean_batch(walk_in, out, executor="serial", progress=False, noise_deg=0.0)
    res = CleanResult.load(record)  # the record as an earlier mocapkit wrote it: no noise_deg, amc_fps, unit
    request = {k: v for k, v in res.params["request"].items() if k not in REQUEST_DEFAULTS}
    res = dataclasses.replace(res, params={**res.params, "request": request})
    res.save(record)
    assert clean_batch(walk_in, out, steps=["fill", "denoise"], executor="serial", progress=False).count("skipped") == 1


def test_a_marker_capture_s_limits_are_part_of_its_request(tmp_path):
    """--max-gap and --max-fill-error change which gaps are filled, so a capture cleaned with others is not this run's
    to skip: refused without overwrite and cleaned again with it, as a joint-angle take cleaned at another threshold
    is (it was skipped as complete, overwrite or not); a record written before the request was kept reads as the
    defaults."""
    import numpy as np

    from mocapkit.batch import marker_request
    from mocapkit.cleaning.pipeline import CleanResult

    src, out = tmp_path / "in", tmp_path / "out"
    src.mkdir()
    shutil.copy(samples.path("Eb015pr.c3d"), src / "e.c3d")
    assert clean_batch(src, out, executor="serial", progress=False).count("done") == 1
    record = out / "e.clean.npz"
    assert CleanResult.load_params(record)["request"] == marker_request()
    assert clean_batch(src, out, executor="serial", progress=False).count("skipped") == 1
    with pytest.raises(MocapFormatError, match=r"e\.c3d: exists from an earlier run, but it was cleaned "
                                               r"without max_gap_s \(now max_gap_s=0\.05\); use overwrite=True"):
        clean_batch(src, out, executor="serial", progress=False, max_gap_s=0.05)
    s = clean_batch(src, out, executor="serial", progress=False, max_gap_s=0.05, overwrite=True)
    assert s.count("done") == 1
    assert CleanResult.load_params(record)["request"] == marker_request(max_gap_s=0.05)
    assert clean_batch(src, out, executor="serial", progress=False, max_gap_s=0.05).count("skipped") == 1
    with pytest.raises(MocapFormatError, match=r"without max_error_mm \(now max_error_mm=20\)"):
        clean_batch(src, out, executor="serial", progress=False, max_gap_s=0.05, max_error_mm=20.0)
    # an earlier mocapkit's record, without its request: the defaults
    with np.load(record) as data:
        kept = {k: data[k] for k in data.files if k != "request"}
    np.savez_compressed(record, **kept)
    assert CleanResult.load_params(record)["kind"] == "markers" and "request" not in CleanResult.load_params(record)
    with pytest.raises(MocapFormatError, match=r"without max_gap_s \(now max_gap_s=0\.05\)"):
        clean_batch(src, out, executor="serial", progress=False, max_gap_s=0.05)


@pytest.mark.parametrize("code", ["ENOSPC", "EDQUOT", "EROFS"])
def test_a_full_disk_stops_the_batch_and_a_rerun_resumes(tmp_path, short_bvh, monkeypatch, code):
    """Trial 25: on a full 3 MB output folder the batch went on cleaning the 175 other takes, each failing with
    the same "no space left on the device". It stops at the first, keeps what it wrote, and says so."""
    import errno

    import mocapkit.batch as batch

    src, out = tmp_path / "in", tmp_path / "out"
    src.mkdir()
    for k in range(6):
        shutil.copy(short_bvh, src / f"t{k}.bvh")
    real, tried, told = batch.clean_file, [], []

    def fills_up(inp, staged, **kwargs):  # the first take fits, the second fills the disk
        tried.append(Path(inp).name)
        if len(tried) > 1:
            raise OSError(getattr(errno, code), os.strerror(getattr(errno, code)), str(staged))
        return real(inp, staged, **kwargs)

    monkeypatch.setattr(batch, "clean_file", fills_up)
    s = clean_batch(src, out, steps=STEPS, executor="serial", progress=False,
                    on_row=lambda row, n, total: told.append((row["status"], n, total)))
    assert tried == ["t0.bvh", "t1.bvh"]  # nothing handed out after the full disk
    assert told == [("done", 1, 6), ("failed", 2, 6)]
    assert [r["status"] for r in s.rows] == ["done", "failed"] and s.rows[1]["errno"] == code
    assert s.not_started == 4 and s.stopped.startswith(f"{out / 't1.bvh'}: ")
    assert "stopped: 1 of 6 takes complete, 4 not started; the same command resumes the rest" in s.stopped
    assert visible_files(out) == ["t0.bvh", "t0.clean.npz"]
    monkeypatch.undo()
    again = clean_batch(src, out, steps=STEPS, executor="serial", progress=False)  # room again: it resumes
    assert [r["status"] for r in again.rows] == ["skipped"] + ["done"] * 5 and not again.stopped


def test_a_take_that_fails_otherwise_does_not_stop_the_batch(tmp_path, short_bvh, monkeypatch):
    import errno

    import mocapkit.batch as batch

    src = tmp_path / "in"
    src.mkdir()
    for k in range(3):
        shutil.copy(short_bvh, src / f"t{k}.bvh")

    def denied(inp, staged, **kwargs):  # one folder without permission says nothing about the next take's
        raise PermissionError(errno.EACCES, "Permission denied", str(staged))

    monkeypatch.setattr(batch, "clean_file", denied)
    s = clean_batch(src, tmp_path / "out", steps=STEPS, executor="serial", progress=False)
    assert [r["status"] for r in s.rows] == ["failed"] * 3 and not s.stopped and "errno" not in s.rows[0]


def test_no_context_is_spoken_of_when_no_step_reads_one(tmp_path):
    # a Bandai Namco take's joints differ from the bundled default context's; fill and denoise read no context, so
    # clean says nothing of it (detect, which reads it, says it was not used)
    from mocapkit.batch import clean_file

    take = Path(__file__).parent / "data" / "dataset-2_run_active_049.bvh"
    _, res = clean_file(take, tmp_path / "out.bvh", steps="fill,denoise")
    assert not any("context" in n for n in res.notes), res.notes
    api = mocapkit.clean(take, steps="fill,denoise")
    assert not any("context" in n for n in api.notes), api.notes


def test_a_batch_report_names_the_record_where_it_is_placed(tmp_path, walk_in):
    """A batch cleans each take in a staging folder and moves its files into place: the report's command names the
    record at its place, not at the staging folder (gone once the take is placed)."""
    out = tmp_path / "out"
    s = clean_batch(walk_in, out, steps=["fill", "detect"], executor="serial", progress=False, report=True)
    assert s.count("done") == 1, s.rows
    page = (out / "walk.report.html").read_text()
    assert ".part" not in page
    assert str(out / "walk.clean.npz") in page


def test_a_batch_report_of_a_marker_capture_names_the_record_where_it_is_placed(tmp_path):
    src = tmp_path / "in"
    src.mkdir()
    shutil.copy(samples.path("Eb015pr.c3d"), src / "Eb015pr.c3d")
    out = tmp_path / "out"
    s = clean_batch(src, out, executor="serial", progress=False, report=True)
    assert s.count("done") == 1, s.rows
    page = (out / "Eb015pr.report.html").read_text()
    assert ".part" not in page
    assert str(out / "Eb015pr.clean.npz") in page


def test_a_take_cleaned_under_another_joint_map_is_not_complete(tmp_path, walk_in, short_bvh, monkeypatch):
    """The joint map a context folder is built with shapes the cleaning as the context does: a batch rerun with an
    edited map is not skipped as complete, the same map is."""
    monkeypatch.setenv("MOCAPKIT_CACHE_DIR", str(tmp_path / "cache"))
    folder = tmp_path / "ctx"
    folder.mkdir()
    shutil.copy(short_bvh, folder / "other.bvh")
    names = mocapkit.load(short_bvh).skeleton.joint_names
    first, edited = {names[0]: names[0]}, {names[0]: names[0], names[1]: names[1]}  # renames that keep the rig
    out = tmp_path / "out"
    run = dict(context=[folder], executor="serial", progress=False)
    assert clean_batch(walk_in, out, joint_map=first, **run).count("done") == 1
    assert clean_batch(walk_in, out, joint_map=first, **run).count("skipped") == 1
    with pytest.raises(MocapFormatError, match=r"walk.bvh: exists from an earlier run, but it was cleaned with "
                                               r"a joint_map of digest [0-9a-f]{8} \(now of digest [0-9a-f]{8}\); use overwrite=True"):
        clean_batch(walk_in, out, joint_map=edited, **run)
    with pytest.raises(MocapFormatError, match=r"a joint_map of digest [0-9a-f]{8} \(now without it\)"):
        clean_batch(walk_in, out, **run)
    assert clean_batch(walk_in, out, joint_map=edited, overwrite=True, **run).count("done") == 1
    assert clean_batch(walk_in, out, joint_map=dict(reversed(edited.items())), **run).count("skipped") == 1


def test_a_batchs_refusals_name_the_callers_option(tmp_path, walk_in):
    """``clean_batch`` called from Python names ``overwrite=True`` in its refusals; with ``flags`` (the CLI) the
    flag ``--overwrite``."""
    out = tmp_path / "out"
    clean_batch(walk_in, out, steps=["detect"], executor="serial", progress=False)
    for flags, said in ((False, "use overwrite=True to clean it again"), (True, "use --overwrite to clean it again")):
        with pytest.raises(MocapFormatError, match=r"walk\.bvh: exists from an earlier run, .*; " + said) as exc:
            clean_batch(walk_in, out, executor="serial", progress=False, flags=flags)
        assert ("--" in str(exc.value)) == flags
    shutil.rmtree(out)
    out.mkdir()
    (out / "walk.bvh").write_text("someone's file")
    for flags, said in ((False, "pass overwrite=True"), (True, "pass --overwrite")):
        with pytest.raises(MocapFormatError, match=r"walk\.bvh: already exists; " + said):
            clean_batch(walk_in, out, executor="serial", progress=False, flags=flags)
