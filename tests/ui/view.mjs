// Opens the HILSim's truth view (`heli hilsim --view`) in headless Chromium while a flight
// runs in real time, and photographs it in the hover and during a roll from the pilot's view (the
// big view) and the chase camera (the small one); tests/hil/view.rs starts the processes.
//
//   HELI_VIEW_URL=http://127.0.0.1:PORT/ HELI_UI_OUT=dir node tests/ui/view.mjs
//
// Each check counts rendered pixels (the page's measure(): the helicopter, its shadow, the
// sky and the ground rendered one at a time off screen): the helicopter a solid model at
// least 40 px across, its shadow on the ground, the horizon in view. Prints one JSON line per
// screenshot with what the page drew and its frame rate and state-to-screen latency (in the
// roll and zoomed, the first of a few frames a tenth to a quarter of a second apart that
// passes: see lookUntil); exits non-zero, naming the step, when a check fails. The hover at
// 10 m: every cue in both views; the first roll, flown past the pilot some 30 m off: every cue
// in both views; then the pilot's view with the ground cues turned off: the helicopter alone,
// zoomed.
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
    await new Promise((r) => setTimeout(r, 20));
  }
  throw new Error(`timed out waiting for: ${what} (last: ${JSON.stringify(last)})`);
}

// What each view shows, counted in rendered pixels, with the view's own account.
async function look(page) {
  return page.evaluate(() => {
    const v = window.truthView;
    const out = { t_s: v.t_s, roll_deg: v.roll_deg, height_m: v.height_m, webgl: v.webgl };
    ["main", "side"].forEach((which, k) => {
      out[which] = { ...v[which], pixels: window.heliView.measure(k) };
    });
    return out;
  });
}

// `cues`: what each view must show besides the helicopter ({main: ["shadow", "horizon"],
// side: [...]}): its shadow (at least 20 rendered pixels), the horizon.
function check(step, seen, cues) {
  const fails = [];
  if (!seen.webgl) fails.push("no WebGL: the flat drawing was shown");
  for (const which of ["main", "side"]) {
    const v = seen[which];
    const name = `${which} (${v.camera})`;
    if (!v.heliOnScreen) fails.push(`${name}: the helicopter is not on screen`);
    if (v.pixels.heli.across_px < 40) fails.push(`${name}: the helicopter is ${v.pixels.heli.across_px} px across (< 40)`);
    const wanted = cues[which] || [];
    if (wanted.includes("shadow") && v.pixels.shadow.pixels < 20) fails.push(`${name}: its shadow is not on the ground in view (${v.pixels.shadow.pixels} px)`);
    if (wanted.includes("horizon") && !v.pixels.horizon) fails.push(`${name}: no horizon in view (ground ${v.pixels.ground.pixels} px)`);
  }
  if (fails.length) throw new Error(`${step}: ${fails.join("; ")} (${JSON.stringify(seen)})`);
}

// Looks up to `tries` times, `gapMs` apart, until `ok(seen)` throws nothing; rethrows the last
// look's failure. One rendered frame can show the helicopter smaller than it is framed: its
// rotor's disk edge on is thinner than a pixel and not drawn, its blades in line with the
// eye, so its width is the fuselage's for that frame; the blades turn from frame to frame.
async function lookUntil(page, tries, gapMs, ok) {
  let failure;
  for (let i = 0; i < tries; i++) {
    const seen = await look(page);
    try {
      ok(seen);
      return seen;
    } catch (e) {
      failure = e;
      const px = (which) => seen[which].pixels.heli.across_px;
      console.log(JSON.stringify({ looked_again: i + 1, roll_deg: seen.roll_deg, main_heli_px: px("main"), side_heli_px: px("side") }));
    }
    await new Promise((r) => setTimeout(r, gapMs));
  }
  throw failure;
}

