"""Reads a `dynotraj forecast|estimate|track --record` recording with Python's `mcap` package,
as any user's tool would, prints a summary (channels, schema names, messages per topic, first
and last log time) and exits non-zero when something expected is missing: a Foxglove schema
name, a message that does not decode as JSON or does not match its channel's JSON schema, a
topic without exactly one message per frame, an image that is not a PNG.

    python read_recording.py forecast FILE --frames N [--predictor cv|learned ...]
    python read_recording.py estimate FILE --frames N [--no-truth]
    python read_recording.py track FILE --frames N
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
    "foxglove.ImageAnnotations",
}

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"

# foxglove.PointCloud numeric types written (FLOAT32, UINT32) and their sizes, bytes.
FIELD_BYTES = {7: 4, 5: 4}


def expected_topics(args):
    """Topic -> (schema name, whether it has one message per frame)."""
    if args.command == "forecast":
        topics = {
            "/objects/tracks": ("foxglove.SceneUpdate", True),
            # Only frames the edge estimated place the camera.
            "/tf": ("foxglove.FrameTransform", False),
        }
        for predictor in predictors(args):
            topics[f"/forecasts/{predictor}"] = ("foxglove.SceneUpdate", True)
        return topics
    if args.command == "track":
        return {
            "/camera/left/compressed": ("foxglove.CompressedImage", True),
            "/camera/left/annotations": ("foxglove.ImageAnnotations", True),
            "/tracks/static": ("foxglove.PointCloud", True),
            "/tracks/objects": ("foxglove.PointCloud", True),
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


def predictors(args):
    """The forecast topics' predictors asked for (cv when none is)."""
    return args.predictor or ["cv"]


def stamp_ns(msg, schema_name):
    """The message's own time stamp, nanoseconds."""
    if schema_name == "foxglove.SceneUpdate":
        stamps = [d["timestamp"] for d in msg["deletions"]] + [e["timestamp"] for e in msg["entities"]]
    elif schema_name == "foxglove.ImageAnnotations":
        stamps = [a["timestamp"] for kind in ("circles", "points", "texts") for a in msg[kind]]
    else:
        stamps = [msg["timestamp"]]
    if not stamps:
        return None
    t = stamps[0]
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
        for field in msg["fields"]:
            if field["offset"] + FIELD_BYTES.get(field["type"], 0) > msg["point_stride"]:
                problems.append(f"field {field['name']} of type {field['type']} beyond the point's stride")
            if field["type"] not in FIELD_BYTES:
                problems.append(f"field {field['name']} of unexpected type {field['type']}")
    elif schema_name == "foxglove.CompressedImage":
        data = base64.b64decode(msg["data"], validate=True)
        if msg["format"] == "png" and not data.startswith(PNG_SIGNATURE):
            problems.append(f"format png, but the data starts with {data[:8]!r}")
    elif schema_name == "foxglove.FrameTransform":
        if (msg["parent_frame_id"], msg["child_frame_id"]) != ("world", "camera"):
            problems.append(f"transform {msg['parent_frame_id']} -> {msg['child_frame_id']}")
    return problems


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("command", choices=["forecast", "estimate", "track"])
    parser.add_argument("file")
    parser.add_argument("--frames", type=int, required=True, help="frames the run had")
    parser.add_argument("--predictor", action="append", help="a forecast topic expected (repeat; default cv)")
    parser.add_argument("--no-truth", action="store_true", help="a run without the simulator's truth")
    args = parser.parse_args()

    problems = []
    counts = Counter()
    entities = Counter()
    points = Counter()
    fields = {}
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
            if schema.name == "foxglove.PointCloud":
                points[channel.topic] += len(base64.b64decode(msg["data"])) // msg["point_stride"]
                fields[channel.topic] = [f["name"] for f in msg["fields"]]
            elif schema.name == "foxglove.ImageAnnotations":
                points[channel.topic] += sum(len(a["points"]) for a in msg["points"])
            if "frame_id" in msg and schema.name != "foxglove.PosesInFrame" and msg["frame_id"] != "camera":
                problems.append(f"{where}: frame {msg['frame_id']}, expected camera")

    print(f"{args.file}: {sum(counts.values())} messages, log time {first} .. {last} ns")
    for topic, (name, encoding, message_encoding, _) in sorted(channels.items()):
        extra = ""
        if name == "foxglove.SceneUpdate":
            extra = f", {entities[topic]} entities"
        elif name == "foxglove.PointCloud":
            extra = f", {points[topic]} points (fields {', '.join(fields.get(topic, []))})"
        elif name == "foxglove.ImageAnnotations":
            extra = f", {points[topic]} points drawn"
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
    forecasts = [f"/forecasts/{p}" for p in predictors(args)] if args.command == "forecast" else []
    for topic in ["/objects/tracks", "/objects/estimated"] + forecasts:
        if topic in channels and entities[topic] == 0:
            problems.append(f"{topic}: no entity in any frame")
    if args.command == "track":
        for topic in ("/tracks/static", "/tracks/objects", "/camera/left/annotations"):
            if topic in channels and points[topic] == 0:
                problems.append(f"{topic}: no point in any frame")
        if "/tracks/objects" in fields and "object_id" not in fields["/tracks/objects"]:
            problems.append(f"/tracks/objects: fields {fields['/tracks/objects']}, expected an object_id")

    for p in problems:
        print(f"problem: {p}", file=sys.stderr)
    sys.exit(1 if problems else 0)


if __name__ == "__main__":
    main()
