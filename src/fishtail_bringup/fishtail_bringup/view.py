"""``fishtail-view``: the suite live in a Rerun viewer (a browser or ``rerun``), or a recorded bag.

Live: a ROS node of its own that subscribes to the suite's markers, state and verdicts only while
a viewer is connected, so that a view nobody looks at costs the suite nothing; it serves them
through :mod:`fishtail_bringup.view_rerun`. ``--bag``: replays a bag of ``fishtail-record``
(:mod:`fishtail_bringup.view_replay`). Topics, options and costs: docs/visualisation.md ("Live
view without ROS tools").
"""

from __future__ import annotations

import argparse
import dataclasses
import itertools
import math
import sys
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from fishtail_bringup.view_pacing import LatencyWatch, Lateness, RateLimit
from fishtail_bringup.view_rerun import (
    DEFAULT_GRPC_PORT,
    DEFAULT_SEND_PERIOD_S,
    DEFAULT_WEB_PORT,
    RerunView,
)
from fishtail_bringup.view_scene import (
    DELETE,
    DELETEALL,
    FISH_ROOT,
    TAIL_ROOT,
    TailPlots,
    goal_primitives,
    marker_primitives,
    merged,
    stamp_seconds,
    symmetry_primitives,
)
from fishtail_common.command_line import DURATION, add_parameter_options
from fishtail_common.interface import (
    FISH_MARKERS,
    GOAL_POSE,
    TAIL_MARKERS,
    TAIL_STATE,
    TAIL_SYMMETRY,
)
from fishtail_common.parameters import ParameterSpec

PROGRAM = "fishtail-view"
#: How often the viewers are counted (and subscriptions follow them).
WATCH_PERIOD_S = 0.5
#: How often the view's latency goes to its plot (it is an entity, one more message per batch
#: for the browser's viewer to take in; docs/visualisation.md, "Keeping up").
LATENCY_PLOT_PERIOD_S = 1.0
#: While a bag waits for its first viewer, and after it ends: how often to look again.
IDLE_PERIOD_S = 0.2
#: The highest TCP port.
MAX_PORT = 65_535
#: The options with a range: the bag's pace and the ports.
RATE = ParameterSpec(
    "rate", 1.0, "bag replay speed, 1 = as recorded", "", 0.0, exclusive_minimum=True
)
PORT = ParameterSpec(
    "port", DEFAULT_GRPC_PORT, "Rerun data (gRPC) port, 0 = any free", "", 0, MAX_PORT
)
WEB_PORT = ParameterSpec(
    "web_port", DEFAULT_WEB_PORT, "web viewer (HTTP) port, 0 = any free", "", 0, MAX_PORT
)
#: What the live view sends: each stream decimated, late messages dropped, its latency watched
#: (fishtail_bringup.view_pacing; docs/visualisation.md, "Keeping up").
MARKERS_RATE = ParameterSpec(
    "markers_rate_hz", 10.0, "marker arrays drawn per second, per topic, 0 = all", "Hz", 0.0, 1000.0
)
PLOT_RATE = ParameterSpec(
    "plot_rate_hz", 50.0, "tail/state samples plotted per second, 0 = all", "Hz", 0.0, 1000.0
)
SEND_PERIOD = ParameterSpec(
    "send_period_s", DEFAULT_SEND_PERIOD_S, "period of the batches sent to the viewers", "s",
    0.01, 2.0,
)  # fmt: skip
DROP_LATE = ParameterSpec(
    "drop_late_s", 1.0, "drop messages that arrive this much later than usual, 0 = never", "s",
    0.0, 60.0,
)  # fmt: skip
LATENCY_WARNING = ParameterSpec(
    "latency_warning_s", 1.0, "say so when what is sent is older than this, 0 = never", "s",
    0.0, 60.0,
)  # fmt: skip
PACING_OPTIONS = (MARKERS_RATE, PLOT_RATE, SEND_PERIOD, DROP_LATE, LATENCY_WARNING)


