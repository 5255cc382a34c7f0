# Two commands set everything up on a fresh clone: `make demo` and `make test`.
PYTHON ?= python3
VENV   ?= .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

.PHONY: demo test lint check bench reliability docs package screenshots generate clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[dev]'
	touch $(STAMP)

demo: $(STAMP)
	$(BIN)/robostar --port sim:// demo

# Two workers (pytest-xdist): CI has two cores; the suite takes ~7 min so, ~11 min in one.
test: $(STAMP)
	$(BIN)/python -m pytest -n 2

# The clients' methods are written from the plans in client/surface.py (a test fails when stale).
generate: $(STAMP)
	$(BIN)/python tools/generate_faces.py
	$(BIN)/python -m pip install --quiet grpcio-tools && $(BIN)/python tools/generate_sparkplug.py

lint: $(STAMP)
	$(BIN)/ruff check src tests bench reliability tools
	$(BIN)/ruff format --check src tests bench reliability tools
	$(BIN)/mypy

check: lint test

# The documentation site (mkdocs + material + mkdocstrings) in strict mode: a broken link or
# reference fails the build. Output in site/.
docs: $(STAMP)
	$(BIN)/python -m pip install --quiet -e '.[docs]'
	NO_MKDOCS_2_WARNING=1 $(BIN)/mkdocs build --strict --quiet

# A wheel and an sdist in dist/, checked for the files a user needs (py.typed, the licence).
package: $(STAMP)
	$(BIN)/python -m pip install --quiet -e '.[package]'
	rm -rf dist
	$(BIN)/python -m build --quiet --outdir dist . >/dev/null
	$(BIN)/python tools/check_dist.py dist

# Pictures of every web dashboard page for docs/web.md (Playwright + Debian's chromium).
screenshots: $(STAMP)
	$(BIN)/python tools/web_screenshots.py docs/img

bench: $(STAMP)
	$(BIN)/python -m pip install --quiet -e '.[dev,bench]'
	$(BIN)/python bench/run.py

# The long reliability runs (a million fuzz inputs, the whole fault matrix, a million-exchange
# soak); figures go to reliability/results/ and docs/reliability.md. Not part of CI.
reliability: $(STAMP)
	$(BIN)/python -m pip install --quiet -e '.[dev,fuzz]'
	$(BIN)/python reliability/run.py fuzz --inputs 1000000
	$(BIN)/python reliability/run.py fuzz --engine atheris --inputs 1000000
	$(BIN)/python reliability/run.py matrix
	$(BIN)/python reliability/run.py properties --examples 10000
	$(BIN)/python -m pytest -m slow
	$(BIN)/python reliability/run.py soak --exchanges 1000000
	$(BIN)/python reliability/run.py history --ops 100000 --seeds 1 2 3
	$(BIN)/python reliability/run.py table

clean:
	rm -rf $(VENV) build dist site .pytest_cache .mypy_cache .ruff_cache .hypothesis
