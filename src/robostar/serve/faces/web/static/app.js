// robostar dashboard: live values from /events, confirmed actions, and the jog panel.
// Plain JavaScript, no build step, no CDN: plants are offline.
"use strict";

const csrf = () => document.querySelector('meta[name="csrf-token"]').content;
const role = () => document.body.dataset.role;
const RANK = { anonymous: 0, viewer: 1, operator: 2, engineer: 3, admin: 4 };
const may = (needed) => (RANK[role()] || 0) >= RANK[needed];

// -- live values -------------------------------------------------------------------------------
const renderers = {
  lamps(el, value) {
    for (const lamp of el.querySelectorAll("[data-field]")) {
      const on = value && value[lamp.dataset.field];
      lamp.classList.toggle("on", !!on);
      lamp.classList.toggle("off", !on);
    }
  },
  online(el, value) {
    el.classList.toggle("on", !!value);
    el.classList.toggle("off", !value);
    el.textContent = value ? "online" : "offline";
  },
  speed(el, value) {
    el.textContent = value === null ? "—" : (value / 10).toFixed(1) + " %";
  },
  alarms(el, value) {
    el.replaceChildren();
    for (const alarm of value || []) {
      const div = document.createElement("div");
      div.className = "alarm";
      div.textContent = `${alarm.code} : ${alarm.text}`;
      el.append(div);
    }
    if (!value || value.length === 0) {
      const div = document.createElement("div");
      div.className = "none";
      div.textContent = "No alarms";
      el.append(div);
    }
  },
  job(el, value) {
    el.textContent = value && typeof value === "object" ? `${value.stem}.${value.extension}` : value || "—";
  },
  axis(el, value) {
    if (!value) return;
    const v = value.axes[Number(el.dataset.axis) - 1];
    el.textContent = v === undefined ? "—" : v.toFixed(3);
  },
  axes(el, value) {
    if (!value) return;
    value.axes.forEach((v, i) => {
      const cell = el.querySelector(`[data-axis="${i + 1}"]`);
      if (cell) cell.textContent = v.toFixed(3);
    });
  },
  xyview(el, value) {
    if (!value || value.axes.length < 2) return;
    const now = performance.now();
    const trail = (el._trail = el._trail || []);
    trail.push([value.axes[0], value.axes[1], now]);
    const view = (el._view = el._view || JSON.parse(el.dataset.view));
    while (trail.length && now - trail[0][2] > view.trail * 1000) trail.shift();
    drawXY(el);
  },
  contacts(el, value) {
    if (!value) return;
    for (const contact of el.querySelectorAll("[data-contact]")) {
      const on = value.contacts[Number(contact.dataset.contact)];
      contact.classList.toggle("on", !!on);
      contact.classList.toggle("off", !on);
    }
  },
  history(el, value) {
    el.replaceChildren();
    for (const r of value || []) {
      const tr = document.createElement("tr");
      const time = `${r.day}D ${String(r.hours).padStart(2, "0")}:${String(r.minutes).padStart(2, "0")}:${String(r.seconds).padStart(2, "0")}`;
      for (const text of [time, `CH${r.channel}`, r.code, r.text, r.detail]) {
        const td = document.createElement("td");
        td.textContent = text;
        tr.append(td);
      }
      el.append(tr);
    }
  },
};

// how old each value is: its age when the server sent it, plus the time since (no clock skew)
const ages = {};
function showAges() {
  for (const el of document.querySelectorAll("[data-age-of]")) {
    const known = ages[el.dataset.ageOf];
    if (!known) continue;
    const age = known.age + (performance.now() - known.received) / 1000;
    el.textContent = `${age.toFixed(1)} s ago`;
  }
}

// -- the XY view: workspace, mm axes, taught points, the trail and the current point ------------
function niceStep(span) {
  const raw = span / 6, power = 10 ** Math.floor(Math.log10(raw));
  return [1, 2, 5, 10].map((m) => m * power).find((s) => s >= raw);
}