@dataclasses.dataclass(frozen=True)
class Pacing:
    """How the live view paces what it sends (the PACING_OPTIONS' values)."""

    markers_rate_hz: float = MARKERS_RATE.default  # type: ignore[assignment]
    plot_rate_hz: float = PLOT_RATE.default  # type: ignore[assignment]
    send_period_s: float = SEND_PERIOD.default  # type: ignore[assignment]
    drop_late_s: float = DROP_LATE.default  # type: ignore[assignment]
    latency_warning_s: float = LATENCY_WARNING.default  # type: ignore[assignment]


def _array_stamp(array) -> tuple[float | None, bool]:
    """A MarkerArray's first stamp (None if none) and whether it deletes anything."""
    stamp = None
    deletes = False
    for marker in array.markers:
        if stamp is None and (marker.header.stamp.sec or marker.header.stamp.nanosec):
            stamp = stamp_seconds(marker.header)
        deletes = deletes or int(marker.action) in (DELETE, DELETEALL)
    return stamp, deletes


def _say(text: str) -> None:
    print(f"{PROGRAM}: {text}", flush=True)


def _error(text: str) -> None:
    print(f"{PROGRAM}: error: {text}", file=sys.stderr, flush=True)


class ViewNode:
    """The live view's ROS side: subscriptions that follow the viewers, into a RerunView."""

    def __init__(
        self,
        view: RerunView,
        namespace: str = "",
        say: Callable[[str], None] = _say,
        pacing: Pacing = Pacing(),
    ):
        """Create the node (``namespace`` moves it with the suite) and its timers."""
        import rclpy
        from geometry_msgs.msg import PoseStamped

        from fishtail_common.ros import subscriber_qos

        self.view = view
        self.say = say
        self.node = rclpy.create_node("view", namespace=namespace or None)
        self.pacing = pacing
        self.plots = TailPlots(pacing.plot_rate_hz)
        self.limits: dict[str, RateLimit] = {}
        self.lateness = Lateness(pacing.drop_late_s)
        self.latency = LatencyWatch(pacing.latency_warning_s)
        self.decimated = 0
        self._newest_sent: float | None = None
        self._latency_plotted = -math.inf
        self.subscriptions: list = []
        self.viewers = 0
        self.goal = None
        self.logged = 0
        self.node.create_subscription(
            PoseStamped, GOAL_POSE.name, self._on_goal, subscriber_qos(GOAL_POSE)
        )
        self.node.create_timer(WATCH_PERIOD_S, self.watch)
        self.plot_timer: Any = None

    @property
    def subscribed(self) -> bool:
        """Whether the suite's topics are subscribed (someone is looking)."""
        return bool(self.subscriptions)

    def watch(self) -> None:
        """Count the viewers; subscribe for the first, unsubscribe after the last."""
        viewers = self.view.viewer_count()
        if viewers != self.viewers:
            self.say(f"{viewers} viewer(s) connected")
            if viewers > self.viewers:
                self.view.forget_shown()
            self.viewers = viewers
        if viewers and not self.subscribed:
            self._subscribe()
        elif not viewers and self.subscribed:
            self._unsubscribe()

    def _subscribe(self) -> None:
        from visualization_msgs.msg import MarkerArray

        from fishtail_common.ros import subscriber_qos
        from fishtail_msgs.msg import SymmetryReport, TailState

        node = self.node
        table = (
            (MarkerArray, TAIL_MARKERS, lambda m: self._on_markers(m, TAIL_ROOT)),
            (MarkerArray, FISH_MARKERS, lambda m: self._on_markers(m, FISH_ROOT)),
            (TailState, TAIL_STATE, self._on_state),
            (SymmetryReport, TAIL_SYMMETRY, lambda m: self._log(*symmetry_primitives(m))),
        )
        self.subscriptions = [
            node.create_subscription(kind, topic.name, callback, subscriber_qos(topic))
            for kind, topic, callback in table
        ]
        # The plots go out once per batch: more often would not reach a viewer sooner.
        self.plot_timer = node.create_timer(self.pacing.send_period_s, self._flush_plots)
        if self.goal is not None:
            self._log(*goal_primitives(self.goal))

    def _unsubscribe(self) -> None:
        for subscription in self.subscriptions:
            self.node.destroy_subscription(subscription)
        self.subscriptions = []
        if self.plot_timer is not None:
            self.node.destroy_timer(self.plot_timer)
            self.plot_timer = None
        self.plots.flush()  # samples nobody will see

    def _log(self, stamp_s: float | None, primitives: list) -> None:
        self.logged += self.view.log(stamp_s, primitives)
        if stamp_s is not None and primitives:
            self._newest_sent = max(stamp_s, self._newest_sent or stamp_s)

    def _on_markers(self, array, root: str) -> None:
        """A marker array, unless it is late or its topic's rate is reached (deletions pass)."""
        stamp, deletes = _array_stamp(array)
        if stamp is not None and not deletes:
            if self.lateness.late(stamp, time.time()):
                return
            limit = self.limits.setdefault(root, RateLimit(self.pacing.markers_rate_hz))
            if not limit.admit(stamp):
                self.decimated += 1
                return
        stamp, primitives = marker_primitives(array, root)
        self._log(stamp, merged(primitives, root))

    def _on_state(self, state) -> None:
        if not self.lateness.late(stamp_seconds(state.header), time.time()):
            if not self.plots.add(state):
                self.decimated += 1

    def _flush_plots(self) -> None:
        """Send the gathered samples; the latency of what went out since the last flush."""
        self._log(None, self.plots.flush())
        newest = max((s for s in (self.plots.newest_s, self._newest_sent) if s is not None),
                     default=None)  # fmt: skip
        self.plots.newest_s = self._newest_sent = None
        if newest is None:
            return
        now = time.time()
        latency = now - newest
        note = self.latency.update(latency, now)
        if note is not None:
            self.say(note)
        if note is not None or now - self._latency_plotted >= LATENCY_PLOT_PERIOD_S:
            self._latency_plotted = now
            self.view.log_latency(newest, latency, note)

    def summary(self) -> str:
        """What was logged and what was not."""
        return (
            f"{self.logged} primitives logged; {self.decimated} messages decimated, "
            f"{self.lateness.dropped} dropped as late"
        )

    def _on_goal(self, message) -> None:
        self.goal = message
        if self.subscribed:
            self._log(*goal_primitives(message))


