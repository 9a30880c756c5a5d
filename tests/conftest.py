"""Shared fixtures: where the curated real data lives, and a small random motion for maths tests."""

import os
from pathlib import Path

import numpy as np
import pytest
from hypothesis import settings

# Property tests draw the same examples on every run (`make test` is a gate: a run passes or fails for the code, not
# for the draw or the machine's load: no deadline, one example took 260 ms on a busy 2-core VM); HYPOTHESIS_PROFILE=
# explore draws new ones, as a search for failing examples (keep any it finds with @example).
settings.register_profile("gate", derandomize=True, deadline=None)
settings.register_profile("explore", derandomize=False)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "gate"))

# xdist runs one worker per core: torch's intra-op threads in each would oversubscribe them (a tiny training test
# took 50 s instead of 13 s beside a busy worker). Inference sets its own threads (mocapkit.cleaning.deep.threads).
if os.environ.get("PYTEST_XDIST_WORKER"):
    import torch

    torch.set_num_threads(1)

# ../shared/data beside the checkout; $MOCAPKIT_SHARED_DATA for a checkout elsewhere (a git worktree)
SHARED_DATA = Path(os.environ.get("MOCAPKIT_SHARED_DATA", Path(__file__).resolve().parents[1].parent / "shared" / "data"))


@pytest.fixture
def python_sigint():
    """SIGINT as a plain Python process has it (``default_int_handler``, not blocked) for a test that interrupts
    itself with ``os.kill(os.getpid(), SIGINT)``; restored after. A pytest-xdist worker's disposition is the
    runner's, not the one a user's process starts with."""
    import signal

    before = signal.getsignal(signal.SIGINT)
    blocked = signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT}) if hasattr(signal, "pthread_sigmask") else set()
    signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    signal.signal(signal.SIGINT, before)
    if signal.SIGINT in blocked:
        signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})


@pytest.fixture(scope="session")
def shared_data() -> Path:
    """``../shared/data`` beside the checkout; tests that need it skip on a clone without it."""
    if not SHARED_DATA.is_dir():
        pytest.skip("../shared/data is not present")
    return SHARED_DATA


@pytest.fixture
def rng():
    return np.random.default_rng(12345)


@pytest.fixture(scope="session")
def small_db():
    """A real database from the bundled samples: two HDM05 clips and a CMU walk, mirrored, at 30 fps."""
    from mocapkit import samples
    from mocapkit.database import MotionDatabase

    names = ["12_walk.amc", "HDM_bd_jogLeftCircle4StepsRstart_001_120.amc", "HDM_bk_sneak2StepsLStart_004_120.amc", "HDM_bk_sneak2StepsLStart_005_120.amc"]
    return MotionDatabase.build([samples.path(n) for n in names], fps=30, features=("F15", "F15x3"), mirror=True, executor="serial", progress=False)


@pytest.fixture(scope="session", autouse=True)
def no_precompile_helper():
    """No clean in the tests starts numba's compile helper (mocapkit.cleaning.precompile) behind their back, as it
    would after an edit of a kernel's source; tests/cleaning/test_precompile.py turns it on where it tests it."""
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("MOCAPKIT_PRECOMPILE", "0")
        yield


@pytest.fixture(scope="session", autouse=True)
def context_cache(tmp_path_factory):
    """Contexts built from folders or files are cached here, never in the user's ``~/.cache`` (mocapkit.context)."""
    path = tmp_path_factory.mktemp("mocapkit-cache")
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("MOCAPKIT_CACHE_DIR", str(path))
        yield path


# Modules whose tests cost the most CPU between them: run first, so that with `--dist loadscope` (each module on one
# worker, `make test`) no worker is left with one of them at the end while the other idles. Measured as `make test`
# runs them (serial, one torch thread, warm numba cache, without ../shared, -m "not slow"; CPU user+sys on a 2-core
# VM): tests/cli/test_clean.py 41 s, tests/cli/test_deep.py 40 s, tests/cleaning/ssa/test_word_dtw.py 30 s,
# tests/test_fuzz_commands.py 30 s, tests/cli/test_reconstruct.py 23 s, tests/test_warmup.py 20 s,
# tests/reconstruct/test_accelerometers.py 18 s; the
# same names take tests/cleaning/test_deep.py (torch training) and tests/cleaning/markers/test_clean.py along.
# test_amc_writer.py is long where ../shared is present (every shared AMC round-tripped).
LONG_MODULES = ("test_clean.py", "test_deep.py", "test_word_dtw.py", "test_fuzz_commands.py", "test_warmup.py",
                "test_accelerometers.py", "test_reconstruct.py", "test_amc_writer.py")


def pytest_collection_modifyitems(items):
    items.sort(key=lambda item: item.path.name not in LONG_MODULES)  # stable: the order within each part is kept
