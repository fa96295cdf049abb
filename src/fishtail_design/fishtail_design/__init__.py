"""Synthesis of the tail drive: which linkage, gear ratio and beat make the best fish.

For a fish and a DC gear motor, ``fishtail-design`` searches the linkage's lengths, the gear
ratio and the operating carrier speed for the designs that swim fastest, cost least energy per
metre, turn best or draw least current, with the plant's physics in the loop. The problem, the
method and a worked example: docs/design.md.
"""
