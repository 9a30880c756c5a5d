"""The README runs as written, and stays a page for users."""

import re
from pathlib import Path

import mocapkit

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"


def test_readme_python_examples_run(tmp_path, monkeypatch, capsys):
    blocks = re.findall(r"```python\n(.*?)```", README.read_text(), flags=re.S)
    assert blocks, "README has no python example"
    monkeypatch.chdir(tmp_path)
    for block in blocks:
        exec(compile(block, "README.md", "exec"), {})
    out = capsys.readouterr().out
    # the cleaning example: every step reports, the take is saved whole, and cleaning lowers the error
    for step in ("fill", "detect", "repair", "denoise"):
        assert re.search(rf"^{step} \(", out, flags=re.M), f"no summary line for {step}"
    walk = mocapkit.load(mocapkit.samples.path("12_walk.amc"))
    cleaned = mocapkit.load(tmp_path / "walk_clean.amc")  # read with the ASF save copied beside it
    assert cleaned.num_frames == walk.num_frames
    # the input's text kept: its header, and its frames' lines wherever the corruption and the fix left them
    text, given = (tmp_path / "walk_clean.amc").read_text(), mocapkit.samples.path("12_walk.amc").read_text()
    assert text.split("\n1\n")[0] == given.split("\n1\n")[0]
    assert len(set(text.splitlines()) & set(given.splitlines())) > 0.5 * len(given.splitlines())
    for name, unit in (("joint angles", "deg"), ("joint positions", "cm")):
        before, after = map(float, re.search(rf"{name}: ([\d.]+) {unit} -> ([\d.]+) {unit} RMS", out).groups())
        assert after < 0.25 * before  # the errors of the example (seed 1) move the body: 11.6 -> 0.3 deg, 12.9 -> 0.4 cm
    changed, total = map(int, re.search(r"(\d+) of (\d+) joint samples changed", out).groups())
    assert 0 < changed < total
    # the loading example
    assert mocapkit.load(tmp_path / "131_01_30fps.npz").fps == 30


def test_readme_is_a_users_page():
    text = README.read_text()
    assert len(text.splitlines()) <= 250
    assert "../shared" not in text and "shared/data" not in text
    # every link into docs/ resolves
    for link in re.findall(r"\]\((docs/[^)#]+)", text):
        assert (ROOT / link).is_file(), f"README links to a missing page: {link}"
