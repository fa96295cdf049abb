"""The driver's parameters (name, default, range, meaning: each once) and the backend they make.

Plain Python, so that the node, the launch file and the tests share one table: the node declares
these and checks run-time changes against them, and :func:`make_backend` turns the values in
force into the backend they describe (the simulated ``first_order`` or ``dc`` motor, or the
board). The ``dc`` motor's parameters and defaults: docs/motor-load.md; the serial ones:
docs/serial.md; the rest: README.md ("Parameters").
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping

from fishtail_common.interface import CARRIER_JOINT
from fishtail_common.parameters import ParameterSpec, ParameterValue
from fishtail_driver.backends import MotorBackend, SimBackend, SimMotor
from fishtail_driver.protocol import ProfileTuning, parse_profile_tuning
from fishtail_kinematics.engine.carrier_profile import DEFAULT_TOP_SPEED_RAD_S
from fishtail_plant.linkage_load.surroundings import NO_LOAD, SURROUNDINGS
from fishtail_plant.motor.board_units import Scale
from fishtail_plant.motor.dc_motor import (
    DcMotor,
    DcMotorParameters,
    LoadInertia,
    LoadTorque,
    zero_load,
    zero_load_inertia,
)
from fishtail_plant.motor.first_order import MotorParameters, SimulatedMotor
from fishtail_plant.motor.pid_dc_motor import PidDrivenDcMotor, unstable_speed_loop
from fishtail_plant.motor.speed_loop import PidGains
from fishtail_plant.pivot_actuator import PIVOT_SPEED, PIVOT_STROKE, PivotLimits

ParameterValues = Mapping[str, ParameterValue]
#: ``pivot_actuator`` values.
PIVOT_ACTUATORS = ("none", "sim")
NO_PIVOT = "none"

DRIVER_PARAMETERS: tuple[ParameterSpec, ...] = (
    ParameterSpec("backend", "sim", "motor backend: sim or serial", choices=("sim", "serial"),
                  read_only=True),
    ParameterSpec("publish_rate_hz", 200.0, "encoder publish rate", "Hz", 1.0, 1000.0),
    ParameterSpec("cmd_timeout_sec", 0.5, "stop the motor when no command arrives for this long; "
                  "0 disables the watchdog (sim backend only)", "s", 0.0, 60.0),
    ParameterSpec("max_speed_rad_s", DEFAULT_TOP_SPEED_RAD_S,
                  "commands above this carrier speed are clamped", "rad/s", 0.1, 1000.0,
                  read_only=True),
    ParameterSpec("joint_name", CARRIER_JOINT,
                  "name of the carrier joint in motor/joint_state (not empty)", non_empty=True),
    ParameterSpec("diagnostics_period_sec", 1.0, "period of /diagnostics", "s", 0.1, 60.0,
                  read_only=True),
    ParameterSpec("rate_warn_fraction", 0.8, "WARN when motor/joint_state's rate over the last "
                  "max(diagnostics_period_sec, 1 s) is below this fraction of the promised rate: "
                  "publish_rate_hz, with backend serial at most serial_poll_rate_hz; 0 disables",
                  minimum=0.0, maximum=1.0),
    ParameterSpec("gap_warn_sec", 0.1, "WARN when motor/joint_state has a gap longer than this "
                  "(and than 3 promised periods) in that window; 0 disables", "s", 0.0, 60.0),
    ParameterSpec("encoder_counts_per_revolution", 2048,
                  "encoder counts per motor-shaft revolution", minimum=1, maximum=10_000_000,
                  read_only=True),
    ParameterSpec("gear_ratio", 1.0, "motor-shaft turns per carrier turn", minimum=0.001,
                  maximum=10000.0, read_only=True),
    ParameterSpec("sim_time_constant_sec", 0.15, "sim: first-order speed time constant", "s",
                  0.001, 100.0, read_only=True),
    ParameterSpec("sim_speed_noise_rad_s", 0.0, "sim: std of a stationary speed disturbance "
                  "(correlation time: the time constant)", "rad/s", 0.0, 100.0, read_only=True),
    ParameterSpec("sim_seed", 0, "sim: noise seed", read_only=True),
    ParameterSpec("motor_model", "first_order", "sim: the simulated motor: first_order (a speed "
                  "lag, sim_time_constant_sec) or dc (a DC gear motor under the board firmware's "
                  "speed loop; effort in motor/joint_state)", choices=("first_order", "dc"),
                  read_only=True),
    ParameterSpec("motor_load", NO_LOAD, "sim, motor_model dc: what the motor turns: none, the "
                  "tail in air (its links' inertia), in water with the fish held at rest "
                  "(water_held) or towed at the speed it swims at (water_swimming); the tail, its "
                  "links' masses and the fish are the geometry, link-inertia and fish parameters "
                  "(config/<mechanism>.yaml, config/fish.yaml)", choices=SURROUNDINGS,
                  read_only=True),
    # The DC motor (motor_model dc): electrical and friction figures at the motor shaft, before
    # the gearbox (gear_ratio). Defaults: a Pololu 37D 12 V motor (dc_motor.DcMotorParameters).
    ParameterSpec("supply_voltage_v", 12.0, "dc: motor supply voltage (armature voltage at full "
                  "PWM)", "V", 0.1, 1000.0, read_only=True),
    ParameterSpec("motor_resistance_ohm", 2.18, "dc: armature resistance", "ohm", 1e-4, 1e4,
                  read_only=True),
    ParameterSpec("motor_torque_constant_n_m_a", 0.01115, "dc: torque constant (= back-EMF "
                  "constant in V s/rad)", "N m/A", 1e-6, 100.0, read_only=True),
    ParameterSpec("gearbox_efficiency", 0.76, "dc: fraction of the power the gearbox passes on, "
                  "either way", minimum=0.01, maximum=1.0, read_only=True),
    ParameterSpec("rotor_inertia_kg_m2", 3e-6, "dc: rotor inertia at the motor shaft", "kg m^2",
                  1e-10, 10.0, read_only=True),
    ParameterSpec("viscous_friction_n_m_s", 1.1e-6, "dc: viscous friction at the motor shaft",
                  "N m s/rad", 0.0, 10.0, read_only=True),
    ParameterSpec("coulomb_friction_n_m", 1.1e-3, "dc: Coulomb friction at the motor shaft (also "
                  "the breakaway torque)", "N m", 0.0, 100.0, read_only=True),
    ParameterSpec("pid_kp", 20, "dc: the firmware's speed-loop Kp (as 'u kp:kd:ki:ko' sets it)",
                  minimum=-32768, maximum=32767, read_only=True),
    ParameterSpec("pid_kd", 12, "dc: the firmware's speed-loop Kd", minimum=-32768,
                  maximum=32767, read_only=True),
    ParameterSpec("pid_ki", 0, "dc: the firmware's speed-loop Ki", minimum=-32768, maximum=32767,
                  read_only=True),
    ParameterSpec("pid_ko", 50, "dc: the firmware's speed-loop Ko (the increment's divisor)",
                  minimum=1, maximum=32767, read_only=True),
    # The serial backend (a ROSArduinoBridge board); the encoder is described by
    # encoder_counts_per_revolution and gear_ratio, shared with the sim backend.
    ParameterSpec("serial_port", "/dev/ttyACM0", "serial: device path (prefer "
                  "/dev/serial/by-id/...) or pyserial URL", non_empty=True, read_only=True),
    ParameterSpec("serial_baud", 57600, "serial: baud rate (the firmware's BAUDRATE)",
                  minimum=300, maximum=4_000_000, read_only=True),
    ParameterSpec("serial_read_timeout_sec", 0.1, "serial: longest wait for one reply", "s",
                  0.005, 5.0, read_only=True),
    ParameterSpec("serial_channel", "left", "serial: motor channel of the tail on the board: "
                  "left or right", choices=("left", "right"), read_only=True),
    ParameterSpec("serial_pid_rate_hz", 30, "serial, and sim with motor_model dc: the firmware's "
                  "PID_RATE; the PID frame is 1000 // PID_RATE ms (30 -> 33 ms = 30.30 Hz); m "
                  "speeds are encoder ticks per frame", "Hz", 1, 1000, read_only=True),
    ParameterSpec("serial_poll_rate_hz", 100.0, "serial: encoder ('e') polls per second", "Hz",
                  1.0, 1000.0, read_only=True),
    ParameterSpec("serial_resend_period_sec", 0.5, "serial: re-send the current non-zero speed "
                  "this often, within the board's 2 s auto-stop", "s", 0.05, 1.5, read_only=True),
    ParameterSpec("serial_handshake_timeout_sec", 5.0, "serial: how long the board may take to "
                  "answer after the port opens (boards that reset on open boot for 1-2 s)", "s",
                  0.1, 60.0, read_only=True),
    ParameterSpec("serial_profile_on_board", True, "serial: on the project's motor-board firmware "
                  "(it answers 'v'), send a speed profile once ('f') and let the board follow it "
                  "at every PID frame; false: follow it on the host with 'm' at every encoder "
                  "sample, as on the stock firmware (docs/serial.md)", read_only=True),
    ParameterSpec("serial_profile_tuning", "", "serial: on the project's motor-board firmware, "
                  "how the board follows a profile: 'k LEAD:KV:KA:KS[:KQ]' sent at every connect "
                  "(the law LEAD ms ahead, a feed-forward PWM from its speed, change, friction "
                  "and speed squared; docs/firmware.md, e.g. 8:5955:1889:5:690 for the 37D in "
                  "water); empty: not sent, the firmware's default loop", read_only=True),
    ParameterSpec("serial_stale_timeout_sec", 1.0, "serial: no valid reply for this long: "
                  "reconnect", "s", 0.1, 60.0, read_only=True),
    # The pivot actuator: a lead screw shifting the tail's pivot S along the body axis
    # (fishtail_plant.pivot_actuator); the command watchdog leaves it where it is.
    ParameterSpec("pivot_actuator", "none", "the pivot actuator: none (no pivot topics) or sim (a "
                  "simulated lead screw: pivot/cmd_position in, pivot/joint_state out; backend "
                  "sim only)", choices=PIVOT_ACTUATORS, read_only=True),
    dataclasses.replace(PIVOT_STROKE, read_only=True),
    dataclasses.replace(PIVOT_SPEED, read_only=True),
)  # fmt: skip

#: The specs by name.
SPECS: dict[str, ParameterSpec] = {spec.name: spec for spec in DRIVER_PARAMETERS}

#: The default DC motor's gearbox and encoder (Pololu 37D 30:1, 16 lines counted on all four
#: edges), which ``gear_ratio`` and ``encoder_counts_per_revolution`` do not default to: what
#: ``fishtail-run --motor dc`` and the launch file's ``motor_model:=dc`` set.
DC_MOTOR_ENCODER: dict[str, ParameterValue] = {
    "gear_ratio": DcMotorParameters().gear_ratio,
    "encoder_counts_per_revolution": 64,
}


def _first_order_motor(values: ParameterValues, load: LoadTorque, inertia: LoadInertia) -> SimMotor:
    """The speed lag; it feels no load."""
    return SimulatedMotor(
        MotorParameters(
            time_constant_s=float(values["sim_time_constant_sec"]),
            max_speed_rad_s=float(values["max_speed_rad_s"]),
            counts_per_revolution=int(values["encoder_counts_per_revolution"]),
            gear_ratio=float(values["gear_ratio"]),
            speed_noise_rad_s=float(values["sim_speed_noise_rad_s"]),
            seed=int(values["sim_seed"]),
        )
    )


def _dc_motor(values: ParameterValues, load: LoadTorque, inertia: LoadInertia) -> SimMotor:
    parameters = DcMotorParameters(
        resistance_ohm=float(values["motor_resistance_ohm"]),
        torque_constant_n_m_a=float(values["motor_torque_constant_n_m_a"]),
        supply_voltage_v=float(values["supply_voltage_v"]),
        gear_ratio=float(values["gear_ratio"]),
        gearbox_efficiency=float(values["gearbox_efficiency"]),
        rotor_inertia_kg_m2=float(values["rotor_inertia_kg_m2"]),
        viscous_friction_n_m_s=float(values["viscous_friction_n_m_s"]),
        coulomb_friction_n_m=float(values["coulomb_friction_n_m"]),
    )
    gains = PidGains(
        int(values["pid_kp"]), int(values["pid_kd"]), int(values["pid_ki"]), int(values["pid_ko"])
    )
    scale = Scale(
        int(values["encoder_counts_per_revolution"]),
        float(values["gear_ratio"]),
        int(values["serial_pid_rate_hz"]),
    )
    reason = unstable_speed_loop(
        DcMotor(parameters), scale, gains, float(values["max_speed_rad_s"])
    )
    if reason is not None:
        raise ValueError(reason)
    return PidDrivenDcMotor(DcMotor(parameters, load, inertia), scale, gains)


_SIM_MOTORS: dict[str, Callable[[ParameterValues, LoadTorque, LoadInertia], SimMotor]] = {
    "first_order": _first_order_motor,
    "dc": _dc_motor,
}


def make_sim_motor(
    values: ParameterValues,
    load: LoadTorque = zero_load,
    load_inertia: LoadInertia = zero_load_inertia,
) -> SimMotor:
    """The simulated motor ``motor_model`` names, as the sim backend runs it (for its own clock).

    Raises:
        ValueError: a motor value the model refuses, or a ``dc`` speed loop that would ring
            (the gains on this gearbox and encoder; the reason names the values and the fix).
    """
    return _SIM_MOTORS[str(values["motor_model"])](values, load, load_inertia)


def _sim_backend(values: ParameterValues, load: LoadTorque, inertia: LoadInertia) -> MotorBackend:
    return SimBackend(make_sim_motor(values, load, inertia))


def _serial_backend(
    values: ParameterValues, load: LoadTorque, inertia: LoadInertia
) -> MotorBackend:
    """The board; the load is the real one."""
    # Imported here: pyserial is needed with a board only.
    from fishtail_driver.serial_backend import SerialBackend
    from fishtail_driver.serial_config import SerialConfig

    read_timeout_s = float(values["serial_read_timeout_sec"])
    return SerialBackend(
        SerialConfig(
            port=str(values["serial_port"]),
            baud=int(values["serial_baud"]),
            read_timeout_s=read_timeout_s,
            channel=str(values["serial_channel"]),
            counts_per_revolution=int(values["encoder_counts_per_revolution"]),
            gear_ratio=float(values["gear_ratio"]),
            pid_rate_hz=int(values["serial_pid_rate_hz"]),
            poll_rate_hz=float(values["serial_poll_rate_hz"]),
            resend_period_s=float(values["serial_resend_period_sec"]),
            max_speed_rad_s=float(values["max_speed_rad_s"]),
            handshake_timeout_s=float(values["serial_handshake_timeout_sec"]),
            stale_timeout_s=max(float(values["serial_stale_timeout_sec"]), 2.0 * read_timeout_s),
            profile_on_board=bool(values["serial_profile_on_board"]),
            profile_tuning=_profile_tuning(str(values["serial_profile_tuning"])),
        )
    )


def _profile_tuning(text: str) -> ProfileTuning | None:
    """``serial_profile_tuning``'s value, or a one-line ValueError naming the parameter."""
    try:
        return parse_profile_tuning(text)
    except ValueError as error:
        raise ValueError(f"serial_profile_tuning: {error}") from None


