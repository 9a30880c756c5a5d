"""The entry point: one error line and exit 2 for every failure, --version, --help."""


import mocapkit
from mocapkit.cli import main
from tests.cli.helpers import SAMPLE, one_error_line, run


def test_bad_input_is_one_line_and_exit_2(tmp_path):
    bad = tmp_path / "broken.bvh"
    bad.write_text("HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0 0\n")
    code, out, err = run("info", str(bad))
    assert code == 2
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1 and "broken.bvh" in lines[0]
    code, _, err = run("info", str(tmp_path / "missing.bvh"))
    assert code == 2 and "missing.bvh" in err
    code, _, err = run("convert", SAMPLE, str(tmp_path / "x.fbx"))
    assert code == 2 and "unknown suffix" in err and not (tmp_path / "x.fbx").exists()


def test_never_overwrites_the_input(tmp_path):
    src = tmp_path / "in.bvh"
    src.write_bytes(open(SAMPLE, "rb").read())
    before = src.read_bytes()
    code, _, err = run("convert", str(src), str(src))
    assert code == 2 and "refusing to write over an input" in err
    assert src.read_bytes() == before


def test_help_reads_well():
    code, out, _ = run("--help")
    assert code == 0
    for cmd in ("info", "convert", "corrupt", "plot"):
        assert cmd in out


