"""The guides' Python examples run as written, on bundled takes standing in for the files they name.

README.md's examples run in tests/test_readme.py. A guide's example names a user's own files (``take.bvh``,
``take.c3d``): each test here writes a bundled take under that name into an empty folder, runs the page's
``python`` blocks in order in one namespace (a later block uses what an earlier one made, as a reader does), and
checks what the page says they give. Examples too slow for the suite (reconstruction's database builds, the deep
models' inference) are run by hand in docs trials; these are the ones a change of an API breaks first.
"""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import numpy as np
import pytest

import mocapkit
from mocapkit import corrupt, samples

GUIDE = Path(__file__).resolve().parents[1] / "docs" / "guide"


def _blocks(page: str) -> list[str]:
    """The ``python`` blocks of docs/guide/PAGE, in order."""
    blocks = re.findall(r"```python\n(.*?)```", (GUIDE / page).read_text(), flags=re.S)
    assert blocks, f"{page} has no python example"
    return blocks


def _run(block: str, page: str, scope: dict) -> dict:
    exec(compile(block, page, "exec"), scope)
    return scope


def test_cleaning_guide_examples_clean_decide_and_apply(tmp_path, monkeypatch, capsys):
    """cleaning.md: clean a take and keep its record; write decisions rejecting a change with those tied to it;
    apply them from Python (the page's parts, then mocapkit.clean with decisions= and record=)."""
    monkeypatch.chdir(tmp_path)
    walk = mocapkit.load(samples.path("12_walk.amc"))[:160]  # 1.3 s of the walk: the test's cost
    broken, _, _ = corrupt.real_errors(walk, seed=1)
    mocapkit.save(broken, "take.bvh")  # a BVH take with capture errors, as the page's take.bvh
    first, template, report, parts = _blocks("cleaning.md")
    scope = _run(first, "cleaning.md", {})
    assert re.search(r"^repair \(", capsys.readouterr().out, flags=re.M)  # the summary printed
    assert Path("take_clean.clean.npz").is_file() and Path("take_clean.bvh").read_bytes() != Path("take.bvh").read_bytes()
    scope = _run(template, "cleaning.md", {})
    rejected = [cid for cid, choice in scope["doc"]["decisions"].items() if choice == "reject"]
    assert rejected and set(rejected) == set(scope["tied"])
    shutil.copy("decisions.json", "take.decisions.json")  # as the report's "Download decisions" names it
    original = mocapkit.load("take.bvh")
    scope = _run(parts, "cleaning.md", {"result": scope["result"], "original": original})
    change = scope["found"][0]
    assert isinstance(scope["take"], mocapkit.Motion)
    assert np.array_equal(scope["take"].rotations[change.first:change.last + 1, original.skeleton.index(change.joint)],
                          original.rotations[change.first:change.last + 1, original.skeleton.index(change.joint)])
    scope = _run(report, "cleaning.md", {})
    assert Path("take.html").is_file()
    res = scope["res"]
    assert res.decided is not None and any(line.startswith("rejected ") for line in res.summary())
    kept = mocapkit.load("take_clean.bvh")
    for cid in rejected:  # a rejected change's cells are the input's, an accepted one's the cleaning's
        _, joint, frames = cid.split(":")
        a, b = map(int, frames.split("-"))
        j = original.skeleton.index(joint)
        assert np.array_equal(res.motion.rotations[a:b + 1, j], original.rotations[a:b + 1, j])
    assert not np.array_equal(res.motion.rotations, original.rotations)
    assert kept.num_frames == res.motion.num_frames


