# Everything builds its own virtualenv in .venv, so a fresh machine needs only python3 and make.
VENV ?= .venv
PY := $(VENV)/bin/python
BIN := $(VENV)/bin

.PHONY: demo test lint bench clean browser

# Two stamps: the demo needs only the runtime (.runtime); lint and tests add the test tools
# (.installed, the name kept so `make .venv/.installed` still builds everything).
# uv installs the same packages as pip in a fraction of the time (benchmarks/results/
# suite-workers-2026-11-29.txt); pip stays as the fallback wherever uv cannot be fetched or
# cannot reach the index. --compile-bytecode as pip does: without .pyc files (and with
# PYTHONDONTWRITEBYTECODE set) every command compiled numba's sources at start, 1.9 s
# against 0.9 s, and the suite took 1228 s of CPU instead of about 900.
INSTALL = $(BIN)/uv pip install --quiet --compile-bytecode --python $(PY)
PIP = $(PY) -m pip install --quiet

$(VENV)/.runtime: pyproject.toml
	python3 -m venv $(VENV)
	$(PIP) uv || $(PIP) --upgrade pip
	$(INSTALL) -e . || $(PIP) -e .
	touch $@

$(VENV)/.installed: $(VENV)/.runtime
	$(INSTALL) -e '.[test]' || $(PIP) -e '.[test]'
	touch $@

demo: $(VENV)/.runtime
	$(BIN)/shockdyno demo

lint: $(VENV)/.installed
	$(BIN)/ruff check src tests benchmarks
	$(BIN)/ruff format --check src tests benchmarks
	$(BIN)/mypy src

# The report's browser tests need a Chromium that is already on this machine (the PATH,
# $$SHOCKDYNO_CHROMIUM, Playwright's cache): nothing is installed, `make test` never changes
# the system. Without one they skip, and pytest's summary says so in one line;
# `make browser` tells beforehand which browser the tests will use.
browser:
	@python3 tests/report/browser.py

# Three workers on the CI machine's two cores: a third of the suite waits on real-time
# simulated rigs, and a third worker fills those waits (benchmarks/results/suite-workers-
# 2026-11-29.txt). A module stays on one worker (--dist loadscope), so its recordings
# fixture is made once; the modules marked slow go first (tests/conftest.py orders them,
# --no-loadscope-reorder keeps that order), so none of them starts at the end.
# mypy (about 20 s on one core) runs beside the tests rather than before them, so that its
# core is not idle while it checks; its output follows the tests', and either failing fails
# `make test`.
test: $(VENV)/.installed
	$(BIN)/ruff check src tests benchmarks
	$(BIN)/ruff format --check src tests benchmarks
	@echo "$(BIN)/mypy src (beside the tests; its result after them), $(BIN)/python tests/warm_kernels.py (numba kernels compiled once, before the test workers start)"
	@$(BIN)/mypy src > $(VENV)/mypy.out 2>&1 & mypy=$$!; \
	$(BIN)/python tests/warm_kernels.py || echo "(kernel warm-up failed: each test worker compiles them)"; \
	$(BIN)/pytest -q -n 3 --dist loadscope --no-loadscope-reorder; tests=$$?; \
	wait $$mypy; types=$$?; echo "$(BIN)/mypy src"; cat $(VENV)/mypy.out; \
	test $$tests -eq 0 && test $$types -eq 0

# The benchmarks' own extras (pysindy for bench_diagnose's baseline).
$(VENV)/.bench: $(VENV)/.runtime
	$(INSTALL) -e '.[bench]' || $(PIP) -e '.[bench]'
	touch $@

bench: $(VENV)/.bench
	@for b in benchmarks/bench_*.py; do echo "== $$b"; $(PY) $$b || exit 1; done

clean:
	rm -rf $(VENV) build src/*.egg-info .pytest_cache .mypy_cache .ruff_cache
