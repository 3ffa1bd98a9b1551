// The operator's truth (tests/hil/truth.rs starts the processes): three flights from the
// ground display at 1366×768 in headless Chromium, with faults triggered from the HILSim's
// trainer panel — a take-off refused for too few satellites, a GPS outage, an IMU stall,
// a minute of device notices, a pack draining to the red — each flight stopped and its log
// saved. Every 0.5 s the page is sampled (what the operator sees: header, standing refusal,
// GPS lamp, battery meter, verdicts) and printed as a `SAMPLE` line; the test compares them
// with the vehicle's own state, sampled alongside. Steps print `STEP` lines.
//
//   HELI_UI_URL=… HELI_VIEW_URL=… HELI_UI_OUT=dir node tests/ui/truth.mjs
import { chromium } from "playwright-core";
import { mkdirSync } from "node:fs";
import { join } from "node:path";

const url = process.env.HELI_UI_URL;
const viewUrl = process.env.HELI_VIEW_URL;
const out = process.env.HELI_UI_OUT || "ui-artifacts";
const browserPath = process.env.HELI_CHROMIUM || "/usr/bin/chromium";
mkdirSync(out, { recursive: true });
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));
const step = (name, extra = {}) => console.log("STEP " + JSON.stringify({ step: name, t_ms: Date.now(), ...extra }));

async function waitFor(what, fn, timeoutMs = 20000) {
  const end = Date.now() + timeoutMs;
  let last;
  while (Date.now() < end) {
    try { last = await fn(); if (last) return last; } catch (e) { last = e; }
    await sleep(100);
  }
  throw new Error(`timed out waiting for: ${what} (last: ${last})`);
}

const browser = await chromium.launch({ executablePath: browserPath,
  args: ["--no-sandbox", "--disable-gpu", "--disable-background-timer-throttling",
    "--disable-renderer-backgrounding", "--disable-backgrounding-occluded-windows"] });
