"""The self-contained HTML cleaning report: its file, its data, and the page in a real headless Chromium."""

from __future__ import annotations

import base64
import dataclasses
import json
import os
import re
from pathlib import Path

import numpy as np
import pytest

import mocapkit
from mocapkit.cleaning import ssa
from mocapkit.corrupt import real_errors
from mocapkit.motion import concatenate, unit_scale_cm
from mocapkit.report.html import DEFAULT_MAX_FRAMES, shown_frames, write_report
from mocapkit.rotations import quaternion_from_axis_angle, quaternion_multiply

CHROMIUM = os.environ.get("MOCAPKIT_CHROMIUM", "/usr/bin/chromium")
CHROMIUM_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
                 "--disable-component-update", "--disable-sync", "--no-first-run"]


def chromium_page(path: Path, ready: str):
    """A generator for a module-scoped fixture: one 1280x900 headless Chromium page on the report at ``path``, yielded
    once the JavaScript condition ``ready`` holds; skips without playwright or Chromium, and fails at teardown on a
    page error."""
    sync_api = pytest.importorskip("playwright.sync_api", reason="playwright is not installed (pip install -e '.[test]')")
    if not os.access(CHROMIUM, os.X_OK):
        pytest.skip(f"no Chromium executable at {CHROMIUM} (apt-get install chromium, or set MOCAPKIT_CHROMIUM)")
    errors = []
    with sync_api.sync_playwright() as p:
        b = p.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
        pg = b.new_page(viewport={"width": 1280, "height": 900})
        pg.on("pageerror", lambda e: errors.append(str(e)))
        pg.goto(Path(path).resolve().as_uri())
        pg.wait_for_function(ready, timeout=60000)
        yield pg
        b.close()
    assert not errors


# ---- real clip, real errors, real detection ----------------------------------------------------

@pytest.fixture(scope="module")
def walk():
    return mocapkit.load(mocapkit.samples.path("12_walk.amc"))


@pytest.fixture(scope="module")
def cleaned_walk(walk):
    """12_walk with injected real-style errors, the self-similarity detection and the repair."""
    corrupted, mask, records = real_errors(walk, seed=3)
    det = ssa.detect(corrupted)
    repaired = ssa.repair(corrupted, det)
    changed = np.any(np.abs(repaired.rotations - corrupted.rotations) > 1e-12, axis=-1)
    assert det.flags.any() and changed.any()
    return corrupted, repaired, det, changed


@pytest.fixture(scope="module")
def walk_report(tmp_path_factory, cleaned_walk):
    corrupted, repaired, det, changed = cleaned_walk
    path = tmp_path_factory.mktemp("report") / "walk.html"
    out = write_report(path, corrupted, repaired, mdm=det.mdm, flags=det.flags, changed=changed,
                       title="12_walk <cleaned>")
    return out


def page_data(path: Path) -> dict:
    text = path.read_text(encoding="utf-8")
    m = re.search(r'<script type="application/json" id="mocapkit-data">(.*?)</script>', text, re.S)
    assert m, "the data block is missing"
    return json.loads(m.group(1))


def decode_positions(data: dict, which: str) -> np.ndarray:
    """(N, P, 3) cm positions of 'original' or 'cleaned' as the page decodes them."""
    pos = data["pos"]
    shape = (data["n"], len(data["names"]), 3)
    if which == "original" or "cleaned" in pos:
        return decode_i16(pos[which], pos["lo"], pos["step"]).reshape(shape)
    out = decode_positions(data, "original").reshape(-1, 3)
    where = np.frombuffer(base64.b64decode(pos["cleanedPatch"]["index"]), dtype="<u4")
    out[where] = decode_i16(pos["cleanedPatch"]["values"], pos["lo"], pos["step"]).reshape(-1, 3)
    return out.reshape(shape)


def decode_i16(b64: str, lo: float, step: float) -> np.ndarray:
    q = np.frombuffer(base64.b64decode(b64), dtype="<i2")
    out = lo + (q.astype(np.float64) + 32767) * step
    out[q == -32768] = np.nan
    return out


def with_nan(motion, rows, joint):
    rot = np.array(motion.rotations)
    rot[rows, joint] = np.nan
    root = np.array(motion.root_positions)
    root[rows.start + 40:rows.start + 43] = np.nan
    return dataclasses.replace(motion, rotations=rot, root_positions=root)


# ---- the file --------------------------------------------------------------------------------

def test_report_is_self_contained(walk_report):
    text = walk_report.read_text(encoding="utf-8")
    assert text.startswith("<!DOCTYPE html>")
    for needle in ("http://", "https://", "//cdn", "<link", "@import", "url("):
        assert needle not in text, needle
    assert not re.search(r"\bsrc\s*=", text), "a src= attribute would load something from outside"
    assert not re.search(r"\bhref\s*=", text)
    # the viewer code and the style are inline, the title escaped
    assert "window.mocapkitReport" in text and ".viewer-canvas" in text
    assert "12_walk &lt;cleaned&gt;" in text and "<cleaned>" not in text
    assert text.count("</script>") == 2  # the data block cannot close its script early


def test_report_data_matches_forward_kinematics(walk_report, cleaned_walk):
    corrupted, repaired, det, changed = cleaned_walk
    data = page_data(walk_report)
    F, J = corrupted.num_frames, corrupted.num_joints
    sk = corrupted.skeleton
    assert data["frames"] == data["n"] == F and data["stride"] == 1 and data["numJoints"] == J
    assert data["names"] == list(sk.joint_names) + list(sk.end_site_names)
    assert data["parents"][:J] == [int(p) for p in sk.parents]
    assert data["fps"] == corrupted.fps
    scale = unit_scale_cm(sk)
    assert scale == pytest.approx(2.54 / 0.45)
    for which, motion in (("original", corrupted), ("cleaned", repaired)):
        pos = decode_positions(data, which)
        ref = motion.global_positions(end_sites=True) * scale
        # ASF is y-up already: the page keeps the axes, in cm, to half a quantisation step
        assert np.nanmax(np.abs(pos - ref)) <= data["pos"]["step"] / 2 + 1e-6
        assert data["pos"]["step"] <= 0.1 + 1e-12  # 1 mm
    mdm = np.frombuffer(base64.b64decode(data["mdm"]), dtype=np.uint8).reshape(F, J)
    np.testing.assert_array_equal(mdm, np.rint(det.mdm * 255).astype(np.uint8))
    bits = np.frombuffer(base64.b64decode(data["bits"]), dtype=np.uint8).reshape(F, J)
    np.testing.assert_array_equal(bits & 1 > 0, det.flags)
    np.testing.assert_array_equal(bits & 2 > 0, changed)
    assert data["stats"]["flagged"] == int(det.flags.sum())
    # channel plots: the flagged or changed joints, their rotation channels before and after
    plotted = {p["joint"] for p in data["plots"]}
    assert plotted and plotted <= set(np.flatnonzero((det.flags | changed).any(axis=0)))
    names = corrupted.channel_names()
    for p in data["plots"]:
        jn = sk.joint_names[p["joint"]]
        cols = [names.index(f"{jn}.{c}") for c in p["channels"]]
        for which, motion in (("original", corrupted), ("cleaned", repaired)):
            got = decode_i16(p[which], p["lo"], p["step"]).reshape(F, len(cols))
            np.testing.assert_allclose(got, motion.channel_values()[:, cols], atol=p["step"] / 2 + 1e-6)


