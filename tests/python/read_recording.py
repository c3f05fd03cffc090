"""Reads a `dynotraj forecast|estimate|track --record` recording with Python's `mcap` package,
as any user's tool would, prints a summary (channels, schema names, messages per topic, first
and last log time) and exits non-zero when something expected is missing: a Foxglove schema
name, a message that does not decode (Protobuf, with the FileDescriptorSet the file carries, or
JSON) or does not match its channel's JSON schema or Foxglove's official JSON Schema, a topic
without exactly one message per frame, an image that is not a PNG.

Protobuf messages are turned into Foxglove's JSON encoding (times as {sec, nsec}, enums as
numbers, bytes as base64) before they are checked, so both encodings pass the same checks.

    python read_recording.py forecast FILE --frames N [--predictor cv|learned ...]
    python read_recording.py estimate FILE --frames N [--no-truth]
    python read_recording.py track FILE --frames N
    ... [--encoding protobuf|json] [--official-schemas DIR]

DIR holds Foxglove's official JSON Schemas, one `<Name>.json` per type (from the npm package
@foxglove/schemas); each message is validated against its type's, and a line per channel says
how many were checked and how many failed.
"""

import argparse
import base64
import json
import sys
from collections import Counter

import jsonschema
from google.protobuf.descriptor import FieldDescriptor
from mcap.reader import make_reader
from mcap_protobuf.decoder import DecoderFactory

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


def foxglove_json(message):
    """A decoded Protobuf message in Foxglove's JSON encoding."""
    if message.DESCRIPTOR.full_name in ("google.protobuf.Timestamp", "google.protobuf.Duration"):
        return {"sec": message.seconds, "nsec": message.nanos}
    out = {}
    for field in message.DESCRIPTOR.fields:
        value = getattr(message, field.name)

        def one(x, field=field):
            if field.type == FieldDescriptor.TYPE_MESSAGE:
                return foxglove_json(x)
            if field.type == FieldDescriptor.TYPE_BYTES:
                return base64.b64encode(x).decode()
            return x

        repeated = field.is_repeated if hasattr(field, "is_repeated") else field.label == FieldDescriptor.LABEL_REPEATED
        out[field.name] = [one(x) for x in value] if repeated else one(value)
    return out


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
    parser.add_argument("--encoding", choices=["protobuf", "json"], default="protobuf")
    parser.add_argument("--official-schemas", help="a folder of Foxglove's official JSON Schemas")
    args = parser.parse_args()
    official = {}
    if args.official_schemas:
        for name in FOXGLOVE:
            with open(f"{args.official_schemas}/{name.split('.')[1]}.json") as f:
                official[name] = jsonschema.Draft7Validator(json.load(f))
    checked = Counter()
    failed = Counter()
    decoders = DecoderFactory()

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
            if schema.encoding == "jsonschema":
                text = json.loads(schema.data)
                jsonschema.Draft202012Validator.check_schema(text)
                check = jsonschema.Draft202012Validator(text)
            else:
                check = decoders.decoder_for(channel.message_encoding, schema)
                if check is None:
                    problems.append(f"{channel.topic}: no decoder for {schema.encoding}/{channel.message_encoding}")
                    continue
            channels[channel.topic] = (schema.name, schema.encoding, channel.message_encoding, check)
        for schema, channel, message in reader.iter_messages():
            counts[channel.topic] += 1
            first = message.log_time if first is None else min(first, message.log_time)
            last = message.log_time if last is None else max(last, message.log_time)
            where = f"{channel.topic} at {message.log_time} ns"
            if channel.topic not in channels:
                continue
            check = channels[channel.topic][3]
            if schema.encoding == "jsonschema":
                try:
                    msg = json.loads(message.data)
                except ValueError as e:
                    problems.append(f"{where}: not JSON: {e}")
                    continue
                errors = sorted(check.iter_errors(msg), key=str)
                if errors:
                    problems.append(f"{where}: does not match its schema: {errors[0].message}")
                    continue
            else:
                try:
                    msg = foxglove_json(check(message.data))
                except Exception as e:  # any decoding failure is reported, not raised
                    problems.append(f"{where}: does not decode as {schema.name}: {e}")
                    continue
            if schema.name in official:
                checked[channel.topic] += 1
                errors = sorted(official[schema.name].iter_errors(msg), key=str)
                if errors:
                    failed[channel.topic] += 1
                    if failed[channel.topic] == 1:
                        problems.append(f"{where}: fails Foxglove's {schema.name} schema: {errors[0].message}")
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
    if official:
        for topic in sorted(channels):
            print(f"  official schema {topic}: {checked[topic]} checked, {failed[topic]} failed")

    for topic, (name, encoding, message_encoding, _) in channels.items():
        if name not in FOXGLOVE:
            problems.append(f"{topic}: schema {name} is not one of Foxglove's")
        want = ("jsonschema", "json") if args.encoding == "json" else ("protobuf", "protobuf")
        if (encoding, message_encoding) != want:
            problems.append(f"{topic}: encodings {encoding}/{message_encoding}, expected {want[0]}/{want[1]}")
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
