"""Fuzzing whole commands: ``mocapkit info/convert/clean/db build/detect/denoise`` on mutated real files.

A careless or hostile user does not call a reader: they run a command, with
outputs, on whatever file they have. This module runs the ``mocapkit``
command line as that user would, each run a subprocess in its own folder, and
judges what it did:

* **Cases** (:class:`Case`) are a folder of files (:attr:`Case.files`) and one
  or more command lines run in it (:class:`Step`). Mutated cases
  (:func:`mutant_case`) take a real file (:func:`command_seeds`: the bundled
  clips and, when present, a few files of ``../shared/data``, trimmed to 150
  frames) through the readers' mutators (:func:`tests.fuzzing.readers.mutate`:
  byte flips, truncation, numbers made huge / negative / NaN, header fields,
  lines duplicated or removed) or through :func:`hostile_names` (joint, bone,
  marker and clip names replaced by rich markup, lone surrogates, paths,
  control characters), give the file a plain or a hostile name, and run one
  command on it. Fixed cases (``tests/fuzzing/issue20.py``) are the hand-made
  inputs of issue 20, each with what the command must do.
* **Each run** (:func:`run_step`) is ``python -c LAUNCHER`` in a new session,
  under ``RLIMIT_AS`` (``mem_bytes``, 2 GiB), ``RLIMIT_CPU`` (the command's
  CPU budget), ``RLIMIT_FSIZE`` and no core files, with ``TQDM_DISABLE=1`` and
  one thread per library; a run still alive after ``wall_s`` is killed with its
  whole process group. With a :class:`ForkServer` (the tests' choice) the run is
  instead a process forked, under the same limits and in a new session, from an
  interpreter that has already imported ``mocapkit.cli``: the same command in its
  own process (exit status, signals, CPU and memory of its own), without paying
  Python's start and mocapkit's imports again (about 0.4 s of CPU a run, most of
  what a refused command costs).
* **The oracle** (:func:`judge`) turns a run into :class:`Finding` s, none when
  all is well. Progress bars aside (:func:`strip_progress`), exit 0 with an
  empty standard error, or exit 2 (1 for
  ``clean-batch`` with failed takes) with exactly one line ``mocapkit: error:
  ...``; anything else is a ``traceback`` (a Python traceback, first the
  exception line and the innermost mocapkit frame), ``message`` (other standard
  error), ``exit`` (another exit code) or ``signal``. Over the limits: ``time``
  (CPU over the budget, or killed by ``RLIMIT_CPU``), ``hang`` (wall clock),
  ``memory`` (MemoryError, "Unable to allocate", ``bad_alloc``, or a peak RSS
  over the limit). Every file present before a step is hashed before and after
  it: ``input_lost`` / ``input_changed`` unless it is one of the step's
  declared outputs and the step says ``--overwrite`` (declared inputs are
  protected always). ``partial_output``: a ``*.part`` left anywhere in the
  folder; ``failed_run_output``: anything new after a failed step;
  ``orphan_process``: a process of the run's group alive after it exited.
  Fixed cases add ``refused`` (exit non-zero where the input is valid),
  ``accepted`` (exit 0 where the input must be refused), ``output_size`` and
  ``check`` (a case's own test of its outputs).

Everything is a pure function of the seeds and an integer, so a failure is
reproduced by its case name (``mutant-<n>``) alone: :func:`write_case` lays a
case's files out in a folder for a person to rerun the command.
"""

from __future__ import annotations

import dataclasses
import hashlib
import io
import json
import os
import queue
import random
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from . import readers

__all__ = [
    "Case", "Step", "Symlink", "Finding", "StepResult", "CaseResult", "Limits", "LAUNCHER", "KIND_GROUPS",
    "command_seeds", "mutant_case", "hostile_names", "npz_of", "run_case", "run_cases", "run_step", "judge",
    "summarize", "snapshot", "write_case", "baseline_cpu", "command_kind", "strip_progress", "file_findings",
    "ForkServer", "ForkPool", "FORK_SERVER", "PRELOAD",
]

TRIM_FRAMES = 150

# Sets the limits, then runs the console script's entry point in this process (no exec: one interpreter start).
LAUNCHER = r"""
import resource, sys
mem, cpu, fsize = (int(x) for x in sys.argv[1:4])
resource.setrlimit(resource.RLIMIT_AS, (mem, mem))
resource.setrlimit(resource.RLIMIT_CPU, (cpu, cpu + 5))
resource.setrlimit(resource.RLIMIT_FSIZE, (fsize, fsize))
resource.setrlimit(resource.RLIMIT_CORE, (0, 0))
sys.argv = ["mocapkit", *sys.argv[4:]]
from mocapkit.cli import main
sys.exit(main())
"""

