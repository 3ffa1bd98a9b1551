// The operator's display: draws the station's view and sends the operator's requests.
// Everything the vehicle is told goes through the ground station, which validates it; this
// page only draws and asks.
"use strict";

const ROWS = [
  ["imu", "IMU"], ["state", "STATE"], ["uplink", "UPLINK"], ["servo", "SERVO"],
  ["gps", "GPS"], ["bar", "BAR"], ["cmps", "CMPS"],
];

const page = {
  socket: null,
  client: null,
  seq: 0,
  lastCount: 0,
  lastMessage: 0,
  view: null,
  history: [],
  pending: new Map(),
};

const $ = (id) => document.getElementById(id);

function connectSocket() {
  const scheme = location.protocol === "https:" ? "wss" : "ws";
  const socket = new WebSocket(`${scheme}://${location.host}/ws`);
  page.socket = socket;
  socket.onopen = () => setLink(true);
  socket.onclose = () => {
    setLink(false);
    setTimeout(connectSocket, 1000);
  };
  socket.onmessage = (ev) => {
    let msg;
    try { msg = JSON.parse(ev.data); } catch { return; }
    if (msg.type === "hello") {
      // A new session (perhaps a restarted ground station): its messages are numbered anew.
      page.client = msg.client;
      page.lastMessage = 0;
    }
    else if (msg.type === "view") render(msg.view);
    else if (msg.type === "reply") showReply(msg);
  };
}

function setLink(up) {
  const el = $("link-state");
  el.textContent = up ? "ground station connected" : "no link to the ground station";
  el.className = "pill " + (up ? "good" : "bad");
  // Without the ground station nothing on the page is current and nothing can be sent: the
  // last view is greyed out, every button off and the vehicle's pill says it is not known,
  // until a view comes again.
  document.body.dataset.link = up ? "up" : "down";
  if (!up) {
    for (const b of document.querySelectorAll("button")) b.disabled = true;
    const v = $("vehicle-state");
    v.textContent = "vehicle: not known (no ground station)";
    v.className = "pill bad";
  }
}

// Sends a request; its answer comes back as a reply with the same sequence number.
function send(op, extra = {}) {
  if (!page.socket || page.socket.readyState !== WebSocket.OPEN) {
    showReply({ ok: false, text: "not connected to the ground station" });
    return;
  }
  page.seq += 1;
  page.socket.send(JSON.stringify({ seq: page.seq, op, ...extra }));
}

function showReply(msg) {
  const el = $("reply");
  el.textContent = msg.text || "";
  el.className = msg.ok ? "" : "error";
}

// For tests and scripting: send a request as raw text (a replay, a malformed message).
window.heli = {
  sendRaw: (text) => page.socket.send(text),
  request: (op, extra) => send(op, extra),
  view: () => page.view,
  seq: () => page.seq,
};

function render(view) {
  page.view = view;
  const inControl = page.client !== null && view.operators.holder === page.client;
  renderOperators(view, inControl);
  renderPanel(view, inControl);
  renderVehicle(view);
  renderRows(view);
  renderPower(view);
  renderSafety(view.safety);
  renderMessages(view.messages);
  const last = page.history[page.history.length - 1];
  if (view.instruments && (!last || view.instruments.time_s !== last.time_s)) {
    page.history.push(view.instruments);
    const cut = view.instruments.time_s - 30;
    while (page.history.length && page.history[0].time_s < cut) page.history.shift();
    if (page.history.length > 2000) page.history.shift();
  }
  window.heliInstruments.draw(view.instruments, page.history, view.plan);
}

function renderOperators(view, inControl) {
  const ops = view.operators;
  const token = $("token");
  const who = ops.holder === null ? "nobody" : inControl ? "you" : `operator ${ops.holder}`;
  token.textContent = `${ops.pages} page${ops.pages === 1 ? "" : "s"} · in control: ${who}`;
  token.className = inControl ? "mine" : "";
  $("take-control").disabled = ops.holder !== null;
  $("release-control").disabled = !inControl;
}

