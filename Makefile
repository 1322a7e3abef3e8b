# Two entry points: `make repro` (environment + the whole DVC pipeline) and `make test`.
PYTHON ?= python3.11
VENV ?= .venv
BIN := $(VENV)/bin

.PHONY: repro test bench env

env: $(VENV)/.installed

$(VENV)/.installed: pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install -q --upgrade pip
	$(BIN)/python -m pip install -q -e '.[test]'
	touch $@

repro: env  # dvc repro, two single-threaded stages at once, each clocked (tools/timed_repro.py)
	PATH="$(abspath $(BIN)):$$PATH" $(BIN)/python tools/timed_repro.py --jobs 2

test: env
	if [ "$$CI" = true ]; then bash tests/setup_chromium.sh; fi
	PATH="$(abspath $(BIN)):$$PATH" $(BIN)/python -m pytest

bench: env
	for script in bench/bench_*.py; do $(BIN)/python $$script || exit 1; done
