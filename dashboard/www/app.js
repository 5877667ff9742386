// The prismfarm dashboard's front end: vanilla JavaScript over the master's JSON API
// (docs/dashboard.md). Pages by the URL's hash: #/jobs, #/job/ID, #/workers. Each page
// polls its JSON every second. Reads and actions carry the token the user entered (kept in this
// tab's sessionStorage, sent as "Authorization: Bearer", never in a URL or a cookie): without
// one the master shows only how many jobs there are (docs/security.md); a job's preview, log
// and tasks are its owner's and the administrators'.
"use strict";

const POLL_MS = 1000;
const state = {
    timer : null,
    view : null,
    gen : 0,
    workerRates : new Map(),
    logSeq : 0,
    jobId : 0,
    previewVersion : -1,
    tileMode : "passes",
    photonSeen : null
};

// ---------------------------------------------------------------- helpers

function el(tag, attrs, ...children) {
  const e = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs || {})) {
    if (k === "class") e.className = v;
    else if (k.startsWith("on")) e.addEventListener(k.slice(2), v);
    else if (v !== undefined && v !== null) e.setAttribute(k, v);
  }
  for (const c of children) {
    if (c === null || c === undefined) continue;
    e.append(c instanceof Node ? c : document.createTextNode(String(c)));
  }
  return e;
}

function svg(tag, attrs, text) {
  const e = document.createElementNS("http://www.w3.org/2000/svg", tag);
  for (const [k, v] of Object.entries(attrs || {})) e.setAttribute(k, v);
  if (text !== undefined) e.textContent = text;
  return e;
}

function token() { return sessionStorage.getItem("prismfarm-token") || ""; }

function authHeaders() { return token() ? { Authorization: "Bearer " + token() } : {}; }

async function api(path) {
  const r = await fetch(path, { cache: "no-store", headers: authHeaders() });
  const body = await r.json().catch(() => ({ error: "not JSON (status " + r.status + ")" }));
  if (!r.ok) {
    const e = new Error(body.error || ("HTTP " + r.status));
    e.status = r.status;
    throw e;
  }
  return body;
}

// What a reader without a token is told: how to sign in.
function signIn(what) {
  return el("div", { class: "card", id: "sign-in" }, el("h2", {}, "Sign in"),
    el("p", {}, what + " Paste your token in the box above: the NAME.token file that ",
       el("code", {}, "prismfarm keygen NAME"), " wrote beside NAME.key (its one line of 64 hex " +
       "digits). Your own jobs' previews, logs and tasks show with your token; every job's " +
       "with an administrator's."));
}

// The banner of a dashboard whose reads are open (--dashboard-public).
function publicBanner(actions) {
  const b = document.getElementById("public-banner");
  if (b) b.hidden = !(actions && actions.public_reads);
}

async function act(path, body) {
  const headers = { "Content-Type": "application/json" };
  if (token()) headers["Authorization"] = "Bearer " + token();
  const r = await fetch(path, { method: "POST", headers, body: body ? JSON.stringify(body) : "" });
  const answer = await r.json().catch(() => ({ error: "HTTP " + r.status }));
  if (!r.ok) {
    message((r.status === 401 ? "refused (401): " : r.status === 403 ? "refused (403): " :
             "HTTP " + r.status + ": ") + (answer.error || ""), true);
    return false;
  }
  message(answer.action + " " + answer.id + ": done", false);
  refresh();
  return true;
}

function message(text, isError) {
  const m = document.getElementById("message");
  m.textContent = text;
  m.className = isError ? "error" : "ok";
}

function fmtTime(s) {
  if (s === undefined || s === null || !isFinite(s)) return "–";
  if (s < 60) return s.toFixed(1) + " s";
  const m = Math.floor(s / 60), h = Math.floor(m / 60);
  return h > 0 ? h + " h " + (m % 60) + " min" : m + " min " + Math.round(s % 60) + " s";
}

