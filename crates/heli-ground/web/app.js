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
  // The message area: one element per entry id; the pinned ones shown at the top.
  entries: new Map(),
  pinnedSeq: 0,
  // The sequence number of the last Start Logging check asked (its reply goes beside the
  // button, not in the reply line).
  checkSeq: 0,
  checkTimer: null,
  flightShown: false,
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
      page.entries.clear();
      $("messages").replaceChildren();
    }
    else if (msg.type === "history") renderMessages(msg.messages);
    else if (msg.type === "view") render(msg.view);
    else if (msg.type === "reply" && msg.seq === page.checkSeq && msg.seq) showCheck(msg);
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
    return 0;
  }
  page.seq += 1;
  page.socket.send(JSON.stringify({ seq: page.seq, op, ...extra }));
  return page.seq;
}

function startForm() {
  return {
    suffix: $("suffix").value,
    controller: $("controller").value,
    plan: $("plan").value,
    pack: $("pack").value,
  };
}

// Asks the station what Start Logging would meet with these parameters (nothing is sent to
// the vehicle), a moment after the operator stops typing.
function checkStart() {
  clearTimeout(page.checkTimer);
  page.checkTimer = setTimeout(() => {
    if (page.view && page.view.panel.start) page.checkSeq = send("check-start", startForm());
  }, 250);
}

function showCheck(msg) {
  const el = $("start-check");
  const waits = msg.ok && msg.text.includes("would wait");
  el.textContent = msg.ok ? msg.text : `the vehicle would refuse: ${msg.text}`;
  el.className = !msg.ok ? "no" : waits ? "wait" : "";
  $("start").title = el.textContent;
}

function showReply(msg) {
  const el = $("reply");
  // A command's "sent" is followed on the command line (beside) to its outcome: not said
  // twice.
  el.textContent = msg.ok && / sent$/.test(msg.text || "") ? "" : msg.text || "";
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
  renderPinned(view.pinned, inControl);
  renderCommand(view.command);
  renderFlightForm(view);
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
  for (const [id, active] of [["connect", p.connect], ["start", p.start], ["stop", p.stop], ["kill", p.kill]]) {
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
  el.className = "pill " + (!v.heard ? "bad" : trouble.includes(v.phase) || v.standing ? "warn" : "good");
  // A refusal that stands (until the pilot cycles the auto switch) stays in sight.
  const st = $("standing");
  st.hidden = !v.standing;
  st.textContent = v.standing || "";
  // Whether the vehicle flies what the lab tested; why not stays in sight.
  const lab = $("lab");
  const tested = v.heard ? v.lab.tested : "unknown";
  lab.hidden = tested === "unknown";
  lab.textContent = tested;
  lab.className = "pill " + (tested === "lab-tested" ? "good" : "warn");
  lab.title = v.lab.statement || "";
  const why = $("lab-statement");
  const untested = tested.startsWith("NOT lab-tested");
  why.hidden = !untested;
  why.textContent = untested ? v.lab.statement || "NOT lab-tested (the vehicle's reason not heard yet)" : "";
}

// Start Logging: an augmented or autonomous flight on a configuration the vehicle says is
// not lab-tested is sent only after the operator confirms the override.
function startLogging() {
  const form = startForm();
  const v = page.view && page.view.vehicle;
  if (v && v.heard && v.lab.tested === "NOT lab-tested" && form.controller !== "manual") {
    $("override-why").textContent = v.lab.statement || "NOT lab-tested";
    $("override-dialog").returnValue = "";
    $("override-dialog").showModal();
    return;
  }
  send("start", form);
}

// The last command and what became of it: a refusal in red with the vehicle's reason.
function renderCommand(c) {
  const el = $("command");
  if (!c) { el.textContent = ""; el.className = ""; return; }
  const words = { sent: "sent, waiting for the vehicle", accepted: "accepted",
    refused: "REFUSED", unanswered: "NO ANSWER" };
  el.textContent = `${c.name}: ${words[c.outcome] || c.outcome}${c.text ? " — " + c.text : ""}`;
  el.className = c.outcome;
}

// While a flight this station started flies, every page's form shows its parameters (not
// the page's own choices), locked.
function renderFlightForm(view) {
  const f = view.flight;
  const fields = [["suffix", "suffix"], ["controller", "controller"], ["plan", "plan"], ["pack", "pack"]];
  if (f) {
    for (const [id, key] of fields) {
      const el = $(id);
      if (el.value !== f[key]) el.value = f[key];
      el.disabled = true;
    }
    page.flightShown = true;
  } else if (page.flightShown) {
    for (const [id] of fields) $(id).disabled = false;
    page.flightShown = false;
  }
  // Asked again every 2 s while Start Logging is active: what the vehicle would meet
  // changes with its telemetry.
  if (!view.panel.start) { $("start-check").textContent = ""; $("start").title = ""; }
  else if (Date.now() - (page.checkAt || 0) > 2000) { page.checkAt = Date.now(); checkStart(); }
}

function renderPinned(pinned, inControl) {
  const box = $("pinned-box");
  box.hidden = pinned.length === 0;
  const html = pinned.map((m) => `<li class="${m.severity}">${esc(m.severity.toUpperCase())} ` +
    `${esc(m.text)}${m.count > 1 ? ` (×${m.count})` : ""}</li>`).join("");
  if ($("pinned").innerHTML !== html) $("pinned").innerHTML = html;
  page.pinnedSeq = pinned.reduce((a, m) => Math.max(a, m.seq), 0);
  const ack = $("ack-pinned");
  ack.disabled = !inControl;
  ack.title = inControl ? "acknowledge every pinned message shown" : "take control to acknowledge";
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
      const age = row.stale ? `<span class="age">STALE ${row.age_s.toFixed(1)} s</span>` : "";
      html = `<td class="name">${name}${age}</td>`;
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
    meter.className = "meter " + (b.stale ? "grey" : b.green ? "green" : "red");
    $("battery-pct").textContent = b.stale
      ? `${b.percent.toFixed(0)} % (${b.age_s.toFixed(0)} s ago)` : `${b.percent.toFixed(0)} %`;
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
      `${esc(c.name)}: ${esc(c.meaning)}${c.value ? "" : `: ${esc(c.why || "no")}`}</li>`)
    .join("");
  if (list.innerHTML !== html) list.innerHTML = html;
}

