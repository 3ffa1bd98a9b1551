// The display's lab statement (heli certify) in headless Chromium: the header says
// "lab-tested" or "NOT lab-tested" with why; with HELI_LAB_START=1 the operator takes
// control, connects and starts an autonomous hover, and on an untested configuration the
// override dialog must ask first, naming what changed (tests/hil/lab.rs starts the processes).
//
//   HELI_UI_URL=… HELI_LAB_EXPECT="NOT lab-tested" HELI_LAB_WHY="HOV_VEL_P" HELI_LAB_START=1 node tests/ui/lab.mjs
//
// Prints one JSON line of what the page showed; exits non-zero, naming the step, on a failure.
import { chromium } from "playwright-core";
import { mkdirSync } from "node:fs";
import { join } from "node:path";

const url = process.env.HELI_UI_URL;
const out = process.env.HELI_UI_OUT || "ui-artifacts";
const expect = process.env.HELI_LAB_EXPECT || "lab-tested";
const why = process.env.HELI_LAB_WHY || "";
const start = process.env.HELI_LAB_START === "1";
const tag = process.env.HELI_LAB_TAG || "lab";
mkdirSync(out, { recursive: true });

async function waitFor(what, fn, timeoutMs = 30000) {
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

const browser = await chromium.launch({
  executablePath: process.env.HELI_CHROMIUM || "/usr/bin/chromium",
  args: ["--no-sandbox", "--disable-gpu", "--no-first-run"],
});
let failed = null;
try {
  const page = await browser.newPage({ viewport: { width: 1366, height: 900 } });
  page.on("pageerror", (e) => { failed = failed || new Error(`page error: ${e.message}`); });
  const text = (sel) => page.locator(sel).innerText();
  await page.goto(url);
  await waitFor("the vehicle's heartbeat", async () => (await text("#vehicle-state")).includes("vehicle: idle"));
  const pill = await waitFor(`the header saying ${expect}`, async () => {
    const t = await text("#lab");
    return t === expect ? t : null;
  });
  const statement = await waitFor(`the statement naming ${why || "nothing more"}`, async () => {
    const shown = !(await page.locator("#lab-statement").isHidden());
    const t = shown ? await text("#lab-statement") : "";
    if (expect === "lab-tested") return !shown ? "(none: lab-tested)" : null;
    return t.startsWith("NOT lab-tested:") && t.includes(why) ? t : null;
  });
  await page.screenshot({ path: join(out, `${tag}-header.png`) });
  let dialog = null;
  if (start) {
    await page.click("#take-control");
    await waitFor("control", async () => (await text("#token")).includes("you"));
    await page.click("#connect");
    await waitFor("connected", async () => !(await page.locator("#start").isDisabled()));
    await page.locator("#suffix").fill(`${tag}1`);
    await page.selectOption("#controller", "autonomous");
    await page.selectOption("#plan", "hover");
    await page.click("#start");
    if (expect === "NOT lab-tested") {
      await waitFor("the override dialog", async () => page.locator("#override-dialog").isVisible());
      dialog = await text("#override-why");
      if (!dialog.includes(why)) throw new Error(`the dialog does not say what changed: ${dialog}`);
      await page.screenshot({ path: join(out, `${tag}-override.png`) });
      await page.click("#override-confirm");
    }
    await waitFor("the flight under way", async () => (await text("#vehicle-state")).includes("vehicle: flying"));
  }
  console.log(JSON.stringify({ pill, statement, dialog, started: start }));
} catch (e) {
  failed = failed || e;
} finally {
  await browser.close();
}
if (failed) {
  console.error(`lab page: ${failed.message}`);
  process.exit(1);
}