function fmtCount(n) {
  if (n >= 1e9) return (n / 1e9).toFixed(2) + " G";
  if (n >= 1e6) return (n / 1e6).toFixed(2) + " M";
  if (n >= 1e3) return (n / 1e3).toFixed(1) + " k";
  return String(n);
}

// The relative error estimate (docs/farm.md, "Accuracy"), as the CLI says it: above 100 % the
// noise still exceeds the image's mean, which a bare "245.43 %" does not tell.
function fmtError(e) {
  if (e === undefined) return "–";
  return (100 * e).toFixed(2) + " %" + (e > 1 ? " (noise above the mean)" : "");
}

function bar(fraction) {
  const inner = el("span");
  inner.style.width = Math.max(0, Math.min(100, 100 * fraction)).toFixed(1) + "%";
  return el("span", { class: "bar", title: (100 * fraction).toFixed(1) + " %" }, inner);
}

// The state as `prismfarm jobs` says it ("paused" included).
function stateCell(s, paused) {
  return el("td", { class: "state state-" + s }, s + (paused && s !== "paused" ? " (paused)" : ""));
}

// A figure the master may not know (a job restored after a restart, a finished job the
// scheduler forgot) is absent from the JSON: shown as unknown, never as 0.
function known(v, text) { return v === undefined ? "–" : text; }

// A colour per worker id, so the tile map and the task table agree.
function workerColour(id) { return "hsl(" + ((id * 137.508) % 360).toFixed(0) + ", 70%, 45%)"; }

// ---------------------------------------------------------------- job list

async function viewJobs(gen) {
  const data = await api("/api/jobs");
  if (gen !== state.gen) return;
  publicBanner(data.actions);
  if (data.hidden) {
    const counts = Object.entries(data.counts).map(([k, v]) => v + " " + k).join(", ");
    render(el("div", {}, el("h1", {}, "Jobs"),
              el("p", { id: "job-counts" }, counts ? "This master holds " + counts + " jobs." :
                                                      "This master holds no job."),
              signIn("Without a token the dashboard shows only how many jobs there are.")));
    return;
  }
  const rows = data.jobs.slice().reverse().map((j) => {
    const tr = el("tr", { class: "clickable", "data-job": j.id,
                          onclick: () => { location.hash = "#/job/" + j.id; } },
      el("td", { class: "num" }, j.id),
      el("td", {}, el("a", { href: "#/job/" + j.id }, j.name),
         j.nframes ? el("span", { class: "muted" }, " (" + j.nframes + " frames)") : ""),
      el("td", {}, j.owner || "–"),
      stateCell(j.state, j.paused),
      el("td", { class: "num" }, j.priority === undefined ? "–" : j.priority),
      el("td", {}, bar(j.progress), " ", (100 * j.progress).toFixed(0) + " %"),
      el("td", { class: "num" }, j.spp_done + " / " + known(j.spp, j.spp)),
      el("td", { class: "num" }, fmtError(j.rel_error)),
      el("td", { class: "num" }, fmtTime(j.eta_s)),
      el("td", { class: "num" }, fmtTime(j.elapsed_s)));
    return tr;
  });
  const table = el("table", { id: "jobs-table" },
    el("thead", {}, el("tr", {}, ...["id", "name", "owner", "state", "priority", "progress",
                                     "spp", "error", "ETA", "elapsed"].map((h) => el("th", {}, h)))),
    el("tbody", {}, ...rows));
  render(el("div", {}, el("h1", {}, "Jobs"),
            data.jobs.length ? table : el("p", { class: "muted", id: "no-jobs" },
                                          "No job yet: prismfarm submit SCENE.pbrt")));
}

// ---------------------------------------------------------------- one job

