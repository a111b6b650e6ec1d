"""An asyncio client of the facecast.v1 WebSocket protocol (docs/protocol.md)."""
from __future__ import annotations

import asyncio
import itertools
import json
import struct
from collections import OrderedDict
from dataclasses import dataclass, field
from typing import Any, Callable, Dict, List, Optional, Tuple, Union

import websockets
from websockets.exceptions import ConnectionClosed, InvalidHandshake, InvalidStatusCode

from .messages import (AudioChunk, Event, FacecastError, JpegFrame, ProtocolError, ServerError,
                       StreamEnd, StreamStart, WeightsFrame, parse_binary, parse_text,
                       server_error)

Item = Union[Event, WeightsFrame, AudioChunk, JpegFrame]
MAX_MESSAGE = 16 << 20  # bytes of one server message (JPEG frames are the largest)
MAX_STREAMS = 256  # stream_starts remembered (a stream whose end never came is forgotten)


class FacecastTimeout(FacecastError, TimeoutError):
    """Nothing (or not the awaited answer) came from the server in time."""


@dataclass
class Utterance:
    """Everything one utterance's stream delivered (see Client.collect)."""
    start: Optional[StreamStart] = None
    end: Optional[StreamEnd] = None
    frames: List[WeightsFrame] = field(default_factory=list)
    audio: List[AudioChunk] = field(default_factory=list)
    images: List[JpegFrame] = field(default_factory=list)
    others: List[Event] = field(default_factory=list)  # other messages read meanwhile

    @property
    def names(self) -> List[str]:
        return self.start.names if self.start else []

    @property
    def fps(self) -> float:
        return self.start.fps if self.start else 0.0

    def pcm(self) -> bytes:
        """The speech audio as one PCM16 little-endian mono buffer."""
        return b"".join(chunk.pcm for chunk in self.audio)


class Closed(FacecastError):
    """The connection is closed: `code` is the WebSocket close code (1006: no close frame)."""

    def __init__(self, code: int, reason: str, failure: Optional[BaseException] = None) -> None:
        super().__init__(f"connection closed: {code} {reason}".strip()
                         + (f" ({failure!r})" if failure else ""))
        self.code, self.reason = code, reason
        self.normal = code in (1000, 1001) and failure is None


