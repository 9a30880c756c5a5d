"""The README's Python example runs as written."""

import re
from pathlib import Path

README = Path(__file__).resolve().parents[1] / "README.md"


def test_readme_python_example_runs(tmp_path, monkeypatch, capsys):
    blocks = re.findall(r"```python\n(.*?)```", README.read_text(), flags=re.S)
    assert blocks, "README has no python example"
    monkeypatch.chdir(tmp_path)
    for block in blocks:
        exec(compile(block, "README.md", "exec"), {})
    assert (tmp_path / "noisy.bvh").is_file()
    assert (tmp_path / "walks.db" / "database.json").is_file()
    out = capsys.readouterr().out
    assert "deg RMS" in out
    # the database example's first result is the other take of the sneak
    assert "HDM_bk_sneak2StepsLStart_005_120 " in out