function plotErrors(passes) {
  const W = 600, H = 240, L = 52, R = 12, T = 10, B = 34;
  const pts = passes.filter((p) => p.rel_error !== undefined && p.rel_error > 0);
  const s = svg("svg", { class: "plot", id: "error-plot", viewBox: "0 0 " + W + " " + H,
                         preserveAspectRatio: "none" });
  s.append(svg("line", { class: "axis", x1: L, y1: H - B, x2: W - R, y2: H - B }));
  s.append(svg("line", { class: "axis", x1: L, y1: T, x2: L, y2: H - B }));
  if (pts.length === 0) {
    s.append(svg("text", { x: L + 10, y: T + 20 }, "no error estimate yet (after the second pass)"));
    return s;
  }
  const tmax = Math.max(...pts.map((p) => p.elapsed_s), 1e-3);
  const lmin = Math.floor(Math.log10(Math.min(...pts.map((p) => p.rel_error))));
  const lmax = Math.max(Math.ceil(Math.log10(Math.max(...pts.map((p) => p.rel_error)))), lmin + 1);
  const x = (t) => L + (W - L - R) * t / tmax;
  const y = (e) => T + (H - T - B) * (lmax - Math.log10(e)) / (lmax - lmin);
  for (let d = lmin; d <= lmax; d++) {
    s.append(svg("text", { x: 4, y: y(Math.pow(10, d)) + 4 }, (100 * Math.pow(10, d)) + " %"));
  }
  for (let k = 0; k <= 4; k++) {
    const t = tmax * k / 4;
    s.append(svg("text", { x: x(t) - 10, y: H - B + 16 }, t.toFixed(t < 10 ? 1 : 0) + " s"));
  }
  s.append(svg("text", { x: W / 2 - 60, y: H - 4 }, "time since start; error (log)"));
  s.append(svg("polyline", { class: "curve",
                             points: pts.map((p) => x(p.elapsed_s) + "," + y(p.rel_error)).join(" ") }));
  for (const p of pts) {
    const c = svg("circle", { class: "point", cx: x(p.elapsed_s), cy: y(p.rel_error), r: 3 });
    c.append(svg("title", {}, "pass " + p.pass + ": " + p.spp + " spp, " + fmtError(p.rel_error) +
                              " after " + fmtTime(p.elapsed_s)));
    s.append(c);
  }
  return s;
}

function drawTiles(canvas, map) {
  const scale = Math.max(1, Math.floor(480 / Math.max(map.xres, map.yres)));
  canvas.width = map.xres * scale;
  canvas.height = map.yres * scale;
  const g = canvas.getContext("2d");
  g.fillStyle = "#e4e8ee";
  g.fillRect(0, 0, canvas.width, canvas.height);
  const running = new Map(map.running.map((r) => [r.tile, r]));
  const tmax = Math.max(1, ...map.running.map((r) => r.running_s));
  for (let i = 0; i < map.merged.length; i++) {
    const tx = i % map.tiles_x, ty = Math.floor(i / map.tiles_x);
    const x0 = tx * map.tile * scale, y0 = ty * map.tile * scale;
    const w = Math.min(map.tile, map.xres - tx * map.tile) * scale;
    const h = Math.min(map.tile, map.yres - ty * map.tile) * scale;
    const r = running.get(i);
    // Adaptive sampling: a tile behind the running ones stopped there, converged.
    const stopped = map.adaptive && map.merged[i] < map.passes_done;
    if (state.tileMode === "passes") {
      const f = map.npasses ? map.merged[i] / map.npasses : 0;
      g.fillStyle = stopped ? "hsl(210, 55%, " + (88 - 45 * f).toFixed(0) + "%)"
                            : "hsl(140, 45%, " + (92 - 55 * f).toFixed(0) + "%)";
    } else if (state.tileMode === "spp") {
      const smax = Math.max(1, ...(map.spp || [1]));
      const s = map.spp ? map.spp[i] : 0;
      const f = s > 0 ? Math.log2(s + 1) / Math.log2(smax + 1) : 0;
      g.fillStyle = "hsl(" + (220 - 200 * f).toFixed(0) + ", 70%, " + (90 - 40 * f).toFixed(0) + "%)";
    } else {
      g.fillStyle = r ? "hsl(" + (50 - 50 * r.running_s / tmax).toFixed(0) + ", 85%, 55%)" : "#e4e8ee";
    }
    g.fillRect(x0, y0, w, h);
    g.strokeStyle = "#fff";
    g.lineWidth = 1;
    g.strokeRect(x0 + .5, y0 + .5, w - 1, h - 1);
    if (r) {
      g.strokeStyle = workerColour(r.worker);
      g.lineWidth = 3;
      g.strokeRect(x0 + 2, y0 + 2, w - 4, h - 4);
    }
  }
}

