"""The cleaning summary figure: one PNG drawn on one figure's axes, written atomically."""

import pytest

import mocapkit
from mocapkit import corrupt
from mocapkit.cleaning.pipeline import clean
from mocapkit.report.summary import plot_summary


@pytest.fixture(scope="module")
def cleaned():
    walk = mocapkit.load(mocapkit.samples.path("131_01.bvh"))[:400]
    bad, _, _ = corrupt.real_errors(walk, kinds=("flip",), n_errors=1, seed=2)
    return bad, clean(bad, steps="detect,repair")


def test_plot_summary_writes_one_png(cleaned, tmp_path, monkeypatch):
    import matplotlib.image

    bad, res = cleaned
    monkeypatch.setattr(matplotlib.image, "imread", lambda *a, **k: pytest.fail("no image is read back"))
    p = plot_summary(res, bad, tmp_path / "summary.png", title="walk")
    data = p.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 20_000
    assert list(tmp_path.iterdir()) == [p]  # no temporary images, no partial file left


def test_plot_summary_needs_the_cleaned_motion(cleaned, tmp_path):
    import dataclasses

    bad, res = cleaned
    with pytest.raises(ValueError, match="cleaned motion"):
        plot_summary(dataclasses.replace(res, motion=None), bad, tmp_path / "s.png")
    assert not list(tmp_path.iterdir())


def test_plot_summary_names_and_shades_a_calibration_pose(tmp_path, monkeypatch):
    """CMU 01_01's converter T-pose (frame 0): named in the map's title, its frames shaded."""
    from pathlib import Path

    import matplotlib.axes

    take = mocapkit.load(Path(__file__).resolve().parents[1] / "data" / "cmu_01_01_start.bvh")
    res = clean(take, steps="detect,repair")
    titles, spans = [], []
    real_title, real_span = matplotlib.axes.Axes.set_title, matplotlib.axes.Axes.axvspan
    monkeypatch.setattr(matplotlib.axes.Axes, "set_title", lambda self, t, *a, **k: titles.append(t) or real_title(self, t, *a, **k))
    monkeypatch.setattr(matplotlib.axes.Axes, "axvspan", lambda self, x0, x1, *a, **k: spans.append((x0, x1)) or real_span(self, x0, x1, *a, **k))
    plot_summary(res, take, tmp_path / "s.png", title="01_01")
    assert titles[0] == "01_01: movement digression map (frame 0: calibration T-pose, left alone)"
    assert spans == [(-0.5, 0.5)]
