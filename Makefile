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

.PHONY: demo reproduce test test-fast install clean

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

test: $(STAMP)
	$(BIN)/python -m pytest -q tests

test-fast: $(STAMP)
	$(BIN)/python -m pytest -q -m "not slow" tests

clean:
	rm -rf $(VENV) build *.egg-info
