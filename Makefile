# The two commands of the README: `make demo` (the main job) and `make test`.
# Each creates or updates the virtual environment .venv and installs what it needs.
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed-stamp
# the tests: one worker per core, whole modules at a time, the longest first (tests/conftest.py)
XDIST := -n auto --dist loadfile --no-loadscope-reorder

.PHONY: demo test bench system-deps venv clean

$(STAMP): pyproject.toml Makefile tools/one-opencv.sh
	@test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[dev]'
	@bash tools/one-opencv.sh $(PY)
	@touch $(STAMP)

venv: $(STAMP)

system-deps:
	@bash tools/install-system-deps.sh

demo: system-deps venv
	$(VENV)/bin/catadioptric demo --out out/demo

test: system-deps venv
	$(PY) -m pytest -q -p no:cacheprovider $(XDIST)

bench: venv
	$(PY) bench/run.py

clean:
	rm -rf $(VENV) out
