#!/usr/bin/env bash
# System packages that some tests use, installed where this can be done without asking (root with
# apt-get, as on CI); elsewhere nothing is installed and those tests skip, each saying why.
# - chromium: the test that loads the live view's web viewer in a headless browser.
# - the AVR toolchain, the Arduino core and simavr: the tests of the real motor-board firmware in
#   a simulator (make firmware; firmware/build.sh).
# Run by `make test` before the tests; idempotent (a second run with everything present does
# nothing).
set -uo pipefail
ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
AVR_PACKAGES="gcc-avr avr-libc arduino-core-avr arduino-mk simavr libsimavr-dev libsimavrparts1 libelf-dev"

wanted=()
command -v chromium >/dev/null 2>&1 || wanted+=(chromium)
if ! command -v avr-gcc >/dev/null 2>&1 || [ ! -f /usr/share/arduino/Arduino.mk ] ||
  [ ! -f /usr/include/simavr/parts/uart_pty.h ] || [ ! -f /usr/include/libelf.h ]; then
  wanted+=($AVR_PACKAGES)
fi
if [ ${#wanted[@]} -eq 0 ]; then
  exit 0
fi
if [ "$(id -u)" != 0 ] || ! command -v apt-get >/dev/null 2>&1; then
  echo "test set-up: not installed: ${wanted[*]} (as root: apt-get install ${wanted[*]});" \
    "the tests that need them will skip" >&2
  exit 0
fi
mkdir -p "$ROOT/log"
if { apt-get update -q && DEBIAN_FRONTEND=noninteractive apt-get install -y -q "${wanted[@]}"; } \
  >"$ROOT/log/test-system-packages.log" 2>&1; then
  echo "test set-up: installed ${wanted[*]} (log/test-system-packages.log)"
else
  echo "test set-up: ${wanted[*]} could not be installed (log/test-system-packages.log); the" \
    "tests that need them will skip" >&2
fi
exit 0
