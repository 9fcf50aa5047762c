# Entry points: `make test` (what CI runs), `make bench`, `make demo`.
SHELL := bash
.SHELLFLAGS := -eu -o pipefail -c
.DELETE_ON_ERROR:

PYENV := target/pyenv
PY := $(PYENV)/bin/python
export PCSSS_PYTHON := $(abspath $(PY))
# Paths with spaces or shell characters: refused on one line.
include pipelines/paths.mk

.PHONY: test bench demo bake frames frames-bench blender-check suzanne usd-bunny blender-addon blender-addon-check llvm pyenv build build-and-tools pywheel exrtools slurm lint

## The Python packages the tests use as independent readers (plyfile, trimesh).
pyenv: $(PY).stamp
$(PY).stamp: tests/requirements.txt
	python3 -m venv $(PYENV)
	$(PY) -m pip install --quiet --disable-pip-version-check --no-compile -r tests/requirements.txt
	touch $@

## The interpreter the Python module is built for (an abi3 wheel: any
## CPython from 3.9), the one the project's environment is made from.
SYSPY := $(shell python3 -c 'import sys; print(sys.executable)')

## Everything the tests run, in one cargo invocation (the library, the
## stages, the test harnesses and the Python module's library): one build
## keeps both cores busy where two in a row leave one idle at each's end.
## Run with the environment maturin gives pyo3 for that interpreter
## (PYO3_*), so that maturin finds this build's crates fresh and only
## packages the wheel.
build:
	PYO3_BUILD_EXTENSION_MODULE=1 PYO3_PYTHON=$(SYSPY) \
	  PYO3_ENVIRONMENT_SIGNATURE=$$($(SYSPY) -c 'import sys; print("cpython-%d.%d-64bit" % sys.version_info[:2])') \
	  cargo build --release --workspace --lib --bins --tests

## The build beside the Python packages and the system tools the tests
## use: pip and apt mostly wait on the disk and the network while cargo
## keeps the cores busy (under -j2, cargo takes its jobs from make's).
build-and-tools:
	$(MAKE) -j2 --no-print-directory pyenv build exrtools slurm

## The Python module (python/): an abi3 wheel built by maturin beside the
## library (the workspace shares its compiled crates with the tests'
## build), installed into the project's Python environment. (A folder of
## its own, emptied first: another build's wheel, `pip install ./python`'s
## for one, would match the same name.)
WHEEL_DIR = target/wheels/pcsss
pywheel: build-and-tools
	rm -rf $(WHEEL_DIR)
	$(PYENV)/bin/maturin build --release --quiet -i $(SYSPY) -m python/Cargo.toml -o $(WHEEL_DIR)
	$(PY) -m pip install --quiet --disable-pip-version-check --no-deps --force-reinstall \
	  $(WHEEL_DIR)/pcsss-*-cp39-abi3-*.whl

## The bunny baked from a USD stage (Y up, centimetres, transforms,
## UsdLux lights, a UsdGeomCamera) against the same bake from OBJ and JSON,
## its outputs opened by Pixar's library (pipelines/usd/bunny.py).
usd-bunny: pywheel
	cargo build --release --bins
	$(PY) pipelines/usd/bunny.py

## Debian's OpenEXR tools (exrheader), an independent reader for the tests.
exrtools:
	command -v exrheader >/dev/null || { export DEBIAN_FRONTEND=noninteractive; \
	  apt-get install -y -q openexr || { apt-get update -q && apt-get install -y -q openexr; }; }

## Debian's Slurm (daemons, client) and munge, for the tiled-bake test on
## a throwaway single-node cluster (pipelines/slurm/cluster.sh).
slurm:
	command -v slurmctld >/dev/null && command -v slurmd >/dev/null && command -v sbatch >/dev/null \
	  && command -v munged >/dev/null || { export DEBIAN_FRONTEND=noninteractive; \
	  apt-get install -y -q slurmctld slurmd slurm-client munge \
	  || { apt-get update -q && apt-get install -y -q slurmctld slurmd slurm-client munge; }; }

