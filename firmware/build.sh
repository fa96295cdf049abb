#!/usr/bin/env bash
# Builds the real motor-board firmware and its simulator (`make firmware`):
# 1. unpacks the ROSArduinoBridge sketch (default: the pinned joshnewans fork below; or the folder
#    or .tar.gz given as the first argument / FISHTAIL_FIRMWARE_SOURCE, e.g. your own fork) into
#    build/firmware/sketch, joins its .ino files into one (main file first, as the Arduino IDE
#    does) and builds the ELF for an Arduino Nano (ATmega328P, L298N driver, encoders on the
#    Arduino's pins) with Arduino.mk: build/firmware/ROSArduinoBridge.elf;
#    and lists its variables' addresses (build/firmware/symbols.txt);
# 2. compiles firmware/avr_board.c on libsimavr: build/firmware/avr_board.
# Exits 3 with the install line when the AVR toolchain or simavr is missing.
set -euo pipefail
ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
OUT=$ROOT/build/firmware
PINNED=ros_arduino_bridge-joshnewans-210a122.tar.gz
PINNED_SHA256=987f8fe2e6dd5f5e48d82ec8943381345d158e27d34a9ff1d78410cfaef1ba57
SOURCE=${1:-${FISHTAIL_FIRMWARE_SOURCE:-$ROOT/../shared/upstream/$PINNED}}
PACKAGES="gcc-avr avr-libc arduino-core-avr arduino-mk simavr libsimavr-dev libsimavrparts1 libelf-dev"

missing=()
command -v avr-gcc >/dev/null 2>&1 || missing+=(avr-gcc)
[ -f /usr/share/arduino/Arduino.mk ] || missing+=(Arduino.mk)
[ -f /usr/share/arduino/hardware/arduino/avr/cores/arduino/Arduino.h ] || missing+=(arduino-core)
[ -f /usr/include/simavr/parts/uart_pty.h ] || missing+=(simavr-headers)
[ -f /usr/include/libelf.h ] || missing+=(libelf)
command -v cc >/dev/null 2>&1 || missing+=(cc)
if [ ${#missing[@]} -gt 0 ]; then
  echo "make firmware: missing ${missing[*]}; install the AVR toolchain and simavr with:" >&2
  echo "  sudo apt-get install $PACKAGES" >&2
  exit 3
fi
if [ ! -e "$SOURCE" ]; then
  echo "make firmware: no sketch at $SOURCE: give a ROSArduinoBridge folder or .tar.gz" \
    "(make firmware FIRMWARE_SOURCE=...)" >&2
  exit 2
fi

mkdir -p "$OUT"
rm -rf "$OUT/sketch" "$OUT/unpacked"
mkdir -p "$OUT/unpacked" "$OUT/sketch"
if [ -d "$SOURCE" ]; then
  cp -r "$SOURCE"/. "$OUT/unpacked/"
else
  if [ "$(basename "$SOURCE")" = "$PINNED" ] &&
    [ "$(sha256sum "$SOURCE" | cut -d' ' -f1)" != "$PINNED_SHA256" ]; then
    echo "make firmware: $SOURCE is not the pinned archive (sha256 differs)" >&2
    exit 2
  fi
  tar -xzf "$SOURCE" -C "$OUT/unpacked"
fi
main=$(find "$OUT/unpacked" -name ROSArduinoBridge.ino | head -n 1)
if [ -z "$main" ]; then
  echo "make firmware: no ROSArduinoBridge.ino in $SOURCE" >&2
  exit 2
fi
sketch_dir=$(dirname "$main")
# One translation unit, main file first: the other .ino files use its #defines (USE_BASE, the
# motor driver and encoder choice), as the Arduino IDE's concatenation gives them.
{
  cat "$main"
  for f in "$sketch_dir"/*.ino; do
    [ "$f" = "$main" ] || { echo; cat "$f"; }
  done
} >"$OUT/sketch/sketch.ino"
cp "$sketch_dir"/*.h "$OUT/sketch/"
cp "$ROOT/firmware/sketch.mk" "$OUT/sketch/Makefile"
echo "make firmware: building the sketch from $SOURCE"
make -s -C "$OUT/sketch" >"$OUT/sketch-build.log" 2>&1 || {
  tail -n 30 "$OUT/sketch-build.log" >&2
  echo "make firmware: the sketch did not build (log: $OUT/sketch-build.log)" >&2
  exit 1
}
cp "$OUT/sketch/build-nano-atmega328/ROSArduinoBridge.elf" "$OUT/ROSArduinoBridge.elf"
# The firmware's global variables (name, data-space address, size), for the simulator's --watch
# and --poke (fishtail_boards.avr_board reads them).
avr-nm -S "$OUT/ROSArduinoBridge.elf" | awk '$3 ~ /^[bBdD]$/ {print $4, $1, $2}' >"$OUT/symbols.txt"
avr-size "$OUT/ROSArduinoBridge.elf" | tail -n 1 | awk '{print "make firmware: flash " $1+$2 " B, RAM " $2+$3 " B"}'

cc -O2 -Wall -Wextra -std=gnu11 -I/usr/include/simavr -o "$OUT/avr_board" \
  "$ROOT/firmware/avr_board.c" -lsimavr -lsimavrparts -lelf -lpthread -lutil
echo "make firmware: $OUT/ROSArduinoBridge.elf and $OUT/avr_board"
