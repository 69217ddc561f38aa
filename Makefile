# Set-up is two commands on a fresh machine: `make demo` and `make test`.
PYTHON ?= $(shell command -v python3.11 || command -v python3)
VENV   ?= .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed-stamp
OUT    ?= out

.PHONY: install demo test lint bench fuzz clean

$(STAMP): pyproject.toml Makefile
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e ".[test,cluster,lint]"
	touch $(STAMP)

install: $(STAMP)

demo: $(STAMP)
	$(VENV)/bin/warp-cut run --out $(OUT)/demo

test: $(STAMP)
	$(PY) -m pytest -q

lint: $(STAMP)
	$(VENV)/bin/ruff check warp_cut kernels tests benchmarks examples

bench: $(STAMP)
	$(PY) -m pip install --quiet -e ".[bench]"
	$(PY) benchmarks/run_all.py

# Cut fuzz (not part of `make test`): random meshes and strokes, every invariant after every
# cut event; report in benchmarks/results/fuzz.md (+ fuzz.csv). FUZZ_ARGS="--quick --events 300".
FUZZ_ARGS ?= --events 3000 --seed 1
fuzz: $(STAMP)
	nice $(PY) benchmarks/fuzz_cut.py $(FUZZ_ARGS)
	nice $(PY) benchmarks/fuzz_cut.py --named

clean:
	rm -rf $(VENV) $(OUT) build *.egg-info