function renderPanel(view, inControl) {
  const p = view.panel;
  const watching = inControl ? "" : "take control to command";
  for (const [id, active] of [["connect", p.connect], ["start", p.start], ["stop", p.stop]]) {
    $(id).disabled = !(active && inControl);
    $(id).title = active ? watching : "not active now";
  }
  const ind = $("indicator");
  ind.className = "indicator " + (p.green ? "green" : "red");
  if (p.telemetry_count > page.lastCount) {
    ind.classList.add("flash");
    setTimeout(() => ind.classList.remove("flash"), 120);
  }
  page.lastCount = p.telemetry_count;
  $("counter").textContent = String(p.telemetry_count);
  document.body.dataset.panel = p.state;
}

function renderVehicle(view) {
  const v = view.vehicle;
  const el = $("vehicle-state");
  // The bootstrap's state, the phase actually flown, and the mode asked: a refused take-off
  // or a failsafe reads as such, not as the mode asked for.
  const asked = v.mode ? ` (${v.mode} asked)` : "";
  el.textContent = !v.heard
    ? `vehicle: not heard${v.heartbeat_age_s != null ? ` for ${v.heartbeat_age_s.toFixed(0)} s` : ""}`
    : v.phase
      ? `vehicle: ${v.state}, ${v.phase}${asked}`
      : `vehicle: ${v.state}${v.mode ? ", " + v.mode : ""}`;
  const trouble = ["takeoff-refused", "blind-descent", "ground-failsafe", "autorotation"];
  el.className = "pill " + (!v.heard ? "bad" : trouble.includes(v.phase) ? "warn" : "good");
}

function renderRows(view) {
  const body = $("rows-body");
  if (!body.children.length) {
    for (const [key, name] of ROWS) {
      const tr = document.createElement("tr");
      tr.id = `row-${key}`;
      body.appendChild(tr);
    }
  }
  for (const [key, name] of ROWS) {
    const tr = $(`row-${key}`);
    const row = view.rows[key];
    tr.className = row && row.stale ? "stale" : "";
    let html = `<td class="name">${name}</td>`;
    if (!row) {
      html += `<td class="nothing" colspan="11">NOTHING YET</td>`;
    } else {
      html += `<td><span class="cell-label">Time s</span>${row.time_s.toFixed(2)}</td>`;
      for (const c of row.cells) {
        html += `<td><span class="cell-label">${esc(c.label)}</span>${esc(c.value)}</td>`;
      }
    }
    if (tr.innerHTML !== html) tr.innerHTML = html;
  }
}

function renderPower(view) {
  const b = view.battery;
  const meter = $("battery");
  if (b) {
    $("battery-fill").style.height = `${Math.max(0, Math.min(100, b.percent))}%`;
    meter.className = "meter " + (b.green ? "green" : "red");
    $("battery-pct").textContent = `${b.percent.toFixed(0)} %`;
    $("battery-v").textContent = `${b.volts.toFixed(2)} V`;
  } else {
    $("battery-fill").style.height = "0";
    $("battery-pct").textContent = "–";
    $("battery-v").textContent = "– V";
  }
  const g = view.gps;
  // The lamp follows the freshest fix: grey, with its age, when the fix is old or the
  // vehicle says its GPS is not on time.
  $("gps-indicator").className = "lamp " + (!g ? "red" : g.stale ? "grey" : g.ok ? "green" : "red");
  $("gps-sats").textContent = !g
    ? "no fix"
    : g.stale
      ? `stale: ${g.satellites} satellites ${g.age_s.toFixed(1)} s ago`
      : `${g.satellites} satellites`;
  renderPacks(view.power);
}

function minutes(m) {
  return m == null ? "" : `${m.toFixed(0)} min`;
}

function seconds(s) {
  if (s == null) return "–";
  const m = Math.floor(s / 60);
  return `${m}:${String(Math.floor(s - 60 * m)).padStart(2, "0")}`;
}

