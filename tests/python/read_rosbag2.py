"""Reads a ROS 2 bag with rosbags (AnyReader), the way robotics tools outside the ROS 2 install
read bags, and prints each topic's type and message count; every message is decoded with the
definitions the bag carries. Exits 1 on any error.

    python read_rosbag2.py BAG_FOLDER
"""

import sys
from pathlib import Path

from rosbags.highlevel import AnyReader
from rosbags.typesys import Stores, get_typestore


def main() -> None:
    bag = Path(sys.argv[1])
    with AnyReader([bag], default_typestore=get_typestore(Stores.EMPTY)) as reader:
        counts = {}
        for connection, _, raw in reader.messages():
            reader.deserialize(raw, connection.msgtype)
            counts[connection.topic] = counts.get(connection.topic, 0) + 1
        for connection in sorted(reader.connections, key=lambda c: c.topic):
            print(f"{connection.topic}: {connection.msgtype}, {counts.get(connection.topic, 0)} messages")
        print(f"messages: {reader.message_count}, duration: {reader.duration / 1e9:.3f} s")


if __name__ == "__main__":
    main()
