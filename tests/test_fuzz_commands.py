"""Fuzzing whole commands: the fixed cases of issue 20 one by one, a few mutated real files, and the oracle itself.

Each command runs as a process of its own (forked by a ``commands.ForkServer``
that has imported mocapkit once, so ~60 runs do not each pay ~0.8 s of CPU
for Python's start and the imports) under a 2 GiB address-space limit and a CPU
budget (``tests/fuzzing/commands.py``). ``test_issue20_fixed_case[NAME]``
reports each hand-made case of issue 20 on its own, so a failing run names
the case, the command line and what it did (the exception line and the
innermost mocapkit frame, memory, CPU, files lost). ``benchmarks/fuzz_commands.py``
runs the same with hundreds of mutants.
"""

from __future__ import annotations

import io
import random
import struct
import zipfile
from functools import partial

import numpy as np
import pytest

from mocapkit.cli.clean import start_line
from tests.conftest import SHARED_DATA
from tests.fuzzing import commands, issue20

QUICK_MUTANTS = 8  # a smoke check of the mutation path: benchmarks/fuzz_commands.py runs 500 (each ~1.4 s of CPU)
# Cases that run whole commands on a real take for what in-process tests also check (~23 s of CPU of the ~60 the
# fixed cases take, in a `make test` at the edge of its 10 minutes): joint and file names holding rich markup
# (tests/cli/test_motion.py, test_db.py, test_ssa.py), a lone surrogate in a joint name (tests/io/test_bvh.py,
# test_npz.py) and a deep joint chain (tests/io/test_bvh.py, 20,000 joints). Marked slow here (`pytest -m slow`);
# benchmarks/fuzz_commands.py runs them as commands too.
WHOLE_COMMAND_CASES = ("markup-names-npz", "markup-names-bvh", "lone-surrogate-joint", "bvh-chain-3000")
QUICK_CASES = tuple(n for n in issue20.FIXED_CASES if n not in WHOLE_COMMAND_CASES)
# A run may take its kind's CPU time on the unmutated seed this many times over, plus the issue's 10 s.
CPU_FACTOR, CPU_SLACK_S = 3.0, 10.0


def _report(name: str, r: commands.CaseResult) -> str:
    lines = [f"{name}: {issue20.about(name) if name in issue20.FIXED_CASES else ''}"]
    for cmd, f in r.all_findings:
        st = next((s for s in r.steps if "mocapkit " + " ".join(s.argv) == cmd), None)
        res = f" [exit {st.returncode if st.signal is None else 'signal %d' % st.signal}, CPU {st.cpu_s:.1f} s, " \
              f"peak RSS {st.peak_rss_mb:.0f} MB]" if st else ""
        lines.append(f"  {cmd or '(case)'}: {f.kind}: {f.detail}{res}")
    return "\n".join(lines)


@pytest.fixture(scope="module")
def workdir(tmp_path_factory):
    return tmp_path_factory.mktemp("fuzz-commands")


@pytest.fixture(scope="module")
def fork_pool():
    """The fork servers every command of this module runs from (each started once: ~1 s of CPU)."""
    pool = commands.ForkPool()
    yield pool
    pool.close()


@pytest.fixture(scope="module")
def seeds():
    return commands.command_seeds(SHARED_DATA if SHARED_DATA.is_dir() else None)


@pytest.fixture(scope="module")
def baseline(workdir, seeds, fork_pool):
    """Every command kind on the unmutated BVH seed, one after another (the first run fills numba's cache)."""
    return commands.baseline_cpu(seeds, workdir, commands.Limits(cpu_s={"default": 600.0}), fork=fork_pool)


@pytest.fixture(scope="module")
def limits(baseline):
    cpu, _ = baseline
    budgets = {k: CPU_FACTOR * v + CPU_SLACK_S for k, v in cpu.items() if np.isfinite(v)}
    budgets["default"] = max(budgets.values())
    return commands.Limits(mem_bytes=2 << 30, cpu_s=budgets, wall_s=600.0)


