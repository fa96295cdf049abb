"""config/fish.rviz: the swimming fish in RViz, on the topics and frames the nodes use.

The names come from fishtail_common.interface, so renaming a topic or a frame there without the
config fails here. RViz itself is not run (it is not part of the workspace's venv).
"""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from fishtail_common.interface import (
    BODY_FRAME,
    FISH_MARKERS,
    FISH_ODOM,
    ODOM_FRAME,
    TAIL_MARKERS,
    Topic,
)

CONFIG = Path(__file__).resolve().parents[1] / "config" / "fish.rviz"
#: Topics the config shows, by display class.
SHOWN = {
    "rviz_default_plugins/MarkerArray": [FISH_MARKERS, TAIL_MARKERS],
    "rviz_default_plugins/Odometry": [FISH_ODOM],
}


@pytest.fixture(scope="module")
def manager():
    document = yaml.safe_load(CONFIG.read_text(encoding="utf-8"))
    assert isinstance(document, dict)
    return document["Visualization Manager"]


def displays_of(manager, class_name):
    return [d for d in manager["Displays"] if d["Class"] == class_name]


def test_fixed_frame_is_the_world_the_fish_swims_in(manager):
    assert manager["Global Options"]["Fixed Frame"] == ODOM_FRAME


@pytest.mark.parametrize("class_name", sorted(SHOWN))
def test_shows_the_suite_topics(manager, class_name):
    displays = displays_of(manager, class_name)
    assert all(display["Enabled"] is True for display in displays)
    shown = sorted(display["Topic"]["Value"] for display in displays)
    assert shown == sorted("/" + topic.name for topic in SHOWN[class_name])


def subscription_matches(display: dict, topic: Topic) -> bool:
    """True if the display's subscription QoS can receive the topic's publisher (DDS's rules)."""
    from rclpy.qos import DurabilityPolicy, ReliabilityPolicy

    from fishtail_common.ros import publisher_qos

    qos, offered = display["Topic"], publisher_qos(topic)
    if (
        qos["Reliability Policy"] == "Reliable"
        and offered.reliability != ReliabilityPolicy.RELIABLE
    ):
        return False  # a best-effort publisher cannot serve a reliable subscription
    return not (
        qos["Durability Policy"] == "Transient Local"
        and offered.durability != DurabilityPolicy.TRANSIENT_LOCAL
    )


def test_every_topic_display_can_receive_its_topic(manager):
    topics = {"/" + topic.name: topic for topics in SHOWN.values() for topic in topics}
    for class_name in SHOWN:
        for display in displays_of(manager, class_name):
            topic = topics[display["Topic"]["Value"]]
            assert subscription_matches(display, topic), (display["Name"], topic.qos)


def test_odometry_keeps_a_short_history(manager):
    (odometry,) = displays_of(manager, "rviz_default_plugins/Odometry")
    assert 0 < odometry["Keep"] <= 50


def test_tf_display_and_a_top_down_view_following_the_fish(manager):
    (tf,) = displays_of(manager, "rviz_default_plugins/TF")
    assert tf["Enabled"] is True and tf["Frames"]["All Enabled"] is True
    view = manager["Views"]["Current"]
    assert view["Class"] == "rviz_default_plugins/TopDownOrtho"
    assert view["Target Frame"] == BODY_FRAME
