"""Swimming simulator node: the carrier's samples in, one simulated fish out.

A thin rclpy shell around :class:`~fishtail_plant.fish.follower.SwimFollower`: one fish that swims
with the tail the motor actually turns, integrated between consecutive ``motor/joint_state``
samples (plausible ones only, by the kinematics node's rules), and published as ``fish/odom``,
per-beat ``fish/swimming``, markers, tf and ``/diagnostics``. Every parameter (the geometry and
the fish) is read-only: the fish and its tail are fixed for a run. Topics, parameters and
behaviour: docs/swimming-dynamics.md ("The simulator node").
"""

from __future__ import annotations

import math
import sys
import threading
import time
from typing import TYPE_CHECKING, Any

from diagnostic_msgs.msg import DiagnosticArray
from nav_msgs.msg import Odometry
from sensor_msgs.msg import JointState

from fishtail_common.interface import (
    DIAGNOSTICS,
    FISH_ODOM,
    FISH_SWIMMING,
    MOTOR_JOINT_STATE,
    PIVOT_JOINT,
    PIVOT_JOINT_STATE,
    Level,
    Status,
)
from fishtail_common.parameters import ParameterSpec, read_only
from fishtail_common.ros import (
    ListenedPublisher,
    NodeFactory,
    SuiteNodeBase,
    declare,
    diagnostic_array,
    run_node,
    subscriber_qos,
    suite_publisher,
)
from fishtail_common.stream_timing import PersistentStatus, StreamTiming
from fishtail_kinematics.engine.errors import FishtailKinematicsError
from fishtail_kinematics.engine.input_guard import (
    CARRIER_JUMP,
    ENGINE_REFUSED,
    FOLLOWER_REASONS,
    GUARD_PARAMETERS,
    MAX_CARRIER_SPEED,
    MOTOR_JOINT_NAME,
    NO_CARRIER_JOINT,
    REASON_TEXT,
    STALE_TIMEOUT,
    STAMP_NOT_INCREASING,
    CarrierGuard,
    CarrierJoint,
    DropCounts,
    input_status,
)
from fishtail_msgs.msg import SwimFigures
from fishtail_plant.errors import SwimError
from fishtail_plant.fish import fused
from fishtail_plant.fish.beats import BeatFigures
from fishtail_plant.fish.fish import FISH_PARAMETERS
from fishtail_plant.fish.follower import CarrierJumpError, StampNotIncreasingError, SwimFollower
from fishtail_plant.fish.model import PSI, SURGE, SWAY, YAW_RATE, X, Y
from fishtail_plant.values import TAIL_PARAMETERS, fish_from_values, tail_from_values
from fishtail_swim.frames import yaw_quaternion
from fishtail_swim.nodes.fish_markers import (
    MARKER_PARAMETERS,
    MARKERS_PATH_LENGTH,
    MARKERS_RATE,
    FishMarkerPublisher,
)
from fishtail_swim.nodes.fish_tf import (
    BASE_FRAME_ID,
    FRAME_PARAMETERS,
    ODOM_FRAME_ID,
    PUBLISH_TF,
    FishTfBroadcaster,
    tf_message_type,
)

if TYPE_CHECKING:
    from builtin_interfaces.msg import Time

INPUT_TOPIC = MOTOR_JOINT_STATE.name
DIAGNOSTICS_PERIOD_S = 1.0
#: The smallest pivot movement the simulated tail follows.
PIVOT_RESOLUTION_M = 1e-4
#: A period's mean carrier speed this far above max_carrier_speed_rad_s is warned: the stamps'
#: jitter at both ends of a 1 s period is well below it.
SPEED_WARN_TOLERANCE = 0.01
#: The simulator's drop reasons: the follower's, and a carrier jump.
SIM_REASONS = (*FOLLOWER_REASONS, CARRIER_JUMP)
#: The integrator's phases (diagnostic value ``integrator``): while it is being prepared (numba's
#: cache had no current loop, had one, or cannot tell), and once it is ready.
COMPILING, LOADING, PREPARING = "compiling", "loading", "preparing"
COMPILED, LOADED, READY = "compiled", "loaded", "ready"
PREPARING_PHASES = (COMPILING, LOADING, PREPARING)
#: What a cold compile takes, said beforehand: 6-12 s on an idle 2-core x86 machine, 17-18 s
#: there while the rest of the suite starts.
COMPILE_ESTIMATE_S = 20
#: How often the node looks whether its integrator is ready.
READY_POLL_S = 0.1


