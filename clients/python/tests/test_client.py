"""facecast_client against a real `facecast serve` ($FACECAST_EXE) on a free port."""
from __future__ import annotations

import csv
import json
import os
import random
import signal
import struct
import subprocess
import sys
import tempfile
import time
import unittest
import urllib.request
from typing import Dict, Optional

import websockets

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
import facecast_client as fc  # noqa: E402

KEY = "test-admin-key-0123456789"
PRODUCER = "producer-secret-1"
TEXT = "Hello, papa. Open wide."
server: Dict[str, object] = {}


def setUpModule() -> None:
    exe = os.environ.get("FACECAST_EXE")
    if not exe:
        raise unittest.SkipTest("FACECAST_EXE is not set (the facecast binary)")
    tmp = tempfile.TemporaryDirectory(prefix="facecast-pyclient-")
    config = os.path.join(tmp.name, "server.json")
    with open(config, "w") as f:
        json.dump({"channel_idle": 0, "channels": {"show": {"producer_token": PRODUCER}}}, f)
    out, err = (open(os.path.join(tmp.name, n), "w+") for n in ("serve.out", "serve.err"))
    proc = subprocess.Popen([exe, "serve", "--config", config, "--port", "0", "--token", KEY,
                             "--data", os.path.join(tmp.name, "data"), "--log-level", "warn"],
                            stdout=out, stderr=err, stdin=subprocess.DEVNULL)
    server.update(tmp=tmp, proc=proc, files=(out, err))
    prefix = "facecast: listening on http://"
    deadline = time.monotonic() + 30
    while time.monotonic() < deadline and proc.poll() is None:
        out.seek(0)
        lines = [line for line in out.read().splitlines() if line.startswith(prefix)]
        if lines:
            server["http"] = "http://" + lines[0][len(prefix):].strip()
            server["url"] = server["http"].replace("http://", "ws://") + "/ws"
            break
        time.sleep(0.05)
    while "http" in server and time.monotonic() < deadline:  # rigs loaded: /readyz is 200
        try:
            with urllib.request.urlopen(f"{server['http']}/readyz", timeout=5) as r:
                if r.status == 200:
                    return
        except OSError:
            time.sleep(0.1)
    err.seek(0)
    tearDownModule()
    raise RuntimeError(f"facecast serve did not start: {err.read()[-2000:]}")


def tearDownModule() -> None:
    proc: Optional[subprocess.Popen] = server.get("proc")  # type: ignore[assignment]
    if proc is not None and proc.poll() is None:
        proc.send_signal(signal.SIGINT)  # closes every socket at once (SIGTERM would drain)
        try:
            proc.wait(10)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
    for f in server.get("files", ()):  # type: ignore[attr-defined]
        f.close()
    if "tmp" in server:
        server["tmp"].cleanup()  # type: ignore[attr-defined]
    server.clear()


def viewer_token(channel: str) -> str:
    """A short-lived viewer token (POST /api/tokens) that may only subscribe to `channel`."""
    body = json.dumps({"scope": "channels:subscribe", "channel": channel}).encode()
    req = urllib.request.Request(f"{server['http']}/api/tokens", data=body, method="POST",
                                 headers={"Authorization": f"Bearer {KEY}",
                                          "Content-Type": "application/json"})
    with urllib.request.urlopen(req, timeout=10) as r:
        return json.load(r)["token"]


async def first(client: fc.Client, type_: str) -> object:
    """The next item of `type_` (others skipped)."""
    async for item in client:
        if item.type == type_:
            return item
    raise AssertionError(f"closed before a {type_} message")


