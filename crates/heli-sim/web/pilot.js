// Pilot in the loop (`heli hilsim --view ADDR --pilot`): a person flies the simulated
// helicopter from this page. A gamepad or an RC transmitter's USB port (the browser's
// Gamepad API) or, with none connected, the keyboard gives the sticks and the auto and
// bypass switches; they go to the simulator 50 times a second, which hands them to its
// receiver and servo controller board as a transmitter's would. "Take the transmitter"
// asks the simulator for it — one page holds it at a time, and the sticks of any other page
// are refused — and "Release" gives it back to the scenario's pilot; a page that stops
// sending (or closes) loses the signal after half a second, as a receiver would.
//
// Stick mapping, expo and trims are kept in the browser (localStorage "heli.pilot.v1").
// The trainer's panel triggers failures of the fault catalog now.
// window.heliPilot holds the state, for tests.
"use strict";

(function () {
  const CHANNELS = ["aileron", "elevator", "rudder", "collective"];
  const STORE = "heli.pilot.v1";
  // Mode 2, as most transmitters and gamepads: left stick collective (up) and rudder,
  // right stick cyclic. The Gamepad API gives -1 for a stick pushed up.
  const DEFAULTS = {
    aileron: { axis: 2, invert: false, expo: 0.3, trim: 0 },
    elevator: { axis: 3, invert: false, expo: 0.3, trim: 0 },
    rudder: { axis: 0, invert: false, expo: 0.2, trim: 0 },
    collective: { axis: 1, invert: true, expo: 0, trim: 0 },
    autoButton: 5,
    bypassButton: 4,
    keyCyclic: 0.5,
  };
  const FAULTS = [
    ["engine failure", { kind: "engine-failure" }],
    ["GPS outage 15 s", { kind: "gps-outage", seconds: 15 }],
    ["GPS glitch 20 m", { kind: "gps-glitch", north_m: 20, east_m: 0, seconds: 10 }],
    ["GPS 3 satellites 60 s", { kind: "gps-satellites", satellites: 3, seconds: 60 }],
    ["IMU silent 0.5 s", { kind: "imu-silent", seconds: 0.5 }],
    ["altimeter silent 10 s", { kind: "altimeter-silent", seconds: 10 }],
    ["compass silent 10 s", { kind: "compass-silent", seconds: 10 }],
    ["transmitter lost 3 s", { kind: "transmitter-lost", seconds: 3 }],
    ["servo board silent 3 s", { kind: "servo-board-silent", seconds: 3 }],
    ["aileron servo stuck 2 s", { kind: "servo-stuck", channel: "aileron", seconds: 2 }],
    ["gust 6 m/s from the west 3 s", { kind: "gust", north_mps: 0, east_mps: 6, seconds: 3 }],
  ];

  function load() {
    try {
      const saved = JSON.parse(localStorage.getItem(STORE) || "null");
      if (saved && typeof saved === "object") {
        const out = JSON.parse(JSON.stringify(DEFAULTS));
        for (const k of Object.keys(DEFAULTS)) {
          if (typeof DEFAULTS[k] === "object") Object.assign(out[k], saved[k] || {});
          else if (typeof saved[k] === "number") out[k] = saved[k];
        }
        return out;
      }
    } catch (e) { /* a broken store: the defaults */ }
    return JSON.parse(JSON.stringify(DEFAULTS));
  }

  const st = {
    enabled: false, holding: false, you: null, holder: null, source: "none", settings: load(),
    auto: true, bypass: false, throttle: 0.8, keyCollective: 0,
    keys: new Set(), buttons: [], sent: null, errors: [], frames: 0, trainer: [],
  };
  window.heliPilot = st;

  const clamp = (v, lo, hi) => Math.max(lo, Math.min(hi, v));
  const expo = (x, e) => (1 - e) * x + e * x * x * x;

  function pad() {
    const pads = (navigator.getGamepads && navigator.getGamepads()) || [];
    for (const p of pads) if (p && p.connected !== false) return p;
    return null;
  }

  // Latched switches toggle on a button's press, as a transmitter's switch is flipped.
  function pressed(p, index, which) {
    const now = !!(p.buttons[index] && p.buttons[index].pressed);
    const was = st.buttons[index];
    st.buttons[index] = now;
    if (now && !was) st[which] = !st[which];
  }

  function sticks(dt) {
    const s = st.settings;
    const p = pad();
    const raw = {};
    if (p) {
      st.source = `gamepad: ${p.id}`;
      for (const ch of CHANNELS) {
        const v = p.axes[s[ch].axis] || 0;
        raw[ch] = s[ch].invert ? -v : v;
      }
      pressed(p, s.autoButton, "auto");
      pressed(p, s.bypassButton, "bypass");
    } else {
      st.source = "keyboard";
      const k = (a, b) => (st.keys.has(b) ? s.keyCyclic : 0) - (st.keys.has(a) ? s.keyCyclic : 0);
      raw.aileron = k("ArrowLeft", "ArrowRight");
      raw.elevator = k("ArrowUp", "ArrowDown"); // stick forward: nose down
      raw.rudder = k("a", "d");
      const rate = 0.8 * dt;
      if (st.keys.has("w")) st.keyCollective += rate;
      if (st.keys.has("s")) st.keyCollective -= rate;
      st.keyCollective = clamp(st.keyCollective, -1, 1);
      raw.collective = st.keyCollective;
    }
    const out = {};
    for (const ch of CHANNELS) {
      out[ch] = clamp(expo(clamp(raw[ch], -1, 1), s[ch].expo) + s[ch].trim, -1, 1);
    }
    return out;
  }

  let last = performance.now();
  function tick() {
    const now = performance.now();
    const dt = Math.min(0.1, (now - last) / 1000);
    last = now;
    if (!st.enabled) return;
    const s = sticks(dt);
    if (st.holding) {
      const msg = { type: "pilot", ...s, throttle: st.throttle, auto: st.auto, bypass: st.bypass };
      if (window.heliViewSend && window.heliViewSend(msg)) st.sent = msg;
    }
    show(s);
  }

  function el(tag, attrs, text) {
    const e = document.createElement(tag);
    Object.assign(e, attrs || {});
    if (text !== undefined) e.textContent = text;
    return e;
  }

  function bar(name, v, lo) {
    const w = 120, x = ((v - lo) / (1 - lo)) * w;
    return `<div class="bar"><span>${name}</span><svg width="${w}" height="10">` +
      `<rect width="${w}" height="10" fill="#1b222b"/>` +
      `<rect x="${Math.min(x, ((0 - lo) / (1 - lo)) * w)}" width="${Math.abs(x - ((0 - lo) / (1 - lo)) * w)}" height="10" fill="#6bb5ff"/>` +
      `</svg><b>${v.toFixed(2)}</b></div>`;
  }

  function show(s) {
    const f = st.frame;
    const sw = (on) => (on ? "ON" : "off");
    document.getElementById("pilot-state").innerHTML =
      `<div>${st.holding ? "<b class=ok>you have the transmitter</b>"
        : st.holder !== null ? `page ${st.holder} has the transmitter (you are page ${st.you})`
          : "the scenario's pilot has the transmitter"}` +
      ` · input: ${st.source}</div>` +
      CHANNELS.map((ch) => bar(ch, s[ch], -1)).join("") +
      `<div>auto switch <b id="sw-auto">${sw(st.auto)}</b> · bypass <b id="sw-bypass">${sw(st.bypass)}</b>` +
      ` · throttle ${st.throttle.toFixed(2)}</div>` +
      (f ? `<div>the simulator's receiver: ${f.live_pilot ? "this page" : "scenario"}` +
        `${f.signal_lost ? ", <b class=bad>SIGNAL LOST</b>" : ""}, auto ${sw(f.auto_switch)}, bypass ${sw(f.bypass_switch)}</div>` +
        `<div>servos: ${f.servos.slice(0, 4).map((v) => v.toFixed(2)).join(" ")}</div>` : "");
  }

  function settingsForm() {
    const box = document.getElementById("pilot-settings");
    box.innerHTML = "";
    const t = el("table");
    t.appendChild(el("tr", { innerHTML: "<th>channel</th><th>axis</th><th>invert</th><th>expo</th><th>trim</th>" }));
    for (const ch of CHANNELS) {
      const c = st.settings[ch];
      const tr = el("tr");
      tr.appendChild(el("td", {}, ch));
      const input = (key, attrs) => {
        const td = el("td");
        const i = el("input", { id: `set-${ch}-${key}`, ...attrs });
        if (attrs.type === "checkbox") i.checked = c[key]; else i.value = c[key];
        i.onchange = () => {
          const v = attrs.type === "checkbox" ? i.checked : Number(i.value);
          if (attrs.type !== "checkbox" && !Number.isFinite(v)) { i.value = c[key]; return; }
          c[key] = attrs.type === "checkbox" ? v : clamp(v, Number(attrs.min), Number(attrs.max));
          i.value = attrs.type === "checkbox" ? "" : c[key];
          localStorage.setItem(STORE, JSON.stringify(st.settings));
        };
        td.appendChild(i);
        tr.appendChild(td);
      };
      input("axis", { type: "number", min: 0, max: 15, step: 1 });
      input("invert", { type: "checkbox" });
      input("expo", { type: "number", min: 0, max: 1, step: 0.05 });
      input("trim", { type: "number", min: -0.3, max: 0.3, step: 0.01 });
      t.appendChild(tr);
    }
    box.appendChild(t);
    const reset = el("button", { type: "button" }, "defaults");
    reset.onclick = () => {
      st.settings = JSON.parse(JSON.stringify(DEFAULTS));
      localStorage.setItem(STORE, JSON.stringify(st.settings));
      settingsForm();
    };
    box.appendChild(reset);
  }

  function trainerPanel() {
    const box = document.getElementById("trainer-buttons");
    for (const [label, fault] of FAULTS) {
      const b = el("button", { type: "button" }, label);
      b.onclick = () => window.heliViewSend && window.heliViewSend({ type: "fault", fault });
      box.appendChild(b);
    }
  }

  window.heliPilotHooks = {
    setup(m) {
      st.enabled = !!m.pilot;
      document.getElementById("pilot").hidden = !st.enabled;
      if (m.transmitter) {
        st.auto = !!m.transmitter.auto;
        st.throttle = Number(m.transmitter.throttle) || 0.8;
      }
    },
    frame(m) {
      st.frame = m;
      st.frames++;
      if (m.trainer) {
        st.trainer = m.trainer;
        document.getElementById("trainer-log").textContent =
          m.trainer.map((e) => `t=${e.t_s.toFixed(1)} s  ${e.message}`).join("\n");
      }
    },
    // Who holds the transmitter, from the simulator: this page flies only when it does.
    transmitter(m) {
      st.you = m.you;
      st.holder = m.holder;
      st.holding = m.holder !== null && m.holder === m.you;
      const take = document.getElementById("take");
      take.textContent = st.holding ? "Release the transmitter" : "Take the transmitter";
      take.disabled = m.holder !== null && !st.holding;
      take.title = take.disabled ? `page ${m.holder} holds the transmitter` : "";
    },
    error(m) {
      st.errors.push(m.message);
      document.getElementById("pilot-error").textContent = m.message;
    },
  };

  document.addEventListener("DOMContentLoaded", () => {
    const take = document.getElementById("take");
    take.onclick = () => {
      if (!window.heliViewSend) return;
      window.heliViewSend({ type: st.holding ? "release" : "take" });
    };
    document.getElementById("sw-auto-btn").onclick = () => { st.auto = !st.auto; };
    document.getElementById("sw-bypass-btn").onclick = () => { st.bypass = !st.bypass; };
    settingsForm();
    trainerPanel();
  });
  const keyName = (e) => (e.key.length === 1 ? e.key.toLowerCase() : e.key);
  const FLYING_KEYS = ["ArrowLeft", "ArrowRight", "ArrowUp", "ArrowDown", "a", "d", "w", "s"];
  window.addEventListener("keydown", (e) => {
    if (e.target && e.target.tagName === "INPUT") return;
    const k = keyName(e);
    if (FLYING_KEYS.includes(k)) { st.keys.add(k); e.preventDefault(); }
    if (!e.repeat && k === "m") st.auto = !st.auto;
    if (!e.repeat && k === "b") st.bypass = !st.bypass;
  });
  window.addEventListener("keyup", (e) => st.keys.delete(keyName(e)));
  window.addEventListener("blur", () => st.keys.clear());
  setInterval(tick, 20);
})();
