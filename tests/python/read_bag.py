"""Decodes every message of a ROS 2 bag written by `dynotraj export-bag` with the ROS 2 MCAP
decoder (mcap-ros2-support), as ROS 2 tools would read it, and checks what it holds.

    python read_bag.py BAG.mcap FRAMES

Prints one line per topic (schema, messages, what one message holds) and exits non-zero, with
the reason, when a message does not decode or a topic is missing or short of messages.
"""
import sys
from collections import Counter

from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory


def main(path: str, frames: int) -> int:
    counts: Counter = Counter()
    seen = {}
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for schema, channel, message, ros in reader.iter_decoded_messages():
            counts[channel.topic] += 1
            seen.setdefault(channel.topic, (schema.name, ros))
    expected = {
        "/stereo/left/image_raw": "sensor_msgs/msg/Image",
        "/stereo/right/image_raw": "sensor_msgs/msg/Image",
        "/stereo/left/camera_info": "sensor_msgs/msg/CameraInfo",
        "/stereo/right/camera_info": "sensor_msgs/msg/CameraInfo",
        "/detections": "vision_msgs/msg/Detection2DArray",
    }
    problems = []
    for topic, schema in expected.items():
        if topic not in seen:
            problems.append(f"{topic}: missing")
            continue
        if seen[topic][0] != schema:
            problems.append(f"{topic}: schema {seen[topic][0]}, expected {schema}")
        if counts[topic] != frames:
            problems.append(f"{topic}: {counts[topic]} messages, expected {frames}")
    for topic in sorted(seen):
        schema, ros = seen[topic]
        if schema == "sensor_msgs/msg/Image":
            what = f"{ros.width} x {ros.height} {ros.encoding}, {len(ros.data)} bytes"
            if len(ros.data) != ros.step * ros.height:
                problems.append(f"{topic}: {len(ros.data)} bytes of data for step {ros.step} x {ros.height}")
        elif schema == "sensor_msgs/msg/CameraInfo":
            what = f"fx {ros.p[0]:.2f}, p[3] {ros.p[3]:.2f}"
        elif schema == "vision_msgs/msg/Detection2DArray":
            what = f"{len(ros.detections)} detections, first class {ros.detections[0].results[0].hypothesis.class_id!r}" if ros.detections else "no detections"
        else:
            what = ""
        print(f"{topic}: {schema}, {counts[topic]} messages; first: {what}")
    right = seen.get("/stereo/right/camera_info")
    if right and not right[1].p[3] < 0:
        problems.append("/stereo/right/camera_info: p[3] carries no baseline")
    for p in problems:
        print(f"problem: {p}", file=sys.stderr)
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1], int(sys.argv[2])))
