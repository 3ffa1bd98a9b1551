// The HILSim's view: the simulator's truth (never the vehicle's estimate) in 3D (view3d.js),
// drawn on every animation frame between the frames `heli hilsim --view` sends (30 a second
// at most), interpolated. The view is the pilot's by default (placeable: the inputs, or
// `?pilot=N,E` in metres from the pad), the inset the chase camera; each can be switched
// (`?camera=`, `?inset=`; `?ground=0` the helicopter alone, zoomed, not framed with its
// shadow and the horizon; `?resolution=` the share of the canvas's pixels drawn, `?max_fps=`
// a cap on the frame rate). Where WebGL is not to be had, the flat drawing of instruments.js.
// window.truthView holds what was drawn last; window.heliView the view, for tests.
import { HeliView, StateBuffer } from "./view3d.js";

const DEG = 180 / Math.PI;
const query = new URLSearchParams(location.search);
const state = { setup: null, frame: null, history: [], home: null, frames: 0, buffer: new StateBuffer() };
window.truthView = { frames: 0, main: null, side: null, t_s: null, roll_deg: null };

function connect() {
  const ws = new WebSocket(`ws://${location.host}/ws`);
  // The pilot's panel (pilot.js) sends through this socket.
  window.heliViewSend = (msg) => {
    if (ws.readyState !== WebSocket.OPEN) return false;
    ws.send(JSON.stringify(msg));
    return true;
  };
  const hooks = () => window.heliPilotHooks || {};
  ws.onmessage = (e) => {
    const m = JSON.parse(e.data);
    if (m.type === "error") {
      if (hooks().error) hooks().error(m);
    } else if (m.type === "transmitter") {
      if (hooks().transmitter) hooks().transmitter(m);
    } else if (m.type === "setup") {
      if (hooks().setup) hooks().setup(m);
      state.setup = m;
      document.getElementById("scenario").textContent = `scenario ${m.scenario}`;
    } else if (m.type === "truth") {
      if (hooks().frame) hooks().frame(m);
      if (!state.home) state.home = [m.pos_ned_m[0], m.pos_ned_m[1], 0];
      // A new run (time went back): start the trail again.
      if (state.frame && m.t_s < state.frame.t_s) state.history = [];
      state.frame = m;
      state.frames++;
      state.buffer.push(m, m.taken_unix_ms || Date.now());
      const last = state.history[state.history.length - 1];
      if (!last || m.t_s - last.t_s >= 0.1) state.history.push(m);
      while (state.history.length > 600) state.history.shift(); // 60 s of trail
    }
  };
  ws.onclose = () => {
    document.getElementById("status").textContent = "simulator gone; retrying";
    setTimeout(connect, 1000);
  };
  ws.onopen = () => { document.getElementById("status").textContent = ""; };
}

// The wind, seen from above (north up): an arrow the way it blows, and its speed.
function wind(w) {
  const c = document.getElementById("wind");
  const g = c.getContext("2d");
  g.fillStyle = "#0b0e12";
  g.fillRect(0, 0, c.width, c.height);
  g.strokeStyle = "#27303b";
  g.beginPath(); g.arc(80, 80, 60, 0, 2 * Math.PI); g.stroke();
  g.fillStyle = "#8a94a3";
  g.font = "11px system-ui";
  g.fillText("N", 76, 14);
  const speed = Math.hypot(w[0], w[1]);
  if (speed > 0.05) {
    const k = Math.min(55, 8 * speed) / speed;
    const x = w[1] * k, y = -w[0] * k; // east right, north up
    g.strokeStyle = "#6bb5ff";
    g.lineWidth = 3;
    g.beginPath(); g.moveTo(80 - x, 80 - y); g.lineTo(80 + x, 80 + y); g.stroke();
    const a = Math.atan2(y, x);
    g.beginPath();
    g.moveTo(80 + x, 80 + y);
    g.lineTo(80 + x - 10 * Math.cos(a - 0.4), 80 + y - 10 * Math.sin(a - 0.4));
    g.lineTo(80 + x - 10 * Math.cos(a + 0.4), 80 + y - 10 * Math.sin(a + 0.4));
    g.closePath(); g.fillStyle = "#6bb5ff"; g.fill();
  }
  g.fillStyle = "#e6e9ee";
  g.font = "12px system-ui";
  g.fillText(`wind ${speed.toFixed(1)} m/s`, 38, 156);
}

// The view: 3D where WebGL is (the big camera and the inset in one canvas), else the flat
// drawing (its field camera).
let view = null;
// Drawn at a scale of the canvas's resolution and scaled up, so that a software renderer (a
// laptop without a GPU, headless Chromium) keeps 30 frames a second: half scale to begin with,
// then the scale that holds the frame rate (view3d.js), or `?resolution=` fixed; not adapted
// under a `?max_fps=` cap (its frame count is the cap's).
const FIXED_RESOLUTION = Number(query.get("resolution")) || 0;
// The inset: the chase camera in the top right corner.
const INSET = { x: 1280 - 480 - 12, y: 12, w: 480, h: 300 };