def preparing_text(phase: str, seconds: float) -> str:
    """The simulator's status while its integrator is being prepared.

    >>> preparing_text("compiling", 12.3)
    'compiling the swimming integrator, 12 s so far (first run after set-up or an upgrade, about 20 s): the fish swims once it is ready'
    """  # noqa: E501
    why = (
        f" (first run after set-up or an upgrade, about {COMPILE_ESTIMATE_S} s)"
        if phase == COMPILING
        else ""
    )
    return (
        f"{phase} the swimming integrator, {seconds:.0f} s so far{why}: the fish swims once it "
        "is ready"
    )


MAX_STEP = ParameterSpec(
    "max_step_sec",
    # One sub-step per sample at the driver's default 200 Hz, whose intervals jitter around 5 ms
    # (a 5 ms bound cut every slightly late interval into two), and down to 100 Hz; 31 steps
    # per beat even at the driver's top speed of 20 rad/s, within the 16-48 the checks use.
    0.01,
    "longest RK4 sub-step between two carrier samples (the interval is cut into equal steps)",
    "s",
    1e-5,
    0.1,
)


#: Every parameter of the node, all read-only.
PARAMETERS: tuple[ParameterSpec, ...] = read_only(
    (
        *TAIL_PARAMETERS,
        *FISH_PARAMETERS,
        MOTOR_JOINT_NAME,
        MAX_STEP,
        STALE_TIMEOUT,
        *GUARD_PARAMETERS,
        MAX_CARRIER_SPEED,
        *MARKER_PARAMETERS,
        PUBLISH_TF,
        *FRAME_PARAMETERS,
    )
)
#: The odometry's variances: the state is the integrator's, exact for the model, so nearly 0; not
#: 0, for filters that invert the covariance (robot_localization).
EXACT_VARIANCE = 1e-9


def figures_message(beat: BeatFigures, stamp_ns: int, frame: str) -> SwimFigures:
    """The SwimFigures message of one beat, ending at ``stamp_ns`` (ns since the epoch)."""
    message = SwimFigures()
    message.header.frame_id = frame
    message.header.stamp.sec, message.header.stamp.nanosec = divmod(stamp_ns, 1_000_000_000)
    message.beat_index = beat.beat_index
    message.beat_frequency_hz = beat.frequency_hz
    message.mean_speed_m_s = beat.mean_speed_m_s
    message.body_lengths_per_s = beat.body_lengths_per_s
    message.tip_excursion_m = beat.tip_excursion_m
    message.strouhal_number = beat.strouhal_number
    message.mean_thrust_n = beat.mean_thrust_n
    message.mean_tail_power_w = beat.mean_tail_power_w
    message.froude_efficiency = beat.froude_efficiency
    message.turning_radius_m = beat.turning_radius_m
    message.heading_change_rad = beat.heading_change_rad
    return message