const SEVERITY_RANK = { info: 0, notice: 1, warning: 2, error: 3, critical: 4 };

// The message area: an entry per id, moved to the end when it repeats, with its count and
// rate; the filter hides by severity and device.
function renderMessages(messages) {
  const list = $("messages");
  const atEnd = list.scrollTop + list.clientHeight >= list.scrollHeight - 4;
  let added = false;
  for (const m of messages) {
    if (m.seq <= page.lastMessage) continue;
    page.lastMessage = m.seq;
    let li = page.entries.get(m.id);
    if (!li) {
      li = document.createElement("li");
      page.entries.set(m.id, li);
      noteDevice(m.device);
    }
    li.className = m.severity;
    li.dataset.rank = SEVERITY_RANK[m.severity] ?? 0;
    li.dataset.device = m.device;
    const repeats = m.count > 1
      ? ` <span class="count">×${m.count}${rate(m.rate_hz)}</span>` : "";
    li.innerHTML = `<span class="src">${m.source}</span> ${esc(m.text)}${repeats}`;
    list.appendChild(li);
    filterOne(li);
    added = true;
  }
  while (list.children.length > 2500) {
    const first = list.firstChild;
    for (const [id, el] of page.entries) if (el === first) page.entries.delete(id);
    list.removeChild(first);
  }
  if (added && atEnd) list.scrollTop = list.scrollHeight;
}

// A repeat rate in words: per second when often, per minute when not.
function rate(hz) {
  if (!hz) return "";
  return hz >= 1 ? `, ${hz.toFixed(1)}/s` : `, ${(hz * 60).toFixed(1)}/min`;
}

function noteDevice(device) {
  if (!device) return;
  const sel = $("filter-device");
  if (Array.from(sel.options).some((o) => o.value === device)) return;
  const o = document.createElement("option");
  o.value = device;
  o.textContent = device;
  sel.appendChild(o);
}

function filterOne(li) {
  const min = SEVERITY_RANK[$("filter-severity").value] ?? 0;
  const device = $("filter-device").value;
  li.hidden = Number(li.dataset.rank) < min || (device !== "" && li.dataset.device !== device);
}

function filterAll() {
  for (const li of $("messages").children) filterOne(li);
}

function esc(s) {
  return String(s).replace(/[&<>"]/g, (c) => ({ "&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;" })[c]);
}

function wire() {
  $("take-control").onclick = () => send("take");
  $("release-control").onclick = () => send("release");
  $("connect").onclick = () => send("connect");
  $("acknowledge").onclick = () => send("acknowledge");
  $("start").onclick = startLogging;
  $("override-dialog").addEventListener("close", () => {
    if ($("override-dialog").returnValue === "override") {
      send("start", { ...startForm(), override_untested: true });
    }
  });
  for (const id of ["suffix", "controller", "plan", "pack"]) {
    $(id).addEventListener("input", checkStart);
    $(id).addEventListener("change", checkStart);
  }
  $("ack-pinned").onclick = () => send("acknowledge-messages", { upto: page.pinnedSeq });
  $("filter-severity").onchange = filterAll;
  $("filter-device").onchange = filterAll;
  $("stop").onclick = () => {
    $("final-suffix").value = $("suffix").value;
    // Escape closes the dialog with the last value otherwise: it must mean Cancel.
    $("final-dialog").returnValue = "";
    $("final-dialog").showModal();
  };
  $("kill").onclick = () => {
    $("kill-word").value = "";
    $("kill-dialog").returnValue = "";
    $("kill-dialog").showModal();
  };
  $("kill-dialog").addEventListener("close", () => {
    // Only the typed word confirms: a stray click or Enter kills nothing.
    if ($("kill-dialog").returnValue === "kill" && $("kill-word").value.trim() === "kill") {
      send("kill", { confirmed: true });
    } else if ($("kill-dialog").returnValue === "kill") {
      showReply({ ok: false, text: "kill not confirmed: type kill to confirm" });
    }
  });
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
