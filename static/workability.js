// Site workability page (static/workability.html): choose a record and planners, run a job
// through the REST API, poll its progress, then show its summary, windows and PNG plots.
"use strict";
const $ = (id) => document.getElementById(id);
const el = (tag, text) => { const e = document.createElement(tag); if (text !== undefined) e.textContent = text; return e; };
const pct = (v) => (v === null || v === undefined) ? "–" : (100 * v).toFixed(1) + " %";
const num = (v) => (v === null || v === undefined) ? "–" : Number(v).toPrecision(3);
let mechanisms = [], planners = [], jobId = null;

// the token as the landing page keeps it (sessionStorage, sent as Bearer)
$("token").value = sessionStorage.getItem("twin-token") || "";
$("token").addEventListener("change", () => sessionStorage.setItem("twin-token", $("token").value));

// JSON fetch; throws the server's one-line message on an error status.
async function api(path, options = {}) {
  const headers = { "Content-Type": "application/json" };
  if ($("token").value) headers.Authorization = "Bearer " + $("token").value;
  const response = await fetch(path, { ...options, headers });
  const body = response.status === 204 ? {} : await response.json();
  if (!response.ok) throw new Error(body.message || (typeof body.detail === "string" ? body.detail : JSON.stringify(body.detail)));
  return body;
}

function row(values) {
  const tr = el("tr"); values.forEach((v) => tr.append(el("td", v))); return tr;
}

// planners of the chosen mechanism, from GET /api/planners; its default checked
function fillPlanners() {
  const mechanism = mechanisms.find((m) => m.name === $("mechanism").value);
  const names = planners.filter((p) => p.mechanisms.includes(mechanism.name)).map((p) => p.name);
  $("planners").replaceChildren(...names.map((name) => {
    const label = el("label"); label.style.display = "inline-block"; label.style.marginRight = "1rem";
    const box = el("input"); box.type = "checkbox"; box.value = name; box.name = "planner";
    box.checked = name === mechanism.default_planner;
    label.append(box, " " + name); return label;
  }));
}

async function init() {
  try {
    const [records, mechs, plans] = await Promise.all([
      api("/api/workability/records"), api("/api/mechanisms"), api("/api/planners")]);
    mechanisms = mechs; planners = plans;
    $("record").replaceChildren(...records.map((r) => el("option", r)));
    $("mechanism").replaceChildren(...mechanisms.map((m) => el("option", m.name)));
    fillPlanners();
  } catch (e) { $("status").textContent = e.message; $("status").className = "bad"; }
}
$("mechanism").addEventListener("change", fillPlanners);
// the heading inputs of the chosen strategy: relative heading(s), or the bow's compass heading
function showStrategy() {
  const compass = $("strategy").value === "compass";
  $("relative").hidden = compass; $("compass").hidden = !compass;
}
$("strategy").addEventListener("change", showStrategy);
function heading() {
  if ($("strategy").value === "compass") return { kind: "record", vessel_heading: Number($("vessel-heading").value) };
  const headings = $("heading").value.split(",").map((v) => v.trim()).filter((v) => v).map(Number);
  return { kind: $("strategy").value, headings };
}
// the request's body; an uploaded file (read here, at submission) is sent as record_csv
async function body() {
  const file = $("upload").files[0], upload = file ? await file.text() : null;
  const chosen = [...document.querySelectorAll("input[name=planner]:checked")].map((b) => b.value);
  const out = {
    mechanism: $("mechanism").value, planners: chosen, seeds: Number($("seeds").value),
    duration: Number($("duration").value), method: $("method").value,
    heading: heading(), duplicates: $("duplicates").value,
  };
  if (upload !== null) {
    out.record_csv = upload; out.record_name = file.name;
    if ($("kind").value) out.record_kind = $("kind").value;
  }
  else out.record = $("record").value;
  return out;
}

$("form").addEventListener("submit", async (event) => {
  event.preventDefault();
  $("results").hidden = true;
  $("status").className = "muted";
  try {
    const job = await api("/api/workability", { method: "POST", body: JSON.stringify(await body()) });
    jobId = job.id; $("run").disabled = true; $("cancel").disabled = false;
    poll();
  } catch (e) { $("status").textContent = e.message; $("status").className = "bad"; }
});
$("cancel").addEventListener("click", async () => {
  if (!jobId) return;
  try { await api(`/api/workability/${jobId}/cancel`, { method: "POST" }); }
  catch (e) { $("status").textContent = e.message; $("status").className = "bad"; }
});