## Every test, the interop tests too (Python's readers, exrheader, Slurm,
## openjd-cli: `#[ignore]`d under plain `cargo test`, run here with the
## tools installed above, and failing without them). Ends with a total. Under the release profile, so the
## tests and `make demo` share one optimised build of the library and the
## stages. The Slurm cluster runs for the tests only: stopped at the end,
## whatever their outcome.
## The library's unit tests run beside the integration tests (cargo
## holds no lock while tests run), and the integration tests three at a
## time on two cores: many of them wait on a stage's process, make,
## Slurm, openjd or Python, and the others keep the cores busy meanwhile.
test: pywheel pyenv exrtools slurm
	mkdir -p target
	pipelines/slurm/cluster.sh start target/slurm >/dev/null
	trap 'pipelines/slurm/cluster.sh stop target/slurm' EXIT; \
	  export SLURM_CONF=$(abspath target/slurm/slurm.conf) PCSSS_OPENJD=$(abspath $(PYENV)/bin/openjd); \
	  cargo test --release --lib -- --include-ignored >target/test-lib.log 2>&1 & unit=$$!; \
	  rest=0; cargo test --release --test '*' -- --include-ignored --test-threads=3 2>&1 | tee target/test-rest.log || rest=$$?; \
	  lib=0; wait $$unit || lib=$$?; cat target/test-lib.log; \
	  doc=0; cargo test --release --doc 2>&1 | tee target/test-doc.log || doc=$$?; \
	  cat target/test-lib.log target/test-rest.log target/test-doc.log >target/test.log; \
	  test $$rest = 0 && test $$lib = 0 && test $$doc = 0
	awk '/^test result:/ { p += $$4; f += $$6; i += $$8 } END { printf "%d passed, %d failed, %d ignored\n", p, f, i }' target/test.log

## Benchmarks (figures in the README's performance section), with the
## bench-only Python packages (Embree through embreex) and the Stanford
## dragon (fetched into out/models, not committed).
$(PY).bench.stamp: $(PY).stamp benches/requirements.txt
	$(PY) -m pip install --quiet --disable-pip-version-check -r benches/requirements.txt
	touch $@

## Debian's LLVM 19, for Mitsuba's vectorised (llvm_ad_rgb) variant in
## benches/py/mitsuba_dome.py (Debian 12's default LLVM 14 is too old).
llvm:
	test -e /usr/lib/x86_64-linux-gnu/libLLVM-19.so || { export DEBIAN_FRONTEND=noninteractive; \
	  apt-get install -y -q libllvm19 || { apt-get update -q && apt-get install -y -q libllvm19; }; }

bench: pyenv $(PY).bench.stamp llvm
	$(MAKE) -C pipelines fetch-dragon
	cargo bench

## The bake: the whole chain (pipelines/Makefile) on the embedded
## Stanford bunny, 15 cm tall (METERS_PER_UNIT), in Jensen et al.'s
## measured skin (skin1: the physical model), ending in out/bunny.png.
DEMO = MATERIAL=skin1 METERS_PER_UNIT=0.016 EXPOSURE=3
demo:
	$(MAKE) -C pipelines info $(DEMO)

## Your own asset: make bake MESH=... LIGHTS=... CAMERA=... [MATERIAL=...]
## [UP_AXIS=y|z] [OUT=dir] [BIN=dir] and any variable of pipelines/Makefile;
## paths are taken from where make runs (the sub-make runs in pipelines/).
## The stages: BIN's, else those installed on PATH, else this clone's
## build (made when missing or older than the sources).
## (OUT need not exist yet: it is always a path.)
absolute = $(if $(or $(wildcard $(1)),$(filter OUT,$(2))),$(abspath $(1)),$(1))
bake:
	$(MAKE) -C pipelines bake \
	  $(foreach v,MESH LIGHTS CAMERA MATERIAL DIRECT OUT TEXTURE BIN,$(if $($(v)),$(v)=$(call absolute,$($(v)),$(v))))