# A fork server: imports the console script's module (and PRELOAD) once, readies numba's CPU target (the registries numba
# imports the first time a process loads a kernel, cached or not: ~0.4 s of CPU in every command that reads a take) and
# freezes the garbage collector's objects (gc.freeze: a child's collections then leave the server's objects, and the
# memory pages they lie on, untouched, instead of copying those pages: ~0.25 s of CPU in every forked command); then
# for each request (a JSON line on stdin: argv, cwd, limits, the files for stdout and stderr) forks a child that
# becomes the command exactly as LAUNCHER does (new session, limits, standard streams on the files, sys.argv,
# main()); it answers on its original stdout with the child's pid, then with its wait status and resource usage
# once it has exited.
FORK_SERVER = r"""
import importlib, json, os, resource, sys
from mocapkit.cli import main
for name in sys.argv[1:]:
    importlib.import_module(name)
from numba.core.registry import cpu_target
cpu_target.target_context.refresh()
import gc
gc.freeze()
ctl, buf = os.dup(1), b""
while True:
    while b"\n" not in buf:
        chunk = os.read(0, 1 << 16)
        if not chunk:
            os._exit(0)
        buf += chunk
    line, buf = buf.split(b"\n", 1)
    req = json.loads(line)
    pid = os.fork()
    if pid == 0:
        os.setsid()
        os.close(ctl)
        for fd, path, flags in ((0, os.devnull, os.O_RDONLY), (1, req["out"], os.O_WRONLY | os.O_CREAT | os.O_TRUNC),
                                (2, req["err"], os.O_WRONLY | os.O_CREAT | os.O_TRUNC)):
            f = os.open(path, flags, 0o644)
            os.dup2(f, fd)
            os.close(f)
        os.chdir(req["cwd"])
        mem, cpu, fsize = req["limits"]
        resource.setrlimit(resource.RLIMIT_AS, (mem, mem))
        resource.setrlimit(resource.RLIMIT_CPU, (cpu, cpu + 5))
        resource.setrlimit(resource.RLIMIT_FSIZE, (fsize, fsize))
        resource.setrlimit(resource.RLIMIT_CORE, (0, 0))
        sys.argv = ["mocapkit", *req["argv"]]
        break
    os.write(ctl, (json.dumps({"pid": pid}) + "\n").encode())
    _, status, ru = os.wait4(pid, 0)
    os.write(ctl, (json.dumps({"status": status, "utime": ru.ru_utime, "stime": ru.ru_stime,
                               "maxrss": ru.ru_maxrss}) + "\n").encode())
sys.exit(main())
"""


# What ``mocapkit info`` on a BVH imports (numpy, scipy, numba, rich, the readers and rigs: ~0.8 s of CPU), which
# every command reading a take imports too, and the database and cleaning modules. Not torch (``denoise``'s
# alone, and large in RLIMIT_AS): a forked command is charged no address space it would not have mapped itself, but for
# numba's CPU target (~130 MB of address space, which any command reading a take maps).
PRELOAD = ("mocapkit.cli.streams", "mocapkit.io.takes", "mocapkit.io.bvh", "mocapkit.io.asfamc", "mocapkit.io.c3d",
           "mocapkit.io.npz", "mocapkit.rigs", "mocapkit.features", "mocapkit.digest", "mocapkit.database_folder",
           "mocapkit.reconstruct.output", "mocapkit.database", "mocapkit.cleaning.pipeline")


class ForkServer:
    """A running :data:`FORK_SERVER`: one command at a time (:func:`run_cases` keeps one per worker).

    Started in an empty folder with :func:`_env`'s environment, as each fresh run was; close it with
    :meth:`close` (or use it as a context manager).
    """

    def __init__(self) -> None:
        self._home = tempfile.mkdtemp(prefix="mocapkit-fuzz-fork-")
        self._proc = subprocess.Popen([sys.executable, "-c", FORK_SERVER, *PRELOAD], cwd=self._home, stdin=subprocess.PIPE,
                                      stdout=subprocess.PIPE, env=_env())

    def start(self, argv, cwd: Path, limits: tuple[int, int, int], out: Path, err: Path) -> int:
        """Fork the command; its pid (also its process group's id)."""
        req = {"argv": list(argv), "cwd": str(cwd), "limits": list(limits), "out": str(out), "err": str(err)}
        self._proc.stdin.write((json.dumps(req) + "\n").encode())
        self._proc.stdin.flush()
        return int(self._reply()["pid"])

    def wait(self) -> tuple[int, float, float]:
        """The forked command's wait status, CPU seconds (user + system) and peak RSS (kB), once it has exited."""
        r = self._reply()
        return int(r["status"]), float(r["utime"]) + float(r["stime"]), float(r["maxrss"])

    def _reply(self) -> dict:
        line = self._proc.stdout.readline()
        if not line:
            raise RuntimeError(f"the fork server exited (status {self._proc.poll()})")
        return json.loads(line)

    def close(self) -> None:
        if self._proc.poll() is None:
            self._proc.stdin.close()
            self._proc.wait(timeout=60)
        self._proc.stdout.close()
        shutil.rmtree(self._home, ignore_errors=True)

    def __enter__(self) -> "ForkServer":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


class ForkPool:
    """Fork servers for workers to take and give back (one per worker at a time), started as needed; ``close`` ends them.

    One pool can serve several :func:`run_cases` and :func:`baseline_cpu` calls: each server's start (Python and
    :data:`PRELOAD`, ~1 s of CPU) is paid once.
    """

    def __init__(self) -> None:
        self._free: queue.SimpleQueue = queue.SimpleQueue()
        self._all: list[ForkServer] = []
        self._lock = threading.Lock()

    def take(self) -> ForkServer:
        try:
            return self._free.get_nowait()
        except queue.Empty:
            server = ForkServer()
            with self._lock:
                self._all.append(server)
            return server

    def give(self, server: ForkServer) -> None:
        self._free.put(server)

    def close(self) -> None:
        for server in self._all:
            server.close()
        self._all.clear()


# How findings are counted in a report (benchmarks/fuzz_commands.py, the tests).
KIND_GROUPS = {
    "tracebacks": ("traceback", "message", "exit", "signal"),
    "over_limit": ("time", "hang", "memory"),
    "inputs_lost_or_changed": ("input_lost", "input_changed"),
    "partial_outputs": ("partial_output", "failed_run_output"),
    "orphan_processes": ("orphan_process",),
    "expectation_failures": ("refused", "accepted", "output_size", "check"),
}

