#!/usr/bin/env python3
"""Read a servo run's rerun recording back with rerun-sdk's reader and print its figures.

Usage (rerun-sdk installed, e.g. `pip install 'synthcam[rerun]'`):
    python -m synthcam.rerun_log --scenario ur5e_chessboard --steps 100 -o /tmp/run100.rrd
    python3 benches/rerun_readback.py /tmp/run100.rrd [--json]

Prints the file's size (bytes), its entity paths (with their components), the number of frames
(distinct `step` indices with an image at world/camera/image), the distinct `step` indices of
the error curve, the first and last pixel RMS error, and how long reading took. The reader is
`synthcam.rerun_log.RecordedRun` (rerun.chunk.RrdReader underneath, rerun-sdk 0.41).
"""
import argparse
import json
import sys
import time

from synthcam.rerun_log import RecordedRun


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("rrd", help="the .rrd file")
    parser.add_argument("--json", action="store_true", help="print one JSON object instead of text")
    args = parser.parse_args()

    t0 = time.perf_counter()
    run = RecordedRun(args.rrd)
    steps, rms = run.scalars("error/pixel_rms_px")
    figures = {
        "path": args.rrd,
        "bytes": run.bytes,
        "entities": run.entities,
        "frames": len(run.frames),
        "step_indices": len(set(steps.tolist())),
        "first_rms_px": float(rms[0]) if len(rms) else None,
        "last_rms_px": float(rms[-1]) if len(rms) else None,
        "read_s": round(time.perf_counter() - t0, 3),
    }
    if run.frames:
        figures["image_shape"] = list(run.image(run.frames[-1]).shape)
    if args.json:
        print(json.dumps(figures))
        return 0
    print(f"{args.rrd}: {run.bytes} bytes ({run.bytes / 2**20:.1f} MiB), read in {figures['read_s']} s")
    print(f"frames (step indices with an image): {figures['frames']}" + (f", each {figures['image_shape']}" if run.frames else ""))
    print(f"error/pixel_rms_px: {figures['step_indices']} step indices, {figures['first_rms_px']} -> {figures['last_rms_px']} px")
    print(f"{len(run.entities)} entities:")
    for entity in run.entities:
        print(f"  /{entity}: {', '.join(run.components(entity))}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
