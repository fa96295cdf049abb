#!/usr/bin/env bash
# The real motor-board firmware (the stock one, and the project's in build/firmware/fishtail) and
# its simulator for the tests (firmware/build.sh, into build/firmware), built once by `make test`
# before pytest rather than by a test: the tests only look for what it built. Without the AVR
# toolchain or simavr (build.sh exits 3) or the sketch (exits 2) its one-line reason is printed
# and kept in build/firmware/skip-reason.txt, and the firmware tests skip with it; any other
# failure of the build fails this script.
# Output: one line; the build's own in log/firmware-build.log.
set -uo pipefail
ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
OUT=$ROOT/build/firmware
REASON=$OUT/skip-reason.txt
LOG=$ROOT/log/firmware-build.log

mkdir -p "$OUT" "$ROOT/log"
rm -f "$REASON"
rc=0
# stderr (where build.sh says why it cannot build) kept apart from the log, then appended to it.
errors=$("$ROOT/firmware/build.sh" 2>&1 >"$LOG") || rc=$?
printf '%s\n' "$errors" >>"$LOG"
case $rc in
  0)
    echo "test set-up: firmware built into build/firmware (log/firmware-build.log)"
    ;;
  2 | 3)
    # What it said (the reason, and for exit 3 the install command) on one line.
    reason=$(printf '%s\n' "$errors" | sed 's/^ *//' | tr -s '\n' ' ' | sed 's/ *$//')
    echo "${reason:-firmware/build.sh exited $rc}" >"$REASON"
    echo "test set-up: firmware not built, its tests will skip: ${reason}" >&2
    ;;
  *)
    tail -n 40 "$LOG" >&2
    echo "test set-up: firmware/build.sh failed (exit $rc; log/firmware-build.log)" >&2
    exit "$rc"
    ;;
esac