function drawXY(el) {
  const view = (el._view = el._view || JSON.parse(el.dataset.view));
  const trail = el._trail || [];
  const xs = [], ys = [];
  if (view.workspace) { xs.push(view.workspace.box[0], view.workspace.box[2]); ys.push(view.workspace.box[1], view.workspace.box[3]); }
  for (const p of view.points) { xs.push(p.x); ys.push(p.y); }
  for (const p of trail) { xs.push(p[0]); ys.push(p[1]); }
  if (!xs.length) { xs.push(-100, 100); ys.push(-100, 100); }
  let minX = Math.min(...xs), maxX = Math.max(...xs), minY = Math.min(...ys), maxY = Math.max(...ys);
  const span = Math.max(maxX - minX, maxY - minY, 20) * 1.1;
  const cx = (minX + maxX) / 2, cy = (minY + maxY) / 2;
  minX = cx - span / 2; maxX = cx + span / 2; minY = cy - span / 2; maxY = cy + span / 2;
  const size = el.width, margin = 34, scale = (size - 2 * margin) / span;
  const px = (x) => margin + (x - minX) * scale, py = (y) => size - margin - (y - minY) * scale;
  const ctx = el.getContext("2d");
  ctx.clearRect(0, 0, size, el.height);
  ctx.font = "11px system-ui, sans-serif";
  // grid and mm labels
  const step = niceStep(span);
  ctx.strokeStyle = "#1e293b"; ctx.fillStyle = "#94a3b8"; ctx.lineWidth = 1;
  for (let x = Math.ceil(minX / step) * step; x <= maxX; x += step) {
    ctx.beginPath(); ctx.moveTo(px(x), margin); ctx.lineTo(px(x), size - margin); ctx.stroke();
    ctx.fillText(String(Math.round(x)), px(x) - 10, size - margin + 14);
  }
  for (let y = Math.ceil(minY / step) * step; y <= maxY; y += step) {
    ctx.beginPath(); ctx.moveTo(margin, py(y)); ctx.lineTo(size - margin, py(y)); ctx.stroke();
    ctx.fillText(String(Math.round(y)), 2, py(y) + 4);
  }
  ctx.fillText("X mm →", size - margin - 40, size - 4);
  ctx.fillText("↑ Y mm", margin, 12);
  if (view.workspace) {
    ctx.strokeStyle = "#64748b"; ctx.lineWidth = 1.5;
    for (const curve of view.workspace.outlines) {
      ctx.beginPath();
      curve.forEach(([x, y], i) => (i ? ctx.lineTo(px(x), py(y)) : ctx.moveTo(px(x), py(y))));
      ctx.stroke();
    }
  }
  ctx.fillStyle = "#f59e0b";
  for (const p of view.points) {
    ctx.fillRect(px(p.x) - 3, py(p.y) - 3, 6, 6);
    ctx.fillText(`P${p.n}`, px(p.x) + 5, py(p.y) - 5);
  }
  if (trail.length) {
    ctx.strokeStyle = "#3b82f6"; ctx.lineWidth = 2; ctx.beginPath();
    trail.forEach(([x, y], i) => (i ? ctx.lineTo(px(x), py(y)) : ctx.moveTo(px(x), py(y))));
    ctx.stroke();
    const [x, y] = trail[trail.length - 1];
    ctx.fillStyle = "#22c55e"; ctx.beginPath(); ctx.arc(px(x), py(y), 5, 0, 2 * Math.PI); ctx.fill();
    ctx.fillStyle = "#e2e8f0"; ctx.fillText(`${x.toFixed(1)}, ${y.toFixed(1)}`, px(x) + 8, py(y) + 12);
  }
  el.dataset.drawn = String(trail.length);
}

function apply(change) {
  const key = `${change.line}/${change.key}`;
  if (typeof change.age === "number") ages[key] = { age: change.age, received: performance.now() };
  for (const el of document.querySelectorAll(`[data-key="${CSS.escape(key)}"]`)) {
    el.dataset.quality = change.quality;
    const render = renderers[el.dataset.render];
    if (render) render(el, change.value);
    else el.textContent = change.value === null || change.value === undefined ? "—" : String(change.value);
  }
}

function connect() {
  const state = document.getElementById("stream-state");
  const source = new EventSource("/events");
  source.addEventListener("change", (event) => apply(JSON.parse(event.data)));
  source.addEventListener("status", (event) => {
    const status = JSON.parse(event.data);
    const received = performance.now();
    for (const [key, age] of Object.entries(status.ages)) ages[key] = { age, received };
    showLeases(status.leases);
  });
  source.onopen = () => { state.hidden = true; };
  source.onerror = () => { state.hidden = false; };
  window.robostarStream = source;
}

// -- confirmed actions -------------------------------------------------------------------------
function confirmDialog(text) {
  const dialog = document.getElementById("confirm");
  document.getElementById("confirm-text").textContent = text;
  return new Promise((resolve) => {
    dialog.addEventListener("close", () => resolve(dialog.returnValue === "ok"), { once: true });
    dialog.showModal();
  });
}

function toast(text, bad) {
  const el = document.getElementById("toast");
  el.textContent = text;
  el.className = bad ? "bad shown" : "shown";
  clearTimeout(el._timer);
  el._timer = setTimeout(() => { el.className = ""; }, 5000);
}