_MEMORY_SIGNS = ("MemoryError", "Unable to allocate", "bad_alloc", "Cannot allocate memory")
# What an interrupted atomic write or database save leaves: ``.NAME.XXXX.part`` (file or folder), ``.NAME.XXXX.old``.
_PARTIAL = re.compile(r"\.part$|^\..*\.old$")


# -- cases ---------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Symlink:
    """A symbolic link to lay out in a case's folder (``target`` relative to the link's folder)."""

    target: str


@dataclass(frozen=True)
class Step:
    """One command line run in the case's folder.

    ``argv``: the arguments after ``mocapkit``, paths relative to the folder.
    ``expect``: ``"ok"`` (must exit 0), ``"refuse"`` (must fail with one line), ``"any"``
    (either, cleanly). ``outputs``: what it writes (files or folders); a failed step must
    leave none of them, and only with ``--overwrite`` in ``argv`` may one that existed
    change. ``max_output_ratio``: on success, every output file at most this many times
    the size of the largest input (a writer that blows up).
    """

    argv: tuple[str, ...]
    expect: str = "any"
    outputs: tuple[str, ...] = ()
    max_output_ratio: float | None = None


@dataclass
class Case:
    """Files laid out in a fresh folder, then steps run there in order.

    ``files``: relative path -> bytes, :class:`Symlink`, or None for an empty folder.
    ``inputs``: paths (files or folders) that must be unchanged after every step whatever
    the outputs are. ``readonly``: folders made read-only before the steps (the case is
    skipped when even that cannot stop this user writing there). ``check``: the case's
    own test of the folder after the last step, returning problems. ``wall_s``: a
    tighter wall-clock limit per step than the default; ``cpu_s``: the CPU budget of
    every step, instead of its command kind's (a 50 MB input takes longer to read).
    """

    name: str
    files: dict
    steps: tuple[Step, ...]
    inputs: tuple[str, ...] = ()
    readonly: tuple[str, ...] = ()
    check: Callable[[Path, list], list[str]] | None = None
    wall_s: float | None = None
    cpu_s: float | None = None
    about: str = ""


@dataclass(frozen=True)
class Finding:
    """One thing a run did wrong: ``kind`` (see the module docstring) and what exactly."""

    kind: str
    detail: str


@dataclass
class StepResult:
    """What one command did: exit code (or the signal that ended it), times, peak memory, output, findings."""

    argv: tuple[str, ...]
    returncode: int | None
    signal: int | None
    wall_s: float
    cpu_s: float
    peak_rss_mb: float
    stdout: str
    stderr: str
    findings: list[Finding] = field(default_factory=list)


@dataclass
class CaseResult:
    """The steps' results of a case, its case-level findings, and ``skipped`` (why, when it could not run)."""

    name: str
    steps: list[StepResult] = field(default_factory=list)
    findings: list[Finding] = field(default_factory=list)
    skipped: str = ""

    @property
    def all_findings(self) -> list[tuple[str, Finding]]:
        """Every finding with the command line it belongs to (``""`` for the case's own)."""
        out = [("mocapkit " + " ".join(s.argv), f) for s in self.steps for f in s.findings]
        return out + [("", f) for f in self.findings]


@dataclass(frozen=True)
class Limits:
    """Per-run limits: memory (RLIMIT_AS, bytes), CPU seconds per command kind, wall seconds, file size."""

    mem_bytes: int = 2 << 30
    cpu_s: dict = field(default_factory=lambda: {"default": 60.0})
    wall_s: float = 300.0
    fsize_bytes: int = 1 << 30

    def cpu_for(self, argv) -> float:
        return float(self.cpu_s.get(command_kind(argv), self.cpu_s["default"]))


def command_kind(argv) -> str:
    """``"db build"`` for ``("db", "build", ...)``, else the first word: the key of a CPU budget."""
    argv = tuple(argv)
    if argv[:1] == ("db",):
        return " ".join(argv[:2])
    return argv[0] if argv else ""


# -- seeds ---------------------------------------------------------------------------------------


def command_seeds(shared_data: Path | None = None, frames: int = TRIM_FRAMES) -> list[readers.Seed]:
    """Real files for the commands, trimmed to ``frames`` frames (long enough for detect's motion words).

    The bundled 131_01.bvh, 12_walk.amc (+12.asf), an HDM05 jog (+HDM_bd.asf), Eb015pr.c3d, and
    npz files of the first and the last; when ``shared_data`` is a folder, also CMU 01_01.bvh, a
    Bandai Namco BVH (another rig), CMU backflip.amc, HDM05 depositFloorR and dynamic.c3d.
    """
    from mocapkit import samples

    seeds: list[readers.Seed] = []

    def bvh(p: Path) -> None:
        seeds.append(readers.Seed(p.name, "bvh", readers.trim_bvh(p.read_bytes(), frames)))

    def amc(p: Path, asf: Path) -> None:
        a, s = readers.trim_amc(p.read_bytes(), frames), asf.read_bytes()
        seeds.append(readers.Seed(p.name, "amc", a, s))
        if not any(x.fmt == "asf" and x.name == asf.name for x in seeds):
            seeds.append(readers.Seed(asf.name, "asf", s, a))

    def c3d(p: Path) -> None:
        seeds.append(readers.Seed(p.name, "c3d", readers.trim_c3d(p.read_bytes(), frames)))

    bvh(samples.path("131_01.bvh"))
    amc(samples.path("12_walk.amc"), samples.path("12.asf"))
    amc(samples.path("HDM_bd_jogLeftCircle4StepsRstart_001_120.amc"), samples.path("HDM_bd.asf"))
    c3d(samples.path("Eb015pr.c3d"))
    if shared_data is not None and Path(shared_data).is_dir():
        d = Path(shared_data)
        for rel in ("cmu_bvh/01_01.bvh",):
            if (d / rel).is_file():
                bvh(d / rel)
        bandai = sorted((d / "secondary_bandai_namco_CC-BY-NC").glob("**/*.bvh"))[:1]
        for p in bandai:
            bvh(p)
        for rel, asf in (("cmu_asfamc/backflip.amc", "cmu_asfamc/backflip.asf"),
                         ("hdm05_asfamc/HDM_bd_depositFloorR_001_120.amc", "hdm05_asfamc/HDM_bd.asf")):
            if (d / rel).is_file() and (d / asf).is_file():
                amc(d / rel, d / asf)
        if (d / "c3d_markers/dynamic.c3d").is_file():
            c3d(d / "c3d_markers/dynamic.c3d")
    seeds.append(readers.Seed("131_01.npz", "npz", npz_of(seeds[0])))
    seeds.append(readers.Seed("Eb015pr.npz", "npz", npz_of(next(s for s in seeds if s.fmt == "c3d"))))
    return seeds


