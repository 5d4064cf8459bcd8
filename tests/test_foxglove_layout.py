"""The shipped Foxglove layout: the file is the one ``analysis.foxglove_layout`` builds, it is
package data, and every plotted path names a field of a topic's schema; docs/live_view.md names
every topic."""

import json
import re
from importlib.resources import files
from pathlib import Path

from heft.analysis.foxglove_layout import LAYOUT_FILE, layout_text
from heft.analysis.topics import EVENT_TOPICS, SCENE_SCHEMAS, TOPICS

DOCS = Path(__file__).resolve().parents[1] / "docs" / "live_view.md"


def test_the_shipped_layout_is_the_built_one():
    assert LAYOUT_FILE.read_text() == layout_text()
    assert (files("heft.analysis") / "heft_layout.json").read_text() == layout_text()


def test_every_plotted_path_is_a_field_of_a_topic():
    layout = json.loads(LAYOUT_FILE.read_text())
    schemas = {topic.name: topic.schema() for topic in TOPICS}
    paths = [series["value"] for key, panel in layout["configById"].items() if key.startswith("Plot!")
             for series in panel["paths"]]
    assert len(paths) > 40
    for path in paths:
        topic, *parts = path.split(".")
        node = schemas[topic]
        for part in parts:
            name, index = re.fullmatch(r"(\w+)(?:\[(\d+)\])?", part).groups()
            node = node["properties"][name]
            if index is not None:
                assert node["type"] == "array" and int(index) < node.get("maxItems", 6), path
                node = node["items"]
        assert "number" in node["type"], path
    scene = layout["configById"]["3D!scene"]
    assert set(scene["topics"]) <= set(SCENE_SCHEMAS)
    raw = {panel["topicPath"] for key, panel in layout["configById"].items() if key.startswith("RawMessages!")}
    assert raw == {"/faults", "/load/status"}


def test_the_docs_name_every_topic():
    text = DOCS.read_text()
    for name in [topic.name for topic in TOPICS] + [topic.name for topic in EVENT_TOPICS] + list(SCENE_SCHEMAS):
        assert f"`{name}`" in text, name
