// The instruments of the display, drawn from telemetry (the estimate, never the simulator's
// truth): attitude indicator, top-down track, the 3D view of the helicopter, and plots.
// Plain 2D canvas; no library. The 3D view is view3d.js's (WebGL) where the page set one up
// (window.heliEstimateView), else, once the page has found no WebGL (window.heliEstimateFlat),
// the flat drawing here, which the simulator's page also falls back on.
"use strict";

(function () {
  const DEG = 180 / Math.PI;

  function ctx(id) {
    const c = document.getElementById(id);
    return c ? c.getContext("2d") : null;
  }

  function clear(g, text) {
    g.fillStyle = "#0b0e12";
    g.fillRect(0, 0, g.canvas.width, g.canvas.height);
    if (text) {
      g.fillStyle = "#8a94a3";
      g.font = "13px system-ui";
      g.fillText(text, 12, 22);
    }
  }

  // Attitude indicator: the horizon rolls with the roll angle and moves with the pitch.
  function attitude(inst) {
    const g = ctx("attitude");
    if (!g) return;
    const w = g.canvas.width, h = g.canvas.height, cx = w / 2, cy = h / 2;
    if (!inst) return clear(g, "NOTHING YET");
    const [roll, pitch, yaw] = inst.euler_rad;
    const pxPerRad = h / 1.2;
    g.save();
    g.translate(cx, cy);
    g.rotate(-roll);
    g.translate(0, pitch * pxPerRad);
    g.fillStyle = "#3b7fc4";
    g.fillRect(-w * 2, -h * 4, w * 4, h * 4);
    g.fillStyle = "#8a5a2b";
    g.fillRect(-w * 2, 0, w * 4, h * 4);
    g.strokeStyle = "#fff";
    g.lineWidth = 1;
    g.font = "10px system-ui";
    g.fillStyle = "#fff";
    for (let d = -60; d <= 60; d += 10) {
      if (d === 0) continue;
      const y = -d / DEG * pxPerRad;
      const half = d % 20 === 0 ? 30 : 15;
      g.beginPath(); g.moveTo(-half, y); g.lineTo(half, y); g.stroke();
      if (d % 20 === 0) g.fillText(String(d), half + 4, y + 3);
    }
    g.lineWidth = 2;
    g.beginPath(); g.moveTo(-w * 2, 0); g.lineTo(w * 2, 0); g.stroke();
    g.restore();
    // The aircraft symbol stays fixed.
    g.strokeStyle = "#ffd24a";
    g.lineWidth = 3;
    g.beginPath(); g.moveTo(cx - 45, cy); g.lineTo(cx - 12, cy); g.lineTo(cx, cy + 8);
    g.lineTo(cx + 12, cy); g.lineTo(cx + 45, cy); g.stroke();
    g.fillStyle = "#fff";
    g.font = "12px ui-monospace, monospace";
    const hdg = ((yaw * DEG) % 360 + 360) % 360;
    g.fillText(`HDG ${hdg.toFixed(0).padStart(3, "0")}°`, cx - 32, 16);
    g.fillText(`R ${(roll * DEG).toFixed(0)}° P ${(pitch * DEG).toFixed(0)}°`, 8, h - 8);
  }

  // Top-down track: north up, the trail of the estimate, home, and the helicopter's heading.
  function track(inst, history, plan) {
    const g = ctx("track");
    if (!g) return;
    const w = g.canvas.width, h = g.canvas.height;
    const pts = history.filter((s) => s.pos_ned_m).map((s) => s.pos_ned_m);
    if (!inst || !pts.length) return clear(g, "NOTHING YET");
    clear(g);
    let span = 10;
    for (const p of pts.concat(plan.map((q) => q.point))) {
      span = Math.max(span, Math.abs(p[0]) * 2.4, Math.abs(p[1]) * 2.4);
    }
    const scale = Math.min(w, h) / span;
    const X = (p) => w / 2 + p[1] * scale;
    const Y = (p) => h / 2 - p[0] * scale;
    g.strokeStyle = "#2a323d";
    g.lineWidth = 1;
    const step = [1, 2, 5, 10, 20, 50, 100, 200, 500, 1000].find((s) => s >= span / 8) || 2000;
    for (let m = -Math.ceil(span / step) * step; m <= span; m += step) {
      g.beginPath(); g.moveTo(X([0, m]), 0); g.lineTo(X([0, m]), h); g.stroke();
      g.beginPath(); g.moveTo(0, Y([m, 0])); g.lineTo(w, Y([m, 0])); g.stroke();
    }
    g.fillStyle = "#8a94a3";
    g.font = "11px system-ui";
    g.fillText(`grid ${step} m`, 6, h - 6);
    g.fillText("N", w / 2 - 3, 11);
    // Home.
    g.strokeStyle = "#e0a21b";
    g.strokeRect(X([0, 0]) - 5, Y([0, 0]) - 5, 10, 10);
    // The flight plan: its path dashed, each point marked with its kind's letter.
    if (plan.length) {
      g.setLineDash([5, 4]);
      g.strokeStyle = "#c792ea";
      g.lineWidth = 1.5;
      g.beginPath();
      plan.forEach((q, i) => (i ? g.lineTo(X(q.point), Y(q.point)) : g.moveTo(X(q.point), Y(q.point))));
      g.stroke();
      g.setLineDash([]);
      g.fillStyle = "#c792ea";
      g.font = "11px system-ui";
      const letter = { takeoff: "T", hold: "H", waypoint: "W", rolls: "R", land: "L" };
      for (const q of plan) {
        g.beginPath(); g.arc(X(q.point), Y(q.point), 3, 0, 2 * Math.PI); g.fill();
        g.fillText(letter[q.kind] || "?", X(q.point) + 5, Y(q.point) - 4);
      }
      g.fillText("plan", w - 34, h - 6);
    }
    // Trail.
    g.strokeStyle = "#4a90d9";
    g.lineWidth = 2;
    g.beginPath();
    pts.forEach((p, i) => (i ? g.lineTo(X(p), Y(p)) : g.moveTo(X(p), Y(p))));
    g.stroke();
    const p = inst.pos_ned_m || pts[pts.length - 1];
    const yaw = inst.euler_rad[2];
    g.save();
    g.translate(X(p), Y(p));
    g.rotate(yaw);
    g.fillStyle = "#ffd24a";
    g.beginPath(); g.moveTo(0, -9); g.lineTo(6, 7); g.lineTo(-6, 7); g.closePath(); g.fill();
    g.restore();
    g.fillStyle = "#e6e9ee";
    g.fillText(`N ${p[0].toFixed(1)} E ${p[1].toFixed(1)} h ${(-p[2]).toFixed(1)} m`, 6, 14);
  }

  // Rotation body → NED from roll, pitch, yaw (ZYX).
  function dcm([phi, theta, psi]) {
    const cf = Math.cos(phi), sf = Math.sin(phi), ct = Math.cos(theta), st = Math.sin(theta);
    const cp = Math.cos(psi), sp = Math.sin(psi);
    return [
      [ct * cp, sf * st * cp - cf * sp, cf * st * cp + sf * sp],
      [ct * sp, sf * st * sp + cf * cp, cf * st * sp - sf * cp],
      [-st, sf * ct, cf * ct],
    ];
  }
  const mul = (m, v) => m.map((r) => r[0] * v[0] + r[1] * v[1] + r[2] * v[2]);

  const sub = (a, b) => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
  const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
  const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
  const unit = (a) => { const n = Math.hypot(a[0], a[1], a[2]) || 1; return [a[0] / n, a[1] / n, a[2] / n]; };

  // 3D view of a helicopter state `inst` (pos_ned_m, euler_rad, and flap_rad if known): the
  // field's grid, home, the flight plan, the trail, the helicopter as lines (fuselage, tail
  // boom, skids, and the rotor disk, tilted by the flapping when it is known). Options:
  // canvas (id), camera ("chase": 9 m behind along the heading and 4 m above; "field": fixed
  // 25 m south and 25 m west of home, 6 m up, zooming with the range), label, home ([n, e, d]), flapScale (the disk's tilt is
  // drawn this many times its size). Returns what was drawn, for tests.
  function view3d(inst, history, plan, opts) {
    opts = opts || {};
    const g = ctx(opts.canvas || "view3d");
    // What is on the canvas (heliPx: the rotor's radius in pixels).
    const stats = { heliOnScreen: false, heliXY: null, heliPx: 0, gridLines: 0, trailSegments: 0 };
    if (!g) return stats;
    const w = g.canvas.width, h = g.canvas.height;
    if (!inst || !inst.pos_ned_m) { clear(g, "NOTHING YET"); return stats; }
    const gradient = g.createLinearGradient(0, 0, 0, h);
    gradient.addColorStop(0, "#1d3550");
    gradient.addColorStop(1, "#0b0e12");
    g.fillStyle = gradient;
    g.fillRect(0, 0, w, h);
    const pos = inst.pos_ned_m;
    const yaw = inst.euler_rad[2];
    const home = opts.home || [0, 0, 0];
    const ground = home[2];
    const field = opts.camera === "field";
    const cam = field
      ? [home[0] - 25, home[1] - 25, ground - 6]
      : [pos[0] - 9 * Math.cos(yaw), pos[1] - 9 * Math.sin(yaw), pos[2] - 4];
    // The field camera frames the helicopter and the ground below it, zooming as a camera
    // operator would to keep the helicopter's size while both stay in view.
    const height = Math.max(0, ground - pos[2]);
    const target = field ? [pos[0], pos[1], pos[2] + 0.4 * height] : pos;
    const fwd = unit(sub(target, cam));
    const right = unit(cross([0, 0, 1], fwd));
    const down = cross(fwd, right);
    const range = Math.hypot(...sub(pos, cam));
    const f = field
      ? Math.min(w * 0.9 * Math.max(1, range / 20), (0.7 * h * range) / Math.max(height, 1))
      : w * 0.9;
    const project = (p) => {
      const d = sub(p, cam);
      const z = dot(d, fwd);
      if (z < 0.5) return null;
      return [w / 2 + (f * dot(d, right)) / z, h / 2 + (f * dot(d, down)) / z];
    };
    // Draws a segment; true when some of it is on the canvas.
    const line = (a, b, color, width) => {
      const pa = project(a), pb = project(b);
      if (!pa || !pb) return false;
      g.strokeStyle = color;
      g.lineWidth = width || 1;
      g.beginPath(); g.moveTo(pa[0], pa[1]); g.lineTo(pb[0], pb[1]); g.stroke();
      return Math.max(pa[0], pb[0]) >= 0 && Math.min(pa[0], pb[0]) <= w &&
        Math.max(pa[1], pb[1]) >= 0 && Math.min(pa[1], pb[1]) <= h;
    };
    // Field grid, 5 m, around the point below the helicopter.
    const gx = Math.round(pos[0] / 5) * 5, gy = Math.round(pos[1] / 5) * 5;
    for (let k = -40; k <= 40; k += 5) {
      if (line([gx + k, gy - 40, ground], [gx + k, gy + 40, ground], "#27452f")) stats.gridLines++;
      if (line([gx - 40, gy + k, ground], [gx + 40, gy + k, ground], "#27452f")) stats.gridLines++;
    }
    // Home, the take-off point.
    line([home[0] - 1, home[1], ground], [home[0] + 1, home[1], ground], "#e0a21b", 2);
    line([home[0], home[1] - 1, ground], [home[0], home[1] + 1, ground], "#e0a21b", 2);
    // The flight plan (heights up from home).
    const planNed = (plan || []).map((q) => [home[0] + q.point[0], home[1] + q.point[1], ground - q.point[2]]);
    g.setLineDash([5, 4]);
    for (let i = 1; i < planNed.length; i++) line(planNed[i - 1], planNed[i], "#c792ea", 1.5);
    g.setLineDash([]);
    // Trail.
    const pts = history.filter((s) => s.pos_ned_m).map((s) => s.pos_ned_m);
    for (let i = 1; i < pts.length; i++) if (line(pts[i - 1], pts[i], "#4a90d9", 1.5)) stats.trailSegments++;
    // Shadow straight below.
    line([pos[0], pos[1], ground], [pos[0], pos[1], pos[2]], "#55606e");
    // The helicopter, in the body frame (x forward, y right, z down), metres.
    const R = dcm(inst.euler_rad);
    const at = (b) => { const n = mul(R, b); return [pos[0] + n[0], pos[1] + n[1], pos[2] + n[2]]; };
    line(at([0.6, 0, 0]), at([-0.4, 0, 0]), "#ffd24a", 4);
    line(at([-0.4, 0, 0]), at([-1.4, 0, -0.1]), "#ffd24a", 2);
    line(at([-1.4, 0, -0.1]), at([-1.4, 0, -0.35]), "#ffd24a", 2);
    line(at([0.3, 0.22, 0.35]), at([-0.3, 0.22, 0.35]), "#c9ced6", 2);
    line(at([0.3, -0.22, 0.35]), at([-0.3, -0.22, 0.35]), "#c9ced6", 2);
    line(at([0.2, 0, 0.25]), at([0.2, 0.22, 0.35]), "#c9ced6");
    line(at([0.2, 0, 0.25]), at([0.2, -0.22, 0.35]), "#c9ced6");
    line(at([0, 0, 0]), at([0, 0, -0.3]), "#c9ced6", 2);
    // Rotor disk: tilted back by a1 and right by b1 (its plane spanned by (1, 0, −a1) and
    // (0, 1, b1) in the body frame).
    const k = opts.flapScale || 1;
    const [a1, b1] = inst.flap_rad ? [inst.flap_rad[0] * k, inst.flap_rad[1] * k] : [0, 0];
    const disk = [];
    for (let a = 0; a <= 24; a++) {
      const t = (a / 24) * 2 * Math.PI;
      const c = 0.77 * Math.cos(t), s = 0.77 * Math.sin(t);
      disk.push(at([c, s, -0.3 - a1 * c + b1 * s]));
    }
    for (let i = 1; i < disk.length; i++) line(disk[i - 1], disk[i], "#e6e9ee", 1.5);
    const hp = project(pos);
    stats.heliPx = hp ? (f * 0.77) / Math.max(0.5, dot(sub(pos, cam), fwd)) : 0;
    if (hp && hp[0] >= 0 && hp[0] <= w && hp[1] >= 0 && hp[1] <= h) {
      stats.heliOnScreen = true;
      stats.heliXY = hp;
    }
    g.fillStyle = "#e6e9ee";
    g.font = "12px system-ui";
    g.fillText(opts.label || "estimated (telemetry), chase camera", 8, 16);
    return stats;
  }

  // A strip chart of `series` ([name, color, pick]) over the last 30 s.
  function plot(id, history, series, limit) {
    const g = ctx(id);
    if (!g) return;
    const w = g.canvas.width, h = g.canvas.height;
    if (!history.length) return clear(g, "NOTHING YET");
    clear(g);
    const t1 = history[history.length - 1].time_s, t0 = t1 - 30;
    let max = limit;
    for (const s of history) for (const [, , pick] of series) {
      const v = pick(s);
      if (v !== null && isFinite(v)) max = Math.max(max, Math.abs(v));
    }
    g.strokeStyle = "#2a323d";
    g.beginPath(); g.moveTo(0, h / 2); g.lineTo(w, h / 2); g.stroke();
    series.forEach(([name, color, pick], k) => {
      g.strokeStyle = color;
      g.lineWidth = 1.5;
      g.beginPath();
      let started = false;
      for (const s of history) {
        const v = pick(s);
        if (v === null || !isFinite(v)) continue;
        const x = ((s.time_s - t0) / 30) * w, y = h / 2 - (v / max) * (h / 2 - 4);
        started ? g.lineTo(x, y) : g.moveTo(x, y);
        started = true;
      }
      g.stroke();
      g.fillStyle = color;
      g.font = "11px system-ui";
      g.fillText(name, 6 + k * 22, 12);
    });
    g.fillStyle = "#8a94a3";
    g.fillText(`±${max.toFixed(max < 2 ? 1 : 0)}`, w - 40, 12);
  }

  window.heliInstruments = {
    view3d,
    draw(inst, history, plan) {
      attitude(inst);
      track(inst, history, plan || []);
      // The 3D view of the estimate (view3d.js, set up by the page) where WebGL is; the
      // flat drawing where it is not.
      // (Nothing until the page has tried WebGL: a canvas drawn flat first can never be
      // WebGL's.)
      const solid = window.heliEstimateView;
      if (solid && inst && inst.pos_ned_m) {
        window.heliEstimateDrawn = solid.render(inst, history, plan || [], [0, 0, 0], null)[0];
      } else if (window.heliEstimateFlat) {
        view3d(inst, history, plan || []);
      }
      plot("plot-rates", history, [
        ["p", "#ff6b6b", (s) => s.rate_rps[0] * DEG],
        ["q", "#6bd36b", (s) => s.rate_rps[1] * DEG],
        ["r", "#6bb5ff", (s) => s.rate_rps[2] * DEG],
      ], 10);
      plot("plot-controls", history, [
        ["a", "#ff6b6b", (s) => (s.servo ? s.servo[0] : null)],
        ["e", "#6bd36b", (s) => (s.servo ? s.servo[1] : null)],
        ["r", "#6bb5ff", (s) => (s.servo ? s.servo[2] : null)],
        ["c", "#ffd24a", (s) => (s.servo ? s.servo[3] : null)],
      ], 1);
    },
  };
})();
