# Two entry points for a fresh clone: `make demo` and `make test`.
# Both create .venv when it is missing. torch is pinned to the CPU wheel that lies on disk
# (torch==2.13.0 asked for in the same pip run as the package, which declares torch>=2.2), so nothing pulls a CUDA build.
# pip installs with --no-compile and compileall then byte-compiles the venv's site-packages on every core (-j 0): the
# .pyc files pip writes there, but pip writes them one by one on one core. They are needed: under PYTHONDONTWRITEBYTECODE
# imports write none, and every process would compile what it imports again.
# Installing ends with `python -m mocapkit.warmup`: the numba kernels `mocapkit clean` needs are
# compiled and cached once, so the first clean does not spend its time compiling.
PYTHON ?= python3.11
VENV := .venv
PY := $(VENV)/bin/python
PIP := $(PY) -m pip
# -qq and the exit status ignored: torch/testing/_internal/py312_intrinsics.py is Python 3.12 syntax (pip skips it too).
COMPILE := $(PY) -m compileall -qq -j 0 $$($(PY) -c 'import site; print(*site.getsitepackages())') || true
OUT := demo_out
SAMPLE := src/mocapkit/data/131_01.bvh
WALK := src/mocapkit/data/12_walk.amc
DATA := src/mocapkit/data
SNEAK := $(DATA)/HDM_bk_sneak2StepsLStart_005_120.amc

.PHONY: demo test install install-test bench clean

$(PY):
	@command -v $(PYTHON) >/dev/null 2>&1 || { echo "$(PYTHON) not found; run make PYTHON=python3" >&2; exit 1; }
	$(PYTHON) -m venv $(VENV)
	$(PIP) install --upgrade pip

$(VENV)/.installed: pyproject.toml | $(PY)
	$(PIP) install --no-compile torch==2.13.0 -e .
	$(COMPILE)
	$(PY) -m mocapkit.warmup
	touch $@

# The test install is one pip run with the test extras (not the plain install and then the extras: one resolve, one
# editable build fewer); it also counts as the plain install.
# Beside the warm-up, one pytest collection writes the bytecode of the tests (assertions rewritten) and of the sources
# (imported by --doctest-modules) once, with writing bytecode on whatever PYTHONDONTWRITEBYTECODE says: otherwise each
# xdist worker rewrites every test module itself (~11 s CPU each) and every `mocapkit` subprocess of the tests compiles
# the sources it imports. It runs while the warm-up's shorter process leaves a core free; its output is not needed
# (the test run reports any collection error itself).
$(VENV)/.installed-test: pyproject.toml | $(PY)
	$(PIP) install --no-compile torch==2.13.0 -e '.[test]'
	$(COMPILE)
	env -u PYTHONDONTWRITEBYTECODE $(PY) -m pytest --collect-only -q -p no:cacheprovider >/dev/null 2>&1 & collect=$$!; \
	  $(PY) -m mocapkit.warmup; rc=$$?; wait $$collect; exit $$rc
	touch $(VENV)/.installed $@

install: $(VENV)/.installed
install-test: $(VENV)/.installed-test

