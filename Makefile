# plantlod: every target creates the virtual environment it needs.
#   make demo   run the main job on a bundled example
#   make test   run the test suite (what CI runs)
#   make bench  run the benchmarks and print their figures
#   make golden regenerate the golden files (review the diff like code)

PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
PLANTLOD := $(VENV)/bin/plantlod
STAMP  := $(VENV)/.installed

.PHONY: demo test bench golden clean

$(STAMP): pyproject.toml
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --disable-pip-version-check -e '.[test,plot]'
	touch $(STAMP)

demo: $(STAMP)
	$(PLANTLOD) derive examples/stalk8.lsys -o /tmp/plantlod-demo-stalk8.jsonl
	head -n 2 /tmp/plantlod-demo-stalk8.jsonl
	$(PLANTLOD) simulate /tmp/plantlod-demo-stalk8.jsonl --dt 0.01 --duration 10 \
	    --wind-speed 10 --every 100 | cut -d, -f1-5

test: $(STAMP)
	$(PY) -m pytest -q

bench: $(STAMP)
	$(PY) bench/run.py

golden: $(STAMP)
	PLANTLOD_REGEN_GOLDEN=1 $(PY) -m pytest -q tests -k golden

clean:
	rm -rf $(VENV) build *.egg-info
