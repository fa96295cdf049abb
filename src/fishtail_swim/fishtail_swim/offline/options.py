"""The options that several ``fishtail-swim`` commands share, as parameter specs.

A command that means something else by one of them says so with :func:`dataclasses.replace`
(its own default or text); the name, unit and range stay these.
"""

from __future__ import annotations

from fishtail_common.parameters import ParameterSpec

#: The carrier speed of a run: the fish needs a beating tail.
CARRIER_SPEED = ParameterSpec("speed", 4.0, "carrier speed", "rad/s", 0.0, exclusive_minimum=True)
#: RK4 steps per tail beat of a time-stepped run; the step is the beat period over this.
STEPS_PER_BEAT = ParameterSpec("steps_per_beat", 32, "RK4 steps per tail beat", "", 4, 100_000)
#: Most RK4 steps one run from rest (simulate, animate) takes: the run is held in memory (48 bytes
#: a step) and simulate writes a CSV row a step (about 170 bytes, so at most about 170 MB; 9 s
#: with the compiled loop). Steps = duration x speed / 2 pi x steps per beat.
MAX_STEPS = 1_000_000
#: Most values one list option (carrier speeds, beat frequencies, depths) takes: one batch.
MAX_VALUES = 10_000
