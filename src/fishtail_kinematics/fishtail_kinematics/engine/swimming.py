"""Swimming figures from the tail tip's motion: beat frequency, excursion, Strouhal number, thrust.

The report leaves the hydrodynamics to future work; these are the standard first estimates from
the tip's motion and a given forward speed, fin span and water density (f, the peak-to-peak
excursion A, St = f A / U and Lighthill's mean thrust at the trailing edge), over whole beats
segmented as the monitor segments them. The monitor and the offline analysis share them; the fin
specs here are also the fish's. Formulas, assumptions and references: docs/swimming.md.

>>> import math
>>> import numpy as np
>>> t = np.linspace(0.0, 3.0, 30001)
>>> omega = 2 * math.pi  # 1 Hz
>>> h = 0.05 * np.sin(omega * t)
>>> figures = swimming_figures(
...     t, h, 0.05 * omega * np.cos(omega * t), np.arctan(0.3 * np.sin(omega * t)),
...     SwimmingParameters(forward_speed_m_s=0.4, fin_span_m=0.1))
>>> round(figures.beat_frequency_hz, 6), round(figures.tip_excursion_m, 6)
(1.0, 0.1)
>>> round(figures.strouhal_number, 6)
0.25
"""

from __future__ import annotations

import dataclasses
import math
from array import array
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

from fishtail_common.parameters import ParameterSpec
from fishtail_kinematics.engine.geometry import FloatArray, Real
from fishtail_kinematics.engine.symmetry import DEFAULT_HYSTERESIS_RAD, BeatStatistics, beats_of

#: Strouhal numbers at which efficient swimmers and flyers cruise (Taylor et al. 2003).
EFFICIENT_STROUHAL_RANGE = (0.2, 0.4)


#: Fresh water [kg/m^3].
FRESH_WATER_DENSITY_KG_M3 = 1000.0

#: The fin's span and the water's density: the monitor's, the analysis's and the fish's
#: (fishtail_plant's fish parameters are these very specs, so one fish file sets them all).
FIN_SPAN = ParameterSpec("fin_span_m", 0.1, "fin span s at the trailing edge (the tip)", "m",
                         1e-3, 5.0)  # fmt: skip
WATER_DENSITY = ParameterSpec(
    "water_density_kg_m3", FRESH_WATER_DENSITY_KG_M3, "water density rho", "kg/m^3", 1.0, 2000.0
)
#: What the monitor node declares and the analysis accepts (as flags and in a parameter file).
SWIMMING_PARAMETERS: tuple[ParameterSpec, ...] = (
    ParameterSpec(
        "forward_speed_m_s",
        0.3,
        "forward speed U for St and thrust, used when no simulated speed is available",
        "m/s",
        1e-3,
        20.0,
    ),
    FIN_SPAN,
    WATER_DENSITY,
)


def fin_added_mass_per_length(water_density_kg_m3: Real, fin_span_m: Real) -> Real:
    """Lighthill's m = (pi/4) rho s^2: added mass per unit length of the trailing edge [kg/m].

    Plain arithmetic, so a batch of fish (arrays) works as well as one.

    >>> round(fin_added_mass_per_length(1000.0, 0.1), 4)
    7.854
    """
    return 0.25 * math.pi * water_density_kg_m3 * fin_span_m**2


