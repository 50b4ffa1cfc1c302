"""`Dataset`: a folder written by `synthcam dataset` as a sequence of (image, truth) samples."""

from __future__ import annotations

import glob
import json
import os
from typing import Any, Dict, Iterator, List, NamedTuple, Optional

import numpy as np

from ._synthcam import SynthcamError, load_image
from .results import Truth


class Sample(NamedTuple):
    """One image of a dataset: the pixels, its truth labels and its manifest entry."""

    image: np.ndarray
    """(H, W) uint8 or uint16 (16-bit specs), (H, W, 3) for colour output."""
    truth: Truth
    """The truth labels (the truth JSON as a ``Truth``: camera, cam_from_target, every feature's
    exact pixel and visibility; ``truth["key"]`` answers from the JSON)."""
    entry: Dict[str, Any]
    """The manifest line: k, file, sha256, truth, seed, pose."""


class Dataset:
    """A dataset folder (`synthcam dataset SPEC -o DIR`), in image-index order.

    Reads `manifest.jsonl` (or, before `synthcam dataset merge`, every shard's
    `manifest-*.jsonl`); images are decoded on access. `len(ds)`, `ds[i]`, and iteration yield
    `Sample(image, truth, entry)`, which unpacks as `image, truth, entry`.

    A rig dataset (`[[cameras]]`) holds every camera's image of frame k: `camera="right"` reads
    that camera's (default: the first camera's); `entry["cameras"]` lists them all.
    """

    def __init__(self, path: str | os.PathLike[str], camera: Optional[str] = None) -> None:
        self.path = os.fspath(path)
        self.camera = camera
        self.entries: List[Dict[str, Any]] = [_for_camera(e, camera) for e in _read_manifests(self.path)]

    def __len__(self) -> int:
        return len(self.entries)

    def __getitem__(self, i: int) -> Sample:
        entry = self.entries[i]
        image = load_image(os.path.join(self.path, entry["file"]))
        with open(os.path.join(self.path, entry["truth"]), encoding="utf-8") as f:
            truth = Truth.from_dict(json.load(f))
        return Sample(image, truth, entry)

    def __iter__(self) -> Iterator[Sample]:
        for i in range(len(self)):
            yield self[i]

    def __repr__(self) -> str:
        return f"Dataset({self.path!r}, {len(self)} images)"


def _for_camera(entry: Dict[str, Any], camera: Optional[str]) -> Dict[str, Any]:
    """The entry with `file`, `truth`, `seed` and `cam_from_target` of rig camera `camera`."""
    if camera is None:
        return entry
    for c in entry.get("cameras") or []:
        if c["name"] == camera:
            return {**entry, **{key: c[key] for key in ("file", "sha256", "truth", "seed", "cam_from_target")}}
    names = [c["name"] for c in entry.get("cameras") or []]
    raise SynthcamError(f"image {entry.get('k')}: no camera {camera!r} (cameras: {names or 'none, not a rig dataset'})")


def _read_manifests(path: str) -> List[Dict[str, Any]]:
    """The manifest entries of `path`, sorted by image index, duplicates refused."""
    merged = os.path.join(path, "manifest.jsonl")
    files = [merged] if os.path.exists(merged) else sorted(glob.glob(os.path.join(path, "manifest-*.jsonl")))
    if not files:
        raise SynthcamError(f"{path}: no manifest.jsonl (is it a folder written by `synthcam dataset`?)")
    entries: Dict[int, Dict[str, Any]] = {}
    for name in files:
        with open(name, encoding="utf-8") as f:
            for line_no, line in enumerate(f, 1):
                if not line.strip():
                    continue
                try:
                    entry = json.loads(line)
                    k = int(entry["k"])
                except (ValueError, KeyError, TypeError) as e:
                    raise SynthcamError(f"{name}:{line_no}: not a manifest entry ({e})") from e
                if k in entries:
                    raise SynthcamError(f"{name}:{line_no}: image {k} is listed twice")
                entries[k] = entry
    return [entries[k] for k in sorted(entries)]