def test_atomic_write_leaves_no_temp_and_keeps_old_file_on_error(tmp_path, walk):
    clip = walk[:50]
    out = write_report(tmp_path / "r.html", clip, clip)
    assert out == tmp_path / "r.html"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.html"]
    before = out.read_bytes()
    with pytest.raises(ValueError):
        write_report(out, clip, clip, mdm=np.zeros((3, 3)))
    assert out.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.html"]


def test_interrupted_write_leaves_nothing(tmp_path, walk, monkeypatch):
    import mocapkit.report.html as h

    clip = walk[:50]
    real = h.atomic_write

    class Boom(KeyboardInterrupt):
        pass

    from contextlib import contextmanager

    @contextmanager
    def interrupted(path, mode, **kw):
        with real(path, mode, **kw) as fh:
            fh.write("<!DOCTYPE html> half a page")
            raise Boom()
            yield fh  # pragma: no cover

    monkeypatch.setattr(h, "atomic_write", interrupted)
    with pytest.raises(Boom):
        write_report(tmp_path / "r.html", clip, clip)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("kwargs, message", [
    (dict(mdm=np.zeros((50, 30))), r"mdm: expected shape \(F, J\) = \(50, 31\)"),
    (dict(mdm=np.full((50, 31), 1.5)), r"mdm: values must lie in \[0, 1\]"),
    (dict(flags=np.zeros((49, 31), bool)), r"flags: expected shape"),
    (dict(changed=np.zeros(50, bool)), r"changed: expected shape"),
    (dict(flags=np.full((50, 31), 0.3)), r"flags: expected a boolean"),
    (dict(max_frames=1), r"max_frames must be an integer >= 2"),
    (dict(fps=0), r"fps must be a positive number"),
])
def test_bad_arguments_raise_clear_errors(tmp_path, walk, kwargs, message):
    clip = walk[:50]
    with pytest.raises(ValueError, match=message):
        write_report(tmp_path / "r.html", clip, clip, **kwargs)
    assert list(tmp_path.iterdir()) == []


def test_mismatched_motions_raise(tmp_path, walk):
    with pytest.raises(ValueError, match="50 frames but cleaned has 40"):
        write_report(tmp_path / "r.html", walk[:50], walk[:40])
    other = mocapkit.load(mocapkit.samples.path("131_01.bvh"))[:50]
    with pytest.raises(ValueError, match="share one skeleton"):
        write_report(tmp_path / "r.html", walk[:50], other)
    with pytest.raises(TypeError, match="original must be a Motion"):
        write_report(tmp_path / "r.html", walk.rotations, walk)
    assert list(tmp_path.iterdir()) == []


def test_nan_input_becomes_gaps(tmp_path, walk):
    clip = walk[:120]
    j = clip.skeleton.index("lfemur")
    gappy = with_nan(clip, slice(10, 30), j)
    out = write_report(tmp_path / "nan.html", gappy, clip, flags=gappy.missing(), changed=gappy.missing())
    data = page_data(out)
    F, J = 120, clip.num_joints
    pos = decode_positions(data, "original")
    ref = gappy.global_positions(end_sites=True) * unit_scale_cm(clip.skeleton)
    np.testing.assert_array_equal(np.isnan(pos), np.isnan(ref))
    assert np.isnan(pos[15, clip.skeleton.index("ltibia")]).all()  # below the missing joint
    assert np.isnan(pos[51]).all() and not np.isnan(pos[60]).any()  # root missing: the whole figure
    bits = np.frombuffer(base64.b64decode(data["bits"]), dtype=np.uint8).reshape(F, J)
    np.testing.assert_array_equal(bits & 4 > 0, gappy.missing())
    assert not (bits & 8).any()
    assert data["stats"]["missingOriginal"] == int(gappy.missing().sum())


def frame_list(data: dict) -> np.ndarray:
    """The take frame of each shown frame, as the page decodes it."""
    if data["frameList"] is None:
        return np.arange(data["n"])
    return np.frombuffer(base64.b64decode(data["frameList"]), dtype="<i4")


def test_long_take_shows_every_kth_frame_and_every_flagged_frame(tmp_path, walk):
    F, J = walk.num_frames, walk.num_joints
    flags = np.zeros((F, J), bool)
    flags[5, 3] = True  # one frame, not on the kept grid 0, 4, 8, ...
    mdm = np.zeros((F, J))
    mdm[6, 3] = 0.8
    mdm[101, 7] = 0.6  # far from any flag: not shown, kept as the maximum of the block 100-103
    out = write_report(tmp_path / "r.html", walk, walk, mdm=mdm, flags=flags, max_frames=100)
    data = page_data(out)
    want = sorted(set(range(0, F, 4)) | {F - 1} | set(range(5 - 3, 5 + 4)))  # the grid, the last frame, the flag and 3 either side
    assert data["stride"] == 4 and data["frames"] == F and data["detail"] == "full" and data["margin"] == 3
    assert frame_list(data).tolist() == want and data["n"] == len(want)
    bits = np.frombuffer(base64.b64decode(data["bits"]), dtype=np.uint8).reshape(data["n"], J)
    assert np.argwhere(bits & 1).tolist() == [[want.index(5), 3]]  # on frame 5 itself, nowhere else
    q = np.frombuffer(base64.b64decode(data["mdm"]), dtype=np.uint8).reshape(data["n"], J)
    assert q[want.index(6), 3] == round(0.8 * 255) and q[want.index(100), 7] == round(0.6 * 255)
    assert q.sum() == round(0.8 * 255) + round(0.6 * 255)
    pos = decode_positions(data, "original")
    ref = walk.global_positions(end_sites=True)[want] * unit_scale_cm(walk.skeleton)
    assert np.abs(pos - ref).max() <= data["pos"]["step"] / 2 + 1e-6
    track = np.frombuffer(base64.b64decode(data["view"]["track"]), dtype="<f4").reshape(-1, 2)
    assert track.shape == (data["n"], 2) and np.isfinite(track).all()