## An animation: make frames FRAMES=anim/frame.####.obj LIGHTS=... CAMERA=...
## (one cloud scattered on the first frame, or REST=, followed through all).
frames:
	$(MAKE) -C pipelines frames \
	  $(foreach v,LIGHTS CAMERA MATERIAL DIRECT OUT REST BIN,$(if $($(v)),$(v)=$(call absolute,$($(v)),$(v)))) \
	  $(if $(FRAMES),FRAMES=$(abspath $(FRAMES)))

lint:
	cargo fmt --all -- --check
	cargo clippy --all-targets -- -D warnings

## The per-frame bake time of an animation (HISTORY.md): ten frames of a
## bending cylinder (benches/py/bend_frames.py) baked on one cloud of
## 100,000 points, then again with nothing changed; each run prints a
## time a frame (the last run's are also in target/frames-bench/out/frames.txt).
frames-bench:
	cargo build --release
	rm -rf target/frames-bench
	python3 benches/py/bend_frames.py target/frames-bench
	$(MAKE) -s -C pipelines frames FRAMES=$(CURDIR)/target/frames-bench/bend.####.obj \
	  LIGHTS=$(CURDIR)/target/frames-bench/lights.json CAMERA=$(CURDIR)/target/frames-bench/camera.json \
	  OUT=$(CURDIR)/target/frames-bench/out COUNT=100000 SD=0.1 2>/dev/null
	$(MAKE) -s -C pipelines frames FRAMES=$(CURDIR)/target/frames-bench/bend.####.obj \
	  LIGHTS=$(CURDIR)/target/frames-bench/lights.json CAMERA=$(CURDIR)/target/frames-bench/camera.json \
	  OUT=$(CURDIR)/target/frames-bench/out COUNT=100000 SD=0.1 2>/dev/null

## Blender (bpy from PyPI, about 1 GB: outside `make test`) against the
## toolkit: its light units on a white plane (formats/LIGHTS.md#light-units).
BPYENV := target/bpyenv
$(BPYENV)/bin/python.stamp: pipelines/blender/requirements.txt
	python3 -m venv $(BPYENV)
	$(BPYENV)/bin/python -m pip install --quiet --disable-pip-version-check -r $<
	touch $@

blender-check: $(BPYENV)/bin/python.stamp
	cargo build --release
	$(BPYENV)/bin/python pipelines/blender/light_units.py target/release target/blender-check

## The Blender add-on (pipelines/blender/pcsss_addon/), packaged as
## Blender 4.2+ installs extensions, with the pcsss wheel in it.
ADDON := target/blender/pcsss-addon.zip
blender-addon: pywheel
	$(PY) pipelines/blender/addon_package.py $(wildcard $(WHEEL_DIR)/pcsss-*-cp39-abi3-*.whl) $(ADDON)

## The add-on installed into Blender (bpy from PyPI, without pcsss of its
## own) as an extension, baking Suzanne from its panel: its colour
## attributes against `make bake` of the same scene by the binaries (the
## same bits), and its Cycles material against the bake's medium.
blender-addon-check: $(BPYENV)/bin/python.stamp blender-addon
	cargo build --release
	rm -rf target/blender-addon-check
	BLENDER_USER_RESOURCES=$(CURDIR)/target/blender-addon-check/res $(BPYENV)/bin/python \
	  pipelines/blender/addon_check.py $(ADDON) $(CURDIR)/target/release $(CURDIR)/target/blender-addon-check/work

## Blender's Suzanne, made and exported (Y-up OBJ, Z-up PLY) by Blender,
## baked from each with `make bake`: the same picture (out/suzanne/).
suzanne: $(BPYENV)/bin/python.stamp
	cargo build --release
	$(BPYENV)/bin/python pipelines/blender/suzanne.py $(CURDIR) $(CURDIR)/out/suzanne