class ServerTest(unittest.IsolatedAsyncioTestCase):
    async def connect(self, key: Optional[str] = KEY, via: str = "header") -> fc.Client:
        client = await fc.connect(server["url"], key, via=via, timeout=20)  # type: ignore[arg-type]
        self.addAsyncCleanup(client.close)
        return client

    def check_contiguous(self, result: fc.Utterance) -> None:
        indices = [f.index for f in result.frames]
        self.assertEqual(indices, list(range(len(indices))))
        self.assertEqual(result.end.frames, len(indices))
        self.assertEqual(result.end.dropped, 0)

    async def test_speak_frames(self) -> None:
        client = await self.connect()
        self.assertEqual(client.hello["protocol"], "facecast.v1")
        id = await client.speak(TEXT, fps=60, rig="default")
        result = await client.collect(id)
        self.assertEqual(result.start.fps, 60)
        self.assertEqual(len(result.frames), result.start.frames)
        self.check_contiguous(result)
        self.assertFalse(result.end.cancelled)
        frame = result.frames[10]
        self.assertEqual(frame.names, result.names)
        self.assertEqual(len(frame.values), len(frame.names) + len(frame.extra))
        self.assertAlmostEqual(frame.time, 10 / 60, places=6)
        jaw = [f["jawOpen"] for f in result.frames]
        peak = max(range(len(jaw)), key=jaw.__getitem__)
        self.assertGreater(jaw[peak], 0.3)  # opens...
        self.assertLess(min(jaw[peak:]), 0.05)  # ...and closes
        self.assertLess(jaw[-1], 0.05)
        self.assertEqual(sum(c.count for c in result.audio), result.start.audio["samples"])
        self.assertEqual([c.first for c in result.audio],
                         [sum(c.count for c in result.audio[:i]) for i in range(len(result.audio))])

    async def test_aligned_audio(self) -> None:
        # Speech from the server itself (speak with audio), streamed back in as live audio with its
        # words' text beside it: an aligned stream.
        client = await self.connect()
        spoken = await client.collect(await client.speak("Bring me the maps.", fps=30))
        pcm = b"".join(c.pcm for c in spoken.audio)
        rate = spoken.start.audio["sample_rate"]
        step = rate // 10 * 2  # 100 ms of PCM16
        for i, at in enumerate(range(0, len(pcm), step)):
            await client.send_audio(pcm[at:at + step], rate, at // 2, aligned=at == 0)
            if i == 0:
                await client.audio_text("Bring me the maps.", final=True)
        await client.send_audio(b"", rate, len(pcm) // 2, last=True)
        result = await client.collect("audio-")
        self.assertTrue(result.start.id.startswith("audio-"))
        self.check_contiguous(result)
        self.assertEqual(len(result.frames), int(len(pcm) // 2 / rate * 60) + 1)
        self.assertGreater(max(f["jawOpen"] for f in result.frames), 0.1)
        self.assertEqual([e for e in result.others if e.type == "error"], [])

    async def test_incremental_text(self) -> None:
        client = await self.connect(via="subprotocol")
        id = await client.speak("Good evening.", more=True, fps=30)
        await client.append(id, " Welcome home.")
        await client.end(id)
        result = await client.collect(id)
        self.assertTrue(result.start.raw["open"])
        self.assertIsNone(result.start.frames)
        self.assertIn("segment", [e.type for e in result.others])
        self.check_contiguous(result)
        self.assertGreater(len(result.frames), 30)

    async def test_channel(self) -> None:
        viewer = await self.connect(viewer_token("show"), via="subprotocol")
        subscribed = await viewer.subscribe("show")
        self.assertGreaterEqual(subscribed.raw["subscribers"], 1)
        producer = await self.connect(via="message")
        with self.assertRaises(fc.ServerError) as caught:
            await producer.produce("show", "wrong-token-123")
        self.assertEqual(caught.exception.code, "unauthorized")
        with self.assertRaises(fc.ServerError) as caught:
            await producer.speak("Hi.", channel="show")
            await first(producer, "never")
        self.assertEqual(caught.exception.code, "forbidden")
        self.assertEqual((await producer.produce("show", PRODUCER)).type, "producing")
        await producer.speak("Hello, papa.", id="c1", channel="show")
        result = await viewer.collect("c1")
        self.check_contiguous(result)
        self.assertGreater(len(result.frames), 10)
        self.assertEqual((await viewer.unsubscribe("show")).type, "unsubscribed")
        with self.assertRaises(fc.ServerError) as caught:
            await viewer.subscribe("other")  # the viewer token names "show" only
        self.assertEqual(caught.exception.code, "forbidden")
        with self.assertRaises(fc.ServerError) as caught:
            await producer.subscribe("no-such-channel")
        self.assertEqual(caught.exception.code, "not_found")

    async def test_cancel(self) -> None:
        client = await self.connect()
        id = await client.speak("This sentence is long enough to be cancelled well before it "
                                "ends, which takes some seconds.", fps=30)
        start = await first(client, "stream_start")
        await first(client, "weights")
        await client.cancel(id)
        result = await client.collect(id)
        self.assertTrue(result.end.cancelled)
        self.assertLess(result.end.frames, start.frames)
        with self.assertRaises(fc.ServerError) as caught:
            await client.cancel("not-playing")
            await first(client, "never")
        self.assertEqual((caught.exception.code, caught.exception.id), ("not_found", "not-playing"))

    async def test_error(self) -> None:
        client = await self.connect()
        id = await client.speak("Hello.", rig="no-such-rig")
        with self.assertRaises(fc.ServerError) as caught:
            await client.collect(id)
        self.assertEqual((caught.exception.code, caught.exception.id), ("not_found", id))
        self.assertIn("no-such-rig", caught.exception.message)
        self.assertEqual((await client.ping(1.5)).raw["t"], 1.5)  # the connection stays open

    async def test_refused_without_key(self) -> None:
        with self.assertRaisesRegex(fc.FacecastError, "HTTP 401"):
            await fc.connect(server["url"], timeout=10)  # type: ignore[arg-type]


class MalformedTest(unittest.IsolatedAsyncioTestCase):
    """Bad binary messages raise ProtocolError at once; iteration goes on after them."""

    def test_parse(self) -> None:
        start = fc.StreamStart("stream_start", {}, "u1", 7, 60.0, 2, ["a", "b"], ["x"], None)
        good = struct.pack("<BBHIIId", 1, 1, 0, 7, 5, 2, 0.5) + struct.pack("<6f", *range(6))
        frames = fc.parse_binary(good, {7: start})
        self.assertEqual([(f.index, f.values, f["x"]) for f in frames],
                         [(5, (0, 1, 2), 2), (6, (3, 4, 5), 5)])
        self.assertAlmostEqual(frames[1].time, 0.5 + 1 / 60)
        bad = {"short": good[:23], "kind": b"\x09" + good[1:], "version": good[:1] + b"\x02" +
               good[2:], "payload": good[:-1], "stream": good[:4] + b"\x08" + good[5:],
               "count": good[:12] + struct.pack("<I", 0xFFFFFFFF) + good[16:],
               "audio": b"\x02" + good[1:]}
        for name, data in bad.items():
            with self.subTest(name), self.assertRaises(fc.ProtocolError):
                fc.parse_binary(data, {7: start})
        rng = random.Random(35)  # random corruptions: frames or ProtocolError, nothing else
        for _ in range(3000):
            data = bytearray(good[:rng.randrange(len(good) + 8)])
            for _ in range(rng.randrange(4)):
                if data:
                    data[rng.randrange(len(data))] = rng.randrange(256)
            try:
                fc.parse_binary(bytes(data), {7: start})
            except fc.ProtocolError:
                pass
        for text in ["[]", "{}", '{"type": "stream_start", "stream": "x"}',
                     '{"type": "stream_start", "id": "a", "stream": 1, "fps": 0}',
                     '{"type": "stream_end", "id": "a", "stream": [], "frames": 1}']:
            with self.subTest(text), self.assertRaises(fc.ProtocolError):
                fc.messages.parse_text(text)

    async def test_stream(self) -> None:
        async def serve(ws: websockets.WebSocketServerProtocol, _path: str = "") -> None:
            await ws.send(json.dumps({"type": "hello", "protocol": "facecast.v1"}))
            await ws.send(b"\x01\x01")
            await ws.send("not json")
            await ws.send(json.dumps({"type": "pong", "t": None}))
            await ws.wait_closed()

        async with websockets.serve(serve, "127.0.0.1", 0) as ws_server:
            port = ws_server.sockets[0].getsockname()[1]
            client = await fc.connect(f"ws://127.0.0.1:{port}/ws", timeout=5)
            async with client:
                with self.assertRaisesRegex(fc.ProtocolError, "2 bytes, shorter than"):
                    await client.receive()
                with self.assertRaisesRegex(fc.ProtocolError, "not JSON"):
                    await client.receive()
                self.assertEqual((await client.receive()).type, "pong")
                with self.assertRaises(fc.FacecastTimeout):
                    await client.receive(timeout=0.2)


class CommandTest(unittest.TestCase):
    def run_command(self, *args: str) -> subprocess.CompletedProcess:
        env = dict(os.environ, PYTHONPATH=os.pathsep.join(
            [os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")] +
            [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p]))
        return subprocess.run([sys.executable, "-m", "facecast_client", "--url", server["url"],
                               "--key", KEY, *args], env=env, capture_output=True, text=True,
                              timeout=60)  # type: ignore[list-item]

    def test_json_and_csv(self) -> None:
        with tempfile.TemporaryDirectory() as tmp:
            out = os.path.join(tmp, "weights.json")
            r = self.run_command("--text", TEXT, "--out", out, "--fps", "30", "--rig", "default")
            self.assertEqual(r.returncode, 0, r.stderr)
            self.assertEqual(len(r.stderr.strip().splitlines()), 1, r.stderr)
            with open(out) as f:
                data = json.load(f)
            self.assertEqual(data["fps"], 30)
            self.assertEqual(data["frames"], len(data["weights"]))
            self.assertGreater(max(row[data["shapes"].index("jawOpen")] for row in data["weights"]),
                               0.3)
            self.assertTrue(all(len(row) == len(data["shapes"]) for row in data["weights"]))
            out = os.path.join(tmp, "weights.csv")
            r = self.run_command("--text", "Hello.", "--out", out)
            self.assertEqual(r.returncode, 0, r.stderr)
            with open(out, newline="") as f:
                rows = list(csv.reader(f))
            self.assertEqual(rows[0][:2], ["time", data["shapes"][0]])
            self.assertEqual(len(rows[0]), len(data["shapes"]) + 1)
            self.assertAlmostEqual(float(rows[2][0]), 1 / 60, places=5)
            self.assertIn(f"{len(rows) - 1} frames at 60 fps", r.stderr)

    def test_failure(self) -> None:
        r = self.run_command("--text", "Hi.", "--out", os.path.join(tempfile.gettempdir(),
                                                                     "never.json"),
                             "--rig", "no-such-rig")
        self.assertEqual(r.returncode, 1)
        self.assertEqual(r.stderr.strip().splitlines(),
                         ["facecast_client: error: not_found: rig 'no-such-rig' does not exist"])


if __name__ == "__main__":
    unittest.main()
