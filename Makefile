# fishtail: ROS 2 Jazzy (Python) colcon workspace. `make setup` builds everything from a fresh
# clone (venv with pinned wheels + colcon build); every target below that needs it runs it first
# (about a second when nothing changed).
SHELL := /bin/bash
.SHELLFLAGS := -eo pipefail -c
.DEFAULT_GOAL := test

ROOT := $(abspath $(dir $(lastword $(MAKEFILE_LIST))))
# Prefix for commands that need the workspace environment (venv, install/, AMENT_PREFIX_PATH ...).
WITH_ENV := source $(ROOT)/tools/env.sh &&

CONFIG ?= config/oscillatory.yaml
# What `make run` runs (inside the workspace environment): the geometry's design summary, then the
# node suite on the simulated motor, with the swimming simulator, and a live console until Ctrl-C.
# `make run RUN_ARGS="--duration 10 --speed 6"`: options of fishtail-run (see its --help).
RUN_ARGS ?=
RUN_CMD ?= fishtail-kinematics design --config $(CONFIG) && \
  fishtail-run --swim --config $(CONFIG) $(RUN_ARGS)

# Test locations: every package's test/ plus the integration tests in test/. If none exists,
# pytest is pointed at test/ and fails (exit 4), as it does with exit 5 when it collects nothing.
TEST_DIRS := $(wildcard src/*/test) $(wildcard test)
PYTEST_ARGS ?=
# pytest-xdist workers: one per core. Each test claims a ROS domain of its own (a file lock), so
# tests on different workers never share one.
TEST_JOBS ?= $(shell nproc)
# A fresh ROS_DOMAIN_ID for a run unless one is set; the tests' own nodes each get theirs.
DOMAIN := export ROS_DOMAIN_ID=$${ROS_DOMAIN_ID:-$$((RANDOM % 100 + 1))} &&

.PHONY: setup build run test check lint bench firmware clean distclean

setup:
	tools/bootstrap.sh

build:
	tools/bootstrap.sh --force-build

run: setup
	$(WITH_ENV) $(RUN_CMD)

# ruff (style, import order, and the layer bans: no rclpy outside the nodes, bringup and
# fishtail_common's ROS glue; no plotting or bag I/O in the engine), then mypy over every package
# (strict for the engine, the serial codec and the shared interface; pyproject.toml).
lint: setup
	$(WITH_ENV) ruff check . && mypy

# The whole suite on every core, the 25 slowest tests listed at the end; then the tests marked
# `alone` (real-time measurements, such as a browser's latency) one at a time, so that the runner's
# own parallel tests do not stand in for the load they measure. Each run gets its own ROS domain
# (unless ROS_DOMAIN_ID is set) so that nodes started by tests do not talk to other ROS processes
# on the machine. Set-up first: tools/test-system-packages.sh installs the Debian packages some
# tests use where it can (root with apt-get), and says so where not; then tools/test-firmware.sh
# builds the firmware for its tests (or says why not, and they skip). In the second phase only,
# pytest's status 5 (no test selected: TEST_DIRS without `alone` tests) is not a failure; in the
# first, no test run fails the target.
test: lint
	tools/test-system-packages.sh
	tools/test-firmware.sh
	$(WITH_ENV) $(DOMAIN) \
	  python -m pytest $(or $(TEST_DIRS),test) -n $(TEST_JOBS) -m "not alone" --durations=25 \
	  $(PYTEST_ARGS) && \
	  { status=0; python -m pytest $(or $(TEST_DIRS),test) -m alone $(PYTEST_ARGS) || status=$$?; \
	    [ $$status -eq 0 ] || [ $$status -eq 5 ]; }

# The fast tier, for every change: lint, then the tests that start no process and take under a
# few seconds each (markers: pyproject.toml and conftest.py); under two minutes on 2 cores.
check: lint
	$(WITH_ENV) $(DOMAIN) \
	  python -m pytest $(or $(TEST_DIRS),test) -m "not integration and not slow" -n $(TEST_JOBS) \
	  $(PYTEST_ARGS)

# Every bench/bench_*.py, each with the venv's python from the repository root and the test kit
# (test/support: what tests and benchmarks share) on the path; all run even if
# one fails, and the target fails if any did. Benchmarks write their output under bench/out/
# (git-ignored).
bench: setup
	$(WITH_ENV) export ROS_DOMAIN_ID=$${ROS_DOMAIN_ID:-$$((RANDOM % 100 + 1))} && \
	  export PYTHONPATH=$(ROOT)/test/support$${PYTHONPATH:+:$$PYTHONPATH} && \
	  shopt -s nullglob && files=(bench/bench_*.py) && \
	  if [ $${#files[@]} -eq 0 ]; then echo "bench: no bench/bench_*.py" >&2; exit 1; fi && \
	  mkdir -p bench/out && rc=0 && \
	  for f in "$${files[@]}"; do echo "== $$f"; python "$$f" || { rc=$$?; echo "FAILED: $$f" >&2; }; done; \
	  exit $$rc

# The real motor-board firmware (ROSArduinoBridge for an Arduino Nano) and its simulator on
# libsimavr, into build/firmware, and the project's firmware (the same with firmware/fishtail.patch)
# into build/firmware/fishtail (firmware/build.sh; docs/serial.md, docs/firmware.md). FIRMWARE_SOURCE: a sketch
# folder or .tar.gz of your own (default: the pinned joshnewans fork in ../shared/upstream).
FIRMWARE_SOURCE ?=
firmware:
	firmware/build.sh $(FIRMWARE_SOURCE)

clean:
	rm -rf build install log bench/out .pytest_cache .ruff_cache .hypothesis
	find . -path ./.venv -prune -o -name __pycache__ -type d -prune -exec rm -rf {} +

# clean, and also the venv (the next `make setup` reinstalls every wheel).
distclean: clean
	rm -rf .venv
