# Two entry points: `make repro` (environment + the whole DVC pipeline) and `make test`.
# Python 3.11, 3.12 or 3.13: the first of them that runs here, or the one named by `make PYTHON=...`.
PYTHON ?= $(firstword $(foreach python,python3.11 python3.12 python3.13,\
	$(shell $(python) -c '' >/dev/null 2>&1 && echo $(python))))
VENV ?= .venv
BIN := $(VENV)/bin

.PHONY: repro test bench env

env: $(VENV)/.installed

$(VENV)/.installed: pyproject.toml requirements.lock
	@test -n "$(PYTHON)" || { echo "needs Python 3.11, 3.12 or 3.13 on PATH, or make PYTHON=/path/to/python3.x"; exit 1; }
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install -q --upgrade pip
	$(BIN)/python -m pip install -q -c requirements.lock -e '.[test]'
	touch $@

# the stage commands run on a Dask LocalCluster of this machine (JOBS threads; one worker per GPU),
# listening on 127.0.0.1 only; DASHBOARD=0.0.0.0:8787 opens its dashboard (every stage's command
# and log, no login) to the network. Or on a running cluster over TLS, its certificates in Dask's
# config: make repro DASK_ADDRESS=tls://host:8786; plain tcp:// to another machine only with
# DASK_INSECURE=1, on a network you trust (docs/cluster.md)
JOBS ?= $(shell nproc 2>/dev/null || echo 2)
DASK_ADDRESS ?=
DASK_INSECURE ?=
DASHBOARD ?=
repro: env  # dvc repro, two single-threaded stages at once on 2 cores, each clocked (tools/timed_repro.py)
	PATH="$(abspath $(BIN)):$$PATH" $(BIN)/python -m tools.timed_repro --jobs $(JOBS) \
		$(if $(DASK_ADDRESS),--address $(DASK_ADDRESS)) \
		$(if $(filter 1 yes true,$(DASK_INSECURE)),--insecure) \
		$(if $(DASHBOARD),--dashboard $(DASHBOARD))

# the suite in TEST_WORKERS processes (pytest-xdist), each test file whole in one of them, so that a
# file's shared set-ups are built once; TEST_WORKERS=0 runs it in this process
TEST_WORKERS ?= $(shell nproc 2>/dev/null || echo 2)
test: env
	if [ "$$CI" = true ]; then bash tests/setup_chromium.sh; fi
	PATH="$(abspath $(BIN)):$$PATH" $(BIN)/python -m pytest -n $(TEST_WORKERS) --dist loadfile

# Every speed benchmark (bench/README.md). One that needs a trained model or another pipeline output
# names it and the `dvc repro` that makes it, and exits 3: listed at the end, not a failure.
bench: env
	@failed=""; waiting=""; \
	for script in bench/bench_*.py; do \
	  echo "== $$script"; $(BIN)/python -m bench.$$(basename $$script .py); status=$$?; \
	  if [ $$status -eq 3 ]; then waiting="$$waiting $$script"; \
	  elif [ $$status -ne 0 ]; then failed="$$failed $$script"; fi; \
	done; \
	if [ -n "$$waiting" ]; then echo "needs pipeline outputs (named above):$$waiting"; fi; \
	if [ -n "$$failed" ]; then echo "failed:$$failed"; exit 1; fi