def npz_of(seed: readers.Seed) -> bytes:
    """The npz (mocapkit's own writer) of a bvh or c3d seed."""
    from mocapkit.io import load
    from mocapkit.io.npz import write_npz

    with tempfile.TemporaryDirectory(prefix="mocapkit-fuzz-npz-") as d:
        src = Path(d) / f"seed.{seed.fmt}"
        src.write_bytes(seed.data)
        write_npz(load(src), Path(d) / "seed.npz")
        return (Path(d) / "seed.npz").read_bytes()


# -- hostile names -------------------------------------------------------------------------------

# Strings a name can carry: rich markup, a lone surrogate, paths, control characters, format strings,
# HTML, shell, very long, non-ASCII, option-like.
HOSTILE_NAMES = [
    "[/b]", "[/]", "[bold red]x[/bold red]", "[link=file:///etc/passwd]j", "\ud800", "\udcff", "../../etc/passwd",
    "a/b", "a\\b", "名前", "é", "x" * 4096, "%s%n%x", "{0}{1}", "<script>alert(1)</script>", "$(touch pwned)",
    "'\"", "-o", "--help", "\x1b[31mred", "tab\tname", "nul\x00l", "", " ", "\u202eevil", "NaN", "1e309",
]
# File stems: plain, markup, spaces, non-ASCII, format strings (a path cannot hold "/" or NUL).
FILE_STEMS = ["take", "take", "[/b]take", "[red]x[/red]", "t a k e", "tåke_名前", "take%s{0}", "take.[/]"]


def _encode(name: str) -> bytes:
    """Bytes of a name in a text file: UTF-8, lone surrogates as their (invalid) 3-byte forms."""
    return name.encode("utf-8", "surrogatepass")


def hostile_names(rng: random.Random, seed: readers.Seed) -> tuple[bytes, bytes | None]:
    """``(data, companion)`` of ``seed`` with one joint, bone, marker or clip name made hostile.

    BVH: a ROOT/JOINT name. ASF/AMC: a bone renamed in both files (so the pair still reads and
    the name reaches what the command prints and writes). C3D: a POINT:LABELS entry. npz: an
    entry of ``joint_names`` / ``labels`` or the clip ``name``.
    """
    new = rng.choice(HOSTILE_NAMES)
    data, comp = seed.data, seed.companion
    if seed.fmt == "bvh":
        ms = list(re.finditer(rb"(?:ROOT|JOINT)[ \t]+(\S+)", data))
        m = rng.choice(ms)
        token = _encode(new).replace(b"\n", b"")
        return data[: m.start(1)] + token + data[m.end(1):], comp
    if seed.fmt in ("amc", "asf"):
        asf, amc = (data, comp) if seed.fmt == "asf" else (comp, data)
        names = [n for n in re.findall(rb"^\s*name[ \t]+(\S+)", asf, re.M) if n != b"root"]
        old = rng.choice(names)
        token = _encode(new) if new.strip() else b"_"
        pat = re.compile(rb"(?<![\w])" + re.escape(old) + rb"(?![\w])")
        asf, amc = pat.sub(token.replace(b"\\", b"\\\\"), asf), pat.sub(token.replace(b"\\", b"\\\\"), amc)
        return (asf, amc) if seed.fmt == "asf" else (amc, asf)
    if seed.fmt == "c3d":
        b = bytearray(data)
        p = next((p for p in readers.c3d_parameters(data) if p["group"] == "POINT" and p["name"] == "LABELS"), None)
        if p is None or len(p["dims"]) < 2:
            return data, comp
        width, count = p["dims"][0], p["dims"][1]
        k = rng.randrange(max(1, count))
        label = _encode(new)[:width].ljust(width, b" ")
        at = p["data_at"] + k * width
        b[at: at + width] = label
        return bytes(b), comp
    if seed.fmt == "npz":
        with np.load(io.BytesIO(data), allow_pickle=False) as z:
            arrays = {k: z[k] for k in z.files}
        key = "joint_names" if "joint_names" in arrays else "labels"
        if rng.random() < 0.3:
            arrays["name"] = np.array(new)
        else:
            names = [str(x) for x in arrays[key]]
            names[rng.randrange(len(names))] = new
            arrays[key] = np.array(names)
        buf = io.BytesIO()
        np.savez(buf, **arrays)
        return buf.getvalue(), comp
    return data, comp


# -- mutated cases -------------------------------------------------------------------------------

_SUFFIX = {"bvh": ".bvh", "amc": ".amc", "asf": ".amc", "c3d": ".c3d", "npz": ".npz"}
# Command kinds and their weights: cheap ones more often (denoise imports torch).
_COMMANDS = [("info", 3), ("convert", 3), ("clean", 2), ("db build", 2), ("detect", 2), ("denoise", 1)]