def test_markers_guide_examples_read_write_and_clean(tmp_path, monkeypatch):
    """markers.md: read a C3D, write it back (like itself and like another file), read it with zeros as gaps,
    clean it; the shapes and kinds the page's comments give."""
    monkeypatch.chdir(tmp_path)
    shutil.copy(samples.path("Eb015pr.c3d"), "other.c3d")
    from mocapkit.io import load_markers, save_markers

    capture = load_markers(Path(__file__).parent / "data" / "85_02.c3d")[:160]  # 1.3 s of a CMU capture
    save_markers(capture.select(capture.labels[:18]), "take.c3d")  # the pelvis and legs: the test's cost
    ms = load_markers("take.c3d")
    positions = ms.positions.copy()
    positions[60:80, 5] = np.nan  # a gap for clean to fill
    positions[120, 7] += 80.0  # and a spike
    read, zeros, cleaning, review = _blocks("markers.md")
    scope = _run(read, "markers.md", {"new_positions": positions})
    m = scope["markers"]
    f, n = m.positions.shape[:2]
    assert m.positions.shape == (f, n, 3) and m.missing().shape == (f, n) and m.missing().dtype == bool
    assert m.residuals.shape == (f, n) and m.cameras.shape == (f, n) and m.unit_cm == 0.1
    written = load_markers("take_clean.c3d")
    assert np.allclose(written.positions, positions, atol=1e-3, equal_nan=True) and written.labels == m.labels  # float32
    _run(zeros, "markers.md", {"load_markers": load_markers})
    save_markers(scope["cleaned"], "take.c3d", overwrite=True)  # the capture with its gap and spike, for the cleaning example
    scope = _run(cleaning, "markers.md", {})
    res = scope["res"]
    kinds = {fix.kind for fix in res.fixes}
    assert {"gap", "spike"} <= kinds
    assert res.filled.shape == (f, n) and res.filled[60:80, 5].all() and res.spikes[120, 7]
    assert not res.markers.missing()[60:80, 5].any()
    import json

    from mocapkit.cleaning.markers import decisions as mdec

    res.save("take_clean.clean.npz")  # the record, and decisions rejecting the spike's removal (as a person would)
    given = load_markers("take.c3d")
    found = mdec.changes(given, res.markers, res.fixes)
    doc = mdec.template(given, found, take="take.c3d", output="take_clean.c3d", record="take_clean.clean.npz")
    spike = next(c.id for c in found if c.id.startswith("spike:"))
    doc["decisions"][spike] = "reject"
    Path("take.decisions.json").write_text(json.dumps(doc))
    scope = _run(review, "markers.md", {})
    decided = scope["res"]
    assert np.array_equal(decided.markers.positions[120, 7], given.positions[120, 7])  # the spike as recorded
    assert not decided.markers.missing()[60:80, 5].any()  # the gap filled
    assert any(line.startswith(f"rejected {spike}") for line in decided.summary())


def test_databases_guide_example_builds_opens_and_searches(tmp_path, monkeypatch, capsys):
    """databases-and-search.md: build, save and open a database; the other sneak take ranks first."""
    monkeypatch.chdir(tmp_path)
    (example,) = _blocks("databases-and-search.md")
    with pytest.warns(UserWarning, match="matches asked for"):  # the page's query finds 2 of the 3 asked for
        scope = _run(example, "databases-and-search.md", {})
    first = capsys.readouterr().out.splitlines()[0]
    assert first.startswith("HDM_bk_sneak2StepsLStart_005_120 "), first
    assert scope["dist"].shape == scope["idx"].shape == (4, 16)


def test_deep_models_guide_example_denoises_fills_and_streams(tmp_path, monkeypatch, capsys):
    """deep-models.md: the shipped EBF lowers Mall's 0.5 noise, the EBD fills every gap, and the live denoiser
    gives the offline rows (None for its first ``lag`` pushes, then every frame once)."""
    monkeypatch.chdir(tmp_path)
    (example,) = _blocks("deep-models.md")
    scope = _run(example, "deep-models.md", {})
    noisy_deg, clean_deg = map(float, capsys.readouterr().out.split())
    assert clean_deg < 0.5 * noisy_deg
    assert not scope["filled"].missing().any() and scope["gappy"].missing().any()
    rows, walk = scope["rows"], scope["walk"]
    held = min(scope["stream"].lag, walk.num_frames)
    assert all(r is None for r in rows[:held]) and len(rows) == walk.num_frames + held
    offline = scope["deep"].denoise_rows(walk.skeleton, scope["noisy"].channel_values(), walk.fps)
    assert np.allclose(np.array(rows[held:]), offline, atol=1e-4)


def test_every_code_block_of_the_docs_names_its_language_and_python_ones_parse():
    """A block opened by a bare ``` (reconstruction.md's multilinear example, deep-models.md's console lines) showed
    untagged: no highlighting, and no test could tell a Python example from a console line. Every fence of README.md
    and docs/ names its language (``python``, ``sh``, ``text``, ``json``), and every ``python`` block is Python."""
    import ast

    root = GUIDE.parents[1]
    pages = [root / "README.md", *sorted((root / "docs").rglob("*.md"))]
    untagged, broken = [], []
    for page in pages:
        inside = False
        for k, line in enumerate(page.read_text().splitlines(), 1):
            fence = re.match(r"\s*(```+|~~~+)(.*)$", line)
            if fence and not inside and not fence.group(2).strip():
                untagged.append(f"{page.relative_to(root)}:{k}")
            inside = inside != bool(fence)
        for block in re.findall(r"```python\n(.*?)```", page.read_text(), flags=re.S):
            try:
                ast.parse(block)
            except SyntaxError as exc:
                broken.append(f"{page.relative_to(root)}: {exc}")
    assert not untagged and not broken, untagged + broken
