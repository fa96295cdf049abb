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


def swimming_text(result: SwimmingResult) -> str:
    """One line for the swimming figures and what they assume."""
    p = result.parameters
    figures = result.figures
    assumed = (
        f"U = {p.forward_speed_m_s:g} m/s, fin span {p.fin_span_m:g} m, "
        f"rho = {p.water_density_kg_m3:g} kg/m^3"
    )
    low, high = EFFICIENT_STROUHAL_RANGE
    band = "inside" if figures.strouhal_in_efficient_range else "outside"
    return (
        f"swimming ({assumed}): f = {figures.beat_frequency_hz:.4f} Hz, "
        f"A = {figures.tip_excursion_m:.4f} m (tip, peak to peak), "
        f"St = f A / U = {figures.strouhal_number:.3f} ({band} {low:g}-{high:g}), mean thrust "
        f"(Lighthill, at the tip) = {figures.mean_thrust_n:.4g} N over {figures.beats} beats"
    )


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
