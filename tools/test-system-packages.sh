#!/usr/bin/env bash
# System packages that some tests use, installed where this can be done without asking (root with
# apt-get, as on CI); elsewhere nothing is installed and those tests skip, each saying why.
# - chromium: the test that loads the live view's web viewer in a headless browser.
# Run by `make test` before the tests; idempotent (a second run with chromium present does nothing).
set -uo pipefail
ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
if command -v chromium >/dev/null 2>&1; then
  exit 0
fi
if [ "$(id -u)" != 0 ] || ! command -v apt-get >/dev/null 2>&1; then
  echo "test set-up: chromium is not installed (as root: apt-get install chromium); the web" \
    "viewer test will skip" >&2
  exit 0
fi
mkdir -p "$ROOT/log"
if { apt-get update -q && DEBIAN_FRONTEND=noninteractive apt-get install -y -q chromium; } \
  >"$ROOT/log/test-system-packages.log" 2>&1; then
  echo "test set-up: installed chromium (log/test-system-packages.log)"
else
  echo "test set-up: chromium could not be installed (log/test-system-packages.log); the web" \
    "viewer test will skip" >&2
fi
exit 0