async function makeView() {
  const pilot = (query.get("pilot") || "").split(",").map(Number);
  const pilotNE = pilot.length === 2 && pilot.every(Number.isFinite) ? pilot : null;
  if (pilotNE) {
    document.getElementById("pilot-n").value = pilotNE[0];
    document.getElementById("pilot-e").value = pilotNE[1];
  }
  const cameras = [query.get("camera") || "pilot", query.get("inset") || "chase"];
  // The framing: the shadow and the horizon with the helicopter where they fit, or
  // (`?ground=0`, the box unticked) the helicopter alone, zoomed.
  const ground = document.getElementById("frame-ground");
  ground.checked = query.get("ground") !== "0";
  view = await HeliView.create(document.getElementById("view-main"), {
    camera: cameras[0], inset: { ...INSET, camera: cameras[1] }, flapScale: 3,
    resolution: FIXED_RESOLUTION || 0.5, adaptive: !FIXED_RESOLUTION && !MAX_FPS,
    pilotNE: pilotNE || undefined, frameGround: ground.checked,
  });
  ground.addEventListener("change", () => { if (view) view.setFrameGround(ground.checked); });
  ["camera-main", "camera-side"].forEach((id, k) => {
    const select = document.getElementById(id);
    select.value = cameras[k];
    select.addEventListener("change", () => { if (view) view.setCamera(select.value, k); });
  });
  const place = () => {
    const ne = [Number(document.getElementById("pilot-n").value), Number(document.getElementById("pilot-e").value)];
    if (view && ne.every(Number.isFinite)) view.placePilot(ne);
  };
  document.getElementById("pilot-n").addEventListener("change", place);
  document.getElementById("pilot-e").addEventListener("change", place);
  document.getElementById("label-main").textContent = view
    ? "TRUTH (simulator)" : "TRUTH (simulator), flat drawing: this browser gives no WebGL";
  window.heliView = view;
  window.heliViewInset = INSET;
}

function perf(stats) {
  const el = document.getElementById("perf");
  if (!el || !stats || stats.fps === undefined) return;
  const latency = stats.latency_ms === null ? "–" : `${stats.latency_ms.toFixed(0)} ms`;
  el.textContent = `${stats.fps} frames/s · state to screen ${latency}` +
    ` · drawn at ${Math.round(100 * stats.resolution)} % scale` +
    ` (${Math.round(100 * stats.resolution * stats.resolution)} % of the pixels)`;
}

// A cap on the frames drawn a second (`?max_fps=`; none by default): for a weak machine, or
// a page kept open beside other work (the trainer's page of a test).
const MAX_FPS = Number(query.get("max_fps")) || 0;
let lastDrawMs = -Infinity;

function draw(nowMs) {
  if (MAX_FPS > 0 && nowMs - lastDrawMs < 1000 / MAX_FPS - 2) {
    requestAnimationFrame(draw);
    return;
  }
  lastDrawMs = nowMs;
  const f = state.frame;
  const shown = state.buffer.now();
  if (f && shown) {
    const plan = (state.setup && state.setup.plan) || [];
    let drawn;
    if (view) {
      drawn = view.render(shown.state, state.history, plan, state.home, { produced_ms: shown.produced_ms });
      perf(drawn[0]);
    } else {
      drawn = [window.heliInstruments.view3d(f, state.history, plan, {
        home: state.home, flapScale: 3, canvas: "view-main", camera: "field",
        label: "TRUTH (simulator), field camera",
      })];
    }
    wind(f.wind_ned_mps);
    const [r, p, y] = f.euler_rad;
    const height = state.home[2] - f.pos_ned_m[2];
    document.getElementById("readout").textContent =
      `t ${f.t_s.toFixed(2)} s\n` +
      `roll ${(r * DEG).toFixed(1)}°  pitch ${(p * DEG).toFixed(1)}°  yaw ${(y * DEG).toFixed(1)}°\n` +
      `height ${height.toFixed(2)} m  speed ${Math.hypot(...f.vel_ned_mps).toFixed(1)} m/s\n` +
      `rotor ${f.rotor_rpm.toFixed(0)} rpm  flapping a1 ${(f.flap_rad[0] * DEG).toFixed(2)}° b1 ${(f.flap_rad[1] * DEG).toFixed(2)}°\n` +
      (f.contact_points > 0 ? `on the ground (${f.contact_points} skid ends)` : "in the air");
    window.truthView = {
      frames: state.frames, main: drawn[0], side: drawn[1] || null, t_s: f.t_s, roll_deg: r * DEG,
      height_m: height, trail: state.history.length, webgl: Boolean(view),
    };
  }
  requestAnimationFrame(draw);
}

connect();
makeView().finally(() => requestAnimationFrame(draw));