SPIKE = (502, 503)  # two frames of a 1000-frame take, neither on the grid 0, 3, 6, ... of max_frames=400


def spiked_long_take(walk):
    """12_walk looped to 1000 frames; the input has a 2-frame spike of lhumerus (80 deg) at SPIKE."""
    take = concatenate([walk] * 3)[:1000]
    j = take.skeleton.index("lhumerus")
    rot = np.array(take.rotations)
    a, b = SPIKE[0], SPIKE[1] + 1
    rot[a:b, j] = quaternion_multiply(quaternion_from_axis_angle(np.array([0.0, 0.0, 1.0]), np.radians(80.0)), rot[a:b, j])
    spiked = dataclasses.replace(take, rotations=rot, name="spiked")
    changed = np.zeros((take.num_frames, take.num_joints), bool)
    changed[a:b, j] = True
    return spiked, take, changed, j


@pytest.fixture(scope="module")
def spiked_report(tmp_path_factory, walk):
    """The spiked 1000-frame take and its report at max_frames=400 (written once, read by three tests)."""
    spiked, take, changed, j = spiked_long_take(walk)
    out = write_report(tmp_path_factory.mktemp("spiked") / "r.html", spiked, take, flags=changed, changed=changed,
                       max_frames=400)
    return spiked, take, j, out


def test_long_take_holds_every_frame_of_a_change(spiked_report):
    spiked, take, j, out = spiked_report
    data = page_data(out)
    frames = frame_list(data)
    assert data["stride"] == 3 and data["frames"] == 1000 and data["detail"] == "full"
    # every 3rd frame, both frames of the change and 3 frames either side: sorted, from 0
    assert frames.tolist() == sorted(set(range(0, 1000, 3)) | set(range(SPIKE[0] - 3, SPIKE[1] + 4)))
    rows = [int(np.searchsorted(frames, f)) for f in SPIKE]
    assert frames[rows].tolist() == list(SPIKE)
    # the page's poses are those frames' poses: the spike in the input, not in the cleaned take
    scale = unit_scale_cm(take.skeleton)
    for which, motion in (("original", spiked), ("cleaned", take)):
        ref = motion.global_positions(end_sites=True)[frames] * scale
        assert np.abs(decode_positions(data, which) - ref).max() <= data["pos"]["step"] / 2 + 1e-6
    hand = take.skeleton.index("lhand")
    moved = np.linalg.norm(decode_positions(data, "original")[rows, hand] - decode_positions(data, "cleaned")[rows, hand], axis=-1)
    assert moved.min() > 10  # cm
    # flags and changes sit on exactly those two shown frames; the channel plots have one row per shown frame
    bits = np.frombuffer(base64.b64decode(data["bits"]), dtype=np.uint8).reshape(data["n"], -1)
    assert np.argwhere(bits & 3).tolist() == [[r, j] for r in rows]
    plot = next(p for p in data["plots"] if p["joint"] == j)
    got = decode_i16(plot["original"], plot["lo"], plot["step"]).reshape(data["n"], len(plot["channels"]))
    cols = [spiked.channel_names().index(f"lhumerus.{c}") for c in plot["channels"]]
    np.testing.assert_allclose(got, spiked.channel_values()[frames][:, cols], atol=plot["step"] / 2 + 1e-6)


def test_review_spans_are_shown_whole_even_when_not_in_changed(tmp_path, walk):
    """A rejected change is not in ``changed`` any more, but the review list still jumps to it."""
    take = concatenate([walk] * 3)[:1000]
    review = {"changes": [{"id": "c1", "first": 700, "last": 701}], "decisions": {"decisions": {"c1": "reject"}},
              "flags": [{"first": 850, "last": 850}]}
    data = page_data(write_report(tmp_path / "r.html", take, take, max_frames=400, review=review))
    assert data["stride"] == 3 and data["detail"] == "full"
    assert frame_list(data).tolist() == sorted(set(range(0, 1000, 3)) | set(range(697, 705)) | set(range(847, 854)))


def test_shown_frames_rule_and_its_cap():
    from mocapkit.report.html import DETAIL_MARGIN, shown_frames

    F, J = 1000, 4
    assert DETAIL_MARGIN == 3
    frames, stride, detail = shown_frames(F, F, np.ones((F, J), bool))
    assert frames.tolist() == list(range(F)) and stride == 1 and detail == "all"
    frames, stride, detail = shown_frames(F, 100)
    assert frames.tolist() == list(range(0, F, 10)) + [F - 1] and stride == 10 and detail == "none"
    # a change and a flag: their frames and 3 either side
    ch, fl = np.zeros((F, J), bool), np.zeros((F, J), bool)
    ch[501:503, 1] = True
    fl[777, 2] = True
    frames, stride, detail = shown_frames(F, 100, fl, ch)
    assert detail == "full" and frames.tolist() == sorted(set(range(0, F, 10)) | {F - 1} | set(range(498, 506)) | set(range(774, 781)))
    # a take flagged all through: never more than 2 * max_frames frames; the tiers that fit, in order
    everything = np.ones((F, J), bool)
    frames, stride, detail = shown_frames(F, 100, everything, ch)
    assert len(frames) <= 200 and detail == "changes" and {501, 502} <= set(frames.tolist())
    frames, stride, detail = shown_frames(F, 100, None, everything)
    assert frames.tolist() == list(range(0, F, 10)) + [F - 1] and detail == "starts"  # the one run starts at 0
    # more runs than room: their first frames, evenly spread, up to the cap
    many = np.zeros((F, J), bool)
    many[1::2, 0] = True  # 500 one-frame runs
    frames, stride, detail = shown_frames(F, 100, many)
    assert detail == "some" and len(frames) == 200 and np.all(np.diff(frames) > 0) and frames[-1] == 999
    # the review list's jump targets are shown first of all
    frames, stride, detail = shown_frames(F, 100, everything, starts=[123, 457])
    assert {123, 457} <= set(frames.tolist()) and len(frames) <= 200