@dataclasses.dataclass(frozen=True)
class SwimmingParameters:
    """What the tail's motion does not tell: forward speed U, fin span s, water density rho.

    U is given, not computed (no drag model here; the monitor takes the swimming simulator's
    speed when it has one, :func:`choose_forward_speed`); s is the span (depth) of the fin at the
    trailing edge. SI units.

    Raises:
        ValueError: a value that is not a number, not finite, or not positive (naming the field).
    """

    forward_speed_m_s: float
    fin_span_m: float
    water_density_kg_m3: float = FRESH_WATER_DENSITY_KG_M3

    def __post_init__(self) -> None:
        """Refuse non-finite, zero or negative values with a message naming the field."""
        for field in dataclasses.fields(self):
            value = getattr(self, field.name)
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise ValueError(f"{field.name} must be a number, got {value!r}")
            if not (math.isfinite(value) and value > 0.0):
                raise ValueError(f"{field.name} must be finite and > 0, got {value!r}")
            object.__setattr__(self, field.name, float(value))

    @classmethod
    def from_values(cls, values: Mapping[str, object]) -> SwimmingParameters:
        """The parameters named in ``values``; the others take their specs' defaults.

        Raises:
            ValueError: as the class.
        """
        # Any: __post_init__ checks each value's type and names the field it refuses.
        chosen: dict[str, Any] = {
            spec.name: values.get(spec.name, spec.default) for spec in SWIMMING_PARAMETERS
        }
        return cls(**chosen)

    @property
    def added_mass_per_length_kg_m(self) -> float:
        """Lighthill's m = (pi/4) rho s^2 (:func:`fin_added_mass_per_length`)."""
        return float(fin_added_mass_per_length(self.water_density_kg_m3, self.fin_span_m))


#: Where the forward speed U of the monitor's figures came from (its ``forward_speed_source``).
SPEED_SOURCE_SIMULATED = "simulated"
SPEED_SOURCE_PARAMETER = "parameter"


def choose_forward_speed(
    parameter_m_s: float, simulated_m_s: float, simulated_age_s: float, max_age_s: float
) -> tuple[float, str]:
    """U for a beat's figures and its source: the simulated speed if usable, else the parameter.

    The simulated speed (the swimming simulator's mean speed over its latest beat) is usable when
    it is finite and > 0 (St and the thrust need a fish that moves) and at most ``max_age_s`` old.
    Without one, pass ``math.nan`` as the speed or ``math.inf`` as its age.

    >>> choose_forward_speed(0.3, 0.52, 0.4, 1.0)
    (0.52, 'simulated')
    >>> choose_forward_speed(0.3, 0.52, 1.5, 1.0)
    (0.3, 'parameter')
    """
    if math.isfinite(simulated_m_s) and simulated_m_s > 0.0 and simulated_age_s <= max_age_s:
        return simulated_m_s, SPEED_SOURCE_SIMULATED
    return parameter_m_s, SPEED_SOURCE_PARAMETER


@dataclasses.dataclass(frozen=True)
class TipKinematics:
    """What the swimming figures need from the tip's motion, over ``beats`` whole beats."""

    beats: int
    start_s: float
    end_s: float
    beat_frequency_hz: float
    tip_excursion_m: float  # A, peak to peak
    mean_square_lateral_velocity_m2_s2: float  # mean((dh/dt)^2)
    mean_square_slope: float  # mean((dh/dx)^2) = mean(tan^2(fin angle))


@dataclasses.dataclass(frozen=True)
class SwimmingFigures:
    """Tail-beat frequency, tip excursion, Strouhal number and Lighthill's mean thrust."""

    beats: int
    beat_frequency_hz: float
    tip_excursion_m: float
    strouhal_number: float
    mean_thrust_n: float  # negative: the tail's reactive force is a net drag at this speed
    added_mass_per_length_kg_m: float
    mean_square_lateral_velocity_m2_s2: float
    mean_square_slope: float

    @property
    def strouhal_in_efficient_range(self) -> bool:
        """Whether St lies in the 0.2-0.4 band of efficient swimmers."""
        low, high = EFFICIENT_STROUHAL_RANGE
        return low <= self.strouhal_number <= high


def strouhal_number(frequency_hz: float, excursion_m: float, forward_speed_m_s: float) -> float:
    """St = f A / U with A the peak-to-peak excursion.

    >>> strouhal_number(2.0, 0.05, 0.4)
    0.25

    Raises:
        ValueError: a forward speed that is not finite and > 0.
    """
    if not (math.isfinite(forward_speed_m_s) and forward_speed_m_s > 0.0):
        raise ValueError(f"forward speed must be finite and > 0, got {forward_speed_m_s!r}")
    return frequency_hz * excursion_m / forward_speed_m_s


