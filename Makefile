# Two commands do everything: `make demo` and `make test` (each sets up .venv as needed).
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed-$(shell cat pyproject.toml | cksum | cut -d' ' -f1)

.PHONY: demo test check typecheck bench clean

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
	$(BIN)/python -m pytest

# The quick loop: ruff and every test but the slow end-to-end ones (marked `slow`).
check: $(STAMP)
	$(BIN)/ruff check src tests benchmarks examples
	$(BIN)/python -m pytest -m "not slow" -q

typecheck: $(STAMP)
	$(BIN)/python -m pip install --quiet mypy
	$(BIN)/mypy src/unjello --ignore-missing-imports

bench: $(STAMP)
	$(BIN)/python benchmarks/pairs.py

clean:
	rm -rf $(VENV) build *.egg-info .pytest_cache .ruff_cache
