# raysplat — quick start: `make demo`, then `make test`.
SHELL := /bin/bash
CARGO ?= cargo
PY := $(CURDIR)/.venv/bin/python3
export RAYSPLAT_PYTHON := $(PY)
BIN := target/release/raysplat

.PHONY: setup build demo test test-rust test-python bench scenes clean

## Install what is missing (Debian packages, .venv with usd-core). Idempotent.
setup:
	@scripts/setup.sh

build: setup
	$(CARGO) build --release

## Build, then render the default scene to out/cornell-box.exr and out/cornell-box.png.
demo: build
	@mkdir -p out
	$(BIN) render scenes/cornell-box.usda -o out/cornell-box.exr --preview out/cornell-box.png --spp 64

## The whole test suite: Python converter tests, then Rust unit and integration tests.
test: setup test-python test-rust

test-python:
	$(PY) -m unittest discover -s python/tests -v

test-rust:
	$(CARGO) test --release

## Throughput and accuracy figures (not tests).
bench: build
	$(BIN) bench scenes/cornell-box.usda

## Regenerate the repository's scenes with usd-core.
scenes: setup
	$(PY) scripts/make_scenes.py

clean:
	$(CARGO) clean
	rm -rf out
