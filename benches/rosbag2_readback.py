#!/usr/bin/env python3
"""Open a rosbag2 folder written by synthcam (`servo --rosbag2`, `sim --rosbag2`, `export --format
rosbag2`) with rosbags' AnyReader and print what `ros2 bag info DIR` prints: storage, files and
bytes, duration, start, message count, and each topic's type and count; then decode every message
(Image, CameraInfo, TFMessage with ROS 2 Humble's types) and check the counts against the metadata.

Usage (pip install rosbags):
    synthcam servo --law ibvs --steps 100 --no-stop --no-compare -o /tmp/s100 --rosbag2 /tmp/s100/bag
    python3 benches/rosbag2_readback.py /tmp/s100/bag [--json]
"""
import argparse
import json
import sys
import time
from pathlib import Path

from rosbags.highlevel import AnyReader
from rosbags.typesys import Stores, get_typestore


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folder", help="the rosbag2 folder (metadata.yaml + .mcap)")
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    args = parser.parse_args()
    folder = Path(args.folder)
    t0 = time.perf_counter()
    with AnyReader([folder], default_typestore=get_typestore(Stores.ROS2_HUMBLE)) as reader:
        topics = {c.topic: {"type": c.msgtype, "count": c.msgcount} for c in reader.connections}
        decoded = {}
        for conn, _, raw in reader.messages():
            reader.deserialize(raw, conn.msgtype)
            decoded[conn.topic] = decoded.get(conn.topic, 0) + 1
        figures = {
            "folder": str(folder),
            "files": sorted(p.name for p in folder.iterdir()),
            "bytes": sum(p.stat().st_size for p in folder.iterdir()),
            "duration_ns": reader.duration,
            "start_ns": reader.start_time,
            "messages": reader.message_count,
            "topics": topics,
            "decoded": decoded,
            "read_s": round(time.perf_counter() - t0, 3),
        }
    ok = all(decoded.get(t, 0) == v["count"] for t, v in topics.items()) and sum(decoded.values()) == figures["messages"]
    if args.json:
        print(json.dumps(figures))
    else:
        for k, v in figures.items():
            print(f"{k}: {v}")
        print("counts match the metadata" if ok else "MISMATCH between the metadata and the messages")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