def build_parser() -> argparse.ArgumentParser:
    """Command-line options."""
    parser = argparse.ArgumentParser(
        prog=PROGRAM,
        description=__doc__.splitlines()[0],
        epilog="Ctrl-C (or SIGTERM) stops it. docs/visualisation.md says what is shown.",
    )
    add = parser.add_argument
    add("--bag", type=Path, help="replay this bag of fishtail-record instead")
    add_parameter_options(parser, [RATE])
    add(
        "--config",
        type=Path,
        help="bag: the tail's parameter file (default config/<recorded mechanism>.yaml)",
    )
    add(
        "--fish-config", type=Path, help="bag: the fish's parameter file (default config/fish.yaml)"
    )
    add("--namespace", default="", help="namespace of the suite (relative topics)")
    add(
        "--bind",
        default="127.0.0.1",
        help="address the viewers' data port listens on (127.0.0.1: this computer only, "
        "0.0.0.0: every interface)",
    )
    add_parameter_options(parser, [PORT, WEB_PORT])
    add_parameter_options(parser.add_argument_group("what is sent (live)"), PACING_OPTIONS)
    add(
        "--no-web",
        action="store_true",
        help="serve no web viewer (use the native one: rerun --connect URL)",
    )
    add_parameter_options(parser, [DURATION], optional=True)
    return parser


def open_view(arguments: argparse.Namespace) -> RerunView:
    """Start serving; a taken default port falls back to a free one (said), a chosen one fails."""
    web_port = None if arguments.no_web else arguments.web_port
    try:
        return RerunView(
            arguments.bind, arguments.port, web_port, send_period_s=arguments.send_period_s
        )
    except OSError as error:
        defaults = arguments.port == DEFAULT_GRPC_PORT and web_port in (None, DEFAULT_WEB_PORT)
        if not defaults:
            raise
        _say(f"{error.strerror or error}: using free ports instead")
        return RerunView(
            arguments.bind,
            0,
            None if web_port is None else 0,
            send_period_s=arguments.send_period_s,
        )


