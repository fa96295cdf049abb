# Arduino.mk build of the joined ROSArduinoBridge sketch for an Arduino Nano (ATmega328P, 16 MHz);
# copied into build/firmware/sketch/ as its Makefile by firmware/build.sh.
BOARD_TAG = nano
BOARD_SUB = atmega328
ARDUINO_DIR = /usr/share/arduino
TARGET = ROSArduinoBridge
# The sketch's C++ predates C++17's stricter rules; avr-libc's float.h lacks DECIMAL_DIG,
# which libstdc++'s headers pulled in by Arduino.mk's defaults expect.
CXXFLAGS_STD = -std=gnu++11
include /usr/share/arduino/Arduino.mk
CPPFLAGS += -DDECIMAL_DIG=17
