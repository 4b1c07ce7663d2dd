# plantlod: every target creates the virtual environment it needs.
#   make demo   run the main job on a bundled example
#   make test   run the test suite (what CI runs)
#   make test-slow  the long checks too: the README's long blocks in a fresh clone (minutes)
#   make bench  run the benchmarks and print their figures
#   make golden regenerate the golden files (review the diff like code)
#   make lod-table  the table of every level's errors on the evaluation trees
#   make lod-family pass fractions of levels 1-3 on 200 generated trees (LOD_FAMILY_ARGS)
#   make test-browser  install Debian's chromium if missing, run the page tests in it
#   make view-picture  docs/view.png: a frame of `plantlod view` (original and levels)
#   make help   this list (also what `make` alone prints)

PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
PLANTLOD := $(VENV)/bin/plantlod
STAMP  := $(VENV)/.installed

.PHONY: help demo test test-slow test-browser bench golden lod-table lod-family view-picture clean

# the first target, what `make` alone does: the list above (it printed only that the
# virtual environment was up to date)
help:
	@sed -n 's/^#   make /make /p' $(firstword $(MAKEFILE_LIST))

$(STAMP): pyproject.toml
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --disable-pip-version-check -e '.[test,all]'
	# the installed plantlod ahead of a folder named plantlod beside a script (the clone
	# itself, seen as an empty namespace package): the editable finder asked first
	printf '%s\n' 'import sys; sys.meta_path.sort(key=lambda f: getattr(f, "__name__", "") != "_EditableFinder")' \
	    > "$$($(PY) -c 'import sysconfig; print(sysconfig.get_path("purelib"))')/plantlod-first.pth"
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
	$(PLANTLOD) simplify examples/stalk8.lsys --level 1 -o examples/$(DEMO_OUT)/stalk8-level1.lsys
	$(PLANTLOD) simulate examples/$(DEMO_OUT)/stalk8-level1.lsys --dt 0.01 --duration 10 \
	    --wind-speed 5 -o examples/$(DEMO_OUT)/stalk8-level1.csv
	$(PLANTLOD) export examples/$(DEMO_OUT)/stalk8-level1.lsys examples/$(DEMO_OUT)/stalk8-level1.csv \
	    -o examples/$(DEMO_OUT)/stalk8-level1.glb
	$(PLANTLOD) view examples/$(DEMO_OUT)/stalk8.glb examples/$(DEMO_OUT)/stalk8-level1.glb \
	    -o examples/$(DEMO_OUT)/stalk8.html
	@echo "animation: examples/$(DEMO_OUT)/stalk8.glb (glTF) and stalk8.usda (OpenUSD)"
	@echo "page: examples/$(DEMO_OUT)/stalk8.html (open it in a browser: original and level 1)"
	@echo "figure 4 (t = 4 s): examples/$(DEMO_OUT)/figure4.png, OBJ in examples/$(DEMO_OUT)/figure4/"

test: $(STAMP)
	$(PY) -m pytest -q

test-slow: $(STAMP)
	$(PY) -m pytest -q --run-long -m long tests

# make test-browser: the tests that open `plantlod view`'s page in headless Chromium
# (in make test too, skipped with a reason where chromium is absent)
test-browser: $(STAMP)
	command -v chromium >/dev/null || { $$(command -v sudo) apt-get update -qq && \
	    $$(command -v sudo) apt-get install -y -qq chromium; }
	$(PY) -m pytest -q -m browser -rs tests

# make view-picture: docs/view.png, a frame of the page for abop_1_24c and its levels 1, 2
VIEW := out/view
view-picture: $(STAMP)
	mkdir -p $(VIEW)
	$(PLANTLOD) simplify examples/abop_1_24c.lsys --level 1 -o $(VIEW)/abop_1_24c-level1.lsys
	$(PLANTLOD) simplify examples/abop_1_24c.lsys --level 2 -o $(VIEW)/abop_1_24c-level2.lsys
	for f in examples/abop_1_24c.lsys $(VIEW)/abop_1_24c-level1.lsys $(VIEW)/abop_1_24c-level2.lsys; do \
	    b=$$(basename $$f .lsys); \
	    $(PLANTLOD) simulate $$f --dt 0.01 --duration 6 --wind-speed 8 -o $(VIEW)/$$b.csv && \
	    $(PLANTLOD) export $$f $(VIEW)/$$b.csv -o $(VIEW)/$$b.glb || exit 1; done
	$(PLANTLOD) view $(VIEW)/abop_1_24c.glb $(VIEW)/abop_1_24c-level1.glb \
	    $(VIEW)/abop_1_24c-level2.glb --title "abop_1_24c: original, level 1, level 2 at 8 m/s" \
	    -o $(VIEW)/abop_1_24c.html
	chromium --headless --no-sandbox --use-angle=swiftshader --enable-unsafe-swiftshader \
	    --virtual-time-budget=8000 --window-size=1000,560 --screenshot=docs/view.png \
	    "file://$(abspath $(VIEW))/abop_1_24c.html#t=3" 2>/dev/null
	@echo "docs/view.png: a frame of $(VIEW)/abop_1_24c.html at t = 3 s"

bench: $(STAMP)
	$(PY) bench/run.py

# make lod-table: worst errors of every level of the evaluation trees (docs/lod-table.md)
lod-table: $(STAMP)
	$(PY) bench/lod_table.py --out docs/lod-table.md

# make lod-family: levels 1-3 of the generated family (bench/tree_family.py), pass fractions per
# kind; e.g. make lod-family LOD_FAMILY_ARGS="--held-out --jobs 2 --out out/lod-family.md"
LOD_FAMILY_ARGS ?= --jobs 2
lod-family: $(STAMP)
	$(PY) bench/lod_family.py $(LOD_FAMILY_ARGS)

golden: $(STAMP)
	PLANTLOD_REGEN_GOLDEN=1 $(PY) -m pytest -q tests -k golden

clean:
	rm -rf $(VENV) build *.egg-info