def _is_markers(seed: readers.Seed) -> bool:
    return seed.fmt == "c3d" or (seed.fmt == "npz" and b"labels.npy" in seed.data[:4096] + seed.data[-4096:])


def mutant_case(seeds: list[readers.Seed], n: int) -> Case:
    """Case ``mutant-<n>``: one seed mutated (or its names made hostile), under a plain or hostile file name, one command.

    Deterministic in ``(seeds, n)``.
    """
    rng = random.Random(0x5EED0000 + n)
    seed = seeds[n % len(seeds)]
    how = "names" if rng.random() < 0.2 else "mutate"
    if how == "names":
        try:
            data, comp = hostile_names(rng, seed)
        except Exception:  # a seed without the names to change: fall back to the byte-level mutators
            how = "mutate"
    if how == "mutate":
        data, comp = readers.mutate(seed, 1_000_000 + n, seeds), seed.companion
    stem = rng.choice(FILE_STEMS)
    suffix = _SUFFIX[seed.fmt]
    inp = stem + suffix
    files: dict = {}
    if seed.fmt == "amc":
        files[inp], files[stem + ".asf"] = data, comp
    elif seed.fmt == "asf":
        files[inp], files[stem + ".asf"] = comp, data
    else:
        files[inp] = data
    kinds, weights = zip(*_COMMANDS)
    kind = rng.choices(kinds, weights)[0]
    markers = _is_markers(seed)
    out_dir = rng.choice(["", "", "new/sub/"])
    out_ext = ".npz" if markers or rng.random() < 0.4 else ".bvh"
    out = f"{out_dir}out{out_ext}"
    if kind == "info":
        argv = ("info", inp) + (("--joints",) if rng.random() < 0.5 else ())
        outs: tuple = ()
    elif kind == "convert":
        argv = ("convert", inp, out)
        if rng.random() < 0.3:
            argv += ("--fps", rng.choice(["30", "24", "1000", "0.5", "120"]))
        outs = (out,)
    elif kind == "clean":
        argv = ("clean", inp, "-o", out)
        outs = (out, _clean_record(out))
        if rng.random() < 0.7:
            argv += ("--steps", rng.choice(["fill,detect,repair", "fill,detect", "detect,repair"]))
        if rng.random() < 0.15:
            argv += ("--report", "report.html")
            outs += ("report.html",)
    elif kind == "db build":
        argv = ("db", "build", f"{out_dir}db", inp, "--fps", rng.choice(["30", "30", "24", "120"]))
        outs = (f"{out_dir}db",)
    elif kind == "detect":
        argv = ("detect", inp, "-o", f"{out_dir}det.npz") + (("--json",) if rng.random() < 0.3 else ())
        outs = (f"{out_dir}det.npz",)
    else:
        argv = ("denoise", inp, "-o", out)
        outs = (out,)
    return Case(f"mutant-{n}", files, (Step(argv, "any", outs),), inputs=tuple(files),
                about=f"{seed.name} ({how}) as {inp!r}: mocapkit {' '.join(argv)}")


def _clean_record(out: str) -> str:
    p = Path(out)
    return str(p.with_name(p.stem + ".clean.npz"))


# -- running -------------------------------------------------------------------------------------


def _env() -> dict:
    env = dict(os.environ)
    env.update(TQDM_DISABLE="1", OMP_NUM_THREADS="1", MKL_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1",
               NUMBA_NUM_THREADS="1", MPLBACKEND="Agg", COLUMNS="200", PYTHONDONTWRITEBYTECODE="1")
    env.pop("PYTHONWARNINGS", None)
    return env


def snapshot(root: Path) -> dict[str, str]:
    """Every path under ``root`` -> ``"dir"``, ``"link:<target>"`` or the SHA-256 of the file."""
    out: dict[str, str] = {}
    for dirpath, dirnames, filenames in os.walk(root):
        for n in dirnames + filenames:
            p = Path(dirpath) / n
            rel = str(p.relative_to(root))
            if p.is_symlink():
                out[rel] = "link:" + os.readlink(p)
            elif p.is_dir():
                out[rel] = "dir"
            else:
                h = hashlib.sha256()
                try:
                    with open(p, "rb") as fh:
                        for chunk in iter(lambda: fh.read(1 << 20), b""):
                            h.update(chunk)
                    out[rel] = h.hexdigest()
                except OSError as exc:
                    out[rel] = f"unreadable:{exc.errno}"
    return out


def write_case(case: Case, root: Path) -> None:
    """Lay the case's files out under ``root`` (created)."""
    root.mkdir(parents=True, exist_ok=True)
    for rel, content in case.files.items():
        p = root / rel
        p.parent.mkdir(parents=True, exist_ok=True)
        if content is None:
            p.mkdir(exist_ok=True)
        elif isinstance(content, Symlink):
            p.symlink_to(content.target)
        else:
            p.write_bytes(content)


def _can_write(folder: Path) -> bool:
    probe = folder / ".probe"
    try:
        probe.write_bytes(b"")
    except OSError:
        return False
    probe.unlink()
    return True


def _make_readonly(folder: Path) -> bool:
    """Make ``folder`` unwritable for this user: mode 555, and ``chattr +i`` for root. False if it stays writable."""
    folder.chmod(0o555)
    if _can_write(folder) and shutil.which("chattr"):
        subprocess.run(["chattr", "+i", str(folder)], capture_output=True)
    return not _can_write(folder)