def _run_fixed(names, workdir, limits, fork_pool) -> dict:
    cases = [issue20.FIXED_CASES[n] for n in names]
    return dict(zip(names, commands.run_cases(cases, workdir, limits, workers=2, fork=fork_pool)))


@pytest.fixture(scope="module")
def fixed_results(workdir, limits, fork_pool):
    return _run_fixed(QUICK_CASES, workdir, limits, fork_pool)


@pytest.fixture(scope="module")
def whole_command_results(workdir, limits, fork_pool):
    return _run_fixed(WHOLE_COMMAND_CASES, workdir, limits, fork_pool)


def test_unmutated_seed_runs_cleanly(baseline):
    """info, convert, clean, db build, detect and denoise on a real take: exit 0, quiet, nothing of the input touched."""
    cpu, results = baseline
    assert set(cpu) == {"info", "convert", "clean", "db build", "detect", "denoise"}
    for r in results:
        assert not r.all_findings, _report(r.name, r)
        assert r.steps[0].returncode == 0 and r.steps[0].stdout.strip()


def _check_fixed(r, name):
    if r.skipped:
        pytest.skip(r.skipped)
    assert r.steps, name
    assert not r.all_findings, _report(name, r)


@pytest.mark.parametrize("name", QUICK_CASES)
def test_issue20_fixed_case(fixed_results, name):
    """One hand-made case of issue 20: every command line of it exits cleanly (as the case expects), within limits,
    losing no input and leaving no partial output."""
    _check_fixed(fixed_results[name], name)


@pytest.mark.slow
@pytest.mark.parametrize("name", WHOLE_COMMAND_CASES)
def test_issue20_whole_command_case(whole_command_results, name):
    """The cases of issue 20 that in-process tests also check (:data:`WHOLE_COMMAND_CASES`), as commands."""
    _check_fixed(whole_command_results[name], name)


def test_mutated_commands(workdir, seeds, limits, fork_pool):
    """A few mutated real files through the commands: no traceback, no run over its limits, no input lost."""
    cases = [partial(commands.mutant_case, seeds, n) for n in range(QUICK_MUTANTS)]
    results = commands.run_cases(cases, workdir, limits, workers=2, fork=fork_pool)
    summary = commands.summarize(results)
    assert summary["runs"] == QUICK_MUTANTS
    failing = [r for r in results if r.all_findings]
    assert not failing, "\n".join(
        _report(r.name, r) + "\n    " + commands.mutant_case(seeds, int(r.name.split("-")[1])).about for r in failing)


# -- the harness itself -------------------------------------------------------------------------------


def _result(returncode=0, stderr="", stdout="wrote x", signal=None, cpu=1.0, rss=200.0, argv=("info", "a.bvh")):
    return commands.StepResult(tuple(argv), returncode, signal, 1.0, cpu, rss, stdout, stderr)


START = start_line("in", 2, 3, "this process") + "\n"  # clean-batch's first line on stderr
LIM = commands.Limits(mem_bytes=2 << 30, cpu_s={"default": 20.0})


