"""A trained model's card (mocapkit.cleaning.deep.provenance): the rig family, the training data and the licence it
inherits from real takes, kept in the model file and read back, older files included."""

import dataclasses
from pathlib import Path

import pytest

import mocapkit
from mocapkit.cleaning import deep
from mocapkit.cleaning.deep import provenance, training
from mocapkit.cleaning.deep.provenance import (BANDAI_LICENCE, NOT_STATED, model_licence, model_rig, restricts_use,
                                               training_rig)

DATA = Path(__file__).resolve().parents[1] / "data"
BANDAI = ["dataset-1_bow_active_001.bvh", "dataset-1_dash_chimpira_001.bvh", "dataset-1_run_masculinity_001.bvh"]
CFG = training.TrainConfig(kind="ebf", hidden=4, epochs=1, steps_per_epoch=1, batch=2, crop=40,
                           noise=("angular:0.5",), variants=1)


@pytest.fixture(scope="module")
def bandai():
    return [mocapkit.load(DATA / n) for n in BANDAI]


@pytest.fixture(scope="module")
def walk():
    return mocapkit.load(mocapkit.samples.path("12_walk.amc"))


def test_a_model_trained_on_bandai_takes_inherits_their_rig_and_non_commercial_licence(tmp_path, bandai):
    """A user trial: a model trained on Bandai Namco takes said `rig acclaim` and no licence; the set is CC BY-NC 4.0."""
    # a crop every training take holds (a shorter take is refused: the card counts only takes trained on)
    cfg = dataclasses.replace(CFG, crop=min(c.num_frames for c in bandai[:2]) - 30)
    training.train(bandai[:2], tmp_path, cfg, validation=bandai[2:], executor="serial", progress=False)
    m = deep.load_model(tmp_path / "model.pt")
    assert m.meta["rig"] == model_rig(m) == "bandai_namco"
    assert m.meta["licence"] == model_licence(m) == BANDAI_LICENCE
    assert m.meta["training_data"] == {"takes": 2, "frames": bandai[0].num_frames + bandai[1].num_frames,
                                       "held_out_takes": 1, "held_out_frames": bandai[2].num_frames}
    note = deep.licence_note(m, {"ebf": "--model"})
    assert note.startswith(f"licence of the EBF used: {BANDAI_LICENCE}; --model picks another")
    assert "e.g. ebf.pt" not in note and "no shipped model is cleared for commercial use" in note
    with pytest.warns(mocapkit.errors.LicenceWarning, match="CC BY-NC 4.0"):  # wherever the model is used
        deep.denoise(bandai[2], m)


def test_acclaim_takes_give_the_acclaim_rig_and_a_licence_not_stated(tmp_path, walk):
    training.train([walk[:160]], tmp_path, CFG, executor="serial", progress=False)
    m = deep.load_model(tmp_path / "model.pt")
    assert model_rig(m) == "acclaim" and m.meta["licence"] is None and model_licence(m) == NOT_STATED
    assert deep.licence_note(m) == ""


def test_a_stated_licence_is_kept_and_only_a_restrictive_one_is_said_where_the_model_is_used(tmp_path, walk):
    training.train([walk[:160]], tmp_path, CFG, executor="serial", progress=False, meta={"licence": "CC BY 4.0"})
    m = deep.load_model(tmp_path / "model.pt")
    assert model_licence(m) == "CC BY 4.0" and deep.licence_note(m) == ""  # no restriction: no warning line
    assert restricts_use("CC BY-NC-SA 4.0") and restricts_use("research use only") and not restricts_use(None)


def test_a_model_file_without_a_rig_is_acclaim_only_where_its_joints_are(bandai):
    """Older model files keep no rig: the shipped Acclaim models read as before, a game-rig model is not 'acclaim'."""
    assert model_rig(deep.shipped_model("ebf")) == "acclaim"
    old = dataclasses.replace(deep.shipped_model("ebf", bandai[0]), meta={})
    assert old.layout.joints[0] != "lhipjoint" and model_rig(old) is None