class Client:
    """One connection. Iterate it (`async for item in client`) for typed messages in arrival
    order; an `error` message raises ServerError, a malformed one ProtocolError (iteration may
    go on after either). Use `connect()` to make one."""

    def __init__(self, ws: Any, timeout: Optional[float]) -> None:
        self.timeout = timeout  # seconds to wait for any message (None: forever)
        self.hello: Dict[str, Any] = {}
        self._ws = ws
        self._queue: asyncio.Queue = asyncio.Queue()
        self._streams: "OrderedDict[int, StreamStart]" = OrderedDict()
        self._waiting: List[Tuple[Callable[[Event], bool], asyncio.Future]] = []
        self._ids = itertools.count(1)
        self._reader = asyncio.ensure_future(self._read())

    # ---- receiving ------------------------------------------------------------------------

    async def _read(self) -> None:
        failure: Optional[BaseException] = None
        try:
            while True:
                message = await self._ws.recv()
                try:
                    items = self._decode(message)
                except ProtocolError as e:
                    # No traceback: clearing its frames (unittest does) would close this task.
                    items = [e.with_traceback(None)]
                except Exception as e:  # noqa: BLE001 -- whatever a message holds, go on
                    items = [ProtocolError(f"cannot decode a message: {e!r}")]
                for item in items:
                    if not self._answer(item):
                        self._queue.put_nowait(item)
        except ConnectionClosed:
            pass
        except Exception as e:  # noqa: BLE001 -- a bug here must not leave readers waiting
            failure = e
        closed = Closed(self._ws.close_code or 1006, self._ws.close_reason or "", failure)
        for _, future in self._waiting:
            if not future.done():
                future.set_exception(closed)
        self._queue.put_nowait(closed)

    def _decode(self, message: Union[str, bytes]) -> List[Any]:
        if isinstance(message, bytes):
            return parse_binary(message, self._streams)
        event = parse_text(message)
        if event.type == "error":
            return [server_error(event.raw)]
        if isinstance(event, StreamStart):
            self._streams[event.stream] = event
            while len(self._streams) > MAX_STREAMS:
                self._streams.popitem(last=False)
        elif isinstance(event, StreamEnd) and event.stream is not None:
            self._streams.pop(event.stream, None)
        return [event]

    def _answer(self, item: Any) -> bool:
        """Hands a reply (or an error without id) to a request waiting for it."""
        for i, (matches, future) in enumerate(self._waiting):
            if future.done():
                continue
            if isinstance(item, ServerError) and item.id is None:
                future.set_exception(item)
            elif isinstance(item, Event) and matches(item):
                future.set_result(item)
            else:
                continue
            del self._waiting[i]
            return True
        return False

    async def receive(self, timeout: Optional[float] = -1.0) -> Item:
        """The next message (timeout -1: the client's). Raises ServerError for an `error`
        message, ProtocolError for a malformed one, Closed once closed."""
        wait = self.timeout if timeout is not None and timeout < 0 else timeout
        try:
            item = await asyncio.wait_for(self._queue.get(), wait)
        except asyncio.TimeoutError:
            raise FacecastTimeout(f"no message from the server within {wait} s") from None
        if isinstance(item, Closed):
            self._queue.put_nowait(item)  # every later call sees it too
        if isinstance(item, Exception):
            raise item.with_traceback(None)  # the receiver's frames only
        return item

    def __aiter__(self) -> "Client":
        return self

    async def __anext__(self) -> Item:
        try:
            return await self.receive()
        except Closed as e:
            if e.normal:
                raise StopAsyncIteration from None
            raise

    async def collect(self, id: str, timeout: Optional[float] = -1.0) -> Utterance:
        """Reads until the `stream_end` of utterance `id`; raises its error (other messages go
        to `others`, media of other streams are dropped). id "audio-" collects the next live
        audio stream (its id is "audio-<stream>")."""
        result, stream = Utterance(), None
        while True:
            try:
                item = await self.receive(timeout)
            except ServerError as e:
                if e.id == id:
                    raise
                continue
            if isinstance(item, StreamStart) and stream is None and (
                    item.id == id or (id == "audio-" and item.id.startswith("audio-"))):
                id = item.id
                result.start, stream = item, item.stream
            elif isinstance(item, StreamEnd) and item.id == id:
                result.end = item
                return result
            elif isinstance(item, Event):
                result.others.append(item)
            elif item.stream != stream:
                continue
            elif isinstance(item, WeightsFrame):
                result.frames.append(item)
            elif isinstance(item, AudioChunk):
                result.audio.append(item)
            else:
                result.images.append(item)

    # ---- sending --------------------------------------------------------------------------

    async def send(self, message: Dict[str, Any]) -> None:
        """Sends one JSON message as it is (fields that are None are left out)."""
        try:
            await self._ws.send(json.dumps({k: v for k, v in message.items() if v is not None}))
        except ConnectionClosed as e:
            raise FacecastError(f"send {message.get('type')}: connection closed ({e})") from None

    async def _request(self, message: Dict[str, Any], reply: str) -> Event:
        """Sends and waits for the answer of type `reply` (or an error without id)."""
        key = message.get("channel")
        future: asyncio.Future = asyncio.get_running_loop().create_future()
        matches = lambda e: e.type == reply and e.raw.get("channel") == key  # noqa: E731
        self._waiting.append((matches, future))
        await self.send(message)
        try:
            return await asyncio.wait_for(future, self.timeout)
        except asyncio.TimeoutError:
            raise FacecastTimeout(f"{message['type']}: no answer within {self.timeout} s") from None
        finally:
            self._waiting = [w for w in self._waiting if w[1] is not future]

    async def speak(self, text: Optional[str] = None, *, id: Optional[str] = None,
                    channel: Optional[str] = None, more: Optional[bool] = None,
                    **options: Any) -> str:
        """Queues an utterance and returns its id. `options` are speak fields as they are:
        timestamps, rig, fps, audio, lang, voice, rate, idle, timing, output, size, audio_id."""
        id = id or f"u{next(self._ids)}"
        await self.send({"type": "speak", "id": id, "text": text, "channel": channel,
                         "more": more, **options})
        return id

    async def append(self, id: str, text: str, *, channel: Optional[str] = None) -> None:
        """Adds text to an open utterance (speak with more=True)."""
        await self.send({"type": "append", "id": id, "text": text, "channel": channel})

    async def end(self, id: str, *, channel: Optional[str] = None) -> None:
        """Closes an open utterance: the rest of its text is spoken, then its stream ends."""
        await self.send({"type": "end", "id": id, "channel": channel})

    async def cancel(self, id: str, *, channel: Optional[str] = None) -> None:
        """Stops an utterance (it fades to rest, then stream_end has cancelled: true)."""
        await self.send({"type": "cancel", "id": id, "channel": channel})

    async def send_audio(self, pcm: bytes, sample_rate: int, first: int, *, last: bool = False,
                         aligned: bool = False) -> None:
        """One live audio chunk (docs/protocol.md, "Live audio in"): `pcm` is PCM16 little-endian
        mono at `sample_rate`, `first` the index of its first sample in the stream (0 opens a
        stream; `aligned`: its text comes by audio_text); `last` ends the stream. The weights come
        back as a stream with id "audio-<stream>" (collect("audio-"))."""
        flags = (1 if last else 0) | (2 if aligned else 0)
        header = struct.pack("<BBHIIId", 4, 1, flags, sample_rate, first, len(pcm) // 2, 0.0)
        try:
            await self._ws.send(header + pcm)
        except ConnectionClosed as e:
            raise FacecastError(f"send audio: connection closed ({e})") from None

    async def audio_text(self, text: str, *, start: Optional[float] = None,
                         end: Optional[float] = None, final: Optional[bool] = None) -> None:
        """More text of the open aligned audio stream: as it comes (English, aligned by the
        server), or with its time in the stream (start, end: seconds; any language)."""
        await self.send({"type": "audio_text", "text": text, "start": start, "end": end,
                         "final": final})

    async def expression(self, tags: str) -> None:
        """Expression tags over the open live audio stream ("(smile,40,0.5)")."""
        await self.send({"type": "expression", "tags": tags})

    async def subscribe(self, channel: str) -> Event:
        """Watches a channel; returns the `subscribed` answer (raw: subscribers, playing)."""
        return await self._request({"type": "subscribe", "channel": channel}, "subscribed")

    async def unsubscribe(self, channel: str) -> Event:
        return await self._request({"type": "unsubscribe", "channel": channel}, "unsubscribed")

    async def produce(self, channel: str, token: str) -> Event:
        """Becomes a producer of a channel (then speak(..., channel=...) plays on it)."""
        return await self._request({"type": "produce", "channel": channel, "token": token},
                                   "producing")

    async def ping(self, t: Optional[float] = None) -> Event:
        return await self._request({"type": "ping", "t": t}, "pong")

    async def close(self) -> None:
        await self._ws.close()
        try:
            await asyncio.wait_for(self._reader, 5)
        except (asyncio.TimeoutError, asyncio.CancelledError):
            self._reader.cancel()

    async def __aenter__(self) -> "Client":
        return self

    async def __aexit__(self, *exc: Any) -> None:
        await self.close()


async def connect(url: str, key: Optional[str] = None, *, via: str = "header",
                  timeout: Optional[float] = 30.0) -> Client:
    """Opens ws://HOST:PORT/ws and waits for `hello` (Client.hello). `key` is an API key or a
    viewer token, passed `via` "header" (Authorization: Bearer), "subprotocol"
    (facecast.token.K) or "message" (a first {"type": "auth"} message)."""
    protocols, headers = ["facecast.v1"], {}
    if key and via == "header":
        headers["Authorization"] = f"Bearer {key}"
    elif key and via == "subprotocol":
        protocols.append(f"facecast.token.{key}")
    elif key and via == "message":
        protocols.append("facecast.token")
    elif key:
        raise ValueError(f"via must be header, subprotocol or message, not {via!r}")
    try:
        ws = await websockets.connect(url, subprotocols=protocols, extra_headers=headers,
                                      open_timeout=timeout, close_timeout=5,
                                      max_size=MAX_MESSAGE)
    except InvalidStatusCode as e:
        raise FacecastError(f"{url}: the server refused the connection (HTTP {e.status_code})")
    except (OSError, InvalidHandshake, asyncio.TimeoutError) as e:
        raise FacecastError(f"{url}: cannot connect ({e or type(e).__name__})") from None
    client = Client(ws, timeout)
    try:
        if key and via == "message":
            await client.send({"type": "auth", "token": key})
        hello = await client.receive()
        if not isinstance(hello, Event) or hello.type != "hello":
            raise ProtocolError(f"expected hello, got {getattr(hello, 'type', hello)!r}")
        client.hello = hello.raw
    except BaseException:
        await client.close()
        raise
    return client