def lighthill_mean_thrust(
    mean_square_lateral_velocity_m2_s2: float,
    mean_square_slope: float,
    parameters: SwimmingParameters,
) -> float:
    """Lighthill's mean thrust (m/2) [mean((dh/dt)^2) - U^2 mean((dh/dx)^2)] at the tip."""
    u = parameters.forward_speed_m_s
    return (
        0.5
        * parameters.added_mass_per_length_kg_m
        * (mean_square_lateral_velocity_m2_s2 - u * u * mean_square_slope)
    )


def figures_from_kinematics(
    kinematics: TipKinematics, parameters: SwimmingParameters
) -> SwimmingFigures:
    """The swimming figures of measured tip kinematics for given U, s and rho."""
    return SwimmingFigures(
        beats=kinematics.beats,
        beat_frequency_hz=kinematics.beat_frequency_hz,
        tip_excursion_m=kinematics.tip_excursion_m,
        strouhal_number=strouhal_number(
            kinematics.beat_frequency_hz, kinematics.tip_excursion_m, parameters.forward_speed_m_s
        ),
        mean_thrust_n=lighthill_mean_thrust(
            kinematics.mean_square_lateral_velocity_m2_s2, kinematics.mean_square_slope, parameters
        ),
        added_mass_per_length_kg_m=parameters.added_mass_per_length_kg_m,
        mean_square_lateral_velocity_m2_s2=kinematics.mean_square_lateral_velocity_m2_s2,
        mean_square_slope=kinematics.mean_square_slope,
    )


def _window(
    time_s: FloatArray, values: FloatArray, start: float, end: float
) -> tuple[FloatArray, FloatArray]:
    """(values, times) on [start, end]: the samples inside plus values interpolated at the ends."""
    inside = (time_s > start) & (time_s < end)
    ends = np.interp([start, end], time_s, values)
    window = np.concatenate(([ends[0]], values[inside], [ends[1]]))
    return window, np.concatenate(([start], time_s[inside], [end]))


def _mean(time_s: FloatArray, values: FloatArray, start: float, end: float) -> float:
    window, times = _window(time_s, values, start, end)
    return float(np.trapezoid(window, times) / (end - start))


def tip_kinematics(
    time_s: npt.ArrayLike,
    tip_y: npt.ArrayLike,
    tip_y_velocity: npt.ArrayLike,
    fin_angle: npt.ArrayLike,
    *,
    beats: Sequence[BeatStatistics] | None = None,
    hysteresis_rad: float = DEFAULT_HYSTERESIS_RAD,
) -> TipKinematics:
    """Frequency, excursion and mean squares of the tip motion over whole beats.

    ``time_s`` increasing [s]; ``tip_y`` [m] and ``tip_y_velocity`` [m/s] the tip's lateral
    position and velocity; ``fin_angle`` [rad] the angle of the last link to the body axis
    (theta3 or theta5). Beats are segmented on ``fin_angle`` unless ``beats`` (contiguous, from
    a :class:`~fishtail_kinematics.engine.symmetry.BeatTracker` over the same samples) are given.
    Values are interpolated linearly at the beat boundaries; the means are trapezoidal.

    Raises:
        ValueError: arrays of unequal length or not 1-D, non-finite samples, times not strictly
            increasing, no complete beat, beats not contiguous or not covered by the samples.
    """
    time_s = np.asarray(time_s, float)
    arrays = [np.asarray(a, float) for a in (tip_y, tip_y_velocity, fin_angle)]
    if time_s.ndim != 1 or any(a.shape != time_s.shape for a in arrays):
        raise ValueError("time_s, tip_y, tip_y_velocity and fin_angle must be 1-D and equally long")
    if not all(np.all(np.isfinite(a)) for a in (time_s, *arrays)):
        raise ValueError("the samples must be finite")
    if time_s.size > 1 and not np.all(np.diff(time_s) > 0.0):
        raise ValueError("time_s must be strictly increasing")
    tip_y, tip_y_velocity, fin_angle = arrays
    if beats is None:
        beats = beats_of(time_s, fin_angle, hysteresis_rad)
    if not beats:
        raise ValueError(
            "no complete tail beat in the samples (a beat runs from one upward zero crossing of "
            "the fin angle to the next)"
        )
    for before, after in zip(beats, beats[1:], strict=False):
        if after.start_s != before.end_s:
            raise ValueError("the beats must be contiguous")
    start, end = beats[0].start_s, beats[-1].end_s
    if time_s.size < 2 or start < time_s[0] or end > time_s[-1]:
        raise ValueError(f"the samples do not cover the beats [{start}, {end}] s")
    excursion, _ = _window(time_s, tip_y, start, end)
    return TipKinematics(
        beats=len(beats),
        start_s=start,
        end_s=end,
        beat_frequency_hz=len(beats) / (end - start),
        tip_excursion_m=float(excursion.max() - excursion.min()),
        mean_square_lateral_velocity_m2_s2=_mean(time_s, tip_y_velocity**2, start, end),
        mean_square_slope=_mean(time_s, np.tan(fin_angle) ** 2, start, end),
    )


