"""Reads a `dynotraj forecast|estimate --record` recording with Python's `mcap` package, as
any user's tool would, prints a summary (channels, schema names, messages per topic, first and
last log time) and exits non-zero when something expected is missing: a Foxglove schema name,
a message that does not decode as JSON or does not match its channel's JSON schema, a topic
without exactly one message per frame.

    python read_recording.py forecast FILE --frames N [--predictor cv|learned]
    python read_recording.py estimate FILE --frames N [--no-truth]
"""

import argparse
import base64
import json
import sys
from collections import Counter

import jsonschema
from mcap.reader import make_reader

FOXGLOVE = {
    "foxglove.SceneUpdate",
    "foxglove.FrameTransform",
    "foxglove.PosesInFrame",
    "foxglove.PointCloud",
    "foxglove.CompressedImage",
}


def expected_topics(args):
    """Topic -> (schema name, whether it has one message per frame)."""
    if args.command == "forecast":
        return {
            "/objects/tracks": ("foxglove.SceneUpdate", True),
            f"/forecasts/{args.predictor}": ("foxglove.SceneUpdate", True),
            # Only frames the edge estimated place the camera.
            "/tf": ("foxglove.FrameTransform", False),
        }
    topics = {
        "/tf": ("foxglove.FrameTransform", False),
        "/camera/path": ("foxglove.PosesInFrame", True),
        "/objects/estimated": ("foxglove.SceneUpdate", True),
        "/points/static": ("foxglove.PointCloud", True),
        "/points/objects": ("foxglove.PointCloud", True),
    }
    if not args.no_truth:
        topics["/objects/truth"] = ("foxglove.SceneUpdate", True)
        topics["/camera/truth"] = ("foxglove.PosesInFrame", True)
    return topics


def stamp_ns(msg, schema_name):
    """The message's own time stamp, nanoseconds."""
    if schema_name == "foxglove.SceneUpdate":
        stamps = [d["timestamp"] for d in msg["deletions"]] + [e["timestamp"] for e in msg["entities"]]
        if not stamps:
            return None
        t = stamps[0]
    else:
        t = msg["timestamp"]
    return t["sec"] * 1_000_000_000 + t["nsec"]


def check_message(msg, schema_name):
    """Content checks beyond the schema; returns problems."""
    problems = []
    if schema_name == "foxglove.SceneUpdate":
        for e in msg["entities"]:
            if e["frame_id"] != "world":
                problems.append(f"entity {e['id']} in frame {e['frame_id']}, expected world")
            for line in e["lines"]:
                if any(p["z"] != 0 for p in line["points"]):
                    problems.append(f"entity {e['id']}: a line off the bird's-eye plane (z != 0)")
    elif schema_name == "foxglove.PointCloud":
        data = base64.b64decode(msg["data"], validate=True)
        if len(data) % msg["point_stride"] != 0:
            problems.append(f"point cloud of {len(data)} bytes, stride {msg['point_stride']}")
    elif schema_name == "foxglove.FrameTransform":
        if (msg["parent_frame_id"], msg["child_frame_id"]) != ("world", "camera"):
            problems.append(f"transform {msg['parent_frame_id']} -> {msg['child_frame_id']}")
    return problems


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("command", choices=["forecast", "estimate"])
    parser.add_argument("file")
    parser.add_argument("--frames", type=int, required=True, help="frames the run had")
    parser.add_argument("--predictor", default="cv")
    parser.add_argument("--no-truth", action="store_true", help="a run without the simulator's truth")
    args = parser.parse_args()

    problems = []
    counts = Counter()
    entities = Counter()
    channels = {}
    first = last = None
    with open(args.file, "rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        if summary is None:
            sys.exit(f"{args.file}: no summary section (not finished?)")
        for channel in summary.channels.values():
            schema = summary.schemas.get(channel.schema_id)
            if schema is None:
                problems.append(f"{channel.topic}: no schema")
                continue
            text = json.loads(schema.data)
            jsonschema.Draft202012Validator.check_schema(text)
            channels[channel.topic] = (schema.name, schema.encoding, channel.message_encoding,
                                       jsonschema.Draft202012Validator(text))
        for schema, channel, message in reader.iter_messages():
            counts[channel.topic] += 1
            first = message.log_time if first is None else min(first, message.log_time)
            last = message.log_time if last is None else max(last, message.log_time)
            where = f"{channel.topic} at {message.log_time} ns"
            try:
                msg = json.loads(message.data)
            except ValueError as e:
                problems.append(f"{where}: not JSON: {e}")
                continue
            validator = channels[channel.topic][3]
            errors = sorted(validator.iter_errors(msg), key=str)
            if errors:
                problems.append(f"{where}: does not match its schema: {errors[0].message}")
                continue
            stamp = stamp_ns(msg, schema.name)
            if stamp is not None and stamp != message.log_time:
                problems.append(f"{where}: stamped {stamp} ns")
            problems += [f"{where}: {p}" for p in check_message(msg, schema.name)]
            entities[channel.topic] += len(msg.get("entities", []))

    print(f"{args.file}: {sum(counts.values())} messages, log time {first} .. {last} ns")
    for topic, (name, encoding, message_encoding, _) in sorted(channels.items()):
        extra = f", {entities[topic]} entities" if name == "foxglove.SceneUpdate" else ""
        print(f"  {topic}: {name} ({encoding}/{message_encoding}), {counts[topic]} messages{extra}")

    for topic, (name, encoding, message_encoding, _) in channels.items():
        if name not in FOXGLOVE:
            problems.append(f"{topic}: schema {name} is not one of Foxglove's")
        if (encoding, message_encoding) != ("jsonschema", "json"):
            problems.append(f"{topic}: encodings {encoding}/{message_encoding}, expected jsonschema/json")
    for topic, (name, per_frame) in expected_topics(args).items():
        if topic not in channels:
            problems.append(f"{topic}: missing")
            continue
        if channels[topic][0] != name:
            problems.append(f"{topic}: schema {channels[topic][0]}, expected {name}")
        n = counts[topic]
        if per_frame and n != args.frames:
            problems.append(f"{topic}: {n} messages, expected one per frame ({args.frames})")
        if not per_frame and not 0 < n <= args.frames:
            problems.append(f"{topic}: {n} messages, expected 1 to {args.frames}")
    for topic in ("/objects/tracks", "/objects/estimated", f"/forecasts/{args.predictor}"):
        if topic in channels and entities[topic] == 0:
            problems.append(f"{topic}: no entity in any frame")

    for p in problems:
        print(f"problem: {p}", file=sys.stderr)
    sys.exit(1 if problems else 0)


if __name__ == "__main__":
    main()