_BACKENDS: dict[str, Callable[[ParameterValues, LoadTorque, LoadInertia], MotorBackend]] = {
    "sim": _sim_backend,
    "serial": _serial_backend,
}


def make_backend(
    values: ParameterValues,
    load: LoadTorque = zero_load,
    load_inertia: LoadInertia = zero_load_inertia,
) -> MotorBackend:
    """The backend the ``backend`` parameter names, configured from ``values`` (not started).

    ``load`` and ``load_inertia`` are the carrier's load for a simulated motor that feels one
    (``motor_model`` dc; :mod:`fishtail_plant.motor.dc_motor` says what they return); none by
    default.

    Raises:
        ValueError: with the reason, for settings the backend cannot work with.
    """
    _profile_tuning(str(values["serial_profile_tuning"]))  # refused with any backend
    return _BACKENDS[str(values["backend"])](values, load, load_inertia)


def load_refusal(values: Mapping[str, object]) -> str | None:
    """Why the driver's ``values`` cannot carry their ``motor_load``, or None when they can."""
    load = values["motor_load"]
    if load == NO_LOAD:
        return None
    if values["backend"] != "sim" or values["motor_model"] != "dc":
        return (
            f"motor_load {load} needs backend sim with motor_model dc (got backend "
            f"{values['backend']}, motor_model {values['motor_model']}): only the simulated DC "
            "motor feels a load"
        )
    return None


def pivot_refusal(values: ParameterValues) -> str | None:
    """Why ``values`` cannot have their ``pivot_actuator``, or None when they can."""
    if values["pivot_actuator"] != NO_PIVOT and values["backend"] != "sim":
        return (
            f"pivot_actuator {values['pivot_actuator']} needs backend sim (got backend "
            f"{values['backend']}): a simulated pivot beside a real motor would publish a pivot "
            "position that nothing moves, and the driver does not yet drive a pivot on the motor "
            "board's second channel (docs/serial.md, 'The pivot actuator')"
        )
    return None


def pivot_limits(values: ParameterValues) -> PivotLimits:
    """The pivot actuator's stroke and speed."""
    return PivotLimits(float(values["pivot_stroke_m"]), float(values["pivot_speed_m_s"]))
