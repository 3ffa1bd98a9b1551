// Flies the simulated helicopter from the HILSim's view page (`heli hilsim --view --pilot`)
// in headless Chromium, as a person would: tests/hil/pilot.rs starts the processes and
// the vehicle's flight, and runs this once per phase.
//
//   HELI_VIEW_URL=http://127.0.0.1:PORT/ HELI_PILOT_PHASE=manual|augmented HELI_UI_OUT=dir \
//     node tests/ui/pilot.mjs
//
// manual: a synthetic gamepad (the Gamepad API, replaced before the page loads) lifts the
// helicopter with the collective, rolls it right with the right stick, and puts it down.
// augmented: the keyboard climbs (W), flies forward (up arrow), then the bypass switch (B)
// hands the servos to the sticks, the right arrow rolls it right, and B gives the computer
// back. Also checks the stick settings survive a reload.
// Prints one JSON line per step; exits non-zero, naming the step, when a check fails.
import { chromium } from "playwright-core";
import { mkdirSync } from "node:fs";
import { join } from "node:path";

const url = process.env.HELI_VIEW_URL;
const phase = process.env.HELI_PILOT_PHASE;
const out = process.env.HELI_UI_OUT || "ui-artifacts";
const browserPath = process.env.HELI_CHROMIUM || "/usr/bin/chromium";
mkdirSync(out, { recursive: true });
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

async function frame(page) {
  return page.evaluate(() => {
    const p = window.heliPilot;
    const f = p && p.frame;
    if (!f) return null;
    const DEG = 180 / Math.PI;
    return {
      t_s: f.t_s, height_m: -f.pos_ned_m[2] - 0.0, roll_deg: f.euler_rad[0] * DEG,
      pitch_deg: f.euler_rad[1] * DEG,
      yaw: f.euler_rad[2], vel: f.vel_ned_mps, ground: f.contact_points > 0,
      sticks: f.sticks, servos: f.servos, live: f.live_pilot, auto: f.auto_switch,
      bypass: f.bypass_switch, lost: f.signal_lost, trainer: f.trainer, errors: p.errors,
    };
  });
}

async function waitFor(page, what, predicate, timeoutMs) {
  const end = Date.now() + timeoutMs;
  let last;
  while (Date.now() < end) {
    last = await frame(page);
    if (last && predicate(last)) return last;
    await sleep(40);
  }
  throw new Error(`timed out waiting for: ${what} (last: ${JSON.stringify(last)})`);
}

function say(step, f, extra) {
  console.log(JSON.stringify({ step, t_s: f.t_s, height_m: f.height_m, roll_deg: f.roll_deg,
    ...extra }));
}

// Two pages fly side by side (the second is refused the transmitter): neither may be
// throttled as a background tab, or the holder's sticks would stop.
const browser = await chromium.launch({ executablePath: browserPath, args: ["--no-sandbox",
  "--disable-background-timer-throttling", "--disable-renderer-backgrounding",
  "--disable-backgrounding-occluded-windows"] });