def test_takes_of_several_rig_families_are_named_in_one_line(walk, bandai):
    with pytest.raises(ValueError, match=r"takes of several rigs: 12_walk \(acclaim\), dataset-1_bow_active_001 "
                                         r"\(bandai_namco\); train one rig at a time"):
        training_rig([walk, bandai[0]])
    assert training_rig(bandai) == "bandai_namco"


def test_the_old_spelling_of_the_bandai_rig_is_read_as_bandai_namco(tmp_path, bandai):
    """A user trial: `info ebf_bandai.pt` said `rig bandai` where `denoise`, `clean` and models trained now say
    bandai_namco; a model written with 0.4.0's spelling loads and says the one name, and keeps it when saved again."""
    for kind in ("ebf", "ebd"):
        shipped = deep.load_model(f"{kind}_bandai.pt")
        assert model_rig(shipped) == shipped.meta["rig"] == "bandai_namco"
    old = dataclasses.replace(deep.shipped_model("ebf", bandai[0]), meta={"rig": "bandai", "licence": BANDAI_LICENCE})
    deep.save_model(old, tmp_path / "old.pt")
    read = deep.load_model(tmp_path / "old.pt")
    assert model_rig(read) == read.meta["rig"] == "bandai_namco" and model_licence(read) == BANDAI_LICENCE
    assert model_rig(old) == "bandai_namco" and model_rig(dataclasses.replace(old, meta={"rig": "unity"})) == "unity"
    card = provenance.model_card(bandai[:1], given={"rig": "bandai"})
    assert card["rig"] == "bandai_namco"


def test_a_models_licence_table_words_the_same_families_the_data_terms_name():
    """A model's card words the terms of the same rig families whose takes carry terms (mocapkit.rigs.DATA_TERMS):
    a family added to one table and not the other would leave a model or a database of its takes without them."""
    from mocapkit import rigs

    assert set(provenance.DATA_LICENCES) == set(rigs.DATA_TERMS)


def test_the_shipped_acclaim_pair_states_hdm05s_research_terms_wherever_it_is_used(walk):
    """`info ebf.pt` said "licence not stated" and cleaning an Acclaim take said nothing of its terms, while a Bandai
    take's warning offered ebf.pt as the alternative: the pair was trained on HDM05 takes (research use) and CMU ones,
    so it inherits HDM05's terms, stated as the Bandai pair's are."""
    import numpy as np

    for kind in ("ebf", "ebd"):
        m = deep.shipped_model(kind)
        assert model_licence(m) == provenance.HDM05_LICENCE and restricts_use(model_licence(m))
        assert deep.licence_note(m).startswith(f"licence of the {kind.upper()} used: research use only")
    rot = mocapkit.rotations
    take = walk[:200]
    jitter = rot.euler_to_quaternion(np.random.default_rng(1).normal(0, 2.0, take.rotations.shape[:-1] + (3,)), "XYZ")
    noisy = dataclasses.replace(take, rotations=rot.quaternion_multiply(take.rotations, jitter))
    with pytest.warns(mocapkit.errors.LicenceWarning, match="research use only"):
        deep.denoise(noisy)


def test_a_model_trained_on_hdm05_takes_alone_claims_no_cmu_takes():
    """A model whose card lists HDM05 clips and states no licence inherits HDM05's research terms; trained on HDM05
    takes alone (`mocapkit train` on HDM05 AMCs) it said "... and CMU takes (free for research and commercial
    use)" as the shipped pair does, a claim about training data it never saw."""
    shipped = deep.shipped_model("ebf")
    hdm = [c for c in shipped.meta["train_clips"] if c.startswith("HDM_")][:3]
    alone = dataclasses.replace(shipped, meta={"train_clips": hdm})
    assert model_licence(alone).startswith("research use only: trained on HDM05 takes") and restricts_use(model_licence(alone))
    assert "CMU" not in model_licence(alone) and model_licence(alone) == provenance.HDM05_ONLY_LICENCE
    mixed = dataclasses.replace(shipped, meta={"train_clips": hdm + ["01_01"]})
    assert model_licence(mixed) == provenance.HDM05_LICENCE == model_licence(shipped)
    assert model_licence(dataclasses.replace(shipped, meta={"train_clips": ["01_01"]})) == NOT_STATED
