# `make demo` and `make test` set up everything on a fresh machine (virtual environment,
# pinned install from constraints.txt) before they run.
PYTHON ?= python3.11
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

# The thread defaults of agents/runtime.py (THREAD_VARIABLES, set to 1 unless already set; the reasons
# are in its docstring), exported here too so that `make test` and every process it starts get them
# before numpy is imported.  tests/unit/agents/test_runtime.py checks that the two lists agree.
export OPENBLAS_NUM_THREADS ?= 1
export OMP_NUM_THREADS ?= 1
export MKL_NUM_THREADS ?= 1
export NUMBA_NUM_THREADS ?= 1

.PHONY: demo reproduce test test-slow test-audit test-all test-fast install clean

$(STAMP): pyproject.toml constraints.txt
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -c constraints.txt -e '.[dev,sweep]'
	$(BIN)/python -m agents.warmup
	touch $(STAMP)

install: $(STAMP)

# The demo: train SAC on DeadTime/PID-v3 (fixed mode, configs/sac.yaml, a few minutes on 2 cores),
# then evaluate it against every rule and the oracle on the held-out test set.  Interrupted, it
# resumes from the latest checkpoint; finished, it only re-evaluates (cached per plant).
DEMO := runs/demo
demo: $(STAMP)
	$(BIN)/deadtime train --config configs/sac.yaml --env DeadTime/PID-v3 --out $(DEMO) --resume
	$(BIN)/deadtime evaluate --env DeadTime/PID-v3 --policies agent=$(DEMO)/model.zip,all-rules,oracle \
		--n 50 --seed 0 --out $(DEMO)/eval --workers 2

reproduce: $(STAMP)
	$(BIN)/deadtime reproduce all

# The tests run in TEST_WORKERS processes (pytest-xdist; `make test TEST_WORKERS=auto` takes one per
# core, TEST_WORKERS=0 runs them all in one process).  `make test` runs every test not marked slow (a few
# minutes on 2 cores); `make test-slow` the ones marked slow (training and resuming agents, Ray
# sweeps, the oracle against every rule on every benchmark plant); `make test-all` both.  CI
# (.ci/run) runs `make test`, then `make test-slow`.  A module's tests stay in one process
# (--dist loadscope), so a module's expensive fixture (a trained agent, a sweep) is made once.
TEST_WORKERS ?= 2
PYTEST := $(BIN)/python -m pytest -q -n $(TEST_WORKERS) --dist loadscope

test: $(STAMP)
	$(PYTEST) -m "not slow and not audit" tests

test-slow: $(STAMP)
	$(PYTEST) -m "slow and not audit" tests

# The episode audit (marked audit, in no other target): 1000 disturbed episodes on every v3 id and mode,
# each within the bounds of tests/property/test_bounded_episodes.py (hours on 2 cores; it prints
# the episodes run, the slowest and the memory growth).
test-audit: $(STAMP)
	$(PYTEST) -s -m audit tests

test-all: test test-slow

# the same as `make test`
test-fast: test

clean:
	rm -rf $(VENV) build *.egg-info