function fact(k, v) { return [el("dt", {}, k), el("dd", {}, v)]; }

async function viewJob(gen, id) {
  const j = await api("/api/jobs/" + id);
  // A job's tasks and log are its owner's and the administrators' (j.can_read).
  const tasks = j.can_read ? await api("/api/jobs/" + id + "/tasks") : { tasks: [] };
  let map = null;
  try { map = await api("/api/jobs/" + id + "/tiles"); } catch (e) { map = null; }
  const log = j.can_read ? await api("/api/jobs/" + id + "/log?since=" + (state.jobId === id ? state.logSeq : 0))
                         : { lines: [] };
  if (gen !== state.gen) return;
  publicBanner(j.actions);
  const fresh = state.jobId !== id || !document.getElementById("job-page");
  if (fresh) {
    state.jobId = id;
    state.logSeq = 0;
    state.previewVersion = -1;
    buildJobPage(id);
  }
  document.getElementById("job-title").textContent = "Job " + j.id + ": " + j.name;
  const facts = document.getElementById("job-facts");
  swap(facts, 
    ...fact("state", el("span", { id: "job-state", class: "state state-" + j.state },
                        j.state + (j.paused && j.state !== "paused" ? " (paused)" : ""))),
    ...fact("owner", j.owner || "–"),
    ...fact("priority", j.priority === undefined ? "–" : String(j.priority)),
    // A frame sequence (docs/farm.md): its frames below; a frame: its sequence and number.
    ...(j.nframes ? fact("frames", String(j.nframes)) :
        fact("size", known(j.xres, j.xres + " × " + j.yres) + ", " + j.integrator)),
    ...(j.sequence ? fact("frame", el("span", {}, j.frame + " of ",
                                      el("a", { href: "#/job/" + j.sequence }, "job " + j.sequence))) : []),
    ...fact("progress", el("span", {}, bar(j.progress), " " + (100 * j.progress).toFixed(1) + " %")),
    ...fact("samples per pixel", j.spp_done + " of " + known(j.spp, j.spp) + " (pass " + j.passes_done +
            known(j.npasses, " of " + j.npasses) + ")"),
    ...fact("samples", fmtCount(j.samples_done) + " of " + fmtCount(j.samples_total) +
            (j.nonfinite ? ", " + j.nonfinite + " non-finite dropped" : "")),
    ...fact("tasks", known(j.tasks_total, j.tasks_done + " of " + j.tasks_total + " done, " +
                                         j.tasks_running + " running")),
    ...fact("error estimate", fmtError(j.rel_error)),
    ...fact("elapsed", fmtTime(j.elapsed_s)),
    ...fact("ETA", fmtTime(j.eta_s)),
    ...(j.stop ? fact("ended early", j.stop === "target" ? "target error reached" : "time limit") : []),
    ...(j.error ? fact("error", j.error) : []));
  // The photon phase, for photon jobs.
  const ph = document.getElementById("photon-phase");
  if (j.photon_phase) {
    const p = j.photon_phase;
    ph.hidden = false;
    // Its rate and ETA from this page's polls (the master keeps no clock for the phase, and a
    // refinement's round starts where the last ended): photons merged since first seen.
    const now = Date.now() / 1000, seen = state.photonSeen;
    if (!seen || seen.job !== j.id || p.photons < seen.photons || p.complete)
        state.photonSeen = {job : j.id, photons : p.photons, t : now};
    const dt = now - state.photonSeen.t,
          rate = dt > 0 ? (p.photons - state.photonSeen.photons) / dt : 0;
    const total = p.total || p.photons;
    const what = p.complete ? "complete: " + fmtCount(p.photons) + " photons" +
                                  (p.batches ? " (" + fmtCount(p.emitted) + " emitted)"
                                             : " (kept on the master's disk)")
                            : fmtCount(p.photons) + " of " + fmtCount(total) + " photons traced, " +
                                  p.batches_done + " of " + p.batches + " batches merged" +
                                  (rate > 0 ? ", " + fmtCount(rate) + " photons/s, ETA " +
                                                  fmtTime((total - p.photons) / rate)
                                            : "");
    swap(ph, el("h2", {}, "Photon phase"),
         el("p", {id : "photon-progress"},
            bar(p.complete ? 1
                : total    ? p.photons / total
                           : 0),
            " " + what));
  } else ph.hidden = true;
  // Actions: offered only where they apply (a job not over, a master that has them, a viewer
  // who may act on it: its owner or an administrator).
  const over = ["done", "failed", "cancelled"].includes(j.state);
  const may = !over && j.can_act;
  document.getElementById("action-cancel").hidden = !(may && j.actions.cancel);
  document.getElementById("action-pause").hidden = !(may && j.actions.pause);
  document.getElementById("action-pause").textContent = j.paused ? "Resume" : "Pause";
  document.getElementById("action-pause").dataset.paused = j.paused ? "1" : "0";
  document.getElementById("action-priority").hidden = !(may && j.actions.priority);
  document.getElementById("priority-value").hidden = !(may && j.actions.priority);
  document.getElementById("private-note").hidden = j.can_read;
  document.getElementById("private-note").textContent = j.can_read ? "" : (token() ?
    "This job is " + (j.owner || "an administrator") + "'s: its preview, log and tasks are its owner's and the administrators' to read." :
    "Sign in with your token (the box above) to see this job's preview, log and tasks if it is yours.");
  // The preview: fetched with the token (an <img> cannot send one) when the master wrote a
  // new one, and shown from a blob: URL.
  const img = document.getElementById("preview");
  img.hidden = !(j.can_read && j.preview_version > 0);
  if (j.can_read && j.preview_version !== state.previewVersion && j.preview_version > 0) {
    state.previewVersion = j.preview_version;
    const version = j.preview_version;
    fetch("/api/jobs/" + id + "/preview.png?v=" + version, { cache: "no-store", headers: authHeaders() })
      .then((r) => r.ok ? r.blob() : null)
      .then((b) => {
        if (!b || state.jobId !== id) return;
        if (img.src.startsWith("blob:")) URL.revokeObjectURL(img.src);
        img.src = URL.createObjectURL(b);
        img.dataset.version = version;
      });
    document.getElementById("preview-note").textContent = "at " + j.spp_done + " spp";
  } else if (!j.can_read) {
    document.getElementById("preview-note").textContent = "its owner's";
  } else if (j.preview_version === 0) {
    document.getElementById("preview-note").textContent = "no image yet: a preview follows each pass";
  }
  swap(document.getElementById("plot-box"), plotErrors(j.passes));
  const canvas = document.getElementById("tilemap");
  if (map) drawTiles(canvas, map);
  canvas.hidden = !map;
  if (map && map.adaptive && map.spp && map.spp.length) {
    // Pixels per tile differ only at the clipped edges: the tiles' mean is near the image's.
    const stopped = map.merged.filter((m) => m < map.passes_done).length;
    const mean = map.spp.reduce((a, b) => a + b, 0) / map.spp.length;
    document.getElementById("tile-legend").textContent =
      "adaptive sampling: " + stopped + " of " + map.spp.length + " tiles stopped (blue), tiles' mean " +
      mean.toFixed(1) + " spp, " + Math.min(...map.spp) + "-" + Math.max(...map.spp) +
      " spp; darker: more passes merged; outlined: running";
  }
  // A sequence's frames, each a job of its own.
  const fc = document.getElementById("frames-card");
  fc.hidden = !j.frames;
  if (j.frames)
    swap(document.getElementById("frames-body"), ...j.frames.map((f) =>
      el("tr", { class: "clickable", "data-job": f.id, onclick: () => { location.hash = "#/job/" + f.id; } },
        el("td", { class: "num" }, f.frame),
        el("td", { class: "num" }, f.id),
        el("td", {}, el("a", { href: "#/job/" + f.id }, f.name)),
        stateCell(f.state, f.paused),
        el("td", {}, bar(f.progress), " ", (100 * f.progress).toFixed(0) + " %"),
        el("td", { class: "num" }, f.spp_done + " / " + f.spp),
        el("td", { class: "num" }, fmtError(f.rel_error)),
        el("td", { class: "num" }, fmtTime(f.elapsed_s)))));
  // Running tasks and their workers.
  const rows = tasks.tasks.map((t) => el("tr", { "data-task": t.task },
    el("td", { class: "num" }, t.task),
    el("td", {}, t.kind === "photon" ? "photon batch " + t.batch : "tile " + t.tile + ", pass " + t.pass),
    el("td", { class: "num" }, t.kind === "photon" ? "–" : t.sample_begin + "–" + t.sample_end),
    el("td", {}, el("span", { class: "swatch" }, "■ "), t.worker_name + " (" + t.worker + ")"),
    el("td", { class: "num" }, t.attempt),
    el("td", { class: "num" }, fmtTime(t.running_s)),
    el("td", {}, may && j.actions.requeue ?
       el("button", { onclick: () => act("/api/jobs/" + id + "/tasks/" + t.task + "/requeue") }, "Requeue") : "")));
  rows.forEach((r, i) => { r.querySelector(".swatch").style.color = workerColour(tasks.tasks[i].worker); });
  swap(document.getElementById("tasks-body"), ...rows);
  document.getElementById("tasks-none").hidden = rows.length > 0;
  // The log, appended.
  const pre = document.getElementById("job-log");
  for (const l of log.lines) {
    if (l.seq <= state.logSeq) continue; // an answer to an earlier, overlapping poll
    pre.append(l.text + "\n");
    state.logSeq = l.seq;
  }
  if (log.lines.length) pre.scrollTop = pre.scrollHeight;
}

