// The HILSim's view: the simulator's truth (never the vehicle's estimate), drawn on every
// animation frame from the newest frame `heli hilsim --view` sends (30 a second at most).
// window.truthView holds what was drawn last, for tests.
"use strict";

(function () {
  const DEG = 180 / Math.PI;
  const state = { setup: null, frame: null, history: [], home: null, frames: 0 };
  window.truthView = { frames: 0, chase: null, field: null, t_s: null, roll_deg: null };

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

  function draw() {
    const f = state.frame;
    if (f) {
      const plan = (state.setup && state.setup.plan) || [];
      const common = { home: state.home, flapScale: 3 };
      const chase = window.heliInstruments.view3d(f, state.history, plan,
        { ...common, canvas: "chase", camera: "chase", label: "TRUTH (simulator), chase camera" });
      const field = window.heliInstruments.view3d(f, state.history, plan,
        { ...common, canvas: "field", camera: "field", label: "TRUTH (simulator), field camera" });
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
        frames: state.frames, chase, field, t_s: f.t_s, roll_deg: r * DEG,
        height_m: height, trail: state.history.length,
      };
    }
    requestAnimationFrame(draw);
  }

  connect();
  requestAnimationFrame(draw);
})();
