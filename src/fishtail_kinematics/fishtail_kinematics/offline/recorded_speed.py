"""The forward speed U of each analysed tail beat: the recorded fish's where the bag has it.

St = f A / U and Lighthill's thrust need the fish's forward speed. A bag of the suite with the
swimming simulator (or a tracked real fish) records it: ``fish/odom`` (the surge u of its twist,
per carrier sample) and ``fish/swimming`` (the mean speed over each carrier revolution). For each
beat of the analysis (from one upward zero crossing of the fin angle to the next) U is, in this
order:

1. ``fish/odom``: the time-mean of the surge u over the beat (trapezoidal, interpolated at the
   beat's ends), when the samples cover the beat without a gap longer than :data:`ODOM_MAX_GAP_S`;
2. ``fish/swimming``: the mean of the ``mean_speed_m_s`` of the revolutions overlapping the beat,
   weighted by the overlap, when those revolutions cover the beat (a tail beat and a carrier
   revolution last as long but start at different phases);
3. the assumed ``forward_speed_m_s`` (parameter, ``--forward-speed-m-s``), for a bag without a
   fish, a beat outside the fish's recording, or a recorded U that is not > 0 (a fish at rest).

Pure numpy; docs/recording.md ("fishtail-analyse", swimming figures).

>>> import numpy as np
>>> fish = RecordedFish("/fish/odom", np.linspace(0.0, 2.0, 201), np.full(201, 0.15),
...                     None, np.array([]), np.array([]), np.array([]))
>>> beat_speed(fish, 0.25, 1.25, 0.3)
(0.15, 'fish/odom')
>>> beat_speed(fish, 1.5, 2.5, 0.3)
(0.3, 'assumed')
"""

from __future__ import annotations

import numpy as np

from fishtail_kinematics.offline.recording import RecordedFish

#: fish/odom samples further apart than this inside a beat leave the beat to the next source [s].
ODOM_MAX_GAP_S = 0.1
#: fish/swimming windows must cover the beat to within this share of its duration (their stamps'
#: rounding; a revolution with no message leaves a gap of up to a whole beat).
_COVERAGE = 0.02

SOURCE_ODOM = "fish/odom"
SOURCE_SWIMMING = "fish/swimming"
SOURCE_ASSUMED = "assumed"


def odom_speed(fish: RecordedFish, start_s: float, end_s: float) -> float | None:
    """Time-mean surge over [start_s, end_s] from fish/odom; None if it does not cover the beat."""
    time_s, surge = fish.odom_time_s, fish.odom_surge_m_s
    if time_s.size < 2 or time_s[0] > start_s or time_s[-1] < end_s or end_s <= start_s:
        return None
    inside = (time_s > start_s) & (time_s < end_s)
    times = np.concatenate(([start_s], time_s[inside], [end_s]))
    if np.max(np.diff(times)) > ODOM_MAX_GAP_S:
        return None
    values = np.concatenate(
        ([np.interp(start_s, time_s, surge)], surge[inside], [np.interp(end_s, time_s, surge)])
    )
    return float(np.trapezoid(values, times) / (end_s - start_s))


def swimming_speed(fish: RecordedFish, start_s: float, end_s: float) -> float | None:
    """Overlap-weighted mean speed of the fish/swimming windows covering [start_s, end_s]."""
    if fish.swim_end_s.size == 0 or end_s <= start_s:
        return None
    overlap = np.clip(
        np.minimum(fish.swim_end_s, end_s) - np.maximum(fish.swim_start_s, start_s), 0.0, None
    )
    covered = float(np.sum(overlap))
    if covered < (1.0 - _COVERAGE) * (end_s - start_s):
        return None
    return float(np.dot(overlap, fish.swim_speed_m_s) / covered)


def beat_speed(
    fish: RecordedFish | None, start_s: float, end_s: float, assumed_m_s: float
) -> tuple[float, str]:
    """U of the beat [start_s, end_s] and where it came from (a ``SOURCE_*``)."""
    if fish is not None:
        for speed, source in (
            (odom_speed(fish, start_s, end_s), SOURCE_ODOM),
            (swimming_speed(fish, start_s, end_s), SOURCE_SWIMMING),
        ):
            if speed is not None and np.isfinite(speed) and speed > 0.0:
                return speed, source
    return assumed_m_s, SOURCE_ASSUMED
