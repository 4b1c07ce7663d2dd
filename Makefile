# plantlod: every target creates the virtual environment it needs.
#   make demo   run the main job on a bundled example
#   make test   run the test suite (what CI runs)
#   make bench  run the benchmarks and print their figures
#   make golden regenerate the golden files (review the diff like code)
#   make lod-table  the table of every level's errors on the evaluation trees

PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
PLANTLOD := $(VENV)/bin/plantlod
STAMP  := $(VENV)/.installed

.PHONY: demo test bench golden lod-table clean

$(STAMP): pyproject.toml
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --disable-pip-version-check -e '.[test,all]'
	touch $(STAMP)

# make demo: the short version of the thesis' experiment (examples/Makefile, QUICK=1):
# the stalk simplified to levels 1 and 2 by both methods, compared in two winds.
DEMO_JOBS ?= 4
DEMO_OUT  := out/quick

demo: $(STAMP)
	$(MAKE) -C examples -j$(DEMO_JOBS) QUICK=1 OUT=$(DEMO_OUT) PLANTLOD=$(abspath $(PLANTLOD)) \
	    PYTHON=$(abspath $(PY))
	cat examples/$(DEMO_OUT)/results.md
	$(PLANTLOD) simulate examples/stalk8.lsys --dt 0.01 --duration 10 --wind-speed 5 \
	    -o examples/$(DEMO_OUT)/stalk8.csv
	$(PLANTLOD) export examples/stalk8.lsys examples/$(DEMO_OUT)/stalk8.csv -o examples/$(DEMO_OUT)/stalk8.glb
	$(PLANTLOD) export examples/stalk8.lsys examples/$(DEMO_OUT)/stalk8.csv -o examples/$(DEMO_OUT)/stalk8.usda
	@echo "animation: examples/$(DEMO_OUT)/stalk8.glb (glTF) and stalk8.usda (OpenUSD)"
	@echo "figure 4 (t = 4 s): examples/$(DEMO_OUT)/figure4.png, OBJ in examples/$(DEMO_OUT)/figure4/"

test: $(STAMP)
	$(PY) -m pytest -q

bench: $(STAMP)
	$(PY) bench/run.py

# make lod-table: worst errors of every level of the evaluation trees (docs/lod-table.md)
lod-table: $(STAMP)
	$(PY) bench/lod_table.py --out docs/lod-table.md

golden: $(STAMP)
	PLANTLOD_REGEN_GOLDEN=1 $(PY) -m pytest -q tests -k golden

clean:
	rm -rf $(VENV) build *.egg-info
