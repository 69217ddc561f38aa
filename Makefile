# Set-up is two commands on a fresh machine: `make demo` and `make test`.
PYTHON ?= $(shell command -v python3.11 || command -v python3)
VENV   ?= .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed-stamp
OUT    ?= out

SCENE  ?= straight_incision
PORT   ?= 0
APT    := $(if $(filter 0,$(shell id -u)),,sudo )apt-get

.PHONY: install demo test test-browser lint live bench fuzz mutants clean

$(STAMP): pyproject.toml Makefile
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e ".[test,cluster,lint,live]"
	touch $(STAMP)

install: $(STAMP)

demo: $(STAMP)
	$(VENV)/bin/warp-cut run --out $(OUT)/demo

# the test files spread over the machine's cores (pytest-xdist), each file's tests on one worker
# so its module fixtures are made once
test: $(STAMP)
	$(PY) -m pytest -q -n auto --dist loadfile

lint: $(STAMP)
	$(VENV)/bin/ruff check warp_cut kernels tests benchmarks examples

# the browser test alone: Debian's Chromium (installed if missing), Playwright driving it;
# the screenshot goes to docs/images/live_cut.png
test-browser: $(STAMP)
	command -v chromium >/dev/null || { $(APT) update -qq && DEBIAN_FRONTEND=noninteractive $(APT) install -y -qq chromium; }
	WARP_CUT_SCREENSHOT=docs/images/live_cut.png $(PY) -m pytest -q -rs tests/test_live_browser.py

# cut live in a browser: make live, or SCENE=skin_press PORT=8080 make live (PORT 0: any free port)
live: $(STAMP)
	$(PY) -m pip install --quiet -e ".[live]"
	$(VENV)/bin/warp-cut live $(SCENE) --port $(PORT)

bench: $(STAMP)
	$(PY) -m pip install --quiet -e ".[bench]"
	$(PY) benchmarks/run_all.py

# Cut fuzz (not part of `make test`; 10,000 cut events, about 30 min on a quiet machine, and it stops starting new
# cases after 75 min on a slow one): random meshes and strokes, every invariant
# after every cut event; report in benchmarks/results/fuzz.md (+ fuzz.csv), the named hard cases
# in fuzz_named.md. A quick look: make fuzz FUZZ_ARGS="--quick --events 300".
FUZZ_ARGS ?= --events 10000 --seed 1 --max-minutes 75
fuzz: $(STAMP)
	nice $(PY) benchmarks/fuzz_cut.py $(FUZZ_ARGS)
	nice $(PY) benchmarks/fuzz_cut.py --named

# Mutation testing of the cut's Stage 3 (not part of `make test`; 15-30 min): each of a list of
# deliberate defects in the re-mesh is written into a copy of the package and the tests run
# against it; report in benchmarks/results/mutants.md (+ .csv).
mutants: $(STAMP)
	nice $(PY) benchmarks/mutants.py

clean:
	rm -rf $(VENV) $(OUT) build *.egg-info
