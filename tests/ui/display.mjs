// Drives the ground display in headless Chromium (Debian's, through playwright-core) while
// `heli hilsim`, `heli vehicle` and `heli ground --http` run as processes (tests/hil/display.rs
// starts them). Each step is checked on the page and photographed into HELI_UI_OUT.
//
//   HELI_UI_URL=http://127.0.0.1:PORT/ HELI_UI_OUT=dir node tests/ui/display.mjs
//
// Exits non-zero, naming the step, when a check fails.
import { chromium } from "playwright-core";
import { mkdirSync } from "node:fs";
import { join } from "node:path";

const url = process.env.HELI_UI_URL;
const out = process.env.HELI_UI_OUT || "ui-artifacts";
const browserPath = process.env.HELI_CHROMIUM || "/usr/bin/chromium";
mkdirSync(out, { recursive: true });

const started = Date.now();
const log = (...a) => console.log(`[${((Date.now() - started) / 1000).toFixed(1)} s]`, ...a);

async function waitFor(what, fn, timeoutMs = 20000) {
  const end = Date.now() + timeoutMs;
  let last;
  while (Date.now() < end) {
    try {
      last = await fn();
      if (last) return last;
    } catch (e) {
      last = e;
    }
    await new Promise((r) => setTimeout(r, 200));
  }
  throw new Error(`timed out waiting for: ${what} (last: ${last})`);
}

async function shot(page, name) {
  await page.screenshot({ path: join(out, `${name}.png`), fullPage: true });
  log("screenshot", name);
}

const text = (page, sel) => page.locator(sel).innerText();
const disabled = (page, sel) => page.locator(sel).isDisabled();
const panel = (page) => page.evaluate(() => document.body.dataset.panel);
const messages = (page) => text(page, "#messages");

async function buttons(page) {
  return [await disabled(page, "#connect"), await disabled(page, "#start"), await disabled(page, "#stop")]
    .map((d) => !d);
}

async function expectButtons(page, want, what) {
  await waitFor(`${what}: buttons ${want}`, async () =>
    JSON.stringify(await buttons(page)) === JSON.stringify(want));
}

async function reply(page, before) {
  return waitFor("a reply", async () => {
    const t = await text(page, "#reply");
    return t && t !== before ? t : null;
  });
}

