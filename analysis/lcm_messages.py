"""Every event of an LCM log of ``heft teleop --hardware --record`` as a JSON message: each
channel on its own topic ``/lcm/CHANNEL`` (the decoded message's fields, schema ``lcm.TYPE``),
and the station's status, the load commands and their answers on ``analysis.topics``'
``EVENT_TOPICS`` as well. A channel heft does not know keeps its payload (base64).
"""

from __future__ import annotations

import base64
import math

LCM_PREFIX = "/lcm/"
_JSON_TYPES = {"double": "number", "float": "number", "string": "string", "boolean": "boolean"}


def channel_types(channels) -> dict:
    """Channel name → the LCM types its messages may be (tried in order) for ``channels`` (``LcmChannels``)."""
    from drake import lcmt_iiwa_command, lcmt_iiwa_status

    from heft.hardware_interface.lcmtypes import (heft_ft_sample, heft_ft_samples, heft_gripper_state,
                                                  heft_haptic_command, heft_haptic_state, heft_load_command,
                                                  heft_load_status, heft_station_status, heft_teleop_state)

    return {channels.master_state.name: (heft_haptic_state,), channels.master_command.name: (heft_haptic_command,),
            channels.slave_status.name: (lcmt_iiwa_status,), channels.slave_command.name: (lcmt_iiwa_command,),
            channels.ft_sample.name: (heft_ft_sample, heft_ft_samples),
            channels.gripper_state.name: (heft_gripper_state,), channels.load_command.name: (heft_load_command,),
            channels.load_status.name: (heft_load_status,), channels.station_status.name: (heft_station_status,),
            channels.teleop_state.name: (heft_teleop_state,)}


def _plain(value):
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, (list, tuple)):
        return [_plain(item) for item in value]
    if isinstance(value, bytes):
        return base64.b64encode(value).decode()
    if hasattr(value, "__slots__"):
        return as_dict(value)
    return value


def as_dict(message) -> dict:
    """An lcm-gen message's fields as JSON values (non-finite numbers as null)."""
    return {name: _plain(getattr(message, name)) for name in message.__slots__}


def lcm_schema(message_type) -> dict:
    """The JSON Schema of an lcm-gen type's fields."""
    properties = {}
    for name, typename, dimensions in zip(message_type.__slots__, message_type.__typenames__,
                                          message_type.__dimensions__, strict=True):
        kind = _JSON_TYPES.get(typename, "integer" if typename.startswith(("int", "byte")) else "object")
        schema = {"type": kind}
        for _ in dimensions or ():
            schema = {"type": "array", "items": schema}
        properties[name] = schema
    return {"title": f"lcm.{message_type.__name__}", "type": "object", "properties": properties}


def decode(types, data: bytes):
    """The message of the first of ``types`` that decodes ``data``; None if none does."""
    for message_type in types:
        try:
            return message_type.decode(data)
        except Exception:  # a fingerprint or length the type refuses: try the next
            continue
    return None


def station_status_message(msg) -> dict:
    """The ``/faults`` message of a ``heft_station_status``: health, fault bits, the force gain and,
    per channel, the messages received, unread, rejected per reason, restarts, second publishers."""
    return {"utime": msg.utime, "healthy": bool(msg.healthy), "fault": msg.fault, "gain": _plain(msg.gain),
            "channels": {channel: {"received": msg.received[i], "unread": msg.unread[i],
                                   "rejected": dict(zip(msg.reasons, msg.rejected[i], strict=True)),
                                   "restarts": msg.restarts[i], "second_publisher": bool(msg.second_publisher[i])}
                         for i, channel in enumerate(msg.channels)}}


def event_message(topic: str, msg) -> dict:
    """The message on the event topic ``topic`` (``analysis.topics.EVENT_TOPICS``) of the decoded LCM message
    ``msg``: ``station_status_message``'s on ``/faults``, else its fields."""
    return station_status_message(msg) if topic == "/faults" else as_dict(msg)


def event_from_lcm(topic: str, data: bytes) -> dict:
    """``event_message`` of the LCM message ``data`` of the event topic's type; its size alone if it is not one."""
    from heft.hardware_interface.lcmtypes import heft_load_command, heft_load_status, heft_station_status

    message_type = {"/faults": heft_station_status, "/load/command": heft_load_command,
                    "/load/status": heft_load_status}[topic]
    msg = decode((message_type,), data)
    return {"bytes": len(data)} if msg is None else event_message(topic, msg)


def event_topic(channel: str, channels) -> str | None:
    """The ``analysis.topics.EVENT_TOPICS`` name a channel's messages also go to, or None."""
    names = {channels.station_status.name: "/faults", channels.load_command.name: "/load/command",
             channels.load_status.name: "/load/status"}
    return names.get(channel)


def lcm_log_messages(path, channels):
    """(time (ns since the epoch: the logger's receive time), topic, message) of every event in the
    LCM log at ``path``, in the log's order: on ``/lcm/CHANNEL``, and for the station status and the
    load commands and answers on their event topic too. ``channels``: ``LcmChannels``."""
    import lcm

    types = channel_types(channels)
    for event in lcm.EventLog(str(path), "r"):
        t = event.timestamp * 1000
        msg = decode(types.get(event.channel, ()), event.data)
        if msg is None:
            yield t, LCM_PREFIX + event.channel, {"bytes": len(event.data),
                                                 "data": base64.b64encode(event.data).decode()}
            continue
        yield t, LCM_PREFIX + event.channel, as_dict(msg)
        topic = event_topic(event.channel, channels)
        if topic is not None:
            yield t, topic, event_message(topic, msg)


def lcm_topic_schemas(channels) -> dict:
    """Topic → (schema name, JSON Schema, what it shows) of each known channel's ``/lcm/`` topic
    (``RAW_SCHEMA`` for a channel heft does not know)."""
    out = {}
    for name, message_types in channel_types(channels).items():
        schema = lcm_schema(message_types[0])
        if len(message_types) > 1:
            schema = {"title": "lcm." + " | ".join(t.__name__ for t in message_types),
                      "anyOf": [lcm_schema(t) for t in message_types]}
        out[LCM_PREFIX + name] = (schema["title"], schema, f"every message on the LCM channel {name}, as logged")
    return out


RAW_SCHEMA = ("lcm.raw", {"title": "lcm.raw", "type": "object",
                          "properties": {"bytes": {"type": "integer"}, "data": {"type": "string"}}},
              "the payloads of an LCM channel heft does not know (base64)")