demo: install  # demo_out/ is the demo's own folder: a rerun replaces what the last run wrote there (--overwrite)
	@mkdir -p $(OUT)
	@echo "== the main job: a real take with real-style capture errors, cleaned in one command, with a report"
	$(VENV)/bin/mocapkit corrupt $(WALK) $(OUT)/12_walk_broken.npz --kind errors --seed 7 --overwrite
	$(VENV)/bin/mocapkit clean $(OUT)/12_walk_broken.npz -o $(OUT)/12_walk_cleaned.bvh --reference $(WALK) --report $(OUT)/12_walk_report.html --png $(OUT)/12_walk_summary.png --overwrite
	@echo "== the single tools"
	$(VENV)/bin/mocapkit info $(SAMPLE)
	$(VENV)/bin/mocapkit convert $(SAMPLE) $(OUT)/131_01_30fps.bvh --fps 30 --overwrite
	$(VENV)/bin/mocapkit corrupt $(OUT)/131_01_30fps.bvh $(OUT)/131_01_noisy.bvh --kind noise --amount 0.5 --seed 7 --overwrite
	$(VENV)/bin/mocapkit corrupt $(OUT)/131_01_30fps.bvh $(OUT)/131_01_errors.bvh --kind errors --seed 7 --overwrite
	$(VENV)/bin/mocapkit plot $(OUT)/131_01_30fps.bvh $(OUT)/131_01_noisy.bvh --joint LeftKnee -o $(OUT)/131_01_LeftKnee.png --overwrite
	$(VENV)/bin/mocapkit plot $(OUT)/131_01_30fps.bvh $(OUT)/131_01_errors.bvh --joint LeftElbow -o $(OUT)/131_01_errors_LeftElbow.png --overwrite
	$(VENV)/bin/mocapkit corrupt $(WALK) $(OUT)/12_walk_noisy.npz --kind noise --amount 0.5 --seed 7 --overwrite
	$(VENV)/bin/mocapkit denoise $(OUT)/12_walk_noisy.npz -o $(OUT)/12_walk_denoised.bvh --reference $(WALK) --overwrite
	$(VENV)/bin/mocapkit plot $(WALK) $(OUT)/12_walk_noisy.npz $(OUT)/12_walk_denoised.bvh --joint ltibia -o $(OUT)/12_walk_denoised_ltibia.png --overwrite
	$(VENV)/bin/mocapkit corrupt $(WALK) $(OUT)/12_walk_gaps.npz --kind gaps --seed 7 --overwrite
	$(VENV)/bin/mocapkit fill $(OUT)/12_walk_gaps.npz -o $(OUT)/12_walk_filled.bvh --reference $(WALK) --overwrite
	$(VENV)/bin/mocapkit db build $(OUT)/hdm_db $(DATA)/HDM_bk_sneak2StepsLStart_004_120.amc $(DATA)/HDM_bd_jogLeftCircle4StepsRstart_001_120.amc --fps 30 --mirror --overwrite
	$(VENV)/bin/mocapkit reconstruct --db $(OUT)/hdm_db --markers $(SNEAK) -o $(OUT)/sneak_from_6_markers.bvh --reference $(SNEAK) --overwrite
	$(VENV)/bin/mocapkit reconstruct --db $(OUT)/hdm_db --accelerometers $(SNEAK) -o $(OUT)/sneak_from_4_accelerometers.bvh --reference $(SNEAK) --overwrite
	@echo "demo outputs written to $(OUT)/; open $(OUT)/12_walk_report.html in a browser"
	@echo "$(OUT)/12_walk_cleaned.clean.npz is the cleaning's record: every change and why, so each can be kept or undone."
	@echo "next: review: untick changes in the report, press \"Download decisions\", then apply them without cleaning again:"
	@echo "  mocapkit clean $(OUT)/12_walk_broken.npz -o $(OUT)/12_walk_final.bvh --decisions 12_walk_broken.decisions.json --record $(OUT)/12_walk_cleaned.clean.npz"
	@echo "  (docs/guide/cleaning.md, \"Review and decide\")"

# --dist loadscope keeps each test module on one worker, so a module's costly fixtures are built once
# The browser check (which may apt-get Chromium on a bare machine) runs beside the install, not after it.
# pytest-xdist: one worker process per CPU this process may run on (`nproc`, whatever OMP_NUM_THREADS says; at most
# 4), so a 2-core machine runs two.
# Not xdist's `auto`: that counts physical cores through psutil, one on a 2-vCPU machine whose vCPUs are the two
# hyperthreads of one core (the suite then runs serially, twice as long), and the host's cores in a container.
WORKERS := $(shell n=$$(env -u OMP_NUM_THREADS -u OMP_THREAD_LIMIT nproc 2>/dev/null || echo 2); [ "$$n" -gt 4 ] && n=4; echo $$n)

test:
	@bash scripts/ensure-chromium.sh & browser=$$!; $(MAKE) --no-print-directory install-test; rc=$$?; wait $$browser; exit $$rc
	$(PY) -m pytest -q -m "not slow" --numprocesses=$(WORKERS) --dist loadscope

bench: install-test
	$(PIP) install -e '.[bench]'
	$(PY) benchmarks/io_speed.py --json
	$(PY) benchmarks/knn_speed.py --json
	$(PY) benchmarks/lng_vs_dtw.py --json
	$(PY) benchmarks/olng_update.py --json
	$(PY) benchmarks/krueger_analysis.py --json
	$(PY) benchmarks/ssa_detection.py --json
	$(PY) benchmarks/ssa_dtw.py --json
	$(PY) benchmarks/ssa_repair.py --json
	$(PY) benchmarks/ssa_speed.py --json
	$(PY) benchmarks/ssa_take_scan.py --json
	$(PY) benchmarks/deep_denoise.py --json
	$(PY) benchmarks/deep_gapfill.py --json
	$(PY) benchmarks/deep_speed.py --json
	$(PY) benchmarks/reconstruct_markers.py --json
	$(PY) benchmarks/reconstruct_accelerometers.py --json
	$(PY) benchmarks/reconstruct_ssg.py --json
	$(PY) benchmarks/reconstruct_multilinear.py --json
	$(PY) benchmarks/clean_takes.py --json
	$(PY) benchmarks/first_run.py --json
	$(PY) benchmarks/fuzz_readers.py --json
	$(PY) benchmarks/fuzz_commands.py --json
	$(PY) benchmarks/report.py

clean:
	rm -rf $(OUT) .pytest_cache