const browser = await chromium.launch({
  executablePath: browserPath,
  args: ["--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
    "--disable-background-networking", "--disable-component-update", "--disable-sync"],
});
let failed = null;
try {
  const ctx = await browser.newContext({ viewport: { width: 1366, height: 900 } });
  const page = await ctx.newPage();
  page.on("pageerror", (e) => log(`page error: ${e.message}`));
  page.on("console", (m) => {
    if ((m.type() === "error" || m.type() === "warning") && !m.text().includes("GL Driver Message")) log(`page ${m.type()}: ${m.text()}`);
  });
  page.on("pageerror", (e) => { failed = failed || new Error(`page error: ${e.message}`); });
  await page.goto(url);
  await waitFor("the page's WebSocket", async () =>
    (await text(page, "#link-state")).includes("ground station connected"));
  await waitFor("the vehicle's heartbeat", async () =>
    (await text(page, "#vehicle-state")).includes("vehicle: idle"));
  // Before anything: the rows say NOTHING YET, the indicator is red.
  if (!(await text(page, "#row-imu")).includes("NOTHING YET")) throw new Error("IMU row not empty at first");
  if (!(await page.locator("#indicator").getAttribute("class")).includes("red")) throw new Error("indicator not red");
  // A page that does not hold the token cannot command.
  await expectButtons(page, [false, false, false], "watching");
  await page.click("#take-control");
  await waitFor("the token", async () => (await text(page, "#token")).includes("in control: you"));
  await expectButtons(page, [true, false, false], "idle");
  await shot(page, "01-idle");

  // Connect: the indicator turns green, Connect goes inactive, Start and Stop active.
  await page.click("#connect");
  await waitFor("the green indicator", async () =>
    (await page.locator("#indicator").getAttribute("class")).includes("green"));
  await expectButtons(page, [false, true, true], "connected");
  await shot(page, "02-connected");

  // Malformed input from the browser: a visible error, nothing changes on board.
  await page.fill("#suffix", "bad/suffix");
  let before = await text(page, "#reply");
  await page.click("#start");
  let r = await reply(page, before);
  if (!r.includes("file suffix")) throw new Error(`bad suffix answered: ${r}`);
  if (!(await page.locator("#reply").getAttribute("class")).includes("error")) throw new Error("error not shown as one");
  await shot(page, "03-bad-suffix");
  before = r;
  await page.evaluate(() => window.heli.request("start", { suffix: "ok1", controller: "loop" }));
  r = await reply(page, before);
  if (!r.includes("unknown controller 'loop'")) throw new Error(`unknown controller answered: ${r}`);
  before = r;
  // A replayed request (an old sequence number) is refused.
  await page.evaluate(() => window.heli.sendRaw(JSON.stringify({ seq: 1, op: "connect" })));
  r = await reply(page, before);
  if (!r.includes("replayed request refused")) throw new Error(`replay answered: ${r}`);
  before = r;
  await page.evaluate(() => window.heli.sendRaw("{not json"));
  r = await reply(page, before);
  if (!r.includes("malformed request")) throw new Error(`garbage answered: ${r}`);
  if ((await panel(page)) !== "connected") throw new Error(`panel moved: ${await panel(page)}`);
  await expectButtons(page, [false, true, true], "still connected after bad input");
  log("bad input refused:", r);

  // Start Logging: autonomous, hover. Stop is then the only active button.
  await page.fill("#suffix", "ui1");
  await page.selectOption("#controller", "autonomous");
  await page.selectOption("#plan", "hover");
  await page.click("#start");
  await waitFor("logging", async () => (await panel(page)) === "logging");
  await expectButtons(page, [false, false, true], "logging");
  // The safety check blocks automatic flight until the calibration is done, on the
  // display and on board.
  await waitFor("automatic blocked by the calibration", async () =>
    (await text(page, "#safe-automatic")).includes("NO") &&
    (await text(page, "#safe-automatic")).includes("still calibrating"));
  await waitFor("the vehicle's refusal", async () =>
    (await messages(page)).includes("autonomous flight refused"), 15000);
  await shot(page, "04-calibrating");
  await waitFor("automatic allowed after the calibration", async () =>
    (await text(page, "#safe-automatic")).includes("YES"), 30000);
  log("automatic allowed:", (await text(page, "#safe-automatic")).replace(/\s+/g, " "));

  // The rows fill with live values; the counter rises about three a second.
  for (const row of ["imu", "state", "uplink", "servo", "gps", "bar", "cmps"]) {
    await waitFor(`row ${row}`, async () => !(await text(page, `#row-${row}`)).includes("NOTHING YET"));
  }
  // The GPS row's PosN/PosE: the fix in the estimate's frame, from the origin the vehicle
  // sends (GPS_GLOBAL_ORIGIN) once its navigation has one.
  await waitFor("PosN from the vehicle's origin", async () => {
    const gps = await page.evaluate(() => window.heli.view().rows.gps);
    const posN = gps && gps.cells.find((c) => c.label === "PosN m");
    return posN && posN.value !== "–" && Math.abs(Number(posN.value)) < 50;
  });
  const c0 = Number(await text(page, "#counter"));
  const t0 = Date.now();
  await new Promise((res) => setTimeout(res, 5000));
  const rate = (Number(await text(page, "#counter")) - c0) / ((Date.now() - t0) / 1000);
  log(`telemetry counter: ${rate.toFixed(2)} per second`);
  if (!(rate > 2.2 && rate < 4)) throw new Error(`counter rose ${rate.toFixed(2)}/s, not about 3`);
  // The flight's plan came from the vehicle (mission protocol) and is drawn on the track.
  const plan = await page.evaluate(() => window.heli.view().plan.map((p) => p.kind).join(","));
  if (plan !== "takeoff,hold") throw new Error(`the hover's plan: '${plan}'`);
  // The estimate's 3D view is the simulator's renderer (WebGL), not the flat fallback, and
  // it shows the helicopter.
  await waitFor("the estimate's 3D view", async () => page.evaluate(() =>
    Boolean(window.heliEstimateView && window.heliEstimateDrawn && window.heliEstimateDrawn.heliOnScreen)));
  const solid = await page.evaluate(() => window.heliEstimateView.measure(0));
  log(`estimate's 3D view: the helicopter ${solid.heli.across_px} px across, horizon ${solid.horizon}`);
  if (!(solid.heli.across_px >= 20 && solid.horizon)) throw new Error(`the estimate's 3D view: ${JSON.stringify(solid)}`);
  await shot(page, "05-flying");

  // A second operator sees the same state and cannot command.
  const other = await (await browser.newContext({ viewport: { width: 820, height: 1180 } })).newPage();
  await other.goto(url);
  await waitFor("the second page's view", async () => (await panel(other)) === "logging");
  if (!(await text(other, "#token")).includes("in control: operator")) throw new Error("the watcher does not see the holder");
  await expectButtons(other, [false, false, false], "the watcher");
  if ((await text(other, "#counter")) === "0") throw new Error("the watcher has no telemetry");
  await shot(other, "06-second-operator-tablet");

  // The GPS stops (the scenario's outage): its row is marked stale.
  await waitFor("the GPS row stale", async () =>
    (await page.locator("#row-gps").getAttribute("class")) === "stale", 40000);
  await shot(page, "07-gps-stale");
  // The draining battery: the meter turns red (below a third, about 78 s into the HILSim's
  // run; the wait leaves room on a loaded machine).
  await waitFor("the red battery meter", async () =>
    (await page.locator("#battery").getAttribute("class")).includes("red"), 70000);
  log("battery:", await text(page, "#battery-pct"), await text(page, "#battery-v"));
  // Every pack with its state, the hot-swap's source and times (docs/power.md).
  await waitFor("three packs listed", async () => (await page.locator("#packs li").count()) === 3);
  const packs = await page.locator("#packs li").allTextContents();
  log("packs:", packs.join(" | "));
  if (!packs[0].includes("flight battery") || !packs[1].includes("RTXB") || !packs[2].includes("Sbat")) {
    throw new Error(`packs: ${packs.join(" | ")}`);
  }
  if (!(await text(page, "#power-source")).includes("on the flight battery")) {
    throw new Error(`power source: ${await text(page, "#power-source")}`);
  }
  if (!/flight \d+:\d\d, ground 0:00/.test(await text(page, "#power-times"))) {
    throw new Error(`power times: ${await text(page, "#power-times")}`);
  }
  // The small pack drains faster than a flight pack should: the field rule's banner.
  await waitFor("the field rule's banner", async () => !(await page.locator("#field-rule").isHidden()), 40000);
  if (!(await text(page, "#field-rule-text")).includes("end the flight test")) {
    throw new Error(`field rule: ${await text(page, "#field-rule-text")}`);
  }
  await shot(page, "08-battery-red");

  // Stop: the final parameters are asked for; the buttons return to their first state and
  // the log is transferred with progress messages.
  // Kill is there, red, and kills nothing unless the word is typed.
  if (await disabled(page, "#kill")) throw new Error("Kill is not active in flight");
  await page.click("#kill");
  await page.click("#kill-confirm");
  await waitFor("an unconfirmed kill refused", async () =>
    (await text(page, "#reply")).includes("kill not confirmed"));
  if ((await panel(page)) !== "logging") throw new Error(`after an unconfirmed kill: ${await panel(page)}`);
  await page.click("#stop");
  if (!(await text(page, "#final-air")).includes("lands where it is first")) {
    throw new Error(`the Stop dialog does not say what a Stop in the air does: ${await text(page, "#final-air")}`);
  }
  await page.fill("#final-base", "ui");
  await page.fill("#final-suffix", "mine");
  await page.click("#final-save");
  // In the air the vehicle lands first (tests/hil/stop.rs); the flight ends, and its log is
  // saved, on the skids.
  await waitFor("stopped: buttons true,false,false", async () =>
    JSON.stringify(await buttons(page)) === JSON.stringify([true, false, false]), 90000);
  log("stopped", (await messages(page)).includes("lands where it is first") ? "after landing first" : "on the ground");
  await waitFor("the indicator red again", async () =>
    (await page.locator("#indicator").getAttribute("class")).includes("red"));
  await waitFor("the transfer's progress", async () => (await messages(page)).includes("log transfer:"), 20000);
  await waitFor("the log saved", async () => (await messages(page)).includes("log saved:"), 60000);
  await shot(page, "09-stopped-log-saved");
  // The flight test is over: the banner stays until the operator acknowledges it (the
  // refused Start Logging is the station's unit test, the_field_rule_blocks_...).
  if (await page.locator("#field-rule").isHidden()) throw new Error("the banner left unacknowledged");
  await page.click("#acknowledge");
  await waitFor("the acknowledgement", async () => (await messages(page)).includes("acknowledged:"));
  await waitFor("the banner gone", async () => await page.locator("#field-rule").isHidden());
  await shot(page, "10-field-rule-acknowledged");
  log("done");
} catch (e) {
  failed = e;
}
if (failed) {
  try {
    const pages = browser.contexts().flatMap((c) => c.pages());
    if (pages[0]) await pages[0].screenshot({ path: join(out, "failure.png"), fullPage: true });
  } catch {}
  console.error("FAILED:", failed.message);
}
await browser.close();
process.exit(failed ? 1 : 0);