try {
  const page = await browser.newPage({ viewport: { width: 1340, height: 1000 } });
  // A gamepad the test moves: window.__pad.axes and .buttons.
  await page.addInitScript(() => {
    if (!window.__usePad) window.__usePad = false;
    window.__pad = {
      id: "synthetic test gamepad", connected: true, mapping: "standard",
      axes: [0, 0, 0, 0], buttons: Array.from({ length: 12 }, () => ({ pressed: false, value: 0 })),
    };
    navigator.getGamepads = () => (window.__usePad ? [window.__pad] : []);
  });
  // The view at a few frames a second: this test is of the pilot's panel, and the machine's
  // cores are the flight's (tests/ui/view.mjs measures the view).
  await page.goto(`${url}&max_fps=5`);
  await page.waitForFunction(() => window.heliPilot && window.heliPilot.enabled && window.heliPilot.frames > 0,
    null, { timeout: 20000 });
  // The ground is where the helicopter stands now.
  const ground0 = (await frame(page)).height_m;
  const h = (f) => f.height_m - ground0;

  if (phase === "manual") {
    await page.evaluate(() => { window.__usePad = true; });
    await page.click("#take");
    await page.click("#sw-auto-btn"); // auto off: the pilot flies
    // Up to 15 s: once, on a busy host, the first Take had not shown as held after 5.
    const held = await waitFor(page, "the page holding the transmitter, auto off",
      (f) => f.live && !f.auto, 15000);
    say("manual-holding", held, { source: await page.evaluate(() => window.heliPilot.source) });
    // Collective up (the left stick pushed up: axis 1 at -0.75).
    await page.evaluate(() => { window.__pad.axes[1] = -0.75; });
    const up = await waitFor(page, "the helicopter lifting off on the collective",
      (f) => h(f) > 1.0, 60000);
    say("manual-lift-off", up, { collective_stick: up.sticks[3] });
    await page.evaluate(() => { window.__pad.axes[1] = -0.55; });
    await sleep(300);
    const before = await frame(page);
    await page.evaluate(() => { window.__pad.axes[2] = 0.6; }); // right stick, right
    const rolled = await waitFor(page, "a roll to the right on right cyclic",
      (f) => f.roll_deg - before.roll_deg > 5, 3000);
    say("manual-roll-right", rolled, { roll_change_deg: rolled.roll_deg - before.roll_deg,
      aileron_stick: rolled.sticks[0], aileron_servo: rolled.servos[0] });
    await page.screenshot({ path: join(out, "01-manual-roll-right.png") });
    // Down again, as a pilot would: first the speed taken off at the hover's collective,
    // then the collective a little below the hover's, the cyclic holding the helicopter
    // level and still all the way down (a skid that touches down moving sideways or
    // forward can tip it over).
    const clampStick = (v) => Math.max(-0.4, Math.min(0.4, v));
    const level = async () => {
      const f = await frame(page);
      const fwd = f.vel[0] * Math.cos(f.yaw) + f.vel[1] * Math.sin(f.yaw);
      const right = -f.vel[0] * Math.sin(f.yaw) + f.vel[1] * Math.cos(f.yaw);
      const ail = clampStick(-0.02 * f.roll_deg - 0.05 * right);
      const ele = clampStick(-0.02 * f.pitch_deg + 0.05 * fwd);
      await page.evaluate(([a, e]) => { window.__pad.axes[2] = a; window.__pad.axes[3] = e; }, [ail, ele]);
      await sleep(40);
      return { f, speed: Math.hypot(fwd, right) };
    };
    let stillSince = null;
    for (const end = Date.now() + 10000; Date.now() < end;) {
      const { f, speed } = await level();
      if (f.ground) break;
      stillSince = speed < 0.3 ? (stillSince ?? Date.now()) : null;
      if (stillSince !== null && Date.now() - stillSince > 800) break;
    }
    await page.evaluate(() => { window.__pad.axes[1] = -0.5; });
    let down = null;
    for (const end = Date.now() + 25000; Date.now() < end;) {
      const { f } = await level();
      if (f.ground) { down = f; break; }
    }
    if (!down) throw new Error("timed out waiting for: back on the ground");
    await page.evaluate(() => { window.__pad.axes = [0, 0.5, 0, 0]; });
    await sleep(1500);
    const settled = await frame(page);
    if (!settled.ground || Math.abs(settled.roll_deg) > 15) {
      throw new Error(`the landing: not settled on the skids (${JSON.stringify(settled)})`);
    }
    say("manual-down", down, {});
    // A second pilot page: it sees who holds the transmitter, cannot take it, and its sticks
    // (full collective, sent for a second) are refused — the helicopter never feels them.
    // Done on the ground, the first page holding: a second renderer starting up on a 2-core
    // machine can starve the real-time processes, which a flight in the air would feel.
    const second = await browser.newPage({ viewport: { width: 1340, height: 1000 } });
    await second.goto(`${url}&max_fps=5`);
    await second.waitForFunction(() => window.heliPilot && window.heliPilot.holder !== null &&
      window.heliPilot.you !== window.heliPilot.holder, null, { timeout: 10000 });
    if (!(await second.isDisabled("#take"))) throw new Error("the second page may take a held transmitter");
    await second.evaluate(() => window.heliViewSend({ type: "take" }));
    let maxCollective = -1;
    for (let k = 0; k < 25; k++) {
      await second.evaluate(() => window.heliViewSend({ type: "pilot", aileron: 0, elevator: 0,
        rudder: 0, collective: 1, throttle: 0.8, auto: true, bypass: false }));
      const f = await frame(page);
      maxCollective = Math.max(maxCollective, f.sticks[3]);
      await sleep(40);
    }
    const refusals = await second.evaluate(() => window.heliPilot.errors);
    if (maxCollective > 0.2 || !refusals.some((e) => e.includes("holds the transmitter"))) {
      throw new Error(`a second page moved the sticks: collective up to ${maxCollective}, said ${JSON.stringify(refusals)}`);
    }
    console.log(JSON.stringify({ step: "second-pilot-refused", max_collective_stick: maxCollective,
      refusal: refusals[0] }));
    await second.screenshot({ path: join(out, "02-second-pilot-refused.png") });
    await second.close();
    await page.bringToFront();
  } else if (phase === "augmented") {
    // The stick settings are kept across a reload.
    await page.fill("#set-aileron-expo", "0.45");
    await page.dispatchEvent("#set-aileron-expo", "change");
    await page.reload();
    await page.waitForFunction(() => window.heliPilot && window.heliPilot.enabled, null, { timeout: 20000 });
    const expo = await page.inputValue("#set-aileron-expo");
    if (Number(expo) !== 0.45) throw new Error(`settings: aileron expo ${expo} after a reload, not 0.45`);
    console.log(JSON.stringify({ step: "settings-kept", aileron_expo: Number(expo) }));
    await page.fill("#set-aileron-expo", "0");
    await page.dispatchEvent("#set-aileron-expo", "change");

    await page.click("#take");
    const held = await waitFor(page, "the page holding the transmitter, auto on",
      (f) => f.live && f.auto, 5000);
    say("augmented-holding", held, { source: await page.evaluate(() => window.heliPilot.source) });
    // Collective stick up: climb, high enough that the bypass below (the servos on the sticks,
    // the collective stick low) has room to fall while a loaded machine answers.
    // The keys move the stick at the page's frame rate: held until the stick is there, not
    // for a time (a loaded machine draws fewer frames).
    await page.keyboard.down("w");
    await waitFor(page, "the collective stick up", (f) => f.sticks[3] > 0.7, 10000);
    await page.keyboard.up("w");
    const climbing = await waitFor(page, "the helicopter climbing on the collective stick",
      (f) => h(f) > 6.0, 60000);
    say("augmented-climb", climbing, { collective_stick: climbing.sticks[3] });
    await page.keyboard.down("s"); // back to the centre: hold the height
    await waitFor(page, "the collective stick back at the centre", (f) => f.sticks[3] < 0.53, 10000);
    await page.keyboard.up("s");
    await sleep(1500);
    const start = await frame(page);
    await page.keyboard.down("ArrowUp"); // stick forward: fly forward
    const fwd = (f) => f.vel[0] * Math.cos(f.yaw) + f.vel[1] * Math.sin(f.yaw);
    const forward = await waitFor(page, "forward speed on the stick pushed forward",
      (f) => fwd(f) > 1.0, 15000);
    say("augmented-forward", forward, { forward_mps: fwd(forward), from_mps: fwd(start),
      elevator_stick: forward.sticks[1] });
    await page.screenshot({ path: join(out, "02-augmented-forward.png") });
    await page.keyboard.up("ArrowUp");
    await sleep(2000);

    // The bypass: the servos follow the sticks, not the computer.
    await page.keyboard.press("b");
    const bypassed = await waitFor(page, "the bypass switch on at the receiver",
      (f) => f.bypass, 3000);
    const before = bypassed;
    await page.keyboard.down("ArrowRight");
    const direct = await waitFor(page, "the aileron servo at the stick, the helicopter rolling right",
      (f) => Math.abs(f.servos[0] - f.sticks[0]) < 0.02 && f.sticks[0] > 0.4 &&
        f.roll_deg - before.roll_deg > 1.5, 3000);
    say("bypass-direct", direct, { aileron_stick: direct.sticks[0], aileron_servo: direct.servos[0],
      collective_stick: direct.sticks[3], collective_servo: direct.servos[3],
      roll_change_deg: direct.roll_deg - before.roll_deg });
    await page.screenshot({ path: join(out, "03-bypass.png") });
    await page.keyboard.up("ArrowRight");
    await page.keyboard.press("b");
    const back = await waitFor(page, "the computer flying again, the bypass off",
      (f) => !f.bypass && Math.abs(f.roll_deg) < 15, 5000);
    say("bypass-off", back, { aileron_stick: back.sticks[0], aileron_servo: back.servos[0] });

    // The trainer's panel: a failure from the catalog, shown as done; nonsense refused.
    await page.click("text=GPS outage 15 s");
    const gps = await waitFor(page, "the trainer's GPS outage acknowledged",
      (f) => (f.trainer || []).some((e) => e.message.includes("GPS outage for 15 s")), 3000);
    await page.evaluate(() => window.heliViewSend({ type: "fault", fault: { kind: "gps-outage", seconds: -3 } }));
    await page.evaluate(() => window.heliViewSend({ type: "pilot", aileron: 5 }));
    const refused = await waitFor(page, "the nonsense refused with reasons",
      (f) => (f.trainer || []).some((e) => e.message.includes("refused: seconds -3")) &&
        f.errors.some((e) => e.includes("pilot message")), 3000);
    say("trainer", refused, { trainer: refused.trainer.map((e) => e.message), errors: refused.errors });
    await page.click("#take"); // release
    const released = await waitFor(page, "the transmitter back with the scenario's pilot",
      (f) => !f.live, 3000);
    say("released", released, {});
  } else {
    throw new Error(`HELI_PILOT_PHASE ${phase}: manual or augmented`);
  }
} finally {
  await browser.close();
}
