"""cleaning.deep.layouts: the shipped networks' layouts kept as JSON beside them, so `mocapkit info` needs no torch."""

import json
import subprocess
import sys
from importlib import resources
from pathlib import Path

import numpy as np
import pytest

import mocapkit
from mocapkit import samples
from mocapkit.cleaning import deep
from mocapkit.cleaning.deep import layouts
from mocapkit.motion import Skeleton
from tests.shared import PYBVH, motionbuilder_spelling, unknown_rig, unnamed

BANDAI = Path(__file__).resolve().parents[1] / "data" / "dataset-1_dash_normal_001.bvh"


@pytest.mark.parametrize("name", [n for kind in layouts.SHIPPED for n in layouts.shipped_names(kind)])
def test_each_shipped_layout_json_is_what_its_model_holds(name):
    """The JSON beside each shipped .pt is what write_layout writes for the model in the .pt: a model
    installed without its layout, or with another's, fails here."""
    folder = resources.files("mocapkit") / "models"
    card = json.loads((folder / Path(name).with_suffix(layouts.LAYOUT_SUFFIX).name).read_text(encoding="utf-8"))
    assert card == layouts.layout_card(deep.load_model(name))


def test_a_layout_written_reads_back_as_its_model(tmp_path):
    model = deep.load_model("ebf_bandai.pt")
    path = layouts.write_layout(model, tmp_path / "m.pt")
    assert path == tmp_path / "m.layout.json"
    back = layouts.read_layout(path)
    assert back.layout == model.layout and back.kind == "ebf" and back.fps == model.fps
    assert np.array_equal(back.net.std, model.net.std.double().numpy())
    assert np.array_equal(back.net.mean, model.net.mean.double().numpy())
    path.write_text("{}")
    with pytest.raises(mocapkit.errors.MocapFormatError, match="m.layout.json: malformed model layout"):
        layouts.read_layout(path)


def test_the_layouts_answer_as_the_networks_do(tmp_path):
    """served_by with shipped_layout says what it says with shipped_model, on an ASF take (direct), the CMU BVH
    spelling (joint map), a rig of no known names (its tree), the Bandai rig (its own model), a rig read no way
    and one too small to map (the same reasons, word for word)."""
    walk = mocapkit.load(samples.path("12_walk.amc"))[:60]
    takes = [walk, motionbuilder_spelling(walk), unnamed(motionbuilder_spelling(walk)), mocapkit.load(BANDAI)[:30],
             unknown_rig(tmp_path / "unknown.bvh"), Skeleton(("a", "b", "c"), np.array([-1, 0, 1]), np.ones((3, 3)))]
    for take in takes:
        for kind in layouts.SHIPPED:
            net, lay = deep.shipped_model(kind, take), layouts.shipped_layout(kind, take)
            assert Path(lay.source).name == Path(net.source).with_suffix(layouts.LAYOUT_SUFFIX).name
            a, b = deep.served_by(take, net), deep.served_by(take, lay)
            if isinstance(a, str):
                assert a == b
            else:
                assert (a.family, a.direct, a.joints, a.shares) == (b.family, b.direct, b.joints, b.shares)


def test_info_on_a_rig_of_no_known_family_does_not_import_torch(tmp_path):
    """`mocapkit info` read the shipped networks' layout from their .pt files (importing torch, 2.5-3 s) to say
    whether they serve a rig of no known family; it reads the JSON beside them now."""
    take = unnamed(mocapkit.load(PYBVH))
    mocapkit.save(take, tmp_path / "x.bvh")
    code = ("import sys; from mocapkit.cli import main\n"
            "try:\n    main(['info', sys.argv[1]])\nexcept SystemExit as e:\n    assert not e.code, e.code\n"
            "print('torch' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code, str(tmp_path / "x.bvh")], capture_output=True, text=True,
                         check=True).stdout
    assert "rig family   none known; roles read from its tree and rest pose (the networks" in out, out
    assert out.strip().splitlines()[-1] == "False", out



def test_info_reads_a_model_s_own_layout_without_torch_and_falls_back_to_the_pt(tmp_path, monkeypatch, capsys):
    """`mocapkit info DIR/model.pt` of a model trained here loaded the .pt (torch): the layout JSON was written for
    the shipped models only. `train` writes it beside every model.pt it saves (``write_layout(card=True)``: the
    card and the .pt's size and SHA-256; tests/cleaning/test_deep.py checks train writes it); `info` reads it
    without torch and says what it says from the .pt, and a .pt without its JSON, or replaced, is read itself."""
    import shutil

    import torch

    from mocapkit.cleaning.deep.inference import save_model
    from mocapkit.cli import main

    model = deep.load_model("ebf_bandai.pt")  # a model with a training card, saved as train saves one
    pt = save_model(model, tmp_path / "model.pt")
    layouts.write_layout(model, pt, card=True)
    kept = layouts.layout_beside(pt)
    assert kept is not None and kept.kind == "ebf" and kept.layout == model.layout and kept.meta == model.meta
    with monkeypatch.context() as m:
        m.setattr(torch, "load", lambda *a, **k: pytest.fail("info loaded the .pt"))
        assert main(["info", str(pt)]) == 0
    from_json = capsys.readouterr().out
    assert "EBF model" in from_json and "epochs" in from_json and "licence" in from_json, from_json
    (tmp_path / "model.layout.json").rename(tmp_path / "aside.json")
    assert layouts.layout_beside(pt) is None  # no JSON (an earlier train's model): info reads the .pt, as before
    assert main(["info", str(pt)]) == 0
    assert capsys.readouterr().out == from_json  # the same lines either way
    (tmp_path / "aside.json").rename(tmp_path / "model.layout.json")
    shutil.copy(deep.shipped_model("ebf").source, pt)  # another model copied over it, its JSON left stale
    assert layouts.layout_beside(pt) is None