async function act(button) {
  const line = button.closest("[data-line]")?.dataset.line || location.pathname.split("/")[2];
  const body = { action: button.dataset.action, confirmed: true };
  if (button.dataset.channel) body.channel = Number(button.dataset.channel);
  if (button.dataset.on) body.on = button.dataset.on === "true";
  let text = button.dataset.confirm;
  if (body.action === "speed") {
    body.percent = Number(button.closest(".actions").querySelector(".speed-input").value);
    text = `Set the speed of channel ${body.channel} to ${body.percent} %?`;
  }
  if (body.action === "job_select") {
    const select = button.closest(".actions").querySelector(".job-select");
    body.job = select.value;
    if (!body.job) { toast("Choose a JOB file first", true); return; }
    text = `Select ${body.job} on channel ${body.channel}?`;
  }
  if (body.action === "output") {
    body.port = Number(button.dataset.port);
    body.contact = Number(button.dataset.contact);
    body.on = !button.classList.contains("on");
    text = `Switch output ${body.port}.${body.contact} ${body.on ? "ON" : "OFF"}?`;
  }
  if (!(await confirmDialog(text))) return;
  const response = await fetch(`/line/${encodeURIComponent(line)}/action`, {
    method: "POST",
    headers: { "content-type": "application/json", "x-csrf-token": csrf() },
    body: JSON.stringify(body),
  });
  const answer = await response.json().catch(() => ({ error: response.statusText }));
  if (response.ok) toast(`${body.action}: done`);
  else toast(`${body.action}: ${answer.error}`, true);
}

// the channel's JOB files, read from the controller when the operator opens the list
async function loadJobs(select) {
  if (select.dataset.loaded) return;
  select.dataset.loaded = "yes";
  const line = location.pathname.split("/")[2];
  const response = await fetch(`/line/${encodeURIComponent(line)}/jobs/${select.dataset.channel}`);
  const answer = await response.json().catch(() => ({ error: response.statusText }));
  if (!response.ok) { toast(`Jobs: ${answer.error}`, true); delete select.dataset.loaded; return; }
  for (const job of answer.jobs) {
    const option = document.createElement("option");
    option.value = job.name;
    option.textContent = `${job.number}: ${job.name} (${job.steps} steps)`;
    select.append(option);
  }
}

// the point editor: choosing a point fills the fields with its values
function setupPointEditor(form) {
  const table = JSON.parse(form.dataset.table);
  const number = form.querySelector("#point-number");
  number.addEventListener("input", () => {
    const values = table[String(Number(number.value))];
    form.querySelectorAll(".axis-input").forEach((input, i) => { input.value = values ? values[i] ?? "" : ""; });
  });
}

// -- who has control: each line's lease, refreshed; take (free, operators) and release (holder)
async function refreshLeases() {
  const response = await fetch("/leases").catch(() => null);
  if (response && response.ok) showLeases((await response.json()).leases);
}

let shownLeases = "";
function showLeases(leases) {
  const text = JSON.stringify(leases);
  if (text === shownLeases) return;  // unchanged: no DOM work (the status comes every second)
  shownLeases = text;
  for (const l of leases) {
    const el = document.querySelector(`[data-lease="${CSS.escape(l.line)}"]`);
    if (!el) continue;
    el.querySelector(".lease-state").textContent = leaseText(l);
    el.querySelector(".lease-take").hidden = !l.may_take;
    el.querySelector(".lease-release").hidden = !l.mine;
  }
}

// the words of templates/base.html: a one-shot lease lasts one command (a click, an MQTT
// command) and is given back as it ends; a held one runs until released or unused that long
function leaseText(l) {
  if (l.free) return "control free";
  if (l.once) return `in use by ${l.holder} for one command`;
  return `control held by ${l.holder}, ${l.left} s left unless renewed`;
}

async function leaseAction(button, what) {
  const line = button.dataset.line;
  const path = what === "take" ? `/line/${encodeURIComponent(line)}/lease/take` : `/line/${encodeURIComponent(line)}/lease/release`;
  const response = await fetch(path, { method: "POST", headers: { "x-csrf-token": csrf() } });
  const answer = await response.json().catch(() => ({ error: response.statusText }));
  if (!response.ok) toast(`${line}: ${answer.error}`, true);
  else toast(what === "take" ? `${line}: you have control` : `${line}: control released`);
  refreshLeases();
}

