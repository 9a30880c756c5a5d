"""EBF inference only where its output is used: the same numbers as a run on the whole take."""


import numpy as np
import pytest

import mocapkit
from mocapkit import corrupt
from mocapkit.cleaning import deep
from mocapkit.cleaning.deep import inference
from mocapkit.cleaning.deep.channels import encode


@pytest.fixture(scope="module")
def noisy():
    walk = mocapkit.load(mocapkit.samples.path("12_walk.amc"))
    out, _ = corrupt.angular_noise(walk, amount=0.5, seed=4, joints=["lfemur", "rhumerus"])
    return out


@pytest.mark.parametrize("fps", [None, 60.0])  # at the model's rate, and resampled to it and back
def test_denoise_channels_until_equals_the_whole_take(noisy, fps):
    ebf = deep.shipped_model("ebf")
    take = noisy if fps is None else noisy.resample(fps)
    values, ctx = encode(take, ebf.layout)
    values[40:45, 3] = np.nan  # a gap, lerp-filled for the network
    missing = np.zeros(values.shape, dtype=bool)
    missing[100:110, 5] = True
    whole = inference.denoise_channels(values, ctx, ebf, fps=take.fps, missing=missing)
    for until in (1, 37, len(values) // 2, len(values) - 16, len(values)):
        part = inference.denoise_channels(values, ctx, ebf, fps=take.fps, missing=missing, until=until)
        assert np.array_equal(part[:until], whole[:until], equal_nan=True), until
        assert np.isnan(part[until:]).all()


def test_denoise_cells_equals_the_whole_take_on_those_cells(noisy):
    """The network's own output (``guard=False``: the guard judges each run by its own cells' noise)."""
    ebf = deep.shipped_model("ebf")
    cells = np.zeros(noisy.missing().shape, dtype=bool)
    j = noisy.skeleton.index("lfemur")
    cells[120:200, j] = True
    part = deep.denoise(noisy, ebf, cells=cells, guard=False)
    whole = deep.denoise(noisy, ebf, guard=False)
    assert np.array_equal(part.rotations[cells], whole.rotations[cells])
    assert np.array_equal(part.rotations[~cells], noisy.rotations[~cells])  # the other cells untouched
    assert deep.denoise(noisy, ebf, cells=np.zeros_like(cells), guard=False) is noisy
    with pytest.raises(ValueError, match="cells"):
        deep.denoise(noisy, ebf, cells=cells[:10], guard=False)


def test_clean_reads_each_model_file_once_until_it_changes(tmp_path, monkeypatch):
    """``mocapkit clean --ebf F --ebd G`` checked the files, then fill and denoise read them again (4 reads of the
    EBF, 3 of the EBD); each is read once per process, and again only once the file is written over."""
    import os
    import shutil
    from pathlib import Path

    import torch

    from mocapkit import samples
    from mocapkit.cli import main

    models = Path(inference.__file__).parents[2] / "models"
    ebf, ebd = shutil.copy(models / "ebf.pt", tmp_path), shutil.copy(models / "ebd.pt", tmp_path)
    reads, real = [], torch.load
    monkeypatch.setattr(torch, "load", lambda f, *a, **k: (reads.append(Path(f).resolve()), real(f, *a, **k))[1])
    take = corrupt.gaps(mocapkit.load(samples.path("131_01.bvh")), seed=1)[0]
    take = corrupt.angular_noise(take, amount=3, seed=2)[0]
    inp = mocapkit.save(take, tmp_path / "take.npz")
    assert main(["clean", str(inp), "-o", str(tmp_path / "o.npz"), "--steps", "fill,denoise",
                 "--ebf", str(ebf), "--ebd", str(ebd)]) == 0
    mine = sorted(p.name for p in reads if p.parent == tmp_path.resolve())
    assert mine == ["ebd.pt", "ebf.pt"], mine
    n = len(reads)
    assert deep.load_model(ebf) is deep.load_model(ebf) and len(reads) == n  # the same model, no read
    st = os.stat(ebf)
    os.utime(ebf, ns=(st.st_atime_ns, st.st_mtime_ns + 10**9))  # written over: read again, once
    again = deep.load_model(ebf)
    assert len(reads) == n + 1 and deep.load_model(ebf) is again
    assert not any(p.requires_grad for p in again.net.parameters())