def _undo_readonly(folder: Path) -> None:
    if shutil.which("chattr"):
        subprocess.run(["chattr", "-i", str(folder)], capture_output=True)
    try:
        folder.chmod(0o755)
    except OSError:
        pass


def run_step(argv, cwd: Path, limits: Limits, wall_s: float | None = None, capture: Path | None = None,
             server: ForkServer | None = None) -> StepResult:
    """Run ``mocapkit ARGV`` in ``cwd`` under ``limits``; the result has no findings yet (see :func:`judge`).

    A fresh interpreter (``python -c LAUNCHER``), or a process forked by ``server`` (:class:`ForkServer`).
    """
    argv = tuple(argv)
    cpu = limits.cpu_for(argv)
    wall = wall_s if wall_s is not None else limits.wall_s
    cap = Path(capture) if capture is not None else Path(tempfile.mkdtemp(prefix="mocapkit-fuzz-cap-"))
    cap.mkdir(parents=True, exist_ok=True)
    out_path, err_path = cap / "stdout", cap / "stderr"
    cmd = [sys.executable, "-c", LAUNCHER, str(limits.mem_bytes), str(int(cpu) + 1), str(limits.fsize_bytes), *argv]
    killed = threading.Event()
    t0 = time.monotonic()
    if server is not None:
        pid = server.start(argv, cwd, (limits.mem_bytes, int(cpu) + 1, limits.fsize_bytes), out_path, err_path)

        def kill() -> None:
            killed.set()
            try:
                os.killpg(pid, signal.SIGKILL)
            except OSError:
                pass

        timer = threading.Timer(wall, kill)
        timer.start()
        try:
            status, cpu_used, maxrss_kb = server.wait()
        finally:
            timer.cancel()
        code = os.waitstatus_to_exitcode(status)
    else:
        with open(out_path, "wb") as fo, open(err_path, "wb") as fe:
            proc = subprocess.Popen(cmd, cwd=cwd, stdin=subprocess.DEVNULL, stdout=fo, stderr=fe, env=_env(),
                                    start_new_session=True)
            pid = proc.pid

            def kill() -> None:
                killed.set()
                try:
                    os.killpg(proc.pid, signal.SIGKILL)
                except OSError:
                    pass

            timer = threading.Timer(wall, kill)
            timer.start()
            try:
                _, status, usage = os.wait4(proc.pid, 0)
            finally:
                timer.cancel()
            proc.returncode = os.waitstatus_to_exitcode(status)  # reaped here: keep Popen from waiting again
        code, cpu_used, maxrss_kb = proc.returncode, usage.ru_utime + usage.ru_stime, usage.ru_maxrss
    elapsed = time.monotonic() - t0
    orphans = False
    try:
        os.killpg(pid, 0)  # the leader is reaped: anything left in its group is a process it started
        orphans = True
        os.killpg(pid, signal.SIGKILL)
    except OSError:
        pass
    res = StepResult(argv, code if code >= 0 else None, -code if code < 0 else None, round(elapsed, 3),
                     round(cpu_used, 3), round(maxrss_kb / 1024, 1), _head_and_tail(out_path), _head_and_tail(err_path))
    if killed.is_set():
        res.findings.append(Finding("hang", f"still running after {wall:g} s wall clock (CPU {res.cpu_s:.1f} s); killed"))
    if orphans:
        res.findings.append(Finding("orphan_process", "processes of the command were alive after it exited (killed)"))
    if capture is None:
        shutil.rmtree(cap, ignore_errors=True)
    return res


# tqdm's bars: "desc:  40%|####      | 4/10 [00:01<00:02, 3.1it/s]" and, without a total, "desc: 5it [00:01, 3.1it/s]".
_PROGRESS = re.compile(r"[^\r\n]*?\d+%\|[^|\r\n]*\|[^\[\r\n]*\[[^\]\r\n]*\]|[^\r\n]*?\d+(?:\.\d+)?[kMG]?it \[[^\]\r\n]*\]")
_EXCEPTION_LINE = re.compile(r"^[A-Za-z_][\w.]*(?:Error|Exception|Interrupt|Exit|Warning|error)\b")


#: clean-batch's first line on stderr as its first take is handed out (mocapkit.cli.clean.start_line): no message
_BATCH_START = re.compile(r"cleaning \d+ (?:of \d+ )?takes? in .+ on .+; on a cold numba cache ")


def strip_progress(stderr: str) -> str:
    """Standard error without tqdm's progress bars (and the carriage returns between their updates)."""
    return "\n".join(ln for ln in _PROGRESS.sub("", stderr).replace("\r", "\n").splitlines() if ln.strip())


def _head_and_tail(path: Path, head: int = 4000, tail: int = 16000) -> str:
    """A captured stream: all of it, or its first and last characters (a traceback's header and its exception)."""
    size = path.stat().st_size
    with open(path, "rb") as fh:
        if size <= head + tail:
            return fh.read().decode("utf-8", "replace")
        first = fh.read(head)
        fh.seek(size - tail)
        last = fh.read()
    return first.decode("utf-8", "replace") + "\n[...]\n" + last.decode("utf-8", "replace")


def _traceback_summary(stderr: str) -> str:
    """First the exception line of the last traceback, then the innermost mocapkit frame."""
    block = stderr[stderr.rfind("Traceback (most recent call last)"):]
    lines = [ln for ln in block.splitlines() if ln.strip()]
    exc = next((ln for ln in reversed(lines) if _EXCEPTION_LINE.match(ln)),
               next((ln for ln in reversed(lines) if not ln.startswith((" ", "\t", "Traceback"))), lines[-1] if lines else ""))
    frames = re.findall(r'File "([^"]*mocapkit[/\\][^"]*)", line (\d+), in (\S+)', block)
    where = ""
    if frames:
        f, line, fn = frames[-1]
        where = f" (at mocapkit/{f.split('mocapkit/')[-1]}:{line} in {fn})"
    return (exc.strip() + where)[:600]


