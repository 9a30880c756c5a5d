"""What ``info`` and ``clean-batch`` say of marker files before any cleaning (trial T3: findings 7 and 9)."""

from __future__ import annotations

import shutil

from mocapkit.io import load_markers, save_markers

from .helpers import one_error_line, run


def test_info_prints_the_readers_notes_of_a_marker_file(tmp_path):
    """Finding 7: ``info`` gave a repeated label's in-memory name (``_2``) without the note that says where it comes
    from, which clean and convert print."""
    import mocapkit

    ms = load_markers(mocapkit.samples.path("Eb015pr.c3d"))[:5]
    save_markers(ms, tmp_path / "a.trc")
    text = (tmp_path / "a.trc").read_text()
    first, second = ms.labels[0], ms.labels[1]
    lines = text.split("\n")
    k = next(i for i, ln in enumerate(lines) if f"\t{second}\t" in ln)
    lines[k] = lines[k].replace(f"\t{second}\t", f"\t{first}\t", 1)
    (tmp_path / "rep.trc").write_text("\n".join(lines))
    notes = load_markers(tmp_path / "rep.trc").notes
    assert notes, "the reader says it renamed a repeated label"
    code, stdout, stderr = run("info", tmp_path / "rep.trc")
    assert code == 0, stderr
    for note in notes:
        assert f"note: {tmp_path / 'rep.trc'}: {note}" in stdout, stdout


def test_clean_batch_names_every_output_in_the_way_at_once(tmp_path):
    """Finding 9: the refusal named only the first existing output; the user fixed it, ran again and met the next."""
    import mocapkit

    (tmp_path / "in").mkdir()
    (tmp_path / "out").mkdir()
    for name in ("G.c3d", "T.c3d"):
        shutil.copy(mocapkit.samples.path("Eb015pr.c3d"), tmp_path / "in" / name)
    (tmp_path / "out" / "T.c3d").write_text("mine")
    (tmp_path / "out" / "G.report.html").write_text("mine")
    code, stdout, stderr = run("clean-batch", tmp_path / "in", tmp_path / "out", "--jobs", "1", "--report")
    assert code == 2 and one_error_line(stderr), stdout + stderr
    error = stderr.strip().splitlines()[-1]
    assert str(tmp_path / "out" / "T.c3d") in error and str(tmp_path / "out" / "G.report.html") in error, error
    assert "already exists; pass --overwrite to replace it, and " in error and "which exists too" in error, error
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["G.report.html", "T.c3d"]