function buildJobPage(id) {
  const priority = el("input", { id: "priority-value", type: "number", min: -1000, max: 1000,
                                 value: 0, size: 5, "aria-label": "priority" });
  const page = el("div", { id: "job-page" },
    el("h1", { id: "job-title" }, "Job " + id),
    el("div", { class: "actions" },
      el("button", { id: "action-cancel", class: "danger",
                     onclick: () => { if (confirm("Cancel job " + id + "?")) act("/api/jobs/" + id + "/cancel"); } },
         "Cancel"),
      el("button", { id: "action-pause",
                     onclick: (e) => act("/api/jobs/" + id + (e.target.dataset.paused === "1" ? "/resume" : "/pause")) },
         "Pause"),
      priority,
      el("button", { id: "action-priority",
                     onclick: () => act("/api/jobs/" + id + "/priority", { priority: parseInt(priority.value, 10) }) },
         "Set priority")),
    el("p", { id: "private-note", class: "muted", hidden: "hidden" }),
    el("div", { class: "grid" },
      el("div", { class: "card" }, el("h2", {}, "Preview ", el("span", { id: "preview-note", class: "muted" })),
         el("img", { id: "preview", alt: "progressive preview of job " + id, hidden: "hidden" })),
      el("div", { class: "card" }, el("h2", {}, "Job"), el("dl", { class: "facts", id: "job-facts" }),
         el("div", { id: "photon-phase", hidden: "hidden" }))),
    el("div", { class: "grid" },
      el("div", { class: "card" }, el("h2", {}, "Error against time"), el("div", { id: "plot-box" })),
      el("div", { class: "card" }, el("h2", {}, "Tile map ",
           el("select", { id: "tile-mode", "aria-label": "colour tiles by",
                          onchange: (e) => { state.tileMode = e.target.value; refresh(); } },
              el("option", { value: "passes" }, "by passes merged"),
              el("option", { value: "spp" }, "by samples per pixel"),
              el("option", { value: "time" }, "by running time"))),
         el("canvas", { id: "tilemap" }),
         el("p", { class: "legend", id: "tile-legend" }, "darker: more passes merged; blue: stopped by adaptive sampling (converged); outlined: running, in its worker's colour"))),
    el("div", { class: "card", id: "frames-card", hidden: "hidden" }, el("h2", {}, "Frames"),
      el("table", { id: "frames-table" },
        el("thead", {}, el("tr", {}, ...["frame", "job", "file", "state", "progress", "spp", "error", "elapsed"].map((h) => el("th", {}, h)))),
        el("tbody", { id: "frames-body" }))),
    el("div", { class: "card" }, el("h2", {}, "Running tasks"),
      el("table", { id: "tasks-table" },
        el("thead", {}, el("tr", {}, ...["task", "what", "samples", "worker", "attempt", "running", ""].map((h) => el("th", {}, h)))),
        el("tbody", { id: "tasks-body" })),
      el("p", { id: "tasks-none", class: "muted" }, "No task running.")),
    el("div", { class: "card" }, el("h2", {}, "Log"), el("pre", { class: "log", id: "job-log" })));
  render(page);
  document.getElementById("tile-mode").value = state.tileMode;
}

