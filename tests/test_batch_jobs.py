"""``clean-batch --jobs N``: how many takes local processes clean at once.

User trial U2 (a technical animator cleaning 40 Bandai Namco takes overnight on a shared 2-core machine):
`clean-batch in out --report --jobs 2` was refused ("No such option: --jobs (Possible options: --json)"),
and nothing let a batch leave cores free: it always started one process per core.
"""

from __future__ import annotations

import shutil

import pytest

from mocapkit.batch import clean_batch
from mocapkit.errors import MocapError
from mocapkit.parallel import check_jobs, describe_executor

from .test_batch import short_bvh  # noqa: F401  (fixture)


def test_jobs_refuses_a_count_below_one_or_another_executor_in_one_line_naming_the_flag():
    check_jobs(None, None)
    check_jobs(3, "processes")
    for bad in (0, -2, 1.5, True):
        with pytest.raises(MocapError, match=r"^--jobs must be a whole number of processes, at least 1"):
            check_jobs(bad, None, "--jobs")
    with pytest.raises(MocapError, match=r"^jobs= sets how many local processes .* executor= serial cleans one take"):
        check_jobs(2, "serial")
    with pytest.raises(MocapError, match=r"--executor dask has workers of its own"):
        check_jobs(2, "dask", "--jobs", "--executor")
    assert describe_executor(None, 1) == "this process"
    assert describe_executor("processes", 2).startswith("local processes (2 at once, ")


def test_clean_batch_jobs_one_cleans_in_this_process_and_says_so(tmp_path, short_bvh, capsys):  # noqa: F811
    from mocapkit.cli import main

    src = tmp_path / "in"
    src.mkdir()
    shutil.copy(short_bvh, src / "walk.bvh")
    assert main(["clean-batch", str(src), str(tmp_path / "out"), "--steps", "fill", "--jobs", "1"]) == 0
    out = capsys.readouterr().out
    assert "1 take on this process in " in out and ": 1 cleaned, 0 already complete, 0 failed" in out
    assert main(["clean-batch", str(src), str(tmp_path / "out2"), "--jobs", "0"]) == 2
    assert "--jobs must be a whole number of processes, at least 1, got 0" in capsys.readouterr().err
    with pytest.raises(MocapError, match="^jobs= must be"):
        clean_batch(src, tmp_path / "out3", jobs=0)
    assert not (tmp_path / "out2").exists() and not (tmp_path / "out3").exists()
