"""The EBF paired with an EBD file by the shipped models' naming (mocapkit.cleaning.deep.pairs)."""

from __future__ import annotations

from mocapkit.cleaning.deep import load_model, paired_ebf
from mocapkit.cleaning.deep.pairs import pair_name


def test_pair_name_reads_ebd_as_ebf_in_its_case():
    assert pair_name("ebd.pt") == "ebf.pt" and pair_name("ebd_bandai.pt") == "ebf_bandai.pt"
    assert pair_name("KT_EBD.pt") == "KT_EBF.pt" and pair_name("own_Ebd.pt") == "own_Ebf.pt"
    assert pair_name("model.pt") == ""


def test_a_shipped_ebd_is_paired_with_the_shipped_ebf_of_its_channels_and_nothing_said():
    for ebd, ebf in (("ebd.pt", "ebf.pt"), ("ebd_bandai.pt", "ebf_bandai.pt")):
        pair, said = paired_ebf(load_model(ebd))
        assert pair.layout == load_model(ebf).layout and said == ""


def test_pair_path_reads_the_file_name_else_the_folder_name_as_train_lays_models_out(tmp_path):
    from mocapkit.cleaning.deep.pairs import pair_path

    assert pair_path(tmp_path / "models" / "kt_ebd.pt") == tmp_path / "models" / "kt_ebf.pt"
    assert pair_path(tmp_path / "my_ebd" / "model.pt") == tmp_path / "my_ebf" / "model.pt"  # mocapkit train -o my_ebd
    assert pair_path(tmp_path / "RIG_EBD" / "model.pt") == tmp_path / "RIG_EBF" / "model.pt"
    assert pair_path(tmp_path / "mine" / "model.pt") is None