// ---------------------------------------------------------------- workers

async function viewWorkers(gen) {
  let data;
  try { data = await api("/api/workers"); } catch (e) {
    if (e.status !== 401 || gen !== state.gen) throw e;
    render(el("div", {}, el("h1", {}, "Workers"), signIn("Without a token the workers are not shown.")));
    return;
  }
  if (gen !== state.gen) return;
  publicBanner(data.actions);
  const admin = data.actions.admin === true;
  const now = performance.now() / 1000;
  const rows = data.workers.map((w) => {
    // Samples per second between two polls of the cumulative count.
    const prev = state.workerRates.get(w.id);
    // The master's figure, as `prismfarm workers` shows it; else the change between two polls.
    let rate = prev ? prev.rate : undefined;
    if (prev && now - prev.t >= 0.5) rate = (w.samples_done - prev.samples) / (now - prev.t);
    if (!prev || now - prev.t >= 0.5) state.workerRates.set(w.id, { t: now, samples: w.samples_done, rate });
    if (w.samples_per_s !== undefined) rate = w.samples_per_s;
    const blocked = w.blocklisted === undefined ? "–" : w.blocklisted ? "yes" : "no";
    return el("tr", { "data-worker": w.id },
      el("td", { class: "num" }, w.id),
      el("td", {}, w.name),
      el("td", {}, w.key || "–"),
      el("td", { class: "num" }, w.threads),
      stateCell(w.state),
      el("td", { class: "num" }, w.tasks_running),
      el("td", { class: "num" }, rate === undefined ? "–" : fmtCount(Math.max(0, Math.round(rate)))),
      el("td", { class: "num" }, w.tasks_done),
      el("td", { class: "num" }, w.tasks_failed),
      el("td", {}, blocked),
      el("td", { class: "num" }, fmtTime(w.last_seen_s)),
      // Blocklisting is an administrator's.
      el("td", {}, admin && data.actions.blocklist ?
         el("button", { onclick: () => act("/api/workers/" + w.id + (w.blocklisted ? "/unblock" : "/blocklist")) },
            w.blocklisted ? "Unblock" : "Blocklist") : ""));
  });
  render(el("div", {}, el("h1", {}, "Workers"),
    data.workers.length ? el("table", { id: "workers-table" },
      el("thead", {}, el("tr", {}, ...["id", "host", "key", "threads", "state", "tasks", "samples/s",
                                       "done", "failures", "blocklisted", "last seen", ""].map((h) => el("th", {}, h)))),
      el("tbody", {}, ...rows)) : el("p", { class: "muted" }, "No worker yet: prismfarm worker --master ...")));
}

