"""Typed server messages of facecast.v1 and the bounded decoder of binary media messages."""
from __future__ import annotations

import json
import math
import struct
from dataclasses import dataclass, field
from typing import Any, Dict, List, Optional, Tuple

HEADER = struct.Struct("<BBHIIId")  # kind, version, reserved, stream, first, count, pts
HEADER_SIZE = HEADER.size  # 24
KIND_WEIGHTS, KIND_AUDIO, KIND_JPEG = 1, 2, 3
VERSION = 1


class FacecastError(Exception):
    """Any failure of the client: refused connection, closed socket, bad message."""


class ServerError(FacecastError):
    """An `error` message from the server: `code` (e.g. not_found), `message`, `id` (or None)."""

    def __init__(self, code: str, message: str, id: Optional[str] = None) -> None:
        super().__init__(f"{code}: {message}")
        self.code, self.message, self.id = code, message, id


class ProtocolError(FacecastError):
    """A message from the server that does not follow facecast.v1 (malformed JSON or binary)."""


@dataclass
class Event:
    """Any JSON message from the server; `raw` is the whole object."""
    type: str
    raw: Dict[str, Any] = field(repr=False)


@dataclass
class StreamStart(Event):
    id: str = ""
    stream: int = 0
    fps: float = 0.0
    frames: Optional[int] = None  # None for open (incremental) streams
    names: List[str] = field(default_factory=list)
    extra: List[str] = field(default_factory=list)
    audio: Optional[Dict[str, Any]] = None  # {format, sample_rate, channels, samples} or None


@dataclass
class StreamEnd(Event):
    id: str = ""
    stream: Optional[int] = None  # None: cancelled while queued
    frames: int = 0
    dropped: int = 0
    cancelled: bool = False


@dataclass
class WeightsFrame:
    """One frame: `values` are the rig's blendshape weights (`names`) then the `extra` values."""
    id: str
    stream: int
    index: int
    time: float  # seconds from the start of the utterance's audio
    names: List[str]
    extra: List[str]
    values: Tuple[float, ...]
    type: str = "weights"

    @property
    def weights(self) -> Dict[str, float]:
        return dict(zip(self.names, self.values))

    def __getitem__(self, name: str) -> float:
        """The value of a blendshape or extra channel by name."""
        names = self.names + self.extra
        if name not in names:
            raise KeyError(name)
        return self.values[names.index(name)]


@dataclass
class AudioChunk:
    """PCM16 little-endian mono samples `pcm` starting at sample `first`."""
    id: str
    stream: int
    first: int
    time: float
    sample_rate: int
    pcm: bytes = field(repr=False)
    type: str = "audio"

    @property
    def count(self) -> int:
        return len(self.pcm) // 2


@dataclass
class JpegFrame:
    """A server-rendered frame (output "frames")."""
    id: str
    stream: int
    index: int
    time: float
    jpeg: bytes = field(repr=False)
    type: str = "jpeg"


def parse_text(data: str) -> Event:
    """A typed event for one JSON text message (ServerError is returned, not raised)."""
    try:
        raw = json.loads(data)
    except ValueError as e:
        raise ProtocolError(f"text message is not JSON: {e}") from None
    if not isinstance(raw, dict) or not isinstance(raw.get("type"), str):
        raise ProtocolError(f"text message without a type: {data[:80]!r}")
    kind = raw["type"]
    try:
        if kind == "stream_start":
            names, extra, audio = raw.get("names") or [], raw.get("extra") or [], raw.get("audio")
            if not all(isinstance(n, str) for n in names + extra):
                raise ValueError("names must be strings")
            if not float(raw["fps"]) > 0 or not (audio is None or isinstance(audio, dict)):
                raise ValueError("bad fps or audio")
            frames = None if raw.get("frames") is None else int(raw["frames"])
            return StreamStart(kind, raw, str(raw["id"]), int(raw["stream"]), float(raw["fps"]),
                               frames, list(names), list(extra), audio)
        if kind == "stream_end":
            stream = None if raw.get("stream") is None else int(raw["stream"])
            return StreamEnd(kind, raw, str(raw["id"]), stream, int(raw["frames"]),
                             int(raw.get("dropped", 0)), bool(raw.get("cancelled", False)))
    except (KeyError, TypeError, ValueError, OverflowError) as e:
        raise ProtocolError(f"{kind}: malformed ({e}): {data[:120]!r}") from None
    return Event(kind, raw)


def server_error(raw: Dict[str, Any]) -> ServerError:
    return ServerError(str(raw.get("code", "unknown")), str(raw.get("message", "")), raw.get("id"))


def parse_header(data: bytes) -> Tuple[int, int, int, int, float]:
    """(kind, stream, first, count, pts) of a binary message; ProtocolError when malformed."""
    if len(data) < HEADER_SIZE:
        raise ProtocolError(f"binary message of {len(data)} bytes, shorter than the "
                            f"{HEADER_SIZE}-byte header")
    kind, version, _, stream, first, count, pts = HEADER.unpack_from(data)
    if kind not in (KIND_WEIGHTS, KIND_AUDIO, KIND_JPEG):
        raise ProtocolError(f"binary message: unknown kind {kind}")
    if version != VERSION:
        raise ProtocolError(f"binary message: unknown version {version}")
    if not math.isfinite(pts) or pts < 0:
        raise ProtocolError(f"binary message: bad pts {pts}")
    return kind, stream, first, count, pts


def parse_binary(data: bytes, streams: Dict[int, StreamStart]) -> List[Any]:
    """The frames or audio chunk of one binary message, checked against its `stream_start`."""
    kind, stream, first, count, pts = parse_header(data)
    start = streams.get(stream)
    if start is None:
        raise ProtocolError(f"binary message for stream {stream} without its stream_start")
    payload = memoryview(data)[HEADER_SIZE:]
    if kind == KIND_WEIGHTS:
        width = len(start.names) + len(start.extra)
        if count == 0 or width == 0 or len(payload) != count * width * 4:
            raise ProtocolError(f"weights message: {len(payload)} payload bytes for {count} "
                                f"frames of {width} float32 values")
        values = struct.unpack(f"<{count * width}f", payload)
        return [WeightsFrame(start.id, stream, first + k, pts + k / start.fps, start.names,
                             start.extra, values[k * width:(k + 1) * width]) for k in range(count)]
    if kind == KIND_AUDIO:
        rate = (start.audio or {}).get("sample_rate")
        if not isinstance(rate, int) or rate <= 0:
            raise ProtocolError(f"audio message for stream {stream}, which announced no audio")
        if len(payload) != count * 2:
            raise ProtocolError(f"audio message: {len(payload)} payload bytes for {count} samples")
        return [AudioChunk(start.id, stream, first, pts, rate, bytes(payload))]
    if count != 1 or not payload:
        raise ProtocolError(f"JPEG message: count {count}, {len(payload)} payload bytes")
    return [JpegFrame(start.id, stream, first, pts, bytes(payload))]
