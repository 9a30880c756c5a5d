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
