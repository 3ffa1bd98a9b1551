// Opens the HILSim's truth view (`heli hilsim --view`) in headless Chromium while a flight
// runs, and photographs it before and during a roll (tests/hil/view.rs starts the processes).
//
//   HELI_VIEW_URL=http://127.0.0.1:PORT/ HELI_UI_OUT=dir node tests/ui/view.mjs
//
// Prints one JSON line per screenshot with what the page drew; exits non-zero, naming the
// step, when a check fails.
import { chromium } from "playwright-core";
import { mkdirSync } from "node:fs";
import { join } from "node:path";

const url = process.env.HELI_VIEW_URL;
const out = process.env.HELI_UI_OUT || "ui-artifacts";
const browserPath = process.env.HELI_CHROMIUM || "/usr/bin/chromium";
mkdirSync(out, { recursive: true });

async function waitFor(page, what, predicate, timeoutMs) {
  const end = Date.now() + timeoutMs;
  let last;
  while (Date.now() < end) {
    last = await page.evaluate(() => window.truthView);
    if (last && predicate(last)) return last;
    await new Promise((r) => setTimeout(r, 50));
  }
  throw new Error(`timed out waiting for: ${what} (last: ${JSON.stringify(last)})`);
}

function check(step, v) {
  const fails = [];
  for (const cam of ["chase", "field"]) {
    if (!v[cam] || !v[cam].heliOnScreen) fails.push(`${cam}: the helicopter is not on screen`);
    if (!v[cam] || v[cam].gridLines < 4) fails.push(`${cam}: the field's grid is not in view`);
    if (!v[cam] || v[cam].heliPx < 3) fails.push(`${cam}: the helicopter is too small to see`);
  }
  if (!v.chase || v.chase.trailSegments < 3) fails.push("chase: no trail in view");
  if (!v.field || v.field.trailSegments < 10) fails.push("field: no trail in view");
  if (fails.length) throw new Error(`${step}: ${fails.join("; ")} (${JSON.stringify(v)})`);
}

const browser = await chromium.launch({ executablePath: browserPath, args: ["--no-sandbox"] });
try {
  const page = await browser.newPage({ viewport: { width: 1340, height: 620 } });
  await page.goto(url);
  const before = await waitFor(page, "the helicopter climbing through 15 m",
    (v) => v.height_m > 15, 120000);
  check("before the roll", before);
  await page.screenshot({ path: join(out, "01-before-roll.png") });
  console.log(JSON.stringify({ step: "before-roll", ...before }));
  const rolling = await waitFor(page, "a roll past 90 degrees",
    (v) => Math.abs(v.roll_deg) > 90, 120000);
  check("during the roll", rolling);
  await page.screenshot({ path: join(out, "02-during-roll.png") });
  console.log(JSON.stringify({ step: "during-roll", ...rolling }));
} finally {
  await browser.close();
}