@pytest.mark.parametrize(
    "res, expect, kinds",
    [
        (_result(), "any", set()),
        (_result(2, "mocapkit: error: a.bvh: line 3: bad CHANNELS\n"), "any", set()),
        (_result(2, "clips:  50%|#####     | 1/2 [00:01<00:01, 1.0it/s]\rmocapkit: error: a.bvh: bad\n"), "any", set()),
        (_result(0, "ssa a: 100%|##########| 20/20 [00:00<00:00, 146.27word/s]\n"), "ok", set()),
        (_result(1, 'Traceback (most recent call last):\n  File "/x/src/mocapkit/cli.py", line 90, in info\n'
                    '    console.print(t)\nrich.errors.MarkupError: closing tag \'[/b]\'\n'), "any", {"traceback"}),
        (_result(2, "Error: first\nmocapkit: error: second\n"), "any", {"message"}),
        (_result(0, "RuntimeWarning: invalid value encountered\n"), "any", {"message"}),
        (_result(3, ""), "any", {"exit"}),
        (_result(None, "", signal=11), "any", {"signal"}),
        (_result(None, "", signal=24, cpu=21.0), "any", {"time"}),
        (_result(0, "", cpu=25.0), "any", {"time"}),
        (_result(1, "Traceback (most recent call last):\nnumpy._core._exceptions._ArrayMemoryError: Unable to allocate "
                    "6.63 GiB\n"), "any", {"memory", "traceback"}),
        (_result(0), "refuse", {"accepted"}),
        (_result(2, "mocapkit: error: arm.bvh: no left foot\n"), "ok", {"refused"}),
        (_result(1, "", argv=("clean-batch", "in", "out")), "any", set()),
        # clean-batch's start line is no message: exit 0, a failed take (1), one error line after it (2)
        (_result(0, START, argv=("clean-batch", "in", "out")), "any", set()),
        (_result(1, START, argv=("clean-batch", "in", "out")), "any", set()),
        (_result(2, START + "mocapkit: error: out/a.bvh: no space left on the device\n", argv=("clean-batch", "in", "out")),
         "any", set()),
        (_result(0, START), "any", {"message"}),  # from another command it is one
    ],
)
def test_oracle_judges_exit_and_standard_error(res, expect, kinds):
    step = commands.Step(res.argv, expect)
    assert {f.kind for f in commands.judge(res, step, LIM)} == kinds


def test_oracle_traceback_names_the_exception_and_the_innermost_mocapkit_frame():
    err = ('Traceback (most recent call last):\n  File "/r/src/mocapkit/cli.py", line 5, in main\n    x()\n'
           '  File "/r/src/mocapkit/io/bvh.py", line 627, in write_bvh\n    fh.write(t)\n'
           "UnicodeEncodeError: 'utf-8' codec can't encode character '\\ud800'\n")
    (f,) = commands.judge(_result(1, err), commands.Step(("convert",)), LIM)
    assert f.detail.startswith("UnicodeEncodeError: 'utf-8' codec") and "mocapkit/io/bvh.py:627 in write_bvh" in f.detail


def test_oracle_protects_inputs_and_finds_leftovers(tmp_path):
    before = {"a.bvh": "h1", "p": "dir", "p/notes.txt": "h2", "b.bvh": "h3"}
    step = commands.Step(("db", "build", "p", "a.bvh", "--overwrite"), "refuse", ("p",))
    ok = _result(0)
    # --overwrite may replace what lies in the declared output folder, never a declared input
    after = {"a.bvh": "h1", "p": "dir", "p/database.json": "h9", "b.bvh": "h3"}
    assert commands.file_findings(before, after, step, ok, ("a.bvh",), tmp_path) == []
    found = commands.file_findings(before, after, step, ok, ("a.bvh", "p/notes.txt"), tmp_path)
    assert [(f.kind, f.detail) for f in found] == [("input_lost", "p/notes.txt is gone")]
    # without --overwrite an existing file is protected; a failed run must leave nothing new, and no .part anywhere
    step = commands.Step(("convert", "a.bvh", "b.bvh"), "refuse", ("b.bvh",))
    after = {"a.bvh": "h1", "p": "dir", "p/notes.txt": "h2", "b.bvh": "h4", ".b.bvh.x1y2.part": "h5", "new": "dir"}
    kinds = sorted(f.kind for f in commands.file_findings(before, after, step, _result(2), (), tmp_path))
    assert kinds == ["failed_run_output", "input_changed", "partial_output"]


def test_snapshot_hashes_files_and_notes_folders_and_links(tmp_path):
    commands.write_case(commands.Case("c", {"a/b.txt": b"x", "e": None, "l": commands.Symlink("a/b.txt")}, ()), tmp_path)
    snap = commands.snapshot(tmp_path)
    assert snap["a"] == "dir" and snap["e"] == "dir" and snap["l"] == "link:a/b.txt"
    assert snap["a/b.txt"] == "2d711642b726b04401627ca9fbac32f5c8530fb1903cc4db02258717921a4881"  # sha256(b"x")


