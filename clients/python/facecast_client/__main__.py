"""python3 -m facecast_client: speak a text and write its blendshape weights as JSON or CSV."""
from __future__ import annotations

import argparse
import asyncio
import csv
import json
import sys
from typing import List, Optional

from .client import Utterance, connect
from .messages import FacecastError


def parse_args(argv: Optional[List[str]]) -> argparse.Namespace:
    p = argparse.ArgumentParser(prog="python3 -m facecast_client", description=__doc__)
    p.add_argument("--url", default="ws://127.0.0.1:8080/ws", help="the server's /ws address")
    p.add_argument("--text", required=True, help="text to speak (expression tags allowed)")
    p.add_argument("--out", required=True, help="weights file: .json or .csv")
    p.add_argument("--key", help="API key or viewer token")
    p.add_argument("--rig", help="rig id (default: the server's)")
    p.add_argument("--fps", type=float, help="frame rate (default 60)")
    p.add_argument("--timeout", type=float, default=60.0,
                   help="seconds to wait for any message (default 60)")
    args = p.parse_args(argv)
    if not args.out.lower().endswith((".json", ".csv")):
        p.error("--out must end in .json or .csv")
    return args


def write_weights(result: Utterance, path: str) -> int:
    """Writes the frames (in index order) to `path`; returns how many."""
    frames = sorted(result.frames, key=lambda f: f.index)
    shapes = result.names
    rows = [list(f.values[:len(shapes)]) for f in frames]
    with open(path, "w", newline="") as out:
        if path.lower().endswith(".json"):
            json.dump({"fps": result.fps, "frames": len(rows), "shapes": shapes,
                       "weights": [[round(v, 6) for v in row] for row in rows]}, out)
            out.write("\n")
        else:
            w = csv.writer(out)
            w.writerow(["time"] + shapes)
            for f, row in zip(frames, rows):
                w.writerow([f"{f.time:.6f}"] + [f"{v:.6g}" for v in row])
    return len(rows)


async def run(args: argparse.Namespace) -> str:
    client = await connect(args.url, args.key, timeout=args.timeout)
    async with client:
        id = await client.speak(args.text, rig=args.rig, fps=args.fps)
        result = await client.collect(id)
    if result.start is None or result.end is None:
        raise FacecastError("the stream ended without stream_start")
    count = write_weights(result, args.out)
    dropped = f", {result.end.dropped} dropped" if result.end.dropped else ""
    return (f"{count} frames at {result.fps:g} fps{dropped}, {len(result.names)} shapes, "
            f"{count / result.fps:.2f} s, rig {result.start.raw.get('rig')} -> {args.out}")


def main(argv: Optional[List[str]] = None) -> int:
    args = parse_args(argv)
    try:
        summary = asyncio.run(run(args))
    except (FacecastError, OSError) as e:
        print(f"facecast_client: error: {e}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        return 130
    print(f"facecast_client: {summary}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