def swimming_figures(
    time_s: npt.ArrayLike,
    tip_y: npt.ArrayLike,
    tip_y_velocity: npt.ArrayLike,
    fin_angle: npt.ArrayLike,
    parameters: SwimmingParameters,
    *,
    beats: Sequence[BeatStatistics] | None = None,
    hysteresis_rad: float = DEFAULT_HYSTERESIS_RAD,
) -> SwimmingFigures:
    """f, A, St and Lighthill's mean thrust of a recorded tip motion over whole beats.

    See :func:`tip_kinematics` for the inputs.

    Raises:
        ValueError: as :func:`tip_kinematics` (e.g. no complete beat), or an unusable U.
    """
    kinematics = tip_kinematics(
        time_s, tip_y, tip_y_velocity, fin_angle, beats=beats, hysteresis_rad=hysteresis_rad
    )
    return figures_from_kinematics(kinematics, parameters)


class TipSampleBuffer:
    """The tip samples of the beat in progress, for a live monitor (one beat at a time).

    :meth:`add` costs four appends to typed arrays; :meth:`complete` computes the
    :class:`TipKinematics` of a beat the caller's tracker has just completed and drops the samples
    it no longer needs. More than ``max_samples`` samples in one beat (a very slow beat at a high
    rate) drops the beat: :meth:`complete` then returns None.
    """

    def __init__(self, max_samples: int = 1 << 18) -> None:
        """Create an empty buffer holding at most ``max_samples`` samples."""
        self.max_samples = max_samples
        self.overflowed = False
        self._columns = tuple(array("d") for _ in range(4))

    def reset(self) -> None:
        """Forget every sample (e.g. after a gap, when the caller's tracker resets too)."""
        for column in self._columns:
            del column[:]
        self.overflowed = False

    def add(self, time_s: float, tip_y: float, tip_y_velocity: float, fin_angle: float) -> bool:
        """Append one sample; False (and nothing stored) if it is not finite or not newer.

        Add each sample before :meth:`complete` is called for the beat it ends, so that the
        samples cover the beat's end.
        """
        times, ys, velocities, angles = self._columns
        if (times and not time_s > times[-1]) or not math.isfinite(
            time_s + tip_y + tip_y_velocity + fin_angle
        ):
            return False
        if len(times) >= self.max_samples:
            self.reset()
            self.overflowed = True
        times.append(time_s)
        ys.append(tip_y)
        velocities.append(tip_y_velocity)
        angles.append(fin_angle)
        return True

    def __len__(self) -> int:
        """Samples held."""
        return len(self._columns[0])

    def complete(self, beat: BeatStatistics) -> TipKinematics | None:
        """The kinematics of ``beat`` (None if its samples were dropped); keeps what follows."""
        times = np.frombuffer(self._columns[0], dtype=float)
        result = None
        if not self.overflowed and times.size >= 2 and times[0] <= beat.start_s:
            columns = [np.frombuffer(column, dtype=float).copy() for column in self._columns]
            try:
                result = tip_kinematics(*columns, beats=[beat])
            except ValueError:
                result = None
        # Keep the last sample at or before the beat's end: the next beat starts there.
        keep_from = max(int(np.searchsorted(times, beat.end_s, side="right")) - 1, 0)
        del times
        for column in self._columns:
            del column[:keep_from]
        self.overflowed = False
        return result