def judge(res: StepResult, step: Step, limits: Limits) -> list[Finding]:
    """The oracle for one command's exit, standard error and resources (files are judged in :func:`run_case`)."""
    found: list[Finding] = []
    err = strip_progress(res.stderr)
    lines = [ln for ln in err.splitlines() if not (step.argv[:1] == ("clean-batch",) and _BATCH_START.match(ln))]
    cpu_limit = limits.cpu_for(step.argv)
    hung = any(f.kind == "hang" for f in res.findings)
    if any(s in err for s in _MEMORY_SIGNS) or res.peak_rss_mb * (1 << 20) > limits.mem_bytes:
        first = next((ln for ln in reversed(lines) if any(s in ln for s in _MEMORY_SIGNS)), "")
        found.append(Finding("memory", f"peak RSS {res.peak_rss_mb:.0f} MB under RLIMIT_AS {limits.mem_bytes >> 20} MB: "
                                       f"{first.strip()[:300]}"))
    if res.signal == signal.SIGXCPU or res.cpu_s > cpu_limit:
        found.append(Finding("time", f"CPU {res.cpu_s:.1f} s over the budget of {cpu_limit:.0f} s (wall {res.wall_s:.1f} s)"))
    if "Traceback (most recent call last)" in err:
        found.append(Finding("traceback", _traceback_summary(err)))
    elif res.signal is not None and not hung and res.signal not in (signal.SIGXCPU, signal.SIGXFSZ):
        found.append(Finding("signal", f"killed by signal {res.signal} ({signal.Signals(res.signal).name}); "
                                       f"stderr: {' | '.join(lines[-3:])[:300]}"))
    elif res.signal == signal.SIGXFSZ:
        found.append(Finding("output_size", f"wrote a file over RLIMIT_FSIZE ({limits.fsize_bytes >> 20} MB)"))
    elif res.returncode is not None:
        batch = step.argv[:1] == ("clean-batch",)
        if res.returncode == 0:
            if lines:
                found.append(Finding("message", f"exit 0 with standard error: {' | '.join(lines[:3])[:400]}"))
        elif res.returncode == 2 or (res.returncode == 1 and batch):
            ok_line = len(lines) == 1 and lines[0].startswith("mocapkit: error: ")
            if not ok_line and not (batch and res.returncode == 1 and not lines):
                found.append(Finding("message", f"exit {res.returncode} with {len(lines)} stderr lines, not one "
                                                f"'mocapkit: error: ...': {' | '.join(lines[:4])[:400]}"))
        else:
            found.append(Finding("exit", f"exit code {res.returncode}: {' | '.join(lines[-3:])[:400]}"))
    if res.returncode is not None and not found:
        if step.expect == "ok" and res.returncode != 0:
            found.append(Finding("refused", f"a valid input refused: {lines[-1][:400] if lines else 'exit %d' % res.returncode}"))
        elif step.expect == "refuse" and res.returncode == 0:
            said = res.stdout.strip().splitlines()[0][:300] if res.stdout.strip() else "(nothing on stdout)"
            found.append(Finding("accepted", f"must be refused, exited 0: {said}"))
    return found


def _under(rel: str, outs) -> bool:
    return any(rel == o or rel.startswith(o.rstrip("/") + "/") for o in outs)


def file_findings(before: dict, after: dict, step: Step, res: StepResult, inputs: tuple, root: Path) -> list[Finding]:
    """The oracle for files: ``before`` and ``after`` are :func:`snapshot` s of the case's folder around the step."""
    found: list[Finding] = []
    overwrite = "--overwrite" in step.argv
    replaceable = [o for o in step.outputs] if overwrite else []
    for rel, h in before.items():
        protected = _under(rel, inputs) or not _under(rel, replaceable)
        if not protected:
            continue
        if rel not in after:
            found.append(Finding("input_lost", f"{rel} is gone"))
        elif after[rel] != h:
            found.append(Finding("input_changed", f"{rel} changed"))
    parts = [rel for rel in after if _PARTIAL.search(Path(rel).name) and rel not in before]
    for rel in parts:
        found.append(Finding("partial_output", f"{rel} left behind"))
    # a batch that exits 1 cleaned some takes and reported the others: its outputs are results, not leftovers
    failed = res.returncode != 0 and not (step.argv[:1] == ("clean-batch",) and res.returncode == 1)
    if failed:
        new = sorted(rel for rel in after if rel not in before and rel not in parts)
        if new:
            found.append(Finding("failed_run_output", f"the failed run left {', '.join(new[:6])}"
                                                      + (f" and {len(new) - 6} more" if len(new) > 6 else "")))
    elif step.max_output_ratio is not None:
        ins = [(root / i).stat().st_size for i in inputs if (root / i).is_file()]
        biggest = max(ins) if ins else 1
        for o in step.outputs:
            p = root / o
            if p.is_file() and p.stat().st_size > step.max_output_ratio * biggest:
                found.append(Finding("output_size", f"{o} is {p.stat().st_size / biggest:.1f}x the input "
                                                    f"({p.stat().st_size / 2**20:.1f} MB)"))
    return found


