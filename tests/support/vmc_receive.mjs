// An independent VMC receiver (the npm `osc` package): binds a UDP port, runs COMMAND with "{port}"
// replaced by it, and checks what arrives -- one OSC bundle per frame in real time (arrival times
// against the bundles' /VMC/Ext/T), every shape then Apply, the head and neck bones, the idle body's
// (Spine, Chest, shoulders; the chest turns as it breathes), OK, and a jaw that opens and closes.
// Usage: [VMC_IDLE=off] node vmc_receive.mjs NAMES(perfect-sync|vrm0|vrm1) JAW_SHAPE -- COMMAND...
import { spawn } from "node:child_process";
import osc from "osc";

const [names, jaw, dashes, ...command] = process.argv.slice(2);
if (dashes !== "--" || command.length === 0) {
  console.error("usage: node vmc_receive.mjs NAMES JAW -- COMMAND...");
  process.exit(2);
}
const bundles = [];
const port = new osc.UDPPort({ localAddress: "127.0.0.1", localPort: 0, metadata: true });
port.on("bundle", (b) => bundles.push({ at: performance.now() / 1000, packets: b.packets }));
port.on("error", (e) => fail(`osc: ${e.message}`));
port.on("ready", () => {
  const p = String(port.socket.address().port);
  const child = spawn(command[0], command.slice(1).map((a) => a.replaceAll("{port}", p)),
                      { stdio: ["ignore", "inherit", "inherit"] });
  child.on("exit", (code) => setTimeout(() => check(code), 300));
});
port.open();

function fail(why) { console.error("FAIL:", why); process.exit(1); }

function check(code) {
  port.close();
  if (code !== 0) fail(`${command[0]} exited ${code}`);
  if (bundles.length < 20) fail(`only ${bundles.length} bundles`);
  const jawValues = [], times = [], chestAngles = [];
  for (const b of bundles) {
    const addresses = b.packets.map((p) => p.address);
    const vals = b.packets.filter((p) => p.address === "/VMC/Ext/Blend/Val");
    const apply = addresses.indexOf("/VMC/Ext/Blend/Apply");
    if (apply < 0 || apply !== vals.length) fail("Apply must follow every Blend/Val");
    if (names === "perfect-sync" && vals.length < 52) fail(`${vals.length} shapes, not 52`);
    const bones = b.packets.filter((p) => p.address === "/VMC/Ext/Bone/Pos").map((p) => p.args[0].value);
    if (!bones.includes("Head") || !bones.includes("Neck")) fail("no Head/Neck bone");
    for (const b of ["Spine", "Chest", "LeftShoulder", "RightShoulder"])
      if (!bones.includes(b)) fail(`no ${b} bone (the idle body)`);
    const chest = b.packets.find((p) => p.address === "/VMC/Ext/Bone/Pos" && p.args[0].value === "Chest");
    chestAngles.push(2 * Math.acos(Math.min(1, Math.abs(chest.args[7].value))));
    if (!addresses.includes("/VMC/Ext/OK")) fail("no /VMC/Ext/OK");
    const t = b.packets.find((p) => p.address === "/VMC/Ext/T");
    if (!t) fail("no /VMC/Ext/T");
    times.push(t.args[0].value);
    const j = vals.find((p) => p.args[0].value === jaw);
    if (!j) fail(`no ${jaw} in the bundle: ${vals.map((p) => p.args[0].value).join(" ")}`);
    jawValues.push(j.args[1].value);
  }
  // The chest breathes (and leans): it turns by a tenth of a degree or more at some point (unless
  // the command ran with --idle off: VMC_IDLE=off).
  const chestPeak = Math.max(...chestAngles) * 180 / Math.PI;
  if (process.env.VMC_IDLE !== "off" && !(chestPeak > 0.1))
    fail(`the Chest bone never turns: ${chestPeak.toFixed(3)} degrees`);
  const peak = Math.max(...jawValues);
  if (!(peak > 0.2)) fail(`${jaw} never opens: ${peak}`);
  if (!(jawValues[jawValues.length - 1] < 0.05)) fail(`${jaw} does not close at the end`);
  // Real time: the bundles arrive spread as their times are (not in a burst, not late).
  const span = bundles[bundles.length - 1].at - bundles[0].at;
  const expected = times[times.length - 1] - times[0];
  if (!(expected > 0.5) || span < 0.85 * expected || span > 1.25 * expected + 0.5)
    fail(`${bundles.length} bundles over ${span.toFixed(2)} s for ${expected.toFixed(2)} s of frames`);
  console.log(`ok: ${bundles.length} bundles over ${span.toFixed(2)} s ` +
              `(${expected.toFixed(2)} s of frames), ${jaw} peak ${peak.toFixed(2)}`);
}