// ---------------------------------------------------------------- the loop

// Replaces a container's children only when the new ones read differently: a poll that
// changed nothing leaves the page alone, so a selection, a hover or a click in progress
// survives it (listeners are closures over the same ids, so the old nodes' still apply).
function swap(container, ...nodes) {
  const html = nodes.map((n) => n.outerHTML).join("");
  if (container.dataset.drawn === html) return;
  container.replaceChildren(...nodes);
  container.dataset.drawn = html;
}

function render(node) {
  swap(document.getElementById("view"), node);
}

function route() {
  const h = location.hash || "#/jobs";
  let m;
  if ((m = h.match(/^#\/job\/(\d+)$/))) return { name: "job", id: parseInt(m[1], 10) };
  if (h === "#/workers") return { name: "workers" };
  return { name: "jobs" };
}

// One poll at a time: a page change and the timer may ask at once, and their answers would
// otherwise be applied twice.
let polling = Promise.resolve();
function refresh() {
  polling = polling.then(poll, poll);
  return polling;
}

async function poll() {
  const r = route();
  const gen = state.gen;
  document.getElementById("nav-jobs").className = r.name !== "workers" ? "active" : "";
  document.getElementById("nav-workers").className = r.name === "workers" ? "active" : "";
  try {
    if (r.name === "job") await viewJob(gen, r.id);
    else if (r.name === "workers") await viewWorkers(gen);
    else await viewJobs(gen);
    document.body.dataset.loaded = "1";
  } catch (e) {
    if (gen !== state.gen) return;
    // A read that needs a token: the page says how to sign in instead of an error.
    if (e.status === 401) { render(signIn(String(e.message || e) + ".")); document.body.dataset.loaded = "1"; }
    else message(String(e.message || e), true);
  }
}

function schedule() {
  clearTimeout(state.timer);
  state.timer = setTimeout(async () => { await refresh(); schedule(); }, POLL_MS);
}

async function showWho() {
  const who = document.getElementById("whoami");
  if (!token()) { who.textContent = "not signed in"; return; }
  try {
    const r = await fetch("/api/whoami", { headers: authHeaders() });
    const b = await r.json();
    who.textContent = r.ok ? "signed in as " + b.name + (b.admin ? " (admin)" : "") : "token refused";
  } catch (e) { who.textContent = "token refused"; }
}

// A new token (or none) shows another page: drawn again from scratch.
function reload() { state.gen++; state.jobId = 0; message("", false); showWho(); refresh(); }

window.addEventListener("hashchange", () => { state.gen++; state.jobId = 0; message("", false); refresh(); });
window.addEventListener("DOMContentLoaded", () => {
  document.getElementById("token-form").addEventListener("submit", (e) => {
    e.preventDefault();
    const t = document.getElementById("token").value.trim();
    if (t) sessionStorage.setItem("prismfarm-token", t);
    document.getElementById("token").value = "";
    reload();
  });
  document.getElementById("token-clear").addEventListener("click", () => {
    sessionStorage.removeItem("prismfarm-token");
    reload();
  });
  showWho();
  refresh();
  schedule();
});