let failed = null;
let sampling = true;
try {
  const page = await (await browser.newContext({ viewport: { width: 1366, height: 768 } })).newPage();
  page.on("pageerror", (e) => { failed = failed || new Error(`page error: ${e.message}`); });
  const trainer = await (await browser.newContext()).newPage();
  // The trainer's page draws a few frames a second: the cores are the flight's.
  await trainer.goto(`${viewUrl}&max_fps=1&resolution=0.25`);
  await trainer.waitForFunction(() => window.heliViewSend && window.heliPilot && window.heliPilot.frames > 0,
    null, { timeout: 20000 });
  const fault = async (f) => {
    await trainer.evaluate((f) => window.heliViewSend({ type: "fault", fault: f }), f);
    step("fault", { fault: f });
  };
  await page.goto(url);
  await waitFor("the vehicle heard", async () => (await page.innerText("#vehicle-state")).includes("vehicle: idle"));

  // What the operator sees, twice a second, for the whole session.
  const sampler = (async () => {
    while (sampling) {
      const s = await page.evaluate(() => {
        const cls = (id) => document.getElementById(id).className;
        const st = document.getElementById("standing");
        const pinned = document.getElementById("pinned-box");
        const r = pinned.getBoundingClientRect();
        return {
          t_ms: Date.now(),
          header: document.getElementById("vehicle-state").textContent,
          standing: st.hidden ? null : st.textContent,
          lamp: cls("gps-indicator").replace("lamp", "").trim(),
          battery: document.getElementById("battery-pct").textContent === "–" ? "none"
            : cls("battery").includes("green") ? "green" : cls("battery").includes("grey") ? "stale" : "red",
          augmented: cls("safe-augmented").includes("yes"),
          automatic: cls("safe-automatic").includes("yes"),
          // What the page says fails, to name a disagreement's cause.
          failing: document.querySelector("#safe-automatic .failing").textContent,
          pinned_above_fold: !pinned.hidden && r.top >= 0 && r.bottom <= window.innerHeight && window.scrollY === 0,
        };
      }).catch(() => null);
      if (s) console.log("SAMPLE " + JSON.stringify(s));
      await sleep(500);
    }
  })();

  const startFlight = async (suffix, controller) => {
    await page.fill("#suffix", suffix);
    await page.selectOption("#controller", controller);
    await page.selectOption("#plan", "hover");
    await page.click("#start");
    await waitFor(`flight ${suffix} logging`, async () =>
      (await page.evaluate(() => document.body.dataset.panel)) === "logging", 30000);
    step("started", { suffix });
  };
  const stopAndSave = async (suffix) => {
    await page.click("#stop");
    await page.fill("#final-base", "truth");
    await page.fill("#final-suffix", suffix);
    await page.click("#final-save");
    // This flight's own save: one message line naming the file it was saved as (an earlier
    // flight's "log saved" and another line naming this flight's file are not it).
    await waitFor(`the log of ${suffix} saved`, async () =>
      (await page.evaluate(() => Array.from(document.querySelectorAll("#messages li"))
        .map((li) => li.innerText))).some((line) =>
        line.includes("log saved: ") && line.includes(`truth/flight_${suffix}.mcap`)), 90000);
    step("saved", { suffix });
  };
  const connect = async () => {
    await waitFor("Connect active", async () => !(await page.isDisabled("#connect")), 30000);
    await page.click("#connect");
    await waitFor("connected", async () => !(await page.isDisabled("#start")), 30000);
  };

  await page.click("#take-control");
  await waitFor("the token", async () => (await page.innerText("#token")).includes("in control: you"));
  await connect();

  // Flight 1: too few satellites; the autonomous take-off is refused, and stays refused
  // when the satellites come back.
  await fault({ kind: "gps-satellites", satellites: 3, seconds: 42 });
  await startFlight("one", "autonomous");
  await waitFor("the take-off refused, standing", async () =>
    ((await page.textContent("#standing")) || "").includes("refused the take-off") &&
    !(await page.isHidden("#standing")), 70000);
  step("refused", { standing: await page.textContent("#standing"),
    automatic: await page.innerText("#safe-automatic") });
  await page.screenshot({ path: join(out, "01-takeoff-refused.png") });
  await waitFor("the satellites back (the GPS lamp green)", async () =>
    (await page.getAttribute("#gps-indicator", "class")).includes("green"), 40000);
  await sleep(3000);
  const still = { standing: await page.isHidden("#standing") ? null : await page.textContent("#standing"),
    automatic: await page.innerText("#safe-automatic") };
  step("refused-after-satellites-back", still);
  if (!still.standing || still.automatic.includes("YES")) {
    throw new Error(`the refusal did not stand: ${JSON.stringify(still)}`);
  }
  await page.screenshot({ path: join(out, "02-refusal-stands.png") });
  await stopAndSave("one");

  // Flight 2: manual, on the ground. The GPS falls silent: the lamp leaves green at once.
  await connect();
  await startFlight("two", "manual");
  await waitFor("the GPS lamp green", async () =>
    (await page.getAttribute("#gps-indicator", "class")).includes("green"), 30000);
  // The GPS falls silent when the fix after its last one does not come. The simulated GPS
  // delivers each fix up to a second after its epoch (the thesis's receiver's latency), so
  // the last fix reaches the vehicle after the outage began: the lamp is timed from the
  // moment the page saw that last fix arrive (the GPS row's time changing), which is later
  // than the vehicle saw it — the interval measured is shorter than the true one by at most
  // a telemetry period, and the fix's age the page shows is checked as well.
  let lastFix = { time: null, wall: 0 };
  let watching = true;
  const watcher = (async () => {
    while (watching) {
      const t = await page.evaluate(() => {
        const v = window.heli.view();
        return v && v.rows.gps ? v.rows.gps.time_s : null;
      }).catch(() => null);
      // A new fix moves the fix time on by about a second; the same fix's time wobbles by
      // the telemetry's own timing (tens of ms) and is not a new one.
      if (t !== null && (lastFix.time === null || t > lastFix.time + 0.5)) {
        lastFix = { time: t, wall: Date.now() };
      }
      await sleep(20);
    }
  })();
  await sleep(1000);
  const silentAt = Date.now();
  await fault({ kind: "gps-outage", seconds: 10 });
  await waitFor("the GPS lamp not green", async () =>
    !(await page.getAttribute("#gps-indicator", "class")).includes("green"), 10000);
  const offAt = Date.now();
  watching = false;
  await watcher;
  const gpsView = await page.evaluate(() => window.heli.view().gps);
  step("gps-lamp", { after_fault_ms: offAt - silentAt, after_last_fix_ms: offAt - lastFix.wall,
    fix_age_shown_s: gpsView.age_s, text: await page.innerText("#gps-sats") });
  await page.screenshot({ path: join(out, "03-gps-silent.png") });
  await sleep(11000);
  // The IMU stalls: a fatal event, pinned above the fold through a minute of notices.
  await fault({ kind: "imu-silent", seconds: 0.5 });
  await waitFor("the fatal event pinned", async () =>
    (await page.innerText("#pinned")).includes("imu silent"), 10000);
  const fatalAt = Date.now();
  for (const f of [{ kind: "compass-silent", seconds: 8 }, { kind: "altimeter-silent", seconds: 8 },
    { kind: "compass-silent", seconds: 8 }, { kind: "altimeter-silent", seconds: 8 },
    { kind: "compass-silent", seconds: 8 }, { kind: "altimeter-silent", seconds: 8 }]) {
    await fault(f);
    await sleep(10000);
  }
  await sleep(Math.max(0, 60000 - (Date.now() - fatalAt)));
  const fold = await page.evaluate(() => {
    const r = document.getElementById("pinned-box").getBoundingClientRect();
    return { top: r.top, bottom: r.bottom, height: window.innerHeight, scroll: window.scrollY,
      text: document.getElementById("pinned").innerText,
      entries: document.querySelectorAll("#messages li").length };
  });
  step("fatal-above-the-fold", fold);
  if (!(fold.text.includes("imu silent") && fold.top >= 0 && fold.bottom <= fold.height)) {
    throw new Error(`the fatal event is not above the fold: ${JSON.stringify(fold)}`);
  }
  await page.screenshot({ path: join(out, "04-fatal-pinned-after-notices.png") });
  // The filter: warnings and worse only.
  await page.selectOption("#filter-severity", "warning");
  const shown = await page.evaluate(() => Array.from(document.querySelectorAll("#messages li"))
    .filter((li) => !li.hidden).map((li) => li.className));
  step("filter", { shown: shown.length });
  if (shown.some((c) => c === "info" || c === "notice")) throw new Error(`the filter shows ${shown}`);
  await page.selectOption("#filter-severity", "info");
  await waitFor("the battery meter red", async () =>
    (await page.getAttribute("#battery", "class")).includes("red"), 60000);
  await page.screenshot({ path: join(out, "05-battery-red.png") });
  await page.click("#ack-pinned");
  await waitFor("the pinned messages acknowledged", async () => await page.isHidden("#pinned-box"));
  await stopAndSave("two");

  // Flight 3: short; the field rule (the pack drained abnormally) is acknowledged first.
  if (!(await page.isHidden("#field-rule"))) {
    await page.click("#acknowledge");
    await waitFor("the banner gone", async () => await page.isHidden("#field-rule"));
  }
  await connect();
  await startFlight("three", "manual");
  await sleep(4000);
  await stopAndSave("three");
  await page.screenshot({ path: join(out, "06-three-saved.png") });
} catch (e) {
  failed = failed || e;
}
sampling = false;
await sleep(600);
if (failed) {
  try {
    const pages = browser.contexts().flatMap((c) => c.pages());
    if (pages[0]) await pages[0].screenshot({ path: join(out, "failure.png") });
  } catch {}
  console.error("FAILED:", failed.message);
}
await browser.close();
process.exit(failed ? 1 : 0);