// -- the stop at the top of every page: one click, no dialog (a stop must not wait) -----------
async function stopEverything(button) {
  if (!may("operator")) { toast("Stopping needs an operator: sign in, or use the pendant's emergency stop.", true); return; }
  const results = await Promise.all(button.dataset.lines.split(" ").filter(Boolean).map(async (line) => {
    const response = await fetch(`/line/${encodeURIComponent(line)}/action`, {
      method: "POST",
      headers: { "content-type": "application/json", "x-csrf-token": csrf() },
      body: JSON.stringify({ action: "emergency_stop", confirmed: true }),
    }).catch((error) => ({ ok: false, statusText: String(error) }));
    return response.ok ? null : `${line}: ${response.statusText}`;
  }));
  const failed = results.filter(Boolean);
  if (failed.length) toast(`Emergency stop failed on ${failed.join(", ")}`, true);
  else toast("Emergency stop sent: reset the alarms to go on.");
}

// -- jog -----------------------------------------------------------------------------------------
const JOG_KEYS = { q: [1, "+"], a: [1, "-"], w: [2, "+"], s: [2, "-"], e: [3, "+"], d: [3, "-"],
                   r: [4, "+"], f: [4, "-"], t: [5, "+"], g: [5, "-"], y: [6, "+"], h: [6, "-"] };

function setupJog(panel) {
  const line = panel.dataset.line;
  const scheme = location.protocol === "https:" ? "wss" : "ws";
  const stateEl = document.getElementById("jog-state");
  const channelEl = document.getElementById("jog-channel");
  const motionEl = document.getElementById("jog-motion");
  let socket = null, timer = null;
  const channel = () => Number(channelEl.value);
  const step = () => Number(document.querySelector('input[name="jog-step"]:checked').value);
  const send = (message) => { if (socket && socket.readyState === 1) socket.send(JSON.stringify(message)); };
  const open = () => new Promise((resolve, reject) => {
    if (socket && socket.readyState === 1) return resolve();
    socket = new WebSocket(`${scheme}://${location.host}/line/${encodeURIComponent(line)}/jog/ws?csrf=${encodeURIComponent(csrf())}`);
    socket.onopen = () => resolve();
    socket.onerror = () => reject(new Error("jog connection refused"));
    socket.onclose = () => { clearInterval(timer); timer = null; stateEl.textContent = "Not connected."; };
    socket.onmessage = (event) => {
      const m = JSON.parse(event.data);
      if (m.type === "moving") stateEl.textContent = `Moving: channel ${m.channel}, axis ${m.axis}.`;
      else if (m.type === "stopped") stateEl.textContent = `Stopped (${m.reason}).`;
      else if (m.type === "inched") stateEl.textContent = `Moved axis ${m.axis} by ${m.step > 0 ? "+" : ""}${m.step}.`;
      else if (m.type === "speed") stateEl.textContent = `Speed of channel ${m.channel}: ${m.percent} %.`;
      else if (m.type === "error") stateEl.textContent = `Refused: ${m.error}`;
    };
  });
  const stop = (reason) => { clearInterval(timer); timer = null; send({ type: "stop", reason }); };
  const press = async (axis, direction) => {
    try { await open(); } catch (error) { stateEl.textContent = String(error); return; }
    const base = { channel: channel(), axis, direction, motion: motionEl.value };
    if (step() > 0) { send({ type: "inch", step: step(), ...base }); return; }
    send({ type: "start", ...base });
    clearInterval(timer);
    timer = setInterval(() => send({ type: "keepalive" }), 100);
  };
  const release = () => { if (timer) stop("released"); };
  for (const button of panel.querySelectorAll(".jog-btn")) {
    button.addEventListener("pointerdown", (event) => {
      event.preventDefault();
      press(Number(button.dataset.axis), button.dataset.direction);
    });
    for (const kind of ["pointerup", "pointerleave", "pointercancel"]) button.addEventListener(kind, release);
  }
  channelEl.addEventListener("change", release);
  motionEl.addEventListener("change", release);
  document.getElementById("jog-speed-set").addEventListener("click", async () => {
    try { await open(); } catch (error) { stateEl.textContent = String(error); return; }
    send({ type: "speed", channel: channel(), percent: Number(document.getElementById("jog-speed").value) });
  });
  // keyboard: hold a key to jog, as a button; key repeats are no new presses
  const typing = (event) => {
    const el = event.target;
    if (el.tagName === "INPUT") return !["radio", "checkbox", "button"].includes(el.type);
    return ["SELECT", "TEXTAREA"].includes(el.tagName) || el.isContentEditable;
  };
  let heldKey = null;
  document.addEventListener("keydown", (event) => {
    if (typing(event) || event.ctrlKey || event.metaKey || event.altKey) return;
    const key = event.key.toLowerCase();
    if (key === "escape" || key === " ") { event.preventDefault(); heldKey = null; stop("stopped from the keyboard"); return; }
    const steps = document.querySelectorAll('input[name="jog-step"]');
    if ("1234".includes(key) && key.length === 1 && steps[Number(key) - 1]) { steps[Number(key) - 1].checked = true; return; }
    const jog = JOG_KEYS[key];
    if (!jog || event.repeat) return;
    const row = panel.querySelector(`.jog-axis[data-axis="${jog[0]}"]`);
    if (!row || row.hidden) return;
    event.preventDefault();
    heldKey = key;
    press(jog[0], jog[1]);
  });
  document.addEventListener("keyup", (event) => {
    if (event.key.toLowerCase() === heldKey) { heldKey = null; release(); }
  });
  document.addEventListener("visibilitychange", () => { if (document.hidden && timer) stop("page hidden"); });
  window.addEventListener("blur", () => { if (timer) stop("page lost focus"); });
  window.robostarJog = { stopKeepalive: () => { clearInterval(timer); timer = null; } };
}