def long_take(walk, seconds=60.0):
    n = int(round(seconds * walk.fps))
    reps = -(-n // walk.num_frames)
    return concatenate([walk] * reps)[:n]


def test_cleaned_travels_as_patch_or_whole(tmp_path, walk, cleaned_walk):
    corrupted, repaired, det, changed = cleaned_walk
    few = page_data(write_report(tmp_path / "few.html", corrupted, repaired, changed=changed))
    assert "cleanedPatch" in few["pos"] and "cleaned" not in few["pos"]
    rot = np.array(walk.rotations)
    rot[:, 1:, 1] += 0.05  # every joint moved in every frame: a denoised take
    moved = dataclasses.replace(walk, rotations=rot / np.linalg.norm(rot, axis=-1, keepdims=True))
    many = page_data(write_report(tmp_path / "many.html", walk, moved))
    assert "cleaned" in many["pos"] and "cleanedPatch" not in many["pos"]
    ref = moved.global_positions(end_sites=True) * unit_scale_cm(walk.skeleton)
    assert np.abs(decode_positions(many, "cleaned") - ref).max() <= many["pos"]["step"] / 2 + 1e-6


def sixty_second_case(walk):
    """A 60 s take at 120 fps (12_walk looped) with 24 real-style errors, cleaned back to the take."""
    take = long_take(walk)
    corrupted, mask, _ = real_errors(take, n_errors=24, seed=1)
    mdm = np.clip(np.random.default_rng(0).random(mask.shape) ** 6 + 0.7 * mask, 0, 1)
    return corrupted, take, mdm, mdm > 0.5, mask


@pytest.fixture(scope="module")
def sixty_second_report(tmp_path_factory, walk):
    """The 60 s case and its report at the default settings (written once: 7,200 frames, two tests read it)."""
    corrupted, take, mdm, flags, changed = sixty_second_case(walk)
    out = write_report(tmp_path_factory.mktemp("sixty") / "long.html", corrupted, take, mdm=mdm, flags=flags,
                       changed=changed)
    return corrupted, take, out


def test_sixty_second_take_stays_a_few_megabytes(sixty_second_report):
    corrupted, take, out = sixty_second_report
    F = take.num_frames
    assert F == 7200 and F <= DEFAULT_MAX_FRAMES
    size_mb = out.stat().st_size / 1e6
    print(f"60 s at 120 fps: {size_mb:.2f} MB")
    data = page_data(out)
    assert data["stride"] == 1 and data["n"] == 7200  # full rate
    assert size_mb < 6.0
    # every frame of both motions is in the page (the cleaned one as a patch of the changed cells)
    scale = unit_scale_cm(take.skeleton)
    assert decode_positions(data, "original").shape[0] == 7200
    rows = np.array([0, 3599, 7199])
    np.testing.assert_allclose(decode_positions(data, "original")[rows],
                               corrupted.global_positions(end_sites=True)[rows] * scale, atol=data["pos"]["step"] / 2 + 1e-6)


# ---- the page in a real headless Chromium ----------------------------------------------------

@pytest.fixture(scope="module")
def browser():
    sync_api = pytest.importorskip("playwright.sync_api", reason="playwright is not installed (pip install -e '.[test]')")
    if not os.access(CHROMIUM, os.X_OK):
        pytest.skip(f"no Chromium executable at {CHROMIUM} (apt-get install chromium, or set MOCAPKIT_CHROMIUM)")
    with sync_api.sync_playwright() as p:
        b = p.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
        try:
            yield b
        finally:
            b.close()


class Page:
    """A report opened in a fresh page, with every console error and page error recorded."""

    def __init__(self, browser, path: Path):
        self.errors: list[str] = []
        self.warnings: list[str] = []
        self.requests: list[str] = []
        self.page = browser.new_page(viewport={"width": 1280, "height": 900})
        self.page.on("console", self._console)
        self.page.on("pageerror", lambda e: self.errors.append(f"pageerror: {e}"))
        self.page.on("request", lambda r: self.requests.append(r.url))
        self.load(path)

    def load(self, path: Path):
        """Open the report at ``path`` in this page (a new document: the last one's script state is gone) and wait
        until it has drawn."""
        self.page.goto(path.resolve().as_uri())
        # readiness, not speed: a generous limit so that a busy machine does not fail the test
        self.wait_for("() => window.mocapkitReport && window.mocapkitReport.drawCount() > 0")
        # warnings after this point may be the tests' own pixel readbacks (willReadFrequently)
        self.warnings_at_load = list(self.warnings)

    def _console(self, msg):
        if msg.type == "error":
            self.errors.append(f"console error: {msg.text}")
        elif msg.type == "warning":
            self.warnings.append(msg.text)

    def js(self, expr, arg=None):
        return self.page.evaluate(expr, arg)

    def next_frames(self):
        """Return after two animation frames: whatever an event scheduled for the next frame has been drawn."""
        self.page.evaluate("() => new Promise(done => requestAnimationFrame(() => requestAnimationFrame(done)))")

    def wait_for(self, condition: str, arg=None):
        """Wait until the JavaScript function ``condition(arg)`` returns true (a readiness signal; fails after 60 s)."""
        self.page.wait_for_function(condition, arg=arg, timeout=60000)

    def ink(self, canvas_id, rgb=None, region=None):
        """Pixels of a canvas that are not white (or, with rgb, close to that colour)."""
        return self.js("""([id, rgb, region]) => {
            const c = document.getElementById(id);
            const [x, y, w, h] = region || [0, 0, c.width, c.height];
            const d = c.getContext('2d').getImageData(x, y, w, h).data;
            let n = 0;
            for (let i = 0; i < d.length; i += 4) {
              if (rgb) { if (Math.abs(d[i]-rgb[0]) < 30 && Math.abs(d[i+1]-rgb[1]) < 30 && Math.abs(d[i+2]-rgb[2]) < 30) n++; }
              else if (d[i] < 235 || d[i+1] < 235 || d[i+2] < 235) n++;
            }
            return n; }""", [canvas_id, rgb, region])

    def close(self):
        self.page.close()


@pytest.fixture
def open_page(browser):
    pages = []

    def _open(path):
        pages.append(Page(browser, path))
        return pages[-1]

    yield _open
    for p in pages:
        p.close()


SEL = (0xF5, 0x9F, 0x00)
RED = (0xE0, 0x31, 0x31)


def test_page_loads_draws_and_plays(open_page, walk_report, cleaned_walk):
    pg = open_page(walk_report)
    assert pg.errors == [] and pg.warnings_at_load == []
    assert all(u.startswith("file://") for u in pg.requests), pg.requests
    w, h = pg.js("[document.getElementById('viewer').width, document.getElementById('viewer').height]")
    # side by side: both halves hold a figure (and the floor grid)
    assert pg.ink("viewer", region=[0, 0, w // 2, h]) > 500
    assert pg.ink("viewer", region=[w // 2, 0, w - w // 2, h]) > 500
    assert pg.ink("heatmap") > 10000
    assert pg.js("document.querySelectorAll('#plot-list canvas').length") == len(page_data(walk_report)["plots"]) > 0
    # a frame with a flagged joint shows red on the skeleton; a clean frame does not
    corrupted, repaired, det, changed = cleaned_walk
    flagged_frame = int(np.flatnonzero(det.flags.any(axis=1))[0])
    clean_frame = int(np.flatnonzero(~det.flags.any(axis=1))[0])
    pg.js(f"window.mocapkitReport.setFrame({clean_frame})")
    assert pg.ink("viewer", rgb=RED) == 0
    pg.js(f"window.mocapkitReport.setFrame({flagged_frame})")
    assert pg.ink("viewer", rgb=RED) > 20
    # playing draws new frames and moves the frame on
    pg.js("window.mocapkitReport.setFrame(0)")
    n0, f0 = pg.js("[window.mocapkitReport.drawCount(), window.mocapkitReport.frame()]")
    pg.page.click("#play")
    pg.wait_for("([n, f]) => window.mocapkitReport.drawCount() >= n + 5 && window.mocapkitReport.frame() > f", [n0, f0])
    n1, f1, playing = pg.js("[window.mocapkitReport.drawCount(), window.mocapkitReport.frame(), window.mocapkitReport.playing()]")
    assert playing and n1 >= n0 + 5 and f1 > f0
    pg.page.click("#play")
    assert not pg.js("window.mocapkitReport.playing()")
    # overlay mode: one viewport, the cleaned figure drawn over the input
    before = pg.js("document.getElementById('viewer').toDataURL()")
    pg.page.click("#mode")
    pg.next_frames()
    assert pg.js("window.mocapkitReport.overlay()") is True
    assert pg.js("document.getElementById('viewer').toDataURL()") != before
    assert pg.errors == []


def test_heatmap_click_jumps_to_frame_and_selects_joint(open_page, walk_report, cleaned_walk):
    corrupted, repaired, det, changed = cleaned_walk
    pg = open_page(walk_report)
    layout = pg.js("window.mocapkitReport.heatmapLayout()")
    assert layout["frames"] == corrupted.num_frames and layout["joints"] == corrupted.num_joints
    assert layout["width"] / layout["frames"] >= 1  # one cell is at least a pixel wide here
    assert pg.js("window.mocapkitReport.selectedJoint()") == -1
    assert pg.ink("viewer", rgb=SEL) == 0
    pg.page.locator("#heatmap").scroll_into_view_if_needed()
    box = pg.page.locator("#heatmap").bounding_box()
    # a flagged cell well inside the take
    fj = np.argwhere(det.flags)
    f, j = (int(v) for v in fj[len(fj) // 2])
    x = box["x"] + layout["left"] + (f + 0.5) * layout["width"] / layout["frames"]
    y = box["y"] + layout["top"] + (j + 0.5) * layout["rowHeight"]
    pg.page.mouse.click(x, y)
    pg.next_frames()
    assert pg.js("window.mocapkitReport.frame()") == f
    assert pg.js("window.mocapkitReport.selectedJoint()") == j
    assert pg.js("window.mocapkitReport.selectedJointName()") == corrupted.skeleton.joint_names[j]
    # the highlight shows in the viewer (a ring on the joint) and in the heat map (the row box)
    assert pg.ink("viewer", rgb=SEL) > 20
    assert pg.ink("heatmap", rgb=SEL) > 200
    assert pg.js("document.querySelector('#selected-plot .plot').dataset.joint") == corrupted.skeleton.joint_names[j]
    # another cell: another frame and joint
    f2, j2 = 10, 0
    pg.page.mouse.click(box["x"] + layout["left"] + (f2 + 0.5) * layout["width"] / layout["frames"],
                        box["y"] + layout["top"] + (j2 + 0.5) * layout["rowHeight"])
    assert pg.js("[window.mocapkitReport.frame(), window.mocapkitReport.selectedJoint()]") == [f2, j2]
    assert pg.errors == []


def test_slider_scrubs_and_mouse_orbits(open_page, walk_report, walk):
    pg = open_page(walk_report)
    slider = pg.page.locator("#scrub")
    slider.focus()
    pg.page.keyboard.press("End")
    assert pg.js("window.mocapkitReport.frame()") == walk.num_frames - 1
    pg.page.keyboard.press("Home")
    for _ in range(3):
        pg.page.keyboard.press("ArrowRight")
    assert pg.js("window.mocapkitReport.frame()") == 3
    box = slider.bounding_box()
    pg.page.mouse.click(box["x"] + box["width"] * 0.5, box["y"] + box["height"] / 2)
    mid = pg.js("window.mocapkitReport.frame()")
    assert abs(mid - (walk.num_frames - 1) / 2) < 0.05 * walk.num_frames
    # the label is rewritten on the next animation frame, not by the click itself: wait for that redraw
    from playwright.sync_api import expect  # present: the browser fixture skips without it

    expect(pg.page.locator("#frame-label")).to_contain_text(f"frame {mid} /", timeout=60000)  # a wait, as wait_for
    assert f"frame {mid} /" in pg.page.inner_text("#frame-label")
    # orbit by dragging and zoom by the wheel redraw the view differently
    vb = pg.page.locator("#viewer").bounding_box()
    shot0 = pg.js("document.getElementById('viewer').toDataURL()")
    n0 = pg.js("window.mocapkitReport.drawCount()")
    pg.page.mouse.move(vb["x"] + 200, vb["y"] + 200)
    pg.page.mouse.down()
    pg.page.mouse.move(vb["x"] + 320, vb["y"] + 230, steps=5)
    pg.page.mouse.up()
    pg.next_frames()
    shot1 = pg.js("document.getElementById('viewer').toDataURL()")
    assert shot1 != shot0 and pg.js("window.mocapkitReport.drawCount()") > n0
    pg.page.mouse.wheel(0, -400)
    pg.next_frames()
    assert pg.js("document.getElementById('viewer').toDataURL()") != shot1
    assert pg.errors == []


def test_gappy_and_downsampled_pages_work(open_page, tmp_path, walk):
    clip = walk[:200]
    gappy = with_nan(clip, slice(10, 60), clip.skeleton.index("lhumerus"))
    nan_page = write_report(tmp_path / "nan.html", gappy, clip, flags=gappy.missing())
    pg = open_page(nan_page)
    pg.js("window.mocapkitReport.setFrame(51)")  # root missing: the input half is empty
    w, h = pg.js("[document.getElementById('viewer').width, document.getElementById('viewer').height]")
    grid_only = pg.ink("viewer", region=[0, 0, w // 2, h])
    pg.js("window.mocapkitReport.setFrame(20)")  # one arm missing: the rest is drawn
    assert pg.ink("viewer", region=[0, 0, w // 2, h]) > grid_only + 200
    n0 = pg.js("window.mocapkitReport.drawCount()")
    pg.js("window.mocapkitReport.play()")
    pg.wait_for("n => window.mocapkitReport.drawCount() >= n + 5", n0)  # plays through the missing frames
    pg.js("window.mocapkitReport.pause()")
    assert pg.errors == []

    twenty = long_take(walk, 20.0)
    long_page = write_report(tmp_path / "long.html", twenty, twenty, max_frames=600)
    pg2 = open_page(long_page)
    note = pg2.page.inner_text("#downsample-note")
    assert "every 4th frame, the last one (601 of 2400)" in note
    pg2.js("window.mocapkitReport.setFrame(1001)")
    assert pg2.js("[window.mocapkitReport.index(), window.mocapkitReport.frame()]") == [250, 1000]
    assert pg2.errors == []


def test_sixty_second_page_loads_and_scrubs(open_page, sixty_second_report):
    corrupted, take, out = sixty_second_report
    pg = open_page(out)
    # the page decodes both motions as forward kinematics gives them (the cleaned one from its patch)
    scale = unit_scale_cm(take.skeleton)
    rows = [0, 1234, 5000, 7199]
    for which, motion in (("original", corrupted), ("cleaned", take)):
        ref = motion[rows[0]:rows[-1] + 1].global_positions()[np.array(rows) - rows[0]] * scale
        got = np.array([[pg.js(f"window.mocapkitReport.position('{which}', {f}, {j})") for j in range(0, 31, 5)]
                        for f in rows], dtype=float)
        assert np.abs(got - ref[:, 0:31:5]).max() < 0.06
    # scrubbing across the whole take redraws each frame asked for (how fast is benchmarks' business)
    n0 = pg.js("window.mocapkitReport.drawCount()")
    seen = pg.js("""() => { const r = window.mocapkitReport, out = [];
        for (let i = 0; i < 24; i++) { r.setIndex(i * 300); out.push([r.index(), r.frame()]); }
        return out; }""")
    assert seen == [[i * 300, i * 300] for i in range(24)]
    pg.next_frames()
    assert pg.js("window.mocapkitReport.drawCount()") > n0
    assert pg.errors == []


# ---- framing: any rig upright and whole ------------------------------------------------------

FIGURE_JS = """([head, foot]) => {
  // per panel (input left, cleaned right): bounding box of the figure's pixels (saturated colour:
  // the blue / green / red strokes; the grid and the labels are grey), and the centre of the
  // orange selection ring on the head, then on the foot, in the cleaned panel (no label there)
  const c = document.getElementById('viewer'), W = c.width, H = c.height, half = Math.round(W / 2);
  const R = window.mocapkitReport, panels = [[0, half - 1], [half + 1, W]];
  function scan() {
    const d = c.getContext('2d').getImageData(0, 0, W, H).data;
    return panels.map(([x0, x1]) => {
      const box = [Infinity, Infinity, -Infinity, -Infinity], ring = [0, 0, 0];
      for (let y = 0; y < H; y++) for (let x = x0; x < x1; x++) {
        const i = (y * W + x) * 4, r = d[i], g = d[i + 1], b = d[i + 2];
        if (r > 200 && g > 120 && g < 190 && b < 80) { ring[0] += x - x0; ring[1] += y; ring[2]++; continue; }
        if (Math.max(r, g, b) - Math.min(r, g, b) > 40) {
          box[0] = Math.min(box[0], x - x0); box[1] = Math.min(box[1], y);
          box[2] = Math.max(box[2], x - x0); box[3] = Math.max(box[3], y);
        }
      }
      return { box: box, ring: ring[2] ? [ring[0] / ring[2], ring[1] / ring[2]] : null, width: x1 - x0, height: H };
    });
  }
  R.select(-1);
  const figure = scan();
  R.select(head); const h = scan()[1].ring;
  R.select(foot); const f = scan()[1].ring;
  R.select(-1);
  return { panels: figure, head: h, foot: f };
}"""


def framing_takes():
    from tests.report.test_view import BANDAI, ZUP, turn_root_z_up

    walk = mocapkit.load(mocapkit.samples.path("12_walk.amc"))[:160]  # walks 1.1 m: framed, not followed
    return {
        "acclaim": walk,  # Y up, CMU units (:units length 0.45)
        "bandai": mocapkit.load(BANDAI),  # Y up, cm, rest pose lying along x, a floor reference joint
        "zup_file": mocapkit.load(ZUP),  # Z up, inches
        "zup_turned": turn_root_z_up(walk),  # Z up in the data, Y up in the rig's rest pose
    }


@pytest.mark.parametrize("name", ["acclaim", "bandai", "zup_file", "zup_turned"])
def test_page_data_stands_every_rig_up_in_centimetres(tmp_path, name):
    """Without a browser: the page's points are cm with the head above the feet; the framing travels with them."""
    from mocapkit.motion import find_joint
    from mocapkit.report.view import camera_distance

    take = framing_takes()[name]
    sk = take.skeleton
    data = page_data(write_report(tmp_path / "r.html", take, take))
    pos = decode_positions(data, "original")
    head, feet = find_joint(sk, "head"), [find_joint(sk, "left_foot"), find_joint(sk, "right_foot")]
    rise = pos[:, head, 1] - pos[:, feet, 1].mean(axis=1)
    assert np.all(rise > 100), rise.min()  # standing or stepping: the head over a metre above the feet
    assert 120 < np.ptp(pos[0, :, 1]) < 230  # a person, in centimetres, whatever the file's unit
    view = data["view"]
    names = data["names"]
    assert [names[p] for p in view["hidden"]] == (["joint_Root"] if name == "bandai" else [])
    for mode in ("fixed", "follow"):
        assert view["distance"][mode] == pytest.approx(camera_distance(view["radius"][mode]))
    track = np.frombuffer(base64.b64decode(view["track"]), dtype="<f4").reshape(-1, 2)
    assert track.shape == (data["n"], 2) and np.isfinite(track).all()
    # the caller's up axis is taken as given: Y-up data declared Z up lies on its back
    if name == "acclaim":
        lying = decode_positions(page_data(write_report(tmp_path / "z.html", take, take, up_axis="z")), "original")
        assert np.all(np.abs(lying[:, head, 1] - lying[:, feet, 1].mean(axis=1)) < 60)


@pytest.mark.parametrize("name", ["acclaim", "bandai", "zup_file", "zup_turned"])
def test_viewer_frames_any_rig_upright_and_whole(open_page, tmp_path, name):
    from mocapkit.motion import find_joint

    take = framing_takes()[name]
    sk = take.skeleton
    head, foot = sk.joint_names[find_joint(sk, "head")], sk.joint_names[find_joint(sk, "left_foot")]
    out = write_report(tmp_path / f"{name}.html", take, take, title=name)
    frames = np.unique(np.linspace(0, take.num_frames - 1, 8).round().astype(int))
    pg = None
    for width in (1280, 360):  # a wide window and a phone-narrow one (panels 611 x 540 and 151 x 280)
        if pg is None:
            pg = open_page(out)
        else:
            pg.load(out)  # loaded afresh at 1280 x 900, as a new tab opens it, then narrowed
        pg.page.set_viewport_size({"width": width, "height": 900})
        pg.next_frames()
        for f in frames:
            pg.js(f"window.mocapkitReport.setFrame({int(f)})")
            got = pg.js(FIGURE_JS, [head, foot])
            for side, p in zip(("input", "cleaned"), got["panels"]):
                x0, y0, x1, y1 = p["box"]
                where = f"{name}, {width} px window, frame {f}, {side} panel {p['width']}x{p['height']}: box {p['box']}"
                assert x1 > x0 and y1 > y0, f"no figure drawn: {where}"
                # whole: every figure pixel lies inside the panel, clear of its edges
                m = max(2, 0.01 * min(p["width"], p["height"]))
                assert x0 >= m and y0 >= m and x1 <= p["width"] - 1 - m and y1 <= p["height"] - 1 - m, where
                # upright: a standing or stepping figure is taller than wide, and not a speck
                assert y1 - y0 > x1 - x0, where
                assert y1 - y0 > 0.3 * min(p["width"], p["height"]), where
            # the head is drawn above the feet, by a good part of the figure's height
            assert got["head"] and got["foot"], f"{name} frame {f}: no selection ring found"
            box = got["panels"][1]["box"]
            assert got["foot"][1] - got["head"][1] > 0.5 * (box[3] - box[1]), (name, width, f, got)
        assert pg.errors == []


# ---- long takes in the browser: every frame of a change, at its own frame number ---------------

RING_JS = """() => {
  // centre of the orange selection ring in each panel (input left, cleaned right), relative to the
  // panel, above the "selected: ..." label at the bottom of the input panel
  const c = document.getElementById('viewer'), W = c.width, H = c.height, half = Math.round(W / 2);
  const d = c.getContext('2d').getImageData(0, 0, W, H).data;
  return [[0, half - 1], [half + 1, W]].map(([x0, x1]) => {
    let sx = 0, sy = 0, n = 0;
    for (let y = 0; y < H - 26; y++) for (let x = x0; x < x1; x++) {
      const i = (y * W + x) * 4;
      if (d[i] > 200 && d[i + 1] > 120 && d[i + 1] < 190 && d[i + 2] < 80) { sx += x - (x0 ? half : 0); sy += y; n++; }
    }
    return n ? [sx / n, sy / n] : null;
  });
}"""


def test_long_take_page_jumps_to_and_draws_the_changed_frames(open_page, spiked_report):
    spiked, take, _, out = spiked_report
    data = page_data(out)
    shown = frame_list(data).tolist()
    pg = open_page(out)
    api = "window.mocapkitReport"
    assert pg.js(f"{api}.shownFrames()") == shown
    assert pg.js(f"{api}.info.shown") == data["n"] and pg.js(f"{api}.heatmapLayout().frames") == 1000
    note = pg.page.inner_text("#downsample-note")
    assert f"every 3rd frame, the last one and every frame of each change and flag, with 3 frames either side ({data['n']} of 1000)" in note
    # each frame of the change is shown as itself, at its own frame number
    hand = take.skeleton.index("lhand")
    scale = unit_scale_cm(take.skeleton)
    for f in SPIKE:
        pg.js(f"{api}.setFrame({f})")
        assert pg.js(f"{api}.frame()") == f and pg.js(f"{api}.index()") == shown.index(f)
        assert pg.page.inner_text("#frame-label").startswith(f"frame {f} / 999")
        for which, motion in (("original", spiked), ("cleaned", take)):
            got = np.array(pg.js(f"{api}.position('{which}', {f}, {hand})"), dtype=float)
            want = motion[f].global_positions()[0, hand] * scale
            assert np.abs(got - want).max() < 0.06, (which, f)
    # a frame that is not shown lands on the shown one before it
    pg.js(f"{api}.setFrame(511)")
    assert pg.js(f"{api}.frame()") == 510
    # the drawn pose: with the hand selected, its ring sits apart in the two panels on the spike, together elsewhere
    pg.js(f"{api}.select({hand})")
    for f in (SPIKE[0] - 3, SPIKE[0], SPIKE[1], SPIKE[1] + 3):
        pg.js(f"{api}.setFrame({f})")
        left, right = pg.js(RING_JS)
        assert left and right, f
        apart = float(np.hypot(left[0] - right[0], left[1] - right[1]))
        if f in SPIKE:
            assert apart > 8, (f, left, right)
        else:
            assert apart < 1.5, (f, left, right)
    # the arrow keys step through the shown frames: one by one across the change
    pg.js(f"document.activeElement && document.activeElement.blur(); {api}.setFrame(496)")
    seen = []
    for _ in range(12):
        pg.page.keyboard.press("ArrowRight")
        seen.append(pg.js(f"{api}.frame()"))
    assert seen == [498] + list(range(499, 507)) + [507, 510, 513]
    assert pg.errors == []


def test_long_take_plays_the_change_at_every_frame(open_page, spiked_report):
    spiked, take, _, out = spiked_report
    shown = set(frame_list(page_data(out)).tolist())
    pg = open_page(out)
    pg.page.select_option("#speed", "0.1")  # 12 take frames a second
    # the page's animation frames driven by hand, 20 ms apart: the same steps on a fast or a busy machine
    seen = pg.js("""() => {
        const r = window.mocapkitReport, seen = [], queue = [];
        const real = window.requestAnimationFrame;
        window.requestAnimationFrame = cb => { queue.push(cb); return queue.length; };
        r.setFrame(496); r.play();
        for (let t = 0; t <= 1500; t += 20) {
          const due = queue.splice(0);
          due.forEach(cb => cb(t));
          seen.push(r.frame());
        }
        r.pause();
        window.requestAnimationFrame = real;
        return seen;
    }""")
    assert seen[0] <= 496 and seen == sorted(seen) and 510 <= seen[-1] < 520, seen  # forwards, at the take's rate
    assert set(seen) <= shown
    # every frame of the change and its margins in turn, the rest at the stride
    assert set(range(499, 507)) <= set(seen), seen
    assert all(f % 3 == 0 for f in seen if not 499 <= f <= 506), seen
    assert pg.errors == []


def test_downsample_note_says_the_ordinal_right(open_page, tmp_path, walk):
    F, J = walk.num_frames, walk.num_joints
    flags = np.zeros((F, J), bool)
    flags[100, 5] = True
    for stride, word in [(2, "2nd"), (3, "3rd"), (4, "4th"), (11, "11th"), (12, "12th"), (13, "13th"),
                         (21, "21st"), (22, "22nd"), (23, "23rd")]:
        max_frames = -(-F // stride)
        assert -(-F // max_frames) == stride
        out = write_report(tmp_path / f"r{stride}.html", walk, walk, flags=flags, max_frames=max_frames)
        n = page_data(out)["n"]
        if stride == 2:
            pg = open_page(out)
        else:
            pg.load(out)  # the next report in the same tab: one renderer, not nine
        note = pg.page.inner_text("#downsample-note")
        assert f"shows every {word} frame, the last one and every frame of each change and flag, with 3 frames either side ({n} of {F})" in note
        assert pg.errors == []


def test_short_take_shows_every_frame_without_a_frame_list(open_page, tmp_path, walk, cleaned_walk):
    corrupted, repaired, det, changed = cleaned_walk
    F = corrupted.num_frames
    out = write_report(tmp_path / "r.html", corrupted, repaired, flags=det.flags, changed=changed, max_frames=F)
    data = page_data(out)
    assert data["frameList"] is None and data["detail"] == "all"
    assert data["n"] == data["frames"] == F and data["stride"] == 1
    pg = open_page(out)
    assert pg.js("window.mocapkitReport.shownFrames()") == list(range(F))
    assert pg.page.locator("#downsample-note").count() == 0
    for f in (0, 1, 171, F - 1):
        pg.js(f"window.mocapkitReport.setFrame({f})")
        assert pg.js("[window.mocapkitReport.index(), window.mocapkitReport.frame()]") == [f, f]
    assert pg.errors == []


def test_shown_frames_of_a_take_shorter_than_its_margins():
    """A take of fewer frames than the margin window (2 * margin + 1) crashed the margin tier (np.convolve 'same')."""
    f = np.zeros(5, bool)
    f[2] = True
    frames, stride, detail = shown_frames(5, 2, f)
    assert stride == 3 and 2 in frames and len(frames) <= 4
    f = np.zeros(150, bool)
    f[70] = True
    frames, _, detail = shown_frames(150, 100, f, margin=100)
    assert detail == "full" and frames.tolist() == list(range(150))  # every frame within 100 of frame 70


def test_joints_not_analysed_are_striped_and_named_not_drawn_as_mdm_0(open_page, tmp_path, cleaned_walk):
    """/tmp/trial19 R3: a joint detection did not analyse has MDM 0, and the heat map drew it as dark as a joint
    checked and found clean. With ``analysed`` the page names those joints and stripes their rows grey."""
    corrupted, repaired, det, changed = cleaned_walk
    assert not det.analysed.all()
    out = write_report(tmp_path / "r.html", corrupted, repaired, mdm=det.mdm, flags=det.flags, changed=changed,
                       analysed=det.analysed)
    names = corrupted.skeleton.joint_names
    skipped = [int(j) for j in np.flatnonzero(~det.analysed)]
    assert page_data(out)["notAnalysed"] == skipped
    pg = open_page(out)
    assert pg.errors == []
    summary = pg.js("document.getElementById('summary').textContent")
    assert f"{len(skipped)} joints not analysed by detection ({', '.join(names[j] for j in skipped)})" in summary
    lay = pg.js("window.mocapkitReport.heatmapLayout()")
    dpr = pg.js("window.devicePixelRatio || 1")

    def row(j, rgb):
        y = int((lay["top"] + (j + 0.5) * lay["rowHeight"]) * dpr)
        return pg.ink("heatmap", rgb=rgb, region=[int(lay["left"] * dpr) + 2, y, int(lay["width"] * dpr) - 4, 1])

    dark = (68, 1, 84)  # the ramp's 0: what an unanalysed row was drawn in
    j, k = skipped[0], int(np.flatnonzero(det.analysed & ~det.flags.any(axis=0) & ~changed.any(axis=0))[1])
    assert row(j, dark) == 0 and row(j, (173, 181, 189)) > 20 and row(j, (222, 226, 230)) > 20
    assert row(k, dark) > 20 and row(k, (173, 181, 189)) == 0  # an analysed joint keeps its colours


def test_a_clean_report_says_the_licence_of_the_non_commercial_model_it_used(tmp_path):
    # the trial: `clean --report` on a Bandai Namco take said nothing of the CC BY-NC 4.0 licence of the shipped
    # Bandai EBF that denoised it, though the console and the record said it: the page is what gets passed on
    from mocapkit.report.html import write_clean_report

    take = Path(__file__).resolve().parents[1] / "data" / "dataset-1_dash_normal_001.bvh"
    from mocapkit.corrupt import angular_noise

    original, _ = angular_noise(mocapkit.load(take), 0.5, seed=0)
    res = mocapkit.clean(original, steps="denoise")
    page = write_clean_report(tmp_path / "r.html", original, res, inp=take).read_text()
    header = page[page.index("<header>"):page.index("</header>")]
    assert "warning:" in header and "CC BY-NC 4.0" in header and "non-commercial use only" in header
    assert any("CC BY-NC 4.0" in w for w in res.warnings)  # the lines `clean` prints as warnings


def test_the_summary_counts_in_the_terminal_s_words_singular_for_one(open_page, tmp_path, cleaned_walk):
    """The header said "44 flagged cells in 1 joints (RThumb)" (a user trial, CMU 131_03): "cells" where the
    terminal and `info` say "joint samples", and "1 joints". One flagged and changed sample reads in the singular."""
    corrupted, repaired, det, _ = cleaned_walk
    flags = np.zeros_like(det.flags)
    flags[10, 5] = True
    changed = np.zeros_like(flags)
    changed[10, 5] = True
    out = write_report(tmp_path / "one.html", corrupted, repaired, mdm=det.mdm, flags=flags, changed=changed)
    pg = open_page(out)
    assert pg.errors == []
    summary = pg.js("document.getElementById('summary').textContent")
    name = corrupted.skeleton.joint_names[5]
    assert f"1 flagged joint sample in 1 joint ({name})" in summary and "1 joint sample changed by the cleaning" in summary
    assert " cells" not in summary, summary
