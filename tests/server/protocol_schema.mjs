// docs/protocol.schema.json (JSON Schema 2020-12, compiled strictly by npm ajv) against a real
// `facecast serve`: every message this test sends is a valid client message, every JSON message
// the server answers is a valid server message (the schema lists every field: no extras allowed),
// each server message type is seen at least once, and the schema refuses malformed messages.
// Usage: node --experimental-websocket protocol_schema.mjs FACECAST SOURCE_DIR
import { spawn } from "node:child_process";
import { mkdtempSync, readFileSync, rmSync, writeFileSync } from "node:fs";
import { tmpdir } from "node:os";
import { join } from "node:path";
import Ajv2020 from "ajv/dist/2020.js";

const [facecast, src] = process.argv.slice(2);
let cleanup = () => {};
const fail = (why) => {
  console.error(`FAIL: ${why}`);
  cleanup();
  process.exit(1);
};
const schema = JSON.parse(readFileSync(join(src, "docs/protocol.schema.json"), "utf8"));
const ajv = new Ajv2020({ strict: true, allErrors: true });
ajv.addSchema(schema);
const client = ajv.getSchema(`${schema.$id}#/$defs/client_message`);
const server = ajv.getSchema(`${schema.$id}#/$defs/server_message`);
const explain = (v) => ajv.errorsText(v.errors?.slice(0, 3));

// The schema is not vacuous.
for (const bad of [{ type: "speak", text: "no id" }, { type: "subscribe" }, { type: "nope" },
                   { type: "ping", extra: 1 }])
  if (client(bad)) fail(`the schema takes ${JSON.stringify(bad)}`);
if (server({ type: "error", id: null, code: "oops", message: "x" })) fail("unknown error code taken");

const dir = mkdtempSync(join(tmpdir(), "facecast-schema-"));
writeFileSync(join(dir, "server.json"), JSON.stringify({
  channel_idle: 0, presence_interval: 0.1,
  channels: { show: { producer_token: "producer-secret-1" } },
}));
const proc = spawn(facecast, ["serve", "--port", "0", "--data", join(dir, "data"), "--config",
                              join(dir, "server.json")], { stdio: ["ignore", "pipe", "pipe"] });
let log = "";
proc.stderr.on("data", (d) => (log += d));
const url = await new Promise((resolve, reject) => {
  let out = "";
  proc.stdout.on("data", (d) => {
    out += d;
    const m = out.match(/listening on (http:\/\/\S+)/);
    if (m) resolve(m[1].replace("http:", "ws:") + "/ws");
  });
  proc.on("exit", (code) => reject(new Error(`serve exited ${code}: ${log}`)));
  proc.on("error", (e) => reject(e));
  setTimeout(() => reject(new Error(`serve did not start: ${log}`)), 30000);
});
cleanup = () => {
  proc.kill("SIGKILL");
  rmSync(dir, { recursive: true, force: true });
};

const seen = new Set();
function open() {
  const ws = new WebSocket(url, ["facecast.v1"]);
  const inbox = [];
  let wake = null;
  ws.binaryType = "arraybuffer";
  ws.addEventListener("message", (e) => {
    if (typeof e.data !== "string") return;  // binary: the header, docs/protocol.md
    const m = JSON.parse(e.data);
    if (!server(m)) fail(`server message not in the schema: ${e.data.slice(0, 300)}: ${explain(server)}`);
    seen.add(m.type);
    inbox.push(m);
    wake?.();
  });
  const send = (m) => {
    if (!client(m)) fail(`client message not in the schema: ${JSON.stringify(m)}: ${explain(client)}`);
    ws.send(JSON.stringify(m));
  };
  // The next message matching `ok`, within 30 s.
  const next = async (ok) => {
    const deadline = Date.now() + 30000;
    for (;;) {
      const i = inbox.findIndex(ok);
      if (i >= 0) return inbox.splice(i, 1)[0];
      if (Date.now() > deadline) fail(`timeout; got ${inbox.map((m) => m.type).join(" ")}`);
      await new Promise((r) => { wake = r; setTimeout(r, 200); });
    }
  };
  return new Promise((resolve) => ws.addEventListener("open", () => resolve({ ws, send, next })));
}

try {
  const a = await open();
  await a.next((m) => m.type === "hello");
  a.send({ type: "ping", t: 1 });
  await a.next((m) => m.type === "pong");
  a.send({ type: "speak", id: "u1", text: "(joy, 40, 0.5) Hello there.", fps: 30 });
  await a.next((m) => m.type === "stream_end" && m.id === "u1");
  a.send({ type: "speak", id: "u2", text: "", more: true, audio: false });
  a.send({ type: "append", id: "u2", text: "First a piece. " });
  a.send({ type: "append", id: "u2", text: "Then another one." });
  a.send({ type: "end", id: "u2" });
  await a.next((m) => m.type === "stream_end" && m.id === "u2");
  a.send({ type: "cancel", id: "nothing" });
  await a.next((m) => m.type === "error");
  a.send({ type: "expression", tags: "(joy,40,0.5)" });
  await a.next((m) => m.type === "error");
  a.send({ type: "audio_text", text: "hello ", final: true });
  await a.next((m) => m.type === "error");
  a.send({ type: "subscribe", channel: "show" });
  await a.next((m) => m.type === "subscribed");
  const b = await open();
  await b.next((m) => m.type === "hello");
  b.send({ type: "produce", channel: "show", token: "producer-secret-1" });
  await b.next((m) => m.type === "producing");
  b.send({ type: "speak", id: "c1", channel: "show", text: "On the show.", fps: 30 });
  await a.next((m) => m.type === "stream_end" && m.id === "c1");
  await a.next((m) => m.type === "presence");
  a.send({ type: "unsubscribe", channel: "show" });
  await a.next((m) => m.type === "unsubscribed");
  const want = JSON.parse(JSON.stringify(Object.keys(schema.$defs)))
    .filter((k) => k.startsWith("server_") && k !== "server_message")
    .map((k) => k.slice("server_".length));
  const missing = want.filter((t) => !seen.has(t));
  if (missing.length) fail(`never seen: ${missing.join(" ")}`);
  console.log(`protocol schema: every message valid; server types seen: ${[...seen].sort().join(" ")}`);
  a.ws.close();
  b.ws.close();
} catch (e) {
  fail(`${e.message}\n${log.slice(-2000)}`);
} finally {
  cleanup();
}
process.exit(0);