async function poll() {
  let job;
  try { job = await api(`/api/workability/${jobId}`); }
  catch (e) { $("status").textContent = e.message; $("status").className = "bad"; return; }
  $("progress").value = job.progress;
  $("status").textContent = `${job.status}: ${job.done} of ${job.total} runs`;
  if (job.status === "queued" || job.status === "running") { setTimeout(poll, 500); return; }
  $("run").disabled = false; $("cancel").disabled = true;
  if (job.status === "failed") { $("status").textContent = "failed: " + job.error; $("status").className = "bad"; return; }
  show(job);
}

// a file fetched with the token (a --private server wants it on reads too), as a blob
async function fetchBlob(path) {
  const headers = {};
  if ($("token").value) headers.Authorization = "Bearer " + $("token").value;
  const response = await fetch(path, { headers });
  if (!response.ok) throw new Error(`${path}: ${response.status}`);
  return response.blob();
}

// a file saved by the browser under `name`
async function download(path, name) {
  try {
    const link = el("a"); link.href = URL.createObjectURL(await fetchBlob(path)); link.download = name;
    link.click(); URL.revokeObjectURL(link.href);
  } catch (e) { $("notes").textContent = e.message; }
}

// a PNG shown as a blob URL
async function loadPlot(img, path) {
  try {
    const blob = await fetchBlob(path);
    if (img.src.startsWith("blob:")) URL.revokeObjectURL(img.src);
    img.src = URL.createObjectURL(blob);
  } catch (e) { $("notes").textContent = e.message; }
}

function show(job) {
  const r = job.result, base = `/api/workability/${job.id}/`;
  $("status").textContent = `done: ${r.runs} runs (${r.new_runs} new) in ${r.elapsed.toFixed(1)} s`;
  $("summary").replaceChildren(...Object.entries(r.planners).map(([name, p]) => {
    const [limit, share] = Object.entries(p.limiting)[0] || ["–", null];
    return row([name, pct(p.workability), pct(p.operable_share), share === null ? "–" : `${limit} (${pct(share)})`]);
  }));
  $("threshold").textContent = "Hs-threshold estimate: " + Object.entries(r.threshold)
    .sort(([a], [b]) => Number(a) - Number(b))
    .map(([limit, t]) => `Hs < ${limit} m: ${pct(t.workability)}`).join(" · ");
  // rows skipped over 5 %: each reason and count, where it cannot be missed
  $("warnings").replaceChildren(...(r.record.warnings || []).map((w) => el("li", "warning: " + w)));
  $("rows-csv").href = base + "rows.csv";
  $("rows-csv").onclick = (event) => { event.preventDefault(); download(base + "rows.csv", "workability_rows.csv"); };
  $("months").replaceChildren(...Object.entries(r.months || {}).map(([m, s]) => row(
    [m, s.hours.toFixed(0), s.years.join(", "), pct(s.coverage), s.partial ? "partial" : ""])));
  const windows = [];
  for (const [name, p] of Object.entries(r.planners)) {
    for (const [w, s] of Object.entries(p.windows || {})) {
      windows.push(row([name, w, String(s.count), num(s.length_mean), num(s.length_max), num(s.wait_mean)]));
    }
  }
  $("windows").replaceChildren(...windows);
  for (const plot of ["monthly", "windows", "strip", "forecast"]) {
    const has = job.plots.includes(plot + ".png"), img = $("plot-" + plot);
    if (has) loadPlot(img, base + plot + ".png");
    const part = $(plot + "-part"); if (part) part.hidden = !has;
    img.hidden = !has;
  }
  // a forecast: each 3 h step per planner with its limiting constraint
  const steps = r.steps || [];
  $("forecast-part").hidden = r.record.kind !== "forecast";
  if (steps.length) {
    const names = Object.keys(r.planners);
    const head = el("tr"); ["time (UTC)", "Hs [m]", "Tp [s]"].concat(names.flatMap((n) => [n, "limited by"])).forEach((h) => head.append(el("th", h)));
    $("steps-head").replaceChildren(head);
    const byTime = new Map();
    for (const s of steps) {
      if (!byTime.has(s.time)) byTime.set(s.time, { s, by: {} });
      byTime.get(s.time).by[s.planner] = s;
    }
    $("steps").replaceChildren(...[...byTime.values()].map(({ s, by }) => row(
      [s.time, num(s.hs), num(s.tp)].concat(names.flatMap((n) => [pct(by[n]?.probability), by[n]?.limiting || "–"])))));
  }
  $("notes").textContent = (r.notes || []).filter((n) => !(r.record.warnings || []).includes(n)).join(" ");
  $("results").hidden = false;
}

init();