def where_to_look(view: RerunView) -> str:
    """The line that says where to look."""
    native = f"rerun --connect {view.grpc_url}"
    if view.web_url is None:
        return f"live view: {native}"
    return f"live view at {view.web_url} (or the native viewer: {native})"


def replay_bag(arguments: argparse.Namespace, view: RerunView, stop: threading.Event) -> int:
    """Replay the bag into ``view`` at its pace once a viewer looks; serve until stopped."""
    from fishtail_bringup.view_replay import BagReplay, ReplayError, fish_from_parameter_file
    from fishtail_common.parameter_files import default_parameter_file

    started = time.monotonic()

    def timed_out() -> bool:
        return bool(arguments.duration) and time.monotonic() - started >= arguments.duration

    try:
        fish_config = arguments.fish_config or default_parameter_file("fish")
        replay = BagReplay(
            arguments.bag,
            arguments.config,
            fish_from_parameter_file(fish_config),
            default_parameter_file,
            arguments.namespace,
        )
        events = replay.events()
        first = next(events, None)  # opens and checks the bag before anyone waits for it
    except (ReplayError, LookupError) as error:
        _error(str(error))
        return 2
    _say(f"replaying {arguments.bag} at {arguments.rate:g}x once a viewer connects")
    while view.viewer_count() == 0 and not stop.wait(IDLE_PERIOD_S):
        if timed_out():
            return 0
    if stop.is_set():
        return 0
    _say("a viewer connected: replaying")
    begin_bag = None if first is None else first[0]
    begin_wall = time.monotonic()
    logged = 0
    try:
        for bag_s, stamp_s, primitives in itertools.chain([first] if first else [], events):
            if begin_bag is None:
                begin_bag = bag_s
            wait = begin_wall + (bag_s - begin_bag) / arguments.rate - time.monotonic()
            if wait > 0.0 and stop.wait(wait):
                break
            if timed_out():
                break
            logged += view.log(stamp_s, primitives)
    except ReplayError as error:
        _error(str(error))
        return 2
    for note in replay.notes:
        _say(note)
    _say(f"replay done: {logged} primitives logged; serving until Ctrl-C")
    while not stop.wait(IDLE_PERIOD_S) and not timed_out():
        pass
    return 0


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``fishtail-view`` (also started by ``fishtail-run --view``)."""
    import rclpy
    from rclpy.signals import SignalHandlerOptions
    from rclpy.utilities import remove_ros_args

    from fishtail_common.ros import install_stop_handlers, spin_until

    full_argv = [PROGRAM, *(sys.argv[1:] if argv is None else argv)]
    arguments = build_parser().parse_args(remove_ros_args(full_argv)[1:])
    stop = install_stop_handlers()
    try:
        view = open_view(arguments)
    except OSError as error:
        _error(f"cannot serve the view: {error.strerror or error}")
        return 2
    _say(where_to_look(view))
    try:
        if arguments.bag is not None:
            return replay_bag(arguments, view, stop)
        rclpy.init(args=full_argv, signal_handler_options=SignalHandlerOptions.NO)
        pacing = Pacing(
            arguments.markers_rate_hz,
            arguments.plot_rate_hz,
            arguments.send_period_s,
            arguments.drop_late_s,
            arguments.latency_warning_s,
        )
        live = ViewNode(view, arguments.namespace, pacing=pacing)
        if arguments.duration:
            timer = threading.Timer(arguments.duration, stop.set)
            timer.daemon = True
            timer.start()
        try:
            spin_until([live.node], stop)
        finally:
            live.node.destroy_node()
            rclpy.try_shutdown()
        _say(f"stopped: {live.summary()}")
        return 0
    finally:
        view.close()


if __name__ == "__main__":
    sys.exit(main())
