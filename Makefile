# raysplat — quick start: `make demo`, then `make test`.
SHELL := /bin/bash
CARGO ?= cargo
PY := $(CURDIR)/.venv/bin/python3
export RAYSPLAT_PYTHON := $(PY)
BIN := target/release/raysplat

.PHONY: setup build demo test test-rust test-python test-cpp bench study scenes clean

## Install what is missing (Debian packages, .venv with usd-core and numpy). Idempotent.
setup:
	@scripts/setup.sh

build: setup
	$(CARGO) build --release

## Build, then render the default scene to out/cornell-box.exr and out/cornell-box.png.
demo: build
	@mkdir -p out
	$(BIN) render scenes/cornell-box.usda -o out/cornell-box.exr --preview out/cornell-box.png

## The whole test suite: Python converter tests, Rust unit and integration tests, the C++ API.
test: setup test-python test-rust test-cpp

test-python:
	$(PY) -m unittest discover -s python/tests -v

test-rust:
	$(CARGO) test --release --no-fail-fast

## The C++ API as a consumer uses it: CMake package, example, API tests (also under AddressSanitizer).
test-cpp:
	$(CARGO) build --release
	cmake -S cpp -B build/cpp -DCMAKE_BUILD_TYPE=Release
	cmake --build build/cpp -j2
	ctest --test-dir build/cpp --output-on-failure

## Throughput and accuracy figures (not tests).
bench: build
	$(BIN) bench scenes/cornell-box.usda
	@# the paper's Table 2 setting (500x500 x 4, M = 200 000), then a small image (fewer eye samples per photon)
	$(BIN) bench --photon-table scenes/cornell-box.usda,scenes/bumpy-box.usda
	$(BIN) bench --photon-table scenes/cornell-box.usda,scenes/bumpy-box.usda --table-resolution 128x128 --table-reference-spp 2048
	@# a caustic scene when the workplace's shared scenes are beside the repository
	S=../shared/scenes/classic/cornell_box/CornellBox-Sphere.usda; \
	$(BIN) bench --auto-table scenes/cornell-box.usda,scenes/secondary-light.usda$$( [ -f $$S ] && echo ,$$S )
	$(BIN) bench --fg-table scenes/cornell-box.usda,scenes/bumpy-box.usda,scenes/concave-corners.usda
	$(BIN) bench --secondary-table scenes/secondary-light.usda
	$(BIN) bench --target-table scenes/cornell-box.usda,scenes/secondary-light.usda
	@# the Cornell box at its own resolution (256x256), with the cheapest photon budgets
	$(BIN) bench --target-table scenes/cornell-box.usda --target-size 0 --target-methods pm,rs,rs-rc \
	    --target-spp 1 --target-aa-spp 4,8 --target-photons 5000,10000 --target-knn 20,50 --target-seeds 3
	@# radiance caching with our direct light (sampled) and with the paper's (direct photons)
	$(BIN) bench --cache-table scenes/cornell-glossy.usda --cache-direct sampled,photons
	@# radiance caching on the larger scene when the workplace's shared scenes are beside the repository
	S=../shared/scenes/classic/crytek_sponza/sponza.usdc; [ ! -f $$S ] || \
	$(BIN) bench --cache-table $$S --cache-size 400 --cache-photons 100000 --cache-reference-spp 128 --cache-direct sampled,photons

## Regenerate docs/accuracy.md and its plots: every method against a path-traced reference.
study: build
	scripts/study.sh

## Regenerate the repository's scenes with usd-core.
scenes: setup
	$(PY) scripts/make_scenes.py

clean:
	$(CARGO) clean
	rm -rf out
