"""The live view's primitives into Rerun: its gRPC server, its web viewer, the layout.

One :class:`RerunView` per process: a recording stream whose only sink is a gRPC server here,
plus the web viewer's pages over HTTP. Rerun does not report its viewers, so
:meth:`RerunView.viewer_count` counts the TCP connections to the gRPC port. Nothing here knows
ROS; :mod:`fishtail_bringup.view_scene` makes the primitives. docs/visualisation.md.
"""

from __future__ import annotations

import errno
import socket
import urllib.parse
from collections.abc import Iterable
from typing import Any

import numpy as np

from fishtail_bringup.view_scene import (
    FISH_ROOT,
    SYMMETRY_LOG,
    TAIL_PLOT,
    TAIL_ROOT,
    TAIL_SERIES,
    Clear,
    Colour,
    Lines,
    Points,
    Primitive,
    Series,
    Shapes,
    Text,
)

APPLICATION_ID = "fishtail"
#: Rerun's own defaults, so that ``rerun --connect`` and a bookmarked page find the view.
DEFAULT_GRPC_PORT = 9876
DEFAULT_WEB_PORT = 9090
#: The timeline every primitive is placed on: the messages' stamps.
TIMELINE = "time"
#: What the gRPC server keeps for viewers that connect later (oldest dropped beyond it). Small:
#: a browser that connects takes in the whole history before it shows now.
SERVER_MEMORY_LIMIT = "32MiB"
#: How often the SDK hands what was logged to the server, in batches (one chunk per entity per
#: batch; the web viewer's cost is mostly per chunk). Rerun's own default is 0.2 s; 0.3 s with
#: about 4 entities per batch keeps a software-rendered page within 2 s (docs/visualisation.md).
DEFAULT_SEND_PERIOD_S = 0.4
#: The view's own latency (send time minus the newest sent stamp, s) and its warnings.
LATENCY_PLOT = "view/latency"
VIEW_NOTES = "view/notes"
#: Seconds of the scrolling plots.
PLOT_WINDOW_S = 10.0
#: Each plotted series' colour, by name.
SERIES_COLOURS = {
    TAIL_SERIES[0]: (51, 204, 102),
    TAIL_SERIES[1]: (230, 120, 40),
    TAIL_SERIES[2]: (64, 140, 242),
    "view latency": (230, 200, 60),
}


def _rgba(colour: Colour) -> list[int]:
    return [round(255 * min(max(channel, 0.0), 1.0)) for channel in colour]


