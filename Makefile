# raysplat — quick start: `make demo`, then `make test`.
SHELL := /bin/bash
CARGO ?= cargo
PY := $(CURDIR)/.venv/bin/python3
export RAYSPLAT_PYTHON := $(PY)
BIN := target/release/raysplat
BENCH := target/release/raysplat-bench
# The build with Embree 4 (`--features embree4`) has a target directory of its own, so that neither
# build makes the other stale.
EMBREE4_TARGET := $(CURDIR)/target/embree4
# The workspace's shared scenes (docs/accuracy.md, the benchmarks' larger scenes), when present.
SHARED_SCENES ?= $(or $(RAYSPLAT_SHARED_SCENES),../shared/scenes)

PREFIX ?= /usr/local

.PHONY: setup build install demo test test-rust test-python test-cpp test-no-oidn test-embree4 bench-embree fuzz bench bench-filters bench-real study study-denoise scenes clean

## Install what is missing (Debian packages, .venv with usd-core and numpy). Idempotent.
setup:
	@scripts/setup.sh

build: setup
	$(CARGO) build --release

## Install into PREFIX (default /usr/local): bin/raysplat, lib/libraysplat.so and libraysplat.a,
## include/raysplat, the CMake package and pkg-config files, private libraries in lib/raysplat.
## The prefix may be moved as a whole afterwards (docs/cpp.md, "Installing").
install: build
	cmake -DPREFIX=$(abspath $(PREFIX)) -P cpp/cmake/install.cmake

## Build, then render the default scene to out/cornell-box.exr and out/cornell-box.png.
demo: build
	@mkdir -p out
	$(BIN) render scenes/cornell-box.usda -o out/cornell-box.exr --preview out/cornell-box.png

## The whole test suite: Python converter tests, Rust unit and integration tests (the library, the
## command line, the benchmarks' own), the C++ API.
test: setup test-python test-rust test-cpp

test-python:
	$(PY) -m unittest discover -s python/tests -v

test-rust:
	$(CARGO) test --release --workspace --no-fail-fast

## The C++ API as a consumer uses it: CMake package, example, API tests (also under AddressSanitizer).
test-cpp:
	$(CARGO) build --release
	cmake -S cpp -B build/cpp -DCMAKE_BUILD_TYPE=Release
	cmake --build build/cpp -j2
	ctest --test-dir build/cpp --output-on-failure

## The denoiser's tests in a build without Open Image Denoise (RAYSPLAT_OIDN=off), as on a machine
## where `make setup` could not install the pyoidn wheel: the crate is rebuilt without it (and
## rebuilt with it by the next plain build). CI runs it after `make test`.
test-no-oidn:
	RAYSPLAT_OIDN=off $(CARGO) test --release --test denoise -p raysplat -p raysplat-cli

## The Rust tests and the C++ API's tests with Embree 4 (`--features embree4`: the embreex wheel
## that `make setup` installs into .venv) instead of Debian's Embree 3, built in target/embree4
## (all but the install test: `make install` supports the Embree 3 build only). CI runs it after
## `make test`.
test-embree4: setup
	CARGO_TARGET_DIR=$(EMBREE4_TARGET) $(CARGO) test --release --workspace --no-fail-fast --features embree4
	CARGO_TARGET_DIR=$(EMBREE4_TARGET) $(CARGO) build --release --features embree4
	cmake -S cpp -B build/cpp-embree4 -DCMAKE_BUILD_TYPE=Release -DRAYSPLAT_TARGET_DIR=$(EMBREE4_TARGET)
	cmake --build build/cpp-embree4 -j2
	ctest --test-dir build/cpp-embree4 --output-on-failure --exclude-regex '^install$$'

## Embree's throughput with each backend, side by side (scenes/cornell-box.usda and, when present,
## the shared Crytek Sponza): `raysplat-bench embree --compare` runs the Embree 4 build's own
## measurement after its own, one after the other.
bench-embree: build
	$(CARGO) build --release -p raysplat-bench
	CARGO_TARGET_DIR=$(EMBREE4_TARGET) $(CARGO) build --release -p raysplat-bench --features embree4
	S=$(SHARED_SCENES)/classic/crytek_sponza/sponza.usdc; \
	$(BENCH) embree scenes/cornell-box.usda --compare $(EMBREE4_TARGET)/release/raysplat-bench && \
	{ [ ! -f $$S ] || $(BENCH) embree $$S --resolution 200x200 --compare $(EMBREE4_TARGET)/release/raysplat-bench; }