// Every pack as the vehicle's gauge reports it, the hot-swap's times, the field rule.
function renderPacks(p) {
  const flight = p.packs.find((k) => k.name === "flight battery");
  $("battery-min").textContent = flight ? minutes(flight.minutes_left) : "";
  let html = "";
  for (const k of p.packs) {
    const pct = k.percent == null ? "–" : `${k.percent.toFixed(0)} %`;
    html += `<li class="pack ${k.state}" data-name="${esc(k.name)}"><span class="pack-name">${esc(k.name)}</span> ` +
      `${k.volts.toFixed(2)} V ${pct} ${minutes(k.minutes_left)}</li>`;
  }
  if ($("packs").innerHTML !== html) $("packs").innerHTML = html;
  $("power-source").textContent = p.source ? `on the ${p.source} battery` : "hot-swap not read";
  $("power-times").textContent = p.source
    ? `flight ${seconds(p.flight_s)}, ground ${seconds(p.ground_s)}`
    : "";
  let book = "";
  for (const k of p.logbook) {
    book += `<li class="${k.in_use ? "in-use" : ""}">${esc(k.name)} (${k.role}): ${k.hours.toFixed(2)} h, ` +
      `${k.flights} flights, ${k.cycles} cycles</li>`;
  }
  if ($("logbook").innerHTML !== book) $("logbook").innerHTML = book;
  const choices = p.logbook.filter((k) => k.role === "flight").map((k) => k.name);
  const sel = $("pack");
  const have = Array.from(sel.options).slice(1).map((o) => o.value);
  if (have.join() !== choices.join()) {
    const keep = sel.value;
    sel.innerHTML = '<option value="">–</option>' +
      choices.map((n) => `<option value="${esc(n)}">${esc(n)}</option>`).join("");
    sel.value = choices.includes(keep) ? keep : "";
  }
  const fr = $("field-rule");
  fr.hidden = !p.field_rule;
  $("field-rule-text").textContent = p.field_rule || "";
}

function renderSafety(s) {
  for (const [id, v] of [["safe-augmented", s.augmented], ["safe-automatic", s.automatic]]) {
    const el = $(id);
    el.className = "verdict " + (v.allowed ? "yes" : "no");
    el.querySelector(".answer").textContent = v.allowed ? "YES" : "NO";
    el.querySelector(".failing").textContent = v.failing;
    el.querySelector(".rule").textContent = v.rule;
  }
  const list = $("conditions");
  const html = s.conditions
    .map((c) => `<li class="${c.value === c.wanted}" title="${esc(c.meaning)}">` +
      `${esc(c.name)}: ${esc(c.meaning)}${c.value ? "" : ": no"}</li>`)
    .join("");
  if (list.innerHTML !== html) list.innerHTML = html;
}

function renderMessages(messages) {
  const list = $("messages");
  let added = false;
  for (const m of messages) {
    if (m.seq <= page.lastMessage) continue;
    page.lastMessage = m.seq;
    const li = document.createElement("li");
    li.className = m.severity;
    li.innerHTML = `<span class="src">${m.source}</span> ${esc(m.text)}`;
    list.appendChild(li);
    added = true;
  }
  while (list.children.length > 500) list.removeChild(list.firstChild);
  if (added) list.scrollTop = list.scrollHeight;
}

function esc(s) {
  return String(s).replace(/[&<>"]/g, (c) => ({ "&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;" })[c]);
}

function wire() {
  $("take-control").onclick = () => send("take");
  $("release-control").onclick = () => send("release");
  $("connect").onclick = () => send("connect");
  $("acknowledge").onclick = () => send("acknowledge");
  $("start").onclick = () => send("start", {
    suffix: $("suffix").value,
    controller: $("controller").value,
    plan: $("plan").value,
    pack: $("pack").value,
  });
  $("stop").onclick = () => {
    $("final-suffix").value = $("suffix").value;
    // Escape closes the dialog with the last value otherwise: it must mean Cancel.
    $("final-dialog").returnValue = "";
    $("final-dialog").showModal();
  };
  $("final-dialog").addEventListener("close", () => {
    const how = $("final-dialog").returnValue;
    if (how === "save") {
      send("stop", { base_dir: $("final-base").value, suffix: $("final-suffix").value });
    } else if (how === "nosave") {
      send("stop", {});
    }
  });
}

wire();
connectSocket();