const browser = await chromium.launch({ executablePath: browserPath, args: ["--no-sandbox"] });
try {
  const page = await browser.newPage({ viewport: { width: 1400, height: 1180 } });
  page.on("console", (m) => { if (m.type() === "error") console.error(`page: ${m.text()}`); });
  page.on("pageerror", (e) => console.error(`page error: ${e.message}`));
  await page.goto(url);
  await waitFor(page, "the views", (v) => v.main && v.side, 30000);
  // The interpolation between the simulator's states: halfway in time is halfway in
  // position, and a roll from 170° to −170° passes through 180°, not back through level.
  const between = await page.evaluate(async () => {
    const { StateBuffer, attitude } = await import("./view3d.js");
    const b = new StateBuffer();
    const D = Math.PI / 180;
    b.push({ pos_ned_m: [0, 0, -10], euler_rad: [170 * D, 0, 0] }, 1000);
    b.push({ pos_ned_m: [2, 0, -10], euler_rad: [-170 * D, 0, 0] }, 1040);
    const mid = b.at(1020);
    return {
      north_m: mid.state.pos_ned_m[0],
      produced_ms: mid.produced_ms,
      inverted: Math.abs(mid.state.quaternion.dot(attitude([Math.PI, 0, 0]))),
      level: Math.abs(mid.state.quaternion.dot(attitude([0, 0, 0]))),
    };
  });
  if (!(Math.abs(between.north_m - 1) < 1e-9 && between.produced_ms === 1020
    && between.inverted > 0.9999 && between.level < 0.01)) {
    throw new Error(`interpolation between states: ${JSON.stringify(between)}`);
  }
  // The drawing's resolution follows the frame rate: frames 20 a second (under 30) for two
  // seconds bring it down to what should give 36; 60 a second for three seconds raise it a
  // step; never under a quarter; a fixed resolution stays.
  const adapted = await page.evaluate(async () => {
    const { HeliView } = await import("./view3d.js");
    const run = async (opts, steps) => {
      const c = document.createElement("canvas");
      c.width = 320; c.height = 256;
      const v = await HeliView.create(c, opts);
      let t = 1000;
      const seen = [];
      for (const [fps, seconds] of steps) {
        for (let k = 0; k < fps * seconds; k++) { t += 1000 / fps; v.adapt(t); }
        seen.push(v.ratio);
      }
      v.renderer.dispose();
      return seen;
    };
    return {
      adaptive: await run({ resolution: 0.5, adaptive: true }, [[20, 1.02], [20, 1.02], [60, 2.05], [60, 1.02], [5, 3.1]]),
      fixed: await run({ resolution: 0.5 }, [[5, 3.1]]),
    };
  });
  const [once, twice, notYet, raised, floor] = adapted.adaptive;
  if (!(once === 0.5 && twice === 0.37 && notYet === 0.37 && raised === 0.44 && floor === 0.25
    && adapted.fixed[0] === 0.5)) {
    throw new Error(`the resolution's adaptation: ${JSON.stringify(adapted)}`);
  }
  // The framing, checked through three.js's own projection: from the pilot's eyes (1.7 m up)
  // the helicopter H m up and D m ahead, its shadow S m ahead and the horizon, on a view
  // 1280x1024 (the page's) or 320x256 (an inset). Every cue the framing holds is on screen,
  // 6 px or more inside the edges, with all of the helicopter's reach (its box's farthest
  // corner), its rotor 44 px across or more (42 where every cue held was held the frame
  // before: no jumping in and out at the limit) and the shadow 3 px tall or more; where it
  // holds none, the helicopter is centred and 80 px across (at most 30 % of the view's
  // height, or what a 3° view makes it). Near, both cues (30 m off and 21 m up, its shadow
  // 34 m off: the demonstration's first roll past the pilot); 97 m off and 30 m up, and 90 m
  // off and 34 m up, the horizon (the shadow under a pixel tall); 36 m up, the horizon only
  // for a view that held it; 38 m up, not even then; 150 m off and 1.9 m up (the narrowest
  // view) the horizon but not the shadow; 200 m off in the inset, nothing.
  const framed = await page.evaluate(async () => {
    const { frameCues } = await import("./view3d.js");
    const THREE = await import("./three.module.min.js");
    const D = Math.PI / 180, EYE = 1.7, R = 0.775, REACH = window.heliView.reach_m;
    const el = (dy, d) => Math.atan2(dy, d) / D;
    const cases = [
      [15, 10, 18, 1024, [], [true, true]],
      [30, 10, 33, 1024, [], [true, true]],
      [30, 21, 34, 1024, [], [true, true]],
      [97, 30, 106, 1024, [], [false, true]],
      [90, 34, 100, 1024, [], [false, true]],
      [90, 36, 100, 1024, [], [false, false]],
      [90, 36, 100, 1024, [false, true], [false, true]],
      [90, 38, 100, 1024, [false, true], [false, false]],
      [150, 1.9, 160, 1024, [], [false, true]],
      [200, 5, 210, 256, [], [false, false]],
      [40, 30, 49, 256, [], [false, false]],
    ];
    return cases.map(([d, H, s, h, before, expected]) => {
      const range = Math.hypot(d, H - EYE), rho = Math.atan(R / range) / D;
      const reach = Math.atan(REACH / range) / D;
      const eH = el(H - EYE, d), sNear = el(-EYE, s - R), sFar = el(-EYE, s + R), eHz = el(-EYE, 2000);
      const f = frameCues(h, 60, eH, rho, [[sNear, sFar, 3], [eHz, eHz]], before, reach);
      const cam = new THREE.PerspectiveCamera(f.fov_deg, 1.25, 0.1, 5000);
      cam.position.set(0, EYE, 0);
      const c = f.centre_deg * D;
      cam.lookAt(0, EYE + Math.sin(c), -Math.cos(c));
      cam.updateMatrixWorld(true);
      const px = (x, y, z) => { const p = new THREE.Vector3(x, y, z).project(cam); return [(p.x + 1) * 0.625 * h, (1 - p.y) * h / 2]; };
      // A point at elevation e (degrees) straight ahead, far off.
      const at = (e) => px(0, EYE + 1000 * Math.sin(e * D), -1000 * Math.cos(e * D))[1];
      const extremes = [at(eH + reach), at(eH - reach)];
      const shadowTall = at(sNear) - at(sFar);
      if (f.held[0]) extremes.push(at(sNear), at(sFar));
      if (f.held[1]) extremes.push(at(eHz));
      const focal = h / 2 / Math.tan(1.5 * D);
      return {
        d, H, h, held: f.held, expected, shadowTall,
        least: f.held.every((x, k) => !x || before[k]) ? 42 : 44,
        alone_px: Math.min(80, 0.3 * h, 2 * focal * Math.tan(rho * D)),
        width_px: px(R, H, -d)[0] - px(-R, H, -d)[0],
        heli_y: px(0, H, -d)[1],
        extremes_y: extremes,
      };
    });
  });
  for (const v of framed) {
    const inside = v.extremes_y.every((y) => y >= 5.5 && y <= v.h - 5.5);
    const ok = JSON.stringify(v.held) === JSON.stringify(v.expected)
      && (!v.held[0] || v.shadowTall >= 3) && (v.held.some((x) => x)
      ? inside && v.width_px >= v.least
      : Math.abs(v.width_px - v.alone_px) < 1 && Math.abs(v.heli_y - v.h / 2) < 1);
    if (!ok) throw new Error(`the framing: ${JSON.stringify(v)}`);
  }
  // The page itself adapts (no ?resolution= or ?max_fps= in its URL).
  if (!(await page.evaluate(() => window.heliView.adaptive))) throw new Error("the page's view does not adapt its resolution");
  const main = await page.evaluate(() => window.truthView.main.camera);
  const side = await page.evaluate(() => window.truthView.side.camera);
  if (main !== "pilot" || side !== "chase") throw new Error(`the views are ${main} and ${side}, not pilot and chase`);
  // The hover at 10 m over the pad: every cue in both views.
  await waitFor(page, "the helicopter hovering at 10 m", (v) => v.height_m > 9.5, 150000);
  await new Promise((r) => setTimeout(r, 2000));
  const hover = await look(page);
  check("in the hover", hover, { main: ["shadow", "horizon"], side: ["shadow", "horizon"] });
  await page.screenshot({ path: join(out, "01-hover.png") });
  console.log(JSON.stringify({ step: "hover", ...hover }));
  await waitFor(page, "a roll past 90 degrees", (v) => Math.abs(v.roll_deg) > 90, 150000);
  // A software renderer that fell below half scale (a quarter on a slow host) draws the
  // pilot's-view shadow, a line some 2 px tall 35 m off, under a drawn pixel: the roll is
  // looked at no coarser than half scale, as `?resolution=0.5` draws it, and the scale the
  // page had fallen to is said in the line. The frame rate and latency are the page's own.
  const fellTo = await page.evaluate(() => {
    const v = window.heliView;
    const had = v.ratio;
    if (had < 0.5) {
      v.adaptive = false;
      v.ratio = 0.5;
      v.renderer.setPixelRatio(0.5);
      v.renderer.setSize(v.size.w, v.size.h, true);
    }
    return had;
  });
  if (fellTo < 0.5) await new Promise((r) => setTimeout(r, 150));
  const rolling = await lookUntil(page, 6, 60, (seen) => check("during the roll", seen, { main: ["shadow", "horizon"], side: ["shadow", "horizon"] }));
  await page.screenshot({ path: join(out, "02-during-roll.png") });
  // From the pilot's eyes, 1.7 m up, the helicopter rolls some 20 m up and 30 m away, as a
  // display is flown past the pilot: the pilot's view holds it near the top, its shadow and
  // the horizon near the bottom. The chase view shows every cue too.
  console.log(JSON.stringify({ step: "during-roll", adaptive_scale: fellTo, ...rolling }));
  await page.evaluate((had) => {
    const v = window.heliView;
    if (had < 0.5) v.adaptive = true;
  }, fellTo);
  // Each camera alone, as docs/pilot.md shows them.
  const box = await page.locator("#view-main").boundingBox();
  const inset = await page.evaluate(() => window.heliViewInset);
  await page.screenshot({ path: join(out, "03-pilot-view-roll.png"), clip: box });
  await page.screenshot({
    path: join(out, "04-chase-view-roll.png"),
    clip: { x: box.x + inset.x, y: box.y + inset.y, width: inset.w, height: inset.h },
  });
  // The box "shadow and horizon in view" unticked: the pilot's view zooms on the helicopter
  // alone, centred, its rotor planned 80 px across; ticked again, the cues come back.
  await page.locator("#frame-ground").uncheck();
  await waitFor(page, "the pilot's view zoomed on the helicopter alone", (v) => v.main.cues_framed.length === 0, 5000);
  const zoomed = await lookUntil(page, 10, 200, (seen) => {
    const z = seen.main;
    if (!(Math.abs(z.planned_heli_px - 80) < 1 && z.pixels.heli.across_px >= 60 && Math.abs(z.heliXY[1] - 512) < 40)) {
      throw new Error(`the pilot's view unframed from the ground: ${JSON.stringify(z)}`);
    }
  });
  console.log(JSON.stringify({ step: "zoomed", ...zoomed }));
  await page.screenshot({ path: join(out, "05-pilot-view-zoomed.png"), clip: box });
  await page.locator("#frame-ground").check();
  await waitFor(page, "the cues framed again", (v) => v.main.cues_framed.length === 2, 5000);
} finally {
  await browser.close();
}
