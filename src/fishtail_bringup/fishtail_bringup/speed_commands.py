"""``fishtail-run``'s speed commands, sent from a thread and an executor of their own.

The driver stops the motor when no ``motor/cmd_speed`` arrived for ``cmd_timeout_sec`` (its
default, in :data:`fishtail_driver.parameters.SPECS`, is the one home of that time). The console's
own loop spins the status line's subscriptions (``tail/state`` at 200 Hz), prints, and waits for
the lock that the node processes' forwarded output holds while a slow terminal takes it: on a
loaded two-core computer it fell up to 0.34 s behind, and once long enough for the watchdog. So
the commands go out from a timer on a thread that does nothing else, :data:`COMMANDS_PER_TIMEOUT`
times per timeout; :meth:`SpeedCommands.lateness_s` says how late they were (docs/serial.md,
"The command watchdog and its margin").
"""

from __future__ import annotations

import math
import threading
import time

from fishtail_common.interface import MOTOR_CMD_SPEED
from fishtail_driver.parameters import SPECS

#: The driver's default watchdog time [s] (the home of the value is the driver's parameter).
COMMAND_TIMEOUT_S = float(SPECS["cmd_timeout_sec"].default)
#: Commands sent per watchdog time: the timer may fall this many periods, less one, behind before
#: the watchdog stops the motor.
COMMANDS_PER_TIMEOUT = 10
#: How often the carrier speed is sent [s].
COMMAND_PERIOD_S = COMMAND_TIMEOUT_S / COMMANDS_PER_TIMEOUT
#: How long :meth:`SpeedCommands.stop` waits for the thread [s].
_JOIN_TIMEOUT_S = 2.0


class SpeedCommands:
    """Publishes ``speed`` on ``motor/cmd_speed`` every ``period_s`` from a thread of its own.

    A node (``fishtail_commander``) in the given rclpy context with a single-threaded executor that
    holds nothing but the timer; the thread spins it until :meth:`stop`. Each tick's time is kept
    to measure how late the timer ran.
    """

    def __init__(self, speed_rad_s: float, namespace: str, period_s: float = COMMAND_PERIOD_S):
        """Create the node, its publisher and timer (sending starts with :meth:`start`).

        Raises:
            ValueError: a speed that is not finite, or a period that is not > 0.
        """
        if not math.isfinite(speed_rad_s):
            raise ValueError(f"speed must be finite, got {speed_rad_s!r}")
        if not (math.isfinite(period_s) and period_s > 0.0):
            raise ValueError(f"period_s must be > 0, got {period_s!r}")
        import rclpy
        from rclpy.executors import SingleThreadedExecutor
        from std_msgs.msg import Float64

        from fishtail_common.ros import publisher_qos

        self.Float64 = Float64
        self.speed = speed_rad_s
        self.period_s = period_s
        self.node = rclpy.create_node("fishtail_commander", namespace=namespace or None)
        self.publisher = self.node.create_publisher(
            Float64, MOTOR_CMD_SPEED.name, publisher_qos(MOTOR_CMD_SPEED)
        )
        self.executor = SingleThreadedExecutor()
        self.executor.add_node(self.node)
        self.tick_times_s: list[float] = []
        self._stopping = threading.Event()
        self.node.create_timer(period_s, self._tick)
        self._thread = threading.Thread(target=self._spin, name="speed-commands", daemon=True)

    def start(self) -> None:
        """Start sending."""
        self._thread.start()

    def _spin(self) -> None:
        while not self._stopping.is_set():
            self.executor.spin_once(timeout_sec=self.period_s)

    def _tick(self) -> None:
        if self._stopping.is_set():
            return
        self.publisher.publish(self.Float64(data=self.speed))
        self.tick_times_s.append(time.monotonic())

    def stop(self, final_speed_rad_s: float = 0.0) -> None:
        """Stop the timer's thread, then publish ``final_speed_rad_s`` once (the motor's stop)."""
        self._stopping.set()
        if self._thread.is_alive():
            self._thread.join(_JOIN_TIMEOUT_S)
        self.publisher.publish(self.Float64(data=final_speed_rad_s))

    def close(self) -> None:
        """Release the executor and the node (after :meth:`stop`)."""
        self.executor.shutdown()
        self.node.destroy_node()

    def lateness_s(self) -> tuple[float, float]:
        """How much longer than a period the intervals between commands were: (99 %, max) [s]."""
        return interval_lateness(self.tick_times_s, self.period_s)


def interval_lateness(times_s: list[float], period_s: float) -> tuple[float, float]:
    """The 99th percentile and the largest of (interval - period) over ``times_s``; 0 if none.

    >>> interval_lateness([0.0, 0.05, 0.1, 0.3, 0.35], 0.05)
    (0.15, 0.15)
    """
    late = sorted(max(b - a - period_s, 0.0) for a, b in zip(times_s, times_s[1:], strict=False))
    if not late:
        return 0.0, 0.0
    p99 = late[min(len(late) - 1, math.ceil(0.99 * len(late)) - 1)]
    return round(p99, 9), round(late[-1], 9)


def margin_text(lateness: tuple[float, float], period_s: float, timeout_s: float) -> str:
    """One line: how late the commands were against the watchdog's time.

    The margin is the timeout less the longest interval between commands (period plus lateness);
    the driver's own scheduling and its watchdog's check period come out of it.

    >>> margin_text((0.012, 0.031), 0.05, 0.5).split(": ")[1]
    "419 ms left of the driver's 0.5 s watchdog time"
    """
    p99, worst = lateness
    left = timeout_s - period_s - worst
    return (
        f"speed commands every {period_s * 1e3:.0f} ms, late by {p99 * 1e3:.0f} ms (99 %) and "
        f"{worst * 1e3:.0f} ms at most: {left * 1e3:.0f} ms left of the driver's "
        f"{timeout_s:g} s watchdog time"
    )