// the channel picks the pad and the position table; the motion names the axes (for everyone)
function setupJogView(channelEl, motionEl) {
  const show = () => {
    for (const el of document.querySelectorAll("table.position[data-channel]")) {
      el.hidden = el.dataset.channel !== channelEl.value;
    }
    for (const row of document.querySelectorAll(".jog-axis[data-names]")) {
      const names = JSON.parse(row.dataset.names)[channelEl.value];
      row.hidden = !names;
      if (names) row.querySelector(".axis-name").textContent = motionEl.value === "linear" ? names.xy : names.joint;
    }
  };
  channelEl.addEventListener("change", show);
  motionEl.addEventListener("change", show);
  show();
}

function setupTeach(section) {
  const line = location.pathname.split("/")[2];
  const numberEl = document.getElementById("teach-number");
  numberEl.addEventListener("input", () => { document.getElementById("teach-n").textContent = numberEl.value; });
  document.getElementById("teach-btn").addEventListener("click", async () => {
    const channel = Number(document.getElementById("jog-channel")?.value || 1);
    const file = document.getElementById("teach-file").value.trim().toUpperCase();
    const number = Number(numberEl.value);
    if (!(await confirmDialog(`Store the current position of channel ${channel} as point ${number} of ${file}? The file on the controller is rewritten.`))) return;
    const response = await fetch(`/line/${encodeURIComponent(line)}/jog/teach`, {
      method: "POST",
      headers: { "content-type": "application/json", "x-csrf-token": csrf() },
      body: JSON.stringify({ channel, file, number, confirmed: true }),
    });
    const answer = await response.json().catch(() => ({ error: response.statusText }));
    if (response.ok) toast(`Point ${answer.point} of ${answer.file}: ${answer.axes.map((v) => v.toFixed(3)).join(", ")}`);
    else toast(`Teach: ${answer.error}`, true);
  });
}

document.addEventListener("DOMContentLoaded", () => {
  connect();
  for (const el of document.querySelectorAll(".operator-only")) el.hidden = !may("operator");
  for (const el of document.querySelectorAll(".engineer-only")) el.hidden = !may("engineer");
  for (const el of document.querySelectorAll(".viewer-only")) el.hidden = !may("viewer");
  document.body.addEventListener("click", (event) => {
    const button = event.target.closest("[data-action]");
    if (button && may("operator")) { event.preventDefault(); act(button); }
  });
  const channelEl = document.getElementById("jog-channel");
  if (channelEl) setupJogView(channelEl, document.getElementById("jog-motion"));
  const panel = document.querySelector(".jog");
  if (panel && may("operator")) setupJog(panel);
  const teach = document.getElementById("teach");
  if (teach && may("engineer")) setupTeach(teach);
  if (document.querySelector("[data-age-of]")) setInterval(showAges, 250);

  for (const el of document.querySelectorAll("canvas.xyview")) drawXY(el);
  for (const b of document.querySelectorAll(".lease-take")) b.addEventListener("click", () => leaseAction(b, "take"));
  for (const b of document.querySelectorAll(".lease-release")) b.addEventListener("click", () => leaseAction(b, "release"));

  const pointForm = document.getElementById("point-form");
  if (pointForm) setupPointEditor(pointForm);
  for (const select of document.querySelectorAll(".job-select")) {
    for (const kind of ["focus", "pointerdown"]) select.addEventListener(kind, () => loadJobs(select));
  }
  const stopAll = document.getElementById("stop-all");
  if (stopAll) stopAll.addEventListener("click", () => stopEverything(stopAll));
});