def port_is_free(host: str, port: int) -> bool:
    """Whether a TCP server could listen on ``host:port`` now."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as probe:
        probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            probe.bind((host, port))
        except OSError as error:
            if error.errno in (errno.EADDRINUSE, errno.EACCES):
                return False
            raise
    return True


def free_port(host: str = "127.0.0.1") -> int:
    """A TCP port nobody listens on now (the kernel's choice)."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as probe:
        probe.bind((host, 0))
        return int(probe.getsockname()[1])


def blueprint() -> Any:
    """The layout: the linkage and the fish on the left, plots and verdicts on the right."""
    import rerun.blueprint as rrb

    scrolling = rrb.VisibleTimeRange(
        TIMELINE,
        start=rrb.TimeRangeBoundary.cursor_relative(seconds=-PLOT_WINDOW_S),
        end=rrb.TimeRangeBoundary.cursor_relative(),
    )
    return rrb.Blueprint(
        rrb.Horizontal(
            rrb.Vertical(
                rrb.Spatial2DView(origin=TAIL_ROOT, name="tail linkage (tail frame, m)"),
                rrb.Spatial2DView(origin=FISH_ROOT, name="fish, top view (world, m)"),
            ),
            rrb.Vertical(
                rrb.TimeSeriesView(origin=TAIL_PLOT, name="tail", time_ranges=scrolling),
                rrb.TimeSeriesView(
                    origin=LATENCY_PLOT, name="view latency [s]", time_ranges=scrolling
                ),
                rrb.TextLogView(
                    origin="/",
                    contents=[f"+ /{SYMMETRY_LOG}", f"+ /{VIEW_NOTES}"],
                    name="symmetry verdicts, view notes",
                ),
                row_shares=[4, 1, 1],
            ),
            column_shares=[3, 2],
        ),
        collapse_panels=True,
    )


class RerunView:
    """A Rerun recording served to viewers over gRPC (and its web viewer over HTTP)."""

    def __init__(
        self,
        bind: str = "127.0.0.1",
        grpc_port: int = DEFAULT_GRPC_PORT,
        web_port: int | None = DEFAULT_WEB_PORT,
        memory_limit: str = SERVER_MEMORY_LIMIT,
        send_period_s: float = DEFAULT_SEND_PERIOD_S,
    ) -> None:
        """Serve the data on ``bind:grpc_port``, the web viewer on ``web_port`` (None: none).

        A port of 0 is any free one. What is logged goes to the server every ``send_period_s``;
        a viewer that connects gets what is logged from then on first, the history after it.

        Raises:
            OSError: a port is taken.
        """
        import rerun as rr

        self.rr = rr
        self.bind = bind
        for port in (grpc_port, web_port):
            if port and not port_is_free("" if bind == "0.0.0.0" else bind, port):
                raise OSError(errno.EADDRINUSE, f"port {port} is in use")
        self.grpc_port = grpc_port or free_port(bind)
        self.recording = rr.RecordingStream(
            APPLICATION_ID, batcher_config=rr.ChunkBatcherConfig(flush_tick=send_period_s)
        )
        self.recording.set_sinks(
            rr.GrpcServerSink(bind_ip=bind, port=self.grpc_port, server_memory_limit=memory_limit,
                              newest_first=True),
            default_blueprint=blueprint(),
        )  # fmt: skip
        host = "127.0.0.1" if bind in ("0.0.0.0", "::") else bind
        self.grpc_url = f"rerun+http://{host}:{self.grpc_port}/proxy"
        self.web_url: str | None = None
        if web_port is not None:
            # The web viewer's HTTP server listens on every interface (Rerun offers no choice);
            # it serves the viewer's own files only, the data come from the gRPC server.
            web_port = web_port or free_port()
            rr.serve_web_viewer(web_port=web_port, open_browser=False, connect_to=self.grpc_url)
            query = urllib.parse.urlencode({"url": self.grpc_url})
            self.web_url = f"http://{host}:{web_port}/?{query}&hide_welcome_screen"
        #: What each drawn entity showed last, to skip re-logging what did not change (the
        #: ring, guides and pivots come with every marker array): a log call costs ~0.3 ms.
        self._shown: dict[str, tuple] = {}
        #: The series' names each plotted entity was given.
        self._named: dict[str, tuple[str, ...]] = {}
        self._style()

    def _style(self) -> None:
        """The latency's series, and +y up in both pictures (static)."""
        rr = self.rr
        self._name_series(LATENCY_PLOT, ("view latency",))
        # Rerun's 2D views point y down (image rows); the frames here have y to the left of x.
        for root in (TAIL_ROOT, FISH_ROOT):
            rr.log(root, rr.Transform3D(scale=[1.0, -1.0, 1.0]), static=True,
                   recording=self.recording)  # fmt: skip

    def _name_series(self, entity: str, names: tuple[str, ...]) -> None:
        """Names and colours of ``entity``'s series (static), unless it has these already."""
        if not names or self._named.get(entity) == names:
            return
        self._named[entity] = names
        colours = [SERIES_COLOURS.get(name, (200, 200, 200)) for name in names]
        self.rr.log(entity, self.rr.SeriesLines(names=names, colors=colours), static=True,
                    recording=self.recording)  # fmt: skip

    def viewer_count(self) -> int:
        """Viewers connected now: established TCP connections to our gRPC port."""
        import psutil

        connections = psutil.Process().net_connections(kind="tcp")
        return sum(
            1
            for connection in connections
            if connection.status == psutil.CONN_ESTABLISHED
            and connection.laddr
            and connection.laddr.port == self.grpc_port
        )

    def forget_shown(self) -> None:
        """Log everything again from now on (a new viewer may lack what was logged once)."""
        self._shown.clear()

    @staticmethod
    def _key(primitive: Lines | Points | Shapes) -> tuple:
        if isinstance(primitive, Lines):
            return (primitive.colour, primitive.width_m, *(s.tobytes() for s in primitive.strips))
        if isinstance(primitive, Points):
            return (primitive.colour, primitive.diameter_m, primitive.positions.tobytes())
        parts: tuple[Lines | Points, ...] = (*primitive.lines, *primitive.points)
        return tuple(RerunView._key(part) for part in parts)

    def _unchanged(self, primitive: Lines | Points | Shapes) -> bool:
        key = self._key(primitive)
        if self._shown.get(primitive.entity) == key:
            return True
        self._shown[primitive.entity] = key
        return False

    def log(self, stamp_s: float | None, primitives: Iterable[Primitive]) -> int:
        """Log primitives at ``stamp_s`` on the time line (None: where each one says).

        Lines and points that show what their entity already shows are skipped; the count of
        those logged is returned.
        """
        rr = self.rr
        recording = self.recording
        if stamp_s is not None:
            rr.set_time(TIMELINE, timestamp=stamp_s, recording=recording)
        count = 0
        for primitive in primitives:
            if isinstance(primitive, Lines | Points | Shapes) and self._unchanged(primitive):
                continue
            if isinstance(primitive, Clear):
                self._shown = {
                    entity: key
                    for entity, key in self._shown.items()
                    if not (entity + "/").startswith(primitive.entity + "/")
                }
            count += 1
            if isinstance(primitive, Series):
                self._name_series(primitive.entity, primitive.names)
                rr.send_columns(
                    primitive.entity,
                    indexes=[rr.TimeColumn(TIMELINE, timestamp=primitive.times_s)],
                    columns=rr.Scalars.columns(scalars=primitive.values),
                    recording=recording,
                )
            elif isinstance(primitive, Shapes):
                self._log_shapes(primitive)
            elif isinstance(primitive, Lines):
                rr.log(
                    primitive.entity,
                    rr.LineStrips2D(
                        [np.asarray(strip, dtype=np.float32) for strip in primitive.strips],
                        radii=0.5 * primitive.width_m,
                        colors=[_rgba(primitive.colour)],
                    ),
                    recording=recording,
                )
            elif isinstance(primitive, Points):
                rr.log(
                    primitive.entity,
                    rr.Points2D(
                        np.asarray(primitive.positions, dtype=np.float32),
                        radii=0.5 * primitive.diameter_m,
                        colors=[_rgba(primitive.colour)],
                    ),
                    recording=recording,
                )
            elif isinstance(primitive, Text):
                rr.log(
                    primitive.entity,
                    rr.TextLog(primitive.text, level=primitive.level),
                    recording=recording,
                )
            elif isinstance(primitive, Clear):
                rr.log(primitive.entity, rr.Clear(recursive=True), recording=recording)
        return count

    def _log_shapes(self, shapes: Shapes) -> None:
        """A drawing as one entity: its strips and its discs, each with its colour and size."""
        rr = self.rr
        parts: list[Any] = []
        strips = [(lines, strip) for lines in shapes.lines for strip in lines.strips]
        if strips:
            parts.append(rr.LineStrips2D(
                [np.asarray(strip, dtype=np.float32) for _, strip in strips],
                radii=[0.5 * lines.width_m for lines, _ in strips],
                colors=[_rgba(lines.colour) for lines, _ in strips],
            ))  # fmt: skip
        discs = [(points, n) for points in shapes.points for n in range(len(points.positions))]
        if discs:
            parts.append(rr.Points2D(
                np.concatenate([points.positions for points in shapes.points]).astype(np.float32),
                radii=[0.5 * points.diameter_m for points, _ in discs],
                colors=[_rgba(points.colour) for points, _ in discs],
            ))  # fmt: skip
        rr.log(shapes.entity, *parts, recording=self.recording)

    def log_latency(self, stamp_s: float, latency_s: float, note: str | None = None) -> None:
        """The view's latency at ``stamp_s`` (a point of the "view latency" plot), and a note."""
        rr = self.rr
        rr.set_time(TIMELINE, timestamp=stamp_s, recording=self.recording)
        rr.log(LATENCY_PLOT, rr.Scalars(latency_s), recording=self.recording)
        if note is not None:
            level = "WARN" if note.startswith("behind") else "INFO"
            rr.log(VIEW_NOTES, rr.TextLog(note, level=level), recording=self.recording)

    def flush(self) -> None:
        """Hand everything logged so far to the server."""
        self.recording.flush()

    def close(self) -> None:
        """Stop serving (viewers see the stream end)."""
        self.recording.disconnect()