class SimNode(SuiteNodeBase):
    """Thin shell around :class:`SwimFollower`: samples in, odometry and figures out."""

    def __init__(self, **node_options: Any) -> None:
        """Declare parameters, build the tail and the fish (raises on bad values), wire topics."""
        super().__init__("swim", **node_options)
        values = declare(self, PARAMETERS)
        tail = tail_from_values(values)
        fish = fish_from_values(values)
        self.stale_timeout_s = float(values[STALE_TIMEOUT.name])
        self.max_carrier_speed = float(values[MAX_CARRIER_SPEED.name])
        self.follower = SwimFollower(
            tail,
            fish,
            float(values[MAX_STEP.name]),
            max_interval_s=self.stale_timeout_s,
            max_speed_rad_s=self.max_carrier_speed,
        )
        self.motor_joint_name = str(values[MOTOR_JOINT_NAME.name])
        self.carrier_joint = CarrierJoint(self.motor_joint_name)
        self.guard = CarrierGuard()
        self.guard.apply_parameters(values)
        self.drops = DropCounts(SIM_REASONS)
        #: Carrier jumps in total, and the largest of the diagnostics period: (advance, interval).
        self.jumps = 0
        self._period_jump: tuple[float, float] | None = None
        self._period_integrated = (0.0, 0.0)
        self._drop_log = {
            reason: f"{INPUT_TOPIC} sample dropped: {text}" for reason, text in REASON_TEXT.items()
        }
        self.timing = StreamTiming()
        # Gaps and a low rate WARN only once they persist (the machine's jitter is not a fault).
        self.timing_status = PersistentStatus()
        self.received = 0
        self.last_input_ns: int | None = None
        #: Node clock when the guard last accepted a sample (None before the first).
        self._accepted_ns: int | None = None
        self.tail_name = tail.name

        self.odom_frame = str(values[ODOM_FRAME_ID.name])
        self.base_frame = str(values[BASE_FRAME_ID.name])
        self.odom = Odometry()
        self.odom.header.frame_id = self.odom_frame
        self.odom.child_frame_id = self.base_frame
        for index in range(0, 36, 7):  # the diagonals
            self.odom.pose.covariance[index] = EXACT_VARIANCE
            self.odom.twist.covariance[index] = EXACT_VARIANCE
        self.odom_publisher = ListenedPublisher(self, Odometry, FISH_ODOM)
        self.figures_publisher = suite_publisher(self, SwimFigures, FISH_SWIMMING)
        self.diagnostics_publisher = suite_publisher(self, DiagnosticArray, DIAGNOSTICS)
        self.design_tail = tail
        self.pivot_shift_m = 0.0
        self.pivot_refusal = ""
        self.markers = FishMarkerPublisher(
            self,
            tail,
            float(fish.body_length_m),
            float(fish.body_diameter_m),
            float(fish.tail_origin_offset_m),
            float(values[MARKERS_RATE.name]),
            int(values[MARKERS_PATH_LENGTH.name]),
            self.odom_frame,
        )
        self.tf: FishTfBroadcaster | None = None
        tf_type = tf_message_type() if values[PUBLISH_TF.name] else None
        if tf_type is not None:
            self.tf = FishTfBroadcaster(
                self, tf_type, float(fish.tail_origin_offset_m), self.odom_frame, self.base_frame
            )
            self.tf_state = "on"
        elif values[PUBLISH_TF.name]:
            # Where ROS 2 comes from the wheels (they have no tf2_msgs) this is the normal case,
            # so it is said in the start-up line and the diagnostics, not warned.
            self.tf_state = "off: tf2_msgs is not installed"
        else:
            self.tf_state = f"off: {PUBLISH_TF.name} is false"
        self.create_timer(DIAGNOSTICS_PERIOD_S, self._on_diagnostics)
        self.get_logger().info(
            f"swimming simulator up: {tail.name} tail, body {float(fish.body_length_m):g} m, "
            f"sub-steps <= {self.follower.max_step_s * 1e3:g} ms; tf {self.tf_state}"
        )
        self._prepare_integrator()

    def _prepare_integrator(self) -> None:
        """Compile (or load) the integrator in a thread; subscribe to the carrier once it is ready.

        Compiling takes 10-20 s on the first run after set-up or an upgrade (make setup does it
        beforehand, so normally the loop is loaded from numba's cache in a fraction of a second,
        which is done right here).
        Meanwhile the node is up, publishes /diagnostics saying so (``integrator``: compiling,
        loading or preparing, ``integrator_s`` so far), and takes no samples: none waits for the
        compiler while later ones pile up and are lost. The first sample after it is the fish's
        first (joining a carrier that already turns, if it does).
        """
        cached = fused.is_cached()
        self.integrator_phase = (
            PREPARING if cached is None else LOADING if cached else COMPILING
        )  # fmt: skip
        self.warm_up_s: float | None = None
        self._warm_up_error: BaseException | None = None
        self._warm_up_started = time.monotonic()
        if self.integrator_phase == COMPILING:
            self.get_logger().info(
                "compiling the swimming integrator (first run after set-up or an upgrade): "
                f"about {COMPILE_ESTIMATE_S} s, the fish swims once it is ready "
                f"(numba cache {fused.cache_path()})"
            )
        else:
            self.get_logger().info(f"{self.integrator_phase} the swimming integrator")
        self._ready = threading.Event()
        self._compiled_before = fused.compiled_count()
        if self.integrator_phase == LOADING:
            # A fraction of a second: here, as any start-up work (a thread would only compete
            # for the interpreter with the nodes of a --one-process suite).
            self._warm_up()
            self._on_integrator_ready()
            return
        # Polled by a timer (the suite's executor takes no guard conditions): the first sample
        # waits at most a tenth of a second more than the integrator.
        self._ready_timer: Any = self.create_timer(READY_POLL_S, self._on_integrator_ready)
        threading.Thread(target=self._warm_up, name="swim-integrator", daemon=True).start()

    def _warm_up(self) -> None:
        try:
            self.follower.warm_up()
        except Exception as error:  # noqa: BLE001 - reported; the first sample compiles instead
            self._warm_up_error = error
        self.warm_up_s = time.monotonic() - self._warm_up_started
        self._ready.set()

    def _on_integrator_ready(self) -> None:
        """In the executor: say how the preparation went, then follow the carrier."""
        if not self._ready.is_set() or self.integrator_phase not in PREPARING_PHASES:
            return
        if self.integrator_phase != LOADING:
            self._ready_timer.cancel()
            self.destroy_timer(self._ready_timer)
        took = self.warm_up_s or 0.0
        compiled = fused.compiled_count() > self._compiled_before
        self.integrator_phase = COMPILED if compiled else LOADED if fused.AVAILABLE else READY
        if self._warm_up_error is not None:
            self.get_logger().error(f"preparing the integrator failed: {self._warm_up_error}")
        elif compiled:
            self.get_logger().info(
                f"swimming integrator compiled in {took:.1f} s (numba cached it for the next "
                f"runs); following {INPUT_TOPIC}"
            )
        else:
            self.get_logger().info(
                f"swimming integrator {self.integrator_phase} in {took:.1f} s; following "
                f"{INPUT_TOPIC}"
            )
        self.create_subscription(
            JointState, INPUT_TOPIC, self._on_motor_state, subscriber_qos(MOTOR_JOINT_STATE)
        )
        self.create_subscription(
            JointState,
            PIVOT_JOINT_STATE.name,
            self._on_pivot_state,
            subscriber_qos(PIVOT_JOINT_STATE),
        )

    def _on_pivot_state(self, message: JointState) -> None:
        try:
            index = list(message.name).index(PIVOT_JOINT)
            shift = float(message.position[index])
        except (ValueError, IndexError):
            self.pivot_refusal = f"{PIVOT_JOINT_STATE.name} has no position for {PIVOT_JOINT!r}"
            return
        # The actuator creeps: follow it in steps of a tenth of a millimetre, not every sample.
        if abs(shift - self.pivot_shift_m) < PIVOT_RESOLUTION_M:
            return
        try:
            tail = self.design_tail.with_pivot_shift(shift)
        except FishtailKinematicsError as error:
            self.pivot_refusal = f"pivot shift {shift!r} m refused: {error}"
            self.get_logger().warning(self.pivot_refusal, throttle_duration_sec=2.0)
            return
        self.pivot_refusal = ""
        self.pivot_shift_m = shift
        self.follower.set_tail(tail)

    def _reject(self, reason: str, text: str) -> None:
        self.drops.count(reason)
        self.get_logger().warning(text, throttle_duration_sec=2.0)

    def _on_motor_state(self, message: JointState) -> None:
        self.received += 1
        now_ns = self.get_clock().now().nanoseconds
        self.last_input_ns = now_ns
        index = self.carrier_joint.index(message.name)
        if index is None or index >= len(message.position):
            self._reject(
                NO_CARRIER_JOINT,
                f"{INPUT_TOPIC} has no position for joint {self.motor_joint_name!r}",
            )
            return
        angle = float(message.position[index])
        velocity = float(message.velocity[index]) if index < len(message.velocity) else 0.0
        stamp = message.header.stamp
        stamp_ns = stamp.sec * 1_000_000_000 + stamp.nanosec
        # The guard's own rule for following the stream afresh (nothing accepted for
        # restart_after_ns): it then accepts stamps and angles that went back, which the follower
        # must not integrate across, so the follower restarts at the same sample.
        accepted_ns = self._accepted_ns
        fresh = accepted_ns is None or now_ns - accepted_ns > self.guard.restart_after_ns
        reason = self.guard.check(stamp_ns, angle, velocity, now_ns)
        if reason == CARRIER_JUMP:
            self._carrier_jump(*self.guard.jump)
            return
        if reason is not None:
            self._reject(reason, self._drop_log[reason])
            return
        self._accepted_ns = now_ns
        self.timing.observe(stamp_ns * 1e-9)
        follower = self.follower
        rebased_from = self.guard.rebased_from
        taken = True
        try:
            try:
                if rebased_from is not None:
                    # The jump persisted: follow the stream from the jumped sample on.
                    follower.restart(*rebased_from)
                    taken = follower.follow(stamp_ns, angle)
                elif fresh and not self._continues(stamp_ns, angle):
                    follower.restart(stamp_ns, angle, velocity)
                else:
                    # Also after a pause of this node: samples that continue the stream are
                    # integrated, whenever they arrive.
                    taken = follower.follow(stamp_ns, angle, velocity)
            except CarrierJumpError as error:
                # Only where the follower's reference is not the guard's (a refused sample, a
                # pause): the guard took this sample as its reference, so does the fish.
                follower.restart(stamp_ns, angle)
                self._carrier_jump(error.advance_rad, error.elapsed_s)
        except StampNotIncreasingError:
            self._reject(STAMP_NOT_INCREASING, self._drop_log[STAMP_NOT_INCREASING])
            return
        except (FishtailKinematicsError, SwimError) as error:
            # Not expected for a validated geometry and plausible input; if it happens, one
            # sample is dropped and reported, the fish keeps its last good state.
            self._reject(ENGINE_REFUSED, f"engine refused carrier angle {angle!r}: {error}")
            return
        if not taken:
            return  # too soon after the last sample taken: the next one integrates across it
        self.publish_odometry(stamp)
        self.markers.latest = (follower.state, angle, stamp)
        if follower.finished:
            for beat in follower.take_beats():
                end_ns = follower.first_stamp_ns + round(beat.end_time_s * 1e9)
                self.figures_publisher.publish(figures_message(beat, end_ns, self.odom_frame))

    def _continues(self, stamp_ns: int, angle_rad: float) -> bool:
        """True if the sample follows on from the follower's last one (stamp and angle)."""
        follower = self.follower
        return (
            follower.started
            and stamp_ns > follower.last_stamp_ns
            and angle_rad >= follower.angle_rad - self.guard.backwards_tolerance_rad
        )

    def _carrier_jump(self, advance_rad: float, elapsed_s: float) -> None:
        """Count and warn a carrier jump (not integrated) of ``advance_rad`` in ``elapsed_s``."""
        self.jumps += 1
        self.drops.count(CARRIER_JUMP)
        if self._period_jump is None or advance_rad > self._period_jump[0]:
            self._period_jump = (advance_rad, elapsed_s)
        self.get_logger().warning(
            f"{INPUT_TOPIC}: carrier jumped {advance_rad:.6g} rad in {elapsed_s * 1e3:.6g} ms, "
            f"beyond {MAX_CARRIER_SPEED.name} = {self.max_carrier_speed:g}: not integrated",
            throttle_duration_sec=2.0,
        )

    def _carrier_problems(self) -> tuple[list[str], dict[str, str]]:
        """This period's jumps and a mean carrier speed beyond the limit: texts and values."""
        problems = []
        jump, self._period_jump = self._period_jump, None
        if jump is not None:
            problems.append(
                f"carrier jumped (largest {jump[0]:.6g} rad in {jump[1] * 1e3:.6g} ms; "
                f"{self.jumps} jumps in total): not integrated"
            )
        follower = self.follower
        turned = follower.integrated_rad - self._period_integrated[0]
        elapsed = follower.integrated_s - self._period_integrated[1]
        self._period_integrated = (follower.integrated_rad, follower.integrated_s)
        speed = turned / elapsed if elapsed > 0.0 else 0.0
        if speed > self.max_carrier_speed * (1.0 + SPEED_WARN_TOLERANCE):
            problems.append(
                f"carrier at {speed:.4g} rad/s, beyond {MAX_CARRIER_SPEED.name} = "
                f"{self.max_carrier_speed:g}"
            )
        values = {
            "carrier_jumps": str(self.jumps),
            "largest_jump_rad": f"{jump[0]:.6g}" if jump is not None else "0",
            "carrier_speed_rad_s": f"{speed:.6g}",
        }
        return problems, values

    def publish_odometry(self, stamp: Time) -> None:
        """Fill and publish fish/odom from the follower's state, and its pose on /tf.

        Neither is built when nobody subscribes to it (:class:`ListenedPublisher`).
        """
        tf = self.tf if self.tf is not None and self.tf.publisher.listened else None
        if not (self.odom_publisher.listened or tf is not None):
            return
        row = self.follower.state[0]
        odom = self.odom
        odom.header.stamp = stamp
        pose = odom.pose.pose
        pose.position.x = float(row[X])
        pose.position.y = float(row[Y])
        _, _, pose.orientation.z, pose.orientation.w = yaw_quaternion(float(row[PSI]))
        twist = odom.twist.twist
        twist.linear.x = float(row[SURGE])
        twist.linear.y = float(row[SWAY])
        twist.angular.z = float(row[YAW_RATE])
        if self.odom_publisher.listened:
            self.odom_publisher.publish(odom)
        if tf is not None:
            tf.publish(stamp, pose)

    def _on_diagnostics(self) -> None:
        now_ns = self.get_clock().now().nanoseconds
        level, text, input_values = input_status(
            INPUT_TOPIC,
            self.drops,
            self.timing.take_period(),
            DIAGNOSTICS_PERIOD_S,
            self.timing_status,
        )
        carrier_problems, carrier_values = self._carrier_problems()
        if carrier_problems:
            level = Level.WARN
            text = "; ".join((*carrier_problems, text))
        row = self.follower.state[0]
        speed = math.hypot(float(row[SURGE]), float(row[SWAY]))
        # The heading as a compass reads it, in (-180, 180]; the state keeps it unwrapped.
        heading_deg = math.degrees(math.remainder(float(row[PSI]), math.tau))
        preparing = self.integrator_phase in PREPARING_PHASES
        integrator_s = (
            time.monotonic() - self._warm_up_started if preparing else (self.warm_up_s or 0.0)
        )
        if preparing:
            # Not stale: nothing is taken until the integrator is ready.
            level, text = Level.OK, preparing_text(self.integrator_phase, integrator_s)
        elif (
            self.last_input_ns is None
            or (now_ns - self.last_input_ns) * 1e-9 > self.stale_timeout_s
        ):
            level, text = Level.STALE, f"no {INPUT_TOPIC} received recently"
        elif self.pivot_refusal:
            level, text = Level.WARN, self.pivot_refusal
        elif level == Level.OK:
            text = f"fish at {speed:.3f} m/s, heading {heading_deg:.2f} deg; {text}"
        values = {
            "speed_m_s": f"{speed:.6g}",
            "heading_rad": f"{float(row[PSI]):.6g}",
            "x_m": f"{float(row[X]):.6g}",
            "y_m": f"{float(row[Y]):.6g}",
            "beats": str(self.follower.beats_completed),
            "sub_steps": str(self.follower.sub_steps),
            "restarts": str(self.follower.restarts),
            "received": str(self.received),
            "tf": self.tf_state,
            "integrator": self.integrator_phase,
            "integrator_s": f"{integrator_s:.3g}",
            "integrator_ready_s": "" if preparing else f"{integrator_s:.3g}",
            "pivot_shift_m": f"{self.pivot_shift_m:.6g}",
            **carrier_values,
            **input_values,
        }
        self.diagnostics_publisher.publish(
            diagnostic_array(self, Status("swim", level, text, values))
        )


#: How a process creates this node (its own ``main``, or ``fishtail-run --one-process``).
FACTORY = NodeFactory(SimNode, "swim", (FishtailKinematicsError,))


def main() -> int:
    """Entry point of ``ros2 run fishtail_swim sim``."""
    return run_node(FACTORY.create, FACTORY.label, FACTORY.startup_errors)


if __name__ == "__main__":
    sys.exit(main())
