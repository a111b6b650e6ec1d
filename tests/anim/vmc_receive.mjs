// An independent VMC receiver (the npm `osc` package): runs `facecast animate --vmc` against a UDP
// port of its own and checks what arrives -- one OSC bundle per frame in real time, every shape
// then Apply, the head and neck bones, OK, and a jaw that opens and closes.
// Usage: node vmc_receive.mjs FACECAST NAMES(perfect-sync|vrm0|vrm1) JAW_SHAPE
import { spawn } from "node:child_process";
import osc from "osc";

const [facecast, names, jaw] = process.argv.slice(2);
const fps = 30;
const bundles = [];
const port = new osc.UDPPort({ localAddress: "127.0.0.1", localPort: 0, metadata: true });
port.on("bundle", (b) => bundles.push({ at: performance.now() / 1000, packets: b.packets }));
port.on("error", (e) => { console.error("osc error:", e.message); process.exit(1); });
port.on("ready", () => {
  const target = `127.0.0.1:${port.socket.address().port}`;
  const child = spawn(facecast, ["animate", "--text", "Hello, papa. Open wide.", "--idle", "off",
                                 "--fps", String(fps), "--vmc", target, "--vmc-names", names],
                      { stdio: ["ignore", "inherit", "inherit"] });
  child.on("exit", (code) => setTimeout(() => check(code), 300));
});
port.open();

function fail(why) { console.error("FAIL:", why); process.exit(1); }

function check(code) {
  port.close();
  if (code !== 0) fail(`facecast exited ${code}`);
  if (bundles.length < 20) fail(`only ${bundles.length} bundles`);
  const jawValues = [];
  for (const b of bundles) {
    const addresses = b.packets.map((p) => p.address);
    const vals = b.packets.filter((p) => p.address === "/VMC/Ext/Blend/Val");
    const apply = addresses.indexOf("/VMC/Ext/Blend/Apply");
    if (apply < 0 || apply !== vals.length) fail("Apply must follow every Blend/Val");
    if (names === "perfect-sync" && vals.length !== 52) fail(`${vals.length} shapes, not 52`);
    const bones = b.packets.filter((p) => p.address === "/VMC/Ext/Bone/Pos").map((p) => p.args[0].value);
    if (!bones.includes("Head") || !bones.includes("Neck")) fail("no Head/Neck bone");
    if (!addresses.includes("/VMC/Ext/OK")) fail("no /VMC/Ext/OK");
    const j = vals.find((p) => p.args[0].value === jaw);
    if (!j) fail(`no ${jaw} in the bundle: ${vals.map((p) => p.args[0].value).join(" ")}`);
    jawValues.push(j.args[1].value);
  }
  const peak = Math.max(...jawValues);
  if (!(peak > 0.2)) fail(`${jaw} never opens: ${peak}`);
  if (!(jawValues[jawValues.length - 1] < 0.05)) fail(`${jaw} does not close at the end`);
  // Real time: the bundles span the utterance at the frame rate (not sent in a burst).
  const span = bundles[bundles.length - 1].at - bundles[0].at;
  const expected = (bundles.length - 1) / fps;
  if (span < 0.85 * expected || span > 1.5 * expected + 1)
    fail(`${bundles.length} bundles over ${span.toFixed(2)} s, expected ${expected.toFixed(2)} s`);
  console.log(`ok: ${bundles.length} bundles over ${span.toFixed(2)} s, ${jaw} peak ${peak.toFixed(2)}`);
}
