#!/usr/bin/env bash
# Builds the real motor-board firmware and its simulator (`make firmware`):
# 1. unpacks the ROSArduinoBridge sketch (default: the pinned joshnewans fork below; or the folder
#    or .tar.gz given as the first argument / FISHTAIL_FIRMWARE_SOURCE, e.g. your own fork) into
#    build/firmware/unpacked, joins its .ino files into one (main file first, as the Arduino IDE
#    does) and builds the ELF for an Arduino Nano (ATmega328P, L298N driver, encoders on the
#    Arduino's pins) with Arduino.mk: build/firmware/ROSArduinoBridge.elf (the stock firmware);
#    and lists its variables' addresses (symbols.txt) and its functions' (functions.txt);
# 2. the project's firmware: the same sketch with firmware/fishtail.patch applied
#    (firmware/CHANGES.md, docs/firmware.md), built the same way into build/firmware/fishtail/
#    (ROSArduinoBridge.elf, symbols.txt, functions.txt, and avr_board linked to the simulator).
#    A sketch of your own that the patch does not apply to gets the stock build only;
# 3. compiles firmware/avr_board.c on libsimavr: build/firmware/avr_board.
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

# build_sketch UNPACKED DEST: the sketch found under UNPACKED, joined and built into DEST.
build_sketch() {
  local unpacked=$1 dest=$2 main sketch_dir
  main=$(find "$unpacked" -name ROSArduinoBridge.ino | head -n 1)
  if [ -z "$main" ]; then
    echo "make firmware: no ROSArduinoBridge.ino in $SOURCE" >&2
    exit 2
  fi
  sketch_dir=$(dirname "$main")
  rm -rf "$dest/sketch"
  mkdir -p "$dest/sketch"
  # One translation unit, main file first: the other .ino files use its #defines (USE_BASE, the
  # motor driver and encoder choice), as the Arduino IDE's concatenation gives them.
  {
    cat "$main"
    for f in "$sketch_dir"/*.ino; do
      [ "$f" = "$main" ] || { echo; cat "$f"; }
    done
  } >"$dest/sketch/sketch.ino"
  cp "$sketch_dir"/*.h "$dest/sketch/"
  cp "$ROOT/firmware/sketch.mk" "$dest/sketch/Makefile"
  make -s -C "$dest/sketch" >"$dest/sketch-build.log" 2>&1 || {
    tail -n 30 "$dest/sketch-build.log" >&2
    echo "make firmware: the sketch did not build (log: $dest/sketch-build.log)" >&2
    exit 1
  }
  cp "$dest/sketch/build-nano-atmega328/ROSArduinoBridge.elf" "$dest/ROSArduinoBridge.elf"
  # The firmware's global variables (name, data-space address, size), for the simulator's
  # --watch and --poke (fishtail_boards.avr_board reads them); its functions (name, byte
  # address, size), for --time-function.
  avr-nm -S "$dest/ROSArduinoBridge.elf" | awk '$3 ~ /^[bBdD]$/ {print $4, $1, $2}' >"$dest/symbols.txt"
  avr-nm -S "$dest/ROSArduinoBridge.elf" | awk '$3 ~ /^[tT]$/ {print $4, $1, $2}' >"$dest/functions.txt"
  avr-size "$dest/ROSArduinoBridge.elf" | tail -n 1 |
    awk -v what="$3" '{print "make firmware: " what ": flash " $1+$2 " B, RAM " $2+$3 " B"}'
}

mkdir -p "$OUT"
rm -rf "$OUT/unpacked" "$OUT/fishtail/unpacked"
mkdir -p "$OUT/unpacked"
pinned=0 # the pinned archive: the patch must apply
if [ -d "$SOURCE" ]; then
  cp -r "$SOURCE"/. "$OUT/unpacked/"
else
  if [ "$(basename "$SOURCE")" = "$PINNED" ]; then
    if [ "$(sha256sum "$SOURCE" | cut -d' ' -f1)" != "$PINNED_SHA256" ]; then
      echo "make firmware: $SOURCE is not the pinned archive (sha256 differs)" >&2
      exit 2
    fi
    pinned=1
  fi
  tar -xzf "$SOURCE" -C "$OUT/unpacked"
fi
echo "make firmware: building the sketch from $SOURCE"
build_sketch "$OUT/unpacked" "$OUT" "stock"

# The project's firmware: the pristine sketch, patched.
mkdir -p "$OUT/fishtail"
cp -r "$OUT/unpacked" "$OUT/fishtail/unpacked"
patch_dir=$(dirname "$(dirname "$(find "$OUT/fishtail/unpacked" -name ROSArduinoBridge.ino | head -n 1)")")
if patch -s -p1 -d "$patch_dir" --dry-run <"$ROOT/firmware/fishtail.patch" >/dev/null 2>&1; then
  patch -s -p1 -d "$patch_dir" <"$ROOT/firmware/fishtail.patch"
  build_sketch "$OUT/fishtail/unpacked" "$OUT/fishtail" "fishtail"
  ln -sfn ../avr_board "$OUT/fishtail/avr_board"
elif [ "$pinned" = 1 ]; then
  echo "make firmware: firmware/fishtail.patch does not apply to the pinned sketch" >&2
  exit 1
else
  rm -rf "$OUT/fishtail"
  echo "make firmware: firmware/fishtail.patch does not apply to $SOURCE: stock build only"
fi

cc -O2 -Wall -Wextra -std=gnu11 -I/usr/include/simavr -o "$OUT/avr_board" \
  "$ROOT/firmware/avr_board.c" -lsimavr -lsimavrparts -lelf -lpthread -lutil
built="$OUT/ROSArduinoBridge.elf"
[ -f "$OUT/fishtail/ROSArduinoBridge.elf" ] && built="$built, $OUT/fishtail/ROSArduinoBridge.elf"
echo "make firmware: $built and $OUT/avr_board"
