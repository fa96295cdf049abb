"""The analysis's report as text: what ``fishtail-analyse`` prints."""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Sequence

import numpy as np

from fishtail_kinematics.engine.swimming import EFFICIENT_STROUHAL_RANGE
from fishtail_kinematics.engine.symmetry import Verdict
from fishtail_kinematics.offline.analysis import (
    AGREEMENT_TOLERANCE,
    JudgedBeat,
    Report,
    SwimmingResult,
)


def speed_text(result: SwimmingResult) -> str:
    """Which U the swimming figures use: recorded (per beat, from which topic) or assumed."""
    p = result.parameters
    if result.speed_origin == "assumed":
        why = f"; {result.assumed_because}" if result.assumed_because else ""
        return f"U = {p.forward_speed_m_s:g} m/s assumed (forward_speed_m_s{why})"
    speeds = [b.forward_speed_m_s for b in result.per_beat]
    sources = " and ".join(result.speed_sources)
    text = (
        f"U recorded per beat ({sources}), {min(speeds):.3g}-{max(speeds):.3g} m/s, "
        f"mean {p.forward_speed_m_s:.3g} m/s"
    )
    if result.speed_origin != "recorded":
        text += (
            f"; recorded for {result.recorded_beats} of {len(result.per_beat)} beats, "
            f"{result.assumed_speed_m_s:g} m/s assumed (forward_speed_m_s) for the others"
        )
    return text


def swimming_text(result: SwimmingResult) -> str:
    """One line for the swimming figures and what they assume."""
    p = result.parameters
    figures = result.figures
    assumed = (
        f"{speed_text(result)}, fin span {p.fin_span_m:g} m, rho = {p.water_density_kg_m3:g} kg/m^3"
    )
    low, high = EFFICIENT_STROUHAL_RANGE
    band = "inside" if figures.strouhal_in_efficient_range else "outside"
    over = "" if result.speed_origin == "assumed" else " (U: the mean)"
    return (
        f"swimming ({assumed}): f = {figures.beat_frequency_hz:.4f} Hz, "
        f"A = {figures.tip_excursion_m:.4f} m (tip, peak to peak), "
        f"St = f A / U = {figures.strouhal_number:.3f}{over} ({band} {low:g}-{high:g}), "
        f"mean thrust (Lighthill, at the tip) = {figures.mean_thrust_n:.4g} N over "
        f"{figures.beats} beats"
    )


def swimming_beat_lines(result: SwimmingResult) -> list[str]:
    """Per beat: U and its source, f, A, St and thrust (when some U was recorded)."""
    if result.speed_origin == "assumed":
        return []
    lines = [
        f"{'swim':>4} {'start s':>8} {'U m/s':>7} {'U from':<13} {'freq Hz':>7} {'A m':>7} "
        f"{'St':>6} {'thrust N':>9}"
    ]
    for beat in result.per_beat:
        f = beat.figures
        lines.append(
            f"{beat.index:>4} {beat.start_s:>8.3f} {beat.forward_speed_m_s:>7.4f} "
            f"{beat.speed_source:<13} {f.beat_frequency_hz:>7.4f} {f.tip_excursion_m:>7.4f} "
            f"{f.strouhal_number:>6.3f} {f.mean_thrust_n:>9.4g}"
        )
    return lines


def format_report(report: Report) -> str:
    """The report as text (what ``fishtail-analyse`` prints)."""
    recording = report.recording
    lines = [
        f"input: {recording.source} ({recording.description})",
        f"mechanism: {report.geometry.mechanism}; geometry: {report.geometry_source}",
        f"carrier angle: {recording.carrier_source}",
    ]
    lines += [f"note: {note}" for note in recording.notes]
    d = report.disagreement
    if d is None:
        lines.append("disagreement: n/a (no recorded tail state)")
    elif not d.per_field:
        lines.append("disagreement: n/a (no comparable field)")
    else:
        verdict = (
            f"agrees (tolerance {AGREEMENT_TOLERANCE:g})"
            if d.agrees
            else "DISAGREES: was the recording made with another geometry? (--config FILE)"
        )
        lines.append(
            f"disagreement: worst {d.worst:.3g} in {d.worst_field} over {d.samples} recomputed "
            f"tail states: {verdict}"
        )
    lines.append("")
    origin = float(recording.stamp_s[0]) if recording.stamp_s.size else 0.0
    lines += beat_table_lines(report.beats, origin)
    frequencies = report.frequencies_hz
    if frequencies.size:
        lines.append(
            f"beat frequency: {np.mean(frequencies):.4f} Hz (mean of {frequencies.size} beats, "
            f"min {np.min(frequencies):.4f}, max {np.max(frequencies):.4f})"
        )
    else:
        lines.append("beat frequency: n/a (no complete beat)")
    if recording.monitor_verdicts:
        counts = Counter(recording.monitor_verdicts)
        lines.append(
            f"monitor (tail/symmetry in the recording): {len(recording.monitor_verdicts)} beats, "
            + ", ".join(f"{counts.get(int(v), 0)} {v.name}" for v in Verdict)
        )
    if report.swimming is not None:
        lines += swimming_beat_lines(report.swimming)
        lines.append(swimming_text(report.swimming))
    lines.append("figures: " + " ".join(str(path) for path in report.figures))
    return "\n".join(lines)


def beat_table_lines(beats: Sequence[JudgedBeat], origin_s: float = 0.0) -> list[str]:
    """The per-beat symmetry table (start times relative to ``origin_s``), a summary last."""
    if not beats:
        return ["symmetry: no complete beat (theta3 must cross zero upwards twice)"]
    lines = [
        f"{'beat':>4} {'start s':>8} {'period s':>8} {'freq Hz':>7} {'+peak°':>7} {'-peak°':>7} "
        f"{'mean°':>7} {'+share':>6}  verdict     reason"
    ]
    for judged in beats:
        b = judged.beat
        lines.append(
            f"{b.index:>4} {b.start_s - origin_s:>8.3f} {b.period_s:>8.4f} {b.frequency_hz:>7.4f} "
            f"{math.degrees(b.positive_peak_rad):>7.3f} {math.degrees(b.negative_peak_rad):>7.3f} "
            f"{math.degrees(b.mean_angle_rad):>7.3f} {b.positive_time_share:>6.4f}  "
            f"{judged.verdict.name:<10}  {judged.reason}"
        )
    counts = Counter(judged.verdict for judged in beats)
    lines.append(
        f"symmetry: {len(beats)} beats: "
        + ", ".join(f"{counts.get(v, 0)} {v.name}" for v in Verdict)
    )
    return lines