## The hostile-input battery at eight times its size and the readers' property tests at 20 000
## cases, with their figures (panics, aborts, hangs, wrong successes, files left; peak memory).
fuzz: setup
	RAYSPLAT_HOSTILE_SCALE=8 PROPTEST_CASES=20000 $(CARGO) test --release -p raysplat --test hostile -- --nocapture
	cd python/tests && $(PY) -m unittest -v test_convert_hostile

## Throughput and accuracy figures (not tests): raysplat-bench, one subcommand per table.
bench: build
	$(CARGO) build --release -p raysplat-bench --features embree-timing
	$(BENCH) embree scenes/cornell-box.usda
	@# the paper's Table 2 setting (500x500 x 4, M = 200 000), then a small image (fewer eye samples per photon)
	$(BENCH) photons scenes/cornell-box.usda,scenes/bumpy-box.usda
	$(BENCH) photons scenes/cornell-box.usda,scenes/bumpy-box.usda --table-resolution 128x128 --table-reference-spp 2048
	@# a caustic scene when the workplace's shared scenes are present
	S=$(SHARED_SCENES)/classic/cornell_box/CornellBox-Sphere.usda; \
	$(BENCH) auto scenes/cornell-box.usda,scenes/secondary-light.usda$$( [ -f $$S ] && echo ,$$S )
	$(BENCH) fg scenes/cornell-box.usda,scenes/bumpy-box.usda,scenes/concave-corners.usda
	$(BENCH) secondary scenes/secondary-light.usda
	$(BENCH) target scenes/cornell-box.usda,scenes/secondary-light.usda
	@# the Cornell box at its own resolution (256x256), with the cheapest photon budgets
	$(BENCH) target scenes/cornell-box.usda --target-size 0 --target-methods pm,rs,rs-rc \
	    --target-spp 1 --target-aa-spp 4,8 --target-photons 5000,10000 --target-knn 20,50 --target-seeds 3
	@# radiance caching with our direct light (sampled) and with the paper's (direct photons)
	$(BENCH) cache scenes/cornell-glossy.usda --cache-direct sampled,photons
	@# the larger scene's conversion and loading, and radiance caching on it, when present
	S=$(SHARED_SCENES)/classic/crytek_sponza/sponza.usdc; [ ! -f $$S ] || { \
	$(BENCH) load $$S && \
	$(BENCH) cache $$S --cache-size 400 --cache-photons 100000 --cache-reference-spp 128 --cache-direct sampled,photons; }
	@# the path tracer against Mitsuba 3 (when RAYSPLAT_MITSUBA_PYTHON names a Python with mitsuba)
	$(BENCH) pt $(SHARED_SCENES)/classic/cornell_box/CornellBox-Original.usda@256x256,$(SHARED_SCENES)/classic/crytek_sponza/sponza.usdc@200x200 \
	    --mitsuba-script $(SHARED_SCENES)/../peer/usd_to_mitsuba.py
	@# the real-scene table (auto against each method at 1, 4, 16 s) into docs/accuracy.md
	SHARED_SCENES=$(SHARED_SCENES) scripts/real_table.sh

## The Mitsuba comparison of docs/filters.md: pt and Mitsuba 3 with the box and the Gaussian filter,
## errors against each renderer's own reference (about 20 min on 2 busy cores; needs
## RAYSPLAT_MITSUBA_PYTHON, a Python with mitsuba, usd-core and numpy).
bench-filters: build
	$(CARGO) build --release -p raysplat-bench
	$(BENCH) pt $(SHARED_SCENES)/classic/cornell_box/CornellBox-Original.usda@128x128,$(SHARED_SCENES)/classic/crytek_sponza/sponza.usdc@200x200 \
	    --spp 16,64,256 --filter box,gaussian --reference-spp 512 --mitsuba-script $(SHARED_SCENES)/../peer/usd_to_mitsuba.py

## The real-scene table of docs/accuracy.md: auto and each method at 1, 4 and 16 s on the shared
## scenes (when present) and the repository's, against path-traced references cached between runs
## (it prints its expected time first: 55 min with every reference to render on 2 busy cores, about
## 24 min once they are cached). REAL_TIMES, REAL_SIZE, REAL_SCENES change it.
bench-real: build
	SHARED_SCENES=$(SHARED_SCENES) scripts/real_table.sh

## Regenerate docs/accuracy.md and its plots: every method against a path-traced reference.
study: build
	scripts/study.sh

## Regenerate the denoising section of docs/accuracy.md: pt, rs, rs-rc with and without Open Image
## Denoise on the Cornell box, Crytek Sponza (when ../shared/scenes is there) and secondary-light.
study-denoise: build
	scripts/study_denoise.sh

## Regenerate the repository's scenes with usd-core.
scenes: setup
	$(PY) scripts/make_scenes.py

clean:
	$(CARGO) clean
	rm -rf out
