# The two commands a user needs on a fresh machine: `make demo` and `make test`.
# Each creates (or refreshes) .venv with Python 3.11 and installs the project into it.
PYTHON ?= python3.11
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

.PHONY: test demo bench venv clean

$(STAMP): pyproject.toml
	@command -v $(PYTHON) >/dev/null || { echo "error: $(PYTHON) not found; viewadapt needs Python 3.11 (bpy 5.0 requires it)"; exit 1; }
	@test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e ".[test,generator,raster,scale]"
	@# anny builds its model cache on first use (~70 s, 1.7 GB RAM); do it once here and keep
	@# only the compact file it reads afterwards (~51 MB)
	$(BIN)/python -c "from generator.body import build_cache; build_cache(prune=True)"
	@touch $(STAMP)

venv: $(STAMP)

# -n auto: one pytest worker per core (pytest-xdist), --dist loadfile keeps each file's
# module fixtures in one worker
test: $(STAMP)
	$(BIN)/python -m pytest -q -n auto --dist loadfile

demo: $(STAMP)
	$(BIN)/viewadapt demo --out demo-output

bench: $(STAMP)
	$(BIN)/python -m benchmark.studies.core_speed
	$(BIN)/python -m generator.bench

clean:
	rm -rf $(VENV) demo-output .pytest_cache