def run_case(case: Case, workdir: Path, limits: Limits, keep: bool = False, server: ForkServer | None = None) -> CaseResult:
    """Lay the case out in a fresh folder under ``workdir``, run its steps, judge each; remove the folder unless ``keep``.

    ``server``: run the steps as processes forked by it (:func:`run_step`).
    """
    result = CaseResult(case.name)
    base = Path(tempfile.mkdtemp(prefix="case-", dir=workdir))
    root = base / "run"
    try:
        write_case(case, root)
        for ro in case.readonly:
            if not _make_readonly(root / ro):
                result.skipped = f"cannot make {ro} read-only as this user"
                return result
        for k, step in enumerate(case.steps):
            before = snapshot(root)
            lim = limits if case.cpu_s is None else dataclasses.replace(limits, cpu_s={"default": case.cpu_s})
            res = run_step(step.argv, root, lim, wall_s=case.wall_s, capture=base / f"capture-{k}", server=server)
            after = snapshot(root)
            res.findings += judge(res, step, lim)
            res.findings += file_findings(before, after, step, res, case.inputs, root)
            result.steps.append(res)
        if case.check is not None:
            result.findings += [Finding("check", p) for p in case.check(root, result.steps)]
    except Exception as exc:  # the harness itself failed on this case: report it, never hide it
        result.findings.append(Finding("check", f"harness error: {type(exc).__name__}: {exc}"))
    finally:
        for ro in case.readonly:
            _undo_readonly(root / ro)
        if not keep:
            shutil.rmtree(base, ignore_errors=True)
    return result


def run_cases(cases, workdir: Path, limits: Limits, workers: int = 2, on_result=None,
              fork: "bool | ForkPool" = False) -> list[CaseResult]:
    """Run cases (``Case`` objects or zero-argument factories) ``workers`` at a time; results in input order.

    ``fork``: each worker runs its steps through a :class:`ForkServer` of its own (see :func:`run_step`), from
    the :class:`ForkPool` given, or from one made (and closed) for this call when ``True``.
    """
    workdir = Path(workdir)
    workdir.mkdir(parents=True, exist_ok=True)
    pool = fork if isinstance(fork, ForkPool) else (ForkPool() if fork else None)

    def one(c):
        case = c() if callable(c) else c
        server = pool.take() if pool is not None else None
        try:
            r = run_case(case, workdir, limits, server=server)
        finally:
            if server is not None:
                pool.give(server)
        if on_result is not None:
            on_result(case, r)
        return r

    try:
        with ThreadPoolExecutor(max_workers=max(1, workers)) as pool_threads:
            return list(pool_threads.map(one, cases))
    finally:
        if pool is not None and pool is not fork:
            pool.close()


def baseline_cpu(seeds: list[readers.Seed], workdir: Path, limits: Limits,
                 fork: "bool | ForkPool" = False) -> tuple[dict, list[CaseResult]]:
    """CPU seconds of each command kind on an unmutated seed, run one after another (the first warms numba's cache).

    The BVH seed for all but ``denoise``, which runs on the AMC seed (the shipped denoiser's rig).

    Returns ``({kind: cpu_s}, results)``; the results are judged like any case (an unmutated
    seed must run cleanly). ``fork``: run them through a :class:`ForkServer` (of the :class:`ForkPool` given,
    or one of its own when ``True``): their CPU then leaves out Python's start and mocapkit's imports, as the
    runs it budgets do when they are forked too.
    """
    seed = next(s for s in seeds if s.fmt == "bvh")
    walk = next(s for s in seeds if s.fmt == "amc")  # the shipped denoiser's rig (CMU ASF)
    files = {"take.bvh": seed.data, "walk.amc": walk.data, "walk.asf": walk.companion}
    runs = {
        "info": ("info", "take.bvh", "--joints"),
        "convert": ("convert", "take.bvh", "out.npz"),
        "clean": ("clean", "take.bvh", "-o", "out.bvh"),
        "db build": ("db", "build", "db", "take.bvh", "--fps", "30"),
        "detect": ("detect", "take.bvh", "-o", "det.npz"),
        "denoise": ("denoise", "walk.amc", "-o", "out.bvh"),
    }
    cpu: dict[str, float] = {}
    results = []
    pool = fork if isinstance(fork, ForkPool) else (ForkPool() if fork else None)
    server = pool.take() if pool is not None else None
    for kind, argv in runs.items():
        case = Case(f"unmutated-{kind.replace(' ', '-')}", dict(files), (Step(argv, "ok", ()),), inputs=tuple(files))
        results.append(r := run_case(case, Path(workdir), limits, server=server))
        cpu[kind] = r.steps[0].cpu_s if r.steps else float("nan")
    if server is not None:
        pool.give(server)
        if pool is not fork:
            pool.close()
    return cpu, results


def summarize(results: list[CaseResult]) -> dict:
    """Counts by :data:`KIND_GROUPS` (runs with at least one finding of the group), and every finding as a row."""
    runs = sum(len(r.steps) for r in results)
    counts = {g: 0 for g in KIND_GROUPS}
    rows = []
    for r in results:
        for s in r.steps:
            kinds = {f.kind for f in s.findings}
            for g, ks in KIND_GROUPS.items():
                counts[g] += bool(kinds & set(ks))
        if any(f.kind in KIND_GROUPS["expectation_failures"] for f in r.findings):
            counts["expectation_failures"] += 1
        for cmd, f in r.all_findings:
            st = next((s for s in r.steps if "mocapkit " + " ".join(s.argv) == cmd), None)
            rows.append({"case": r.name, "command": cmd, "kind": f.kind, "detail": f.detail,
                         "wall_s": st.wall_s if st else None, "cpu_s": st.cpu_s if st else None,
                         "peak_rss_mb": st.peak_rss_mb if st else None})
    return {"cases": len(results), "runs": runs, "skipped": [r.name + ": " + r.skipped for r in results if r.skipped],
            **counts, "findings": rows}
