// Measures the HILSim's truth view's frame rate in headless Chromium (a measurement for
// docs/BENCHMARKS.md, not a test): opens the page, lets it settle 4 s, then samples once a
// second what the page reports of its big view — frames in the last second, the state-to-
// screen latency, the share of the canvas's pixels drawn — and prints them and the means as
// one JSON line.
//
//   heli hilsim --ptys /tmp/dev --view 127.0.0.1:8093 --scenario demo --duration 200 &
//   node tests/ui/view-fps.mjs 'http://127.0.0.1:8093/?key=KEY&resolution=0.5' 10
//
// Add `&resolution=S` to the URL to fix the share drawn (else the page adapts it).
import { chromium } from "playwright-core";

const [url, seconds = "10"] = process.argv.slice(2);
if (!url) {
  console.error("usage: node view-fps.mjs URL [seconds]");
  process.exit(2);
}
const browser = await chromium.launch({
  executablePath: process.env.HELI_CHROMIUM || "/usr/bin/chromium",
  args: ["--no-sandbox"],
});
try {
  const page = await browser.newPage({ viewport: { width: 1400, height: 1180 } });
  await page.goto(url);
  await page.waitForFunction(() => window.truthView && window.truthView.main, null, { timeout: 30000 });
  await new Promise((r) => setTimeout(r, 4000));
  const samples = [];
  for (let i = 0; i < Number(seconds); i++) {
    await new Promise((r) => setTimeout(r, 1000));
    samples.push(await page.evaluate(() => {
      const m = window.truthView.main;
      return { fps: m.fps, latency_ms: m.latency_ms, resolution: m.resolution };
    }));
  }
  const mean = (k) => samples.reduce((s, x) => s + (x[k] || 0), 0) / samples.length;
  console.log(JSON.stringify({
    fps_mean: Math.round(10 * mean("fps")) / 10,
    latency_ms_mean: Math.round(mean("latency_ms")),
    resolution_last: samples[samples.length - 1].resolution,
    samples,
  }));
} finally {
  await browser.close();
}
