# Two commands do everything: `make demo` and `make test` (each sets up .venv as needed).
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed-$(shell cat pyproject.toml | cksum | cut -d' ' -f1)

.PHONY: demo test test-vapoursynth check typecheck bench clean

$(STAMP): pyproject.toml
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e ".[test]"
	rm -f $(VENV)/.installed-*
	touch $@

demo: $(STAMP)
	$(BIN)/unjello demo -y

test: $(STAMP)
	$(BIN)/ruff check src tests benchmarks examples
	$(BIN)/python -m pytest -n auto --durations=25
	$(MAKE) test-vapoursynth

# VapourSynth's wheel needs CPython 3.12+: its filter is tested in a venv of its own,
# where pyenv has a 3.12 (elsewhere those tests skip, saying why).
VS_VENV := .venv312
test-vapoursynth:
	@if PYENV_VERSION=3.12.1 python3.12 -c pass 2>/dev/null; then \
	  test -x $(VS_VENV)/bin/python || PYENV_VERSION=3.12.1 python3.12 -m venv $(VS_VENV); \
	  $(VS_VENV)/bin/python -m pip install --quiet -e ".[vapoursynth]" pytest; \
	  $(VS_VENV)/bin/python -m pytest -q -p no:cacheprovider tests/test_vapoursynth.py; \
	else echo "no CPython 3.12 here: the VapourSynth tests skip"; fi

# The quick loop: ruff and every test but the slow end-to-end ones (marked `slow`), on
# every core (pytest-xdist).
check: $(STAMP)
	$(BIN)/ruff check src tests benchmarks examples
	$(BIN)/python -m pytest -m "not slow" -q -n auto

typecheck: $(STAMP)
	$(BIN)/python -m pip install --quiet mypy
	$(BIN)/mypy src/unjello --ignore-missing-imports

bench: $(STAMP)
	$(BIN)/python benchmarks/pairs.py

clean:
	rm -rf $(VENV) build *.egg-info .pytest_cache .ruff_cache