def test_strip_progress_keeps_the_error_line():
    err = ("ssa a:   0%|          | 0/20 [00:00<?, ?word/s]\rssa a: 100%|██████████| 20/20 [00:00<00:00, 146.27word/s]\n"
           "clips: 3it [00:00, 5.1it/s]clips:   0%|          | 0/1 [00:00<?, ?item/s]mocapkit: error: x.bvh: bad\n")
    assert commands.strip_progress(err) == "mocapkit: error: x.bvh: bad"


def test_mutant_cases_are_deterministic_and_vary(seeds):
    a, b = commands.mutant_case(seeds, 5), commands.mutant_case(seeds, 5)
    assert a.files == b.files and a.steps == b.steps
    cases = [commands.mutant_case(seeds, n) for n in range(60)]
    assert len({c.steps[0].argv[0] for c in cases}) >= 5  # info, convert, clean, db, detect, denoise
    assert len({tuple(sorted(c.files.items())) for c in cases}) == 60
    assert {s.fmt for s in seeds} == {"bvh", "amc", "asf", "c3d", "npz"}


@pytest.mark.parametrize("fmt", ["bvh", "amc", "asf", "c3d", "npz"])
def test_hostile_names_reach_the_file(seeds, fmt):
    seed = next(s for s in seeds if s.fmt == fmt)
    rng = random.Random(3)
    data, comp = commands.hostile_names(rng, seed)
    assert (data, comp) != (seed.data, seed.companion)
    if fmt in ("amc", "asf"):  # a bone renamed in both files, so the pair still belongs together
        assert data != seed.data and comp != seed.companion


def test_zip_bomb_is_small_and_declares_4_gb(seeds):
    npz = commands.npz_of(next(s for s in seeds if s.fmt == "bvh"))
    bomb = issue20.zip_bomb_npz(npz)
    assert len(bomb) < 8 << 20
    with zipfile.ZipFile(io.BytesIO(bomb)) as zf:
        info = zf.getinfo("rotations.npy")
        assert info.file_size > 3_900_000_000 and info.compress_type == zipfile.ZIP_DEFLATED
        with zf.open(info) as fh:
            head = fh.read(128)
        with zf.open("fps.npy") as fh:
            assert float(np.lib.format.read_array(fh)) == 120.0
    assert head.startswith(b"\x93NUMPY") and b"(4032258, 31, 4)" in head
    n = struct.unpack_from("<H", head, 8)[0]
    assert len(head) == 10 + n


@pytest.mark.parametrize("n", [0, 1, 1000, (1 << 20) + 3, 3 * (1 << 20) + 17])
def test_crc32_of_zeros_matches_zlib(n):
    import zlib

    assert issue20.crc32_of_zeros(n, 0xDEADBEEF) == zlib.crc32(bytes(n), 0xDEADBEEF)


def test_fixed_cases_cover_issue_20():
    names = set(issue20.FIXED_CASES)
    assert set(WHOLE_COMMAND_CASES) < names and set(QUICK_CASES) | set(WHOLE_COMMAND_CASES) == names
    for must in ("bvh-frame-time-1000", "npz-fps-0.01", "npz-zip-bomb", "bvh-chain-3000", "c3d-point-used-32767",
                 "markup-names-npz", "lone-surrogate-joint", "info-base-link1-link2", "clean-output-is-reference",
                 "clean-output-is-context", "db-build-overwrite-over-inputs", "executor-garbage",
                 "output-in-readonly-folder", "output-onto-folder", "output-under-a-file"):
        assert must in names
    c = issue20.fixed_case("db-build-overwrite-over-inputs")
    assert c.steps[0].argv == ("db", "build", "p", "p/takes/backflip.amc", "--overwrite")
    assert set(c.inputs) >= {"p/takes/backflip.amc", "p/notes.txt"}
