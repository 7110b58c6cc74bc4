// drapery's browser viewer: jobs, submission, 3D playback of a job's
// WebSocket stream (three.js) and plots of its statistics (uPlot).
// Plain modules, no build step: the server embeds these files.
import * as THREE from "three";
import { OrbitControls } from "/assets/OrbitControls.js";

const $ = (id) => document.getElementById(id);
const key = () => localStorage.getItem("drapery-key") || "";

// --- API ------------------------------------------------------------------

async function api(path, options = {}) {
  const headers = { ...(options.headers || {}) };
  if (key()) headers.Authorization = `Bearer ${key()}`;
  const r = await fetch(path, { ...options, headers });
  const body = r.headers.get("content-type")?.includes("json") ? await r.json() : null;
  if (!r.ok) throw Object.assign(new Error(body?.error?.message || r.statusText), { status: r.status, body });
  return body;
}

/** A URL that carries the key where headers cannot go (WebSocket, links). */
function withKey(path) {
  if (!key()) return path;
  return `${path}${path.includes("?") ? "&" : "?"}access_token=${encodeURIComponent(key())}`;
}

// --- submission -------------------------------------------------------------

async function loadExamples() {
  const names = await (await fetch("/examples")).json();
  $("example").replaceChildren(...names.map((n) => new Option(n, n)));
  $("example").value = names.includes("sphere-drape-30") ? "sphere-drape-30" : names[0];
}

function showErrors(err) {
  const list = $("errors");
  list.replaceChildren();
  if (!err) return;
  const e = err.body?.error;
  const details = e?.details?.length ? e.details : [{ path: e?.path || "", message: e?.message || err.message }];
  for (const d of details) {
    const li = document.createElement("li");
    if (d.path) {
      const code = document.createElement("code");
      code.textContent = d.path;
      code.title = "show in the spec";
      code.onclick = () => selectField(d.path);
      li.append(code, `: ${d.message}`);
    } else {
      li.textContent = d.message;
    }
    list.append(li);
  }
}

/** Selects the spec field a path like `cloth.grid[0]` names in the editor. */
function selectField(path) {
  const box = $("spec-text");
  const last = path.split(".").pop().replace(/\[\d+\]$/, "");
  const at = box.value.indexOf(`"${last}"`);
  $("custom").open = true;
  box.focus();
  if (at >= 0) box.setSelectionRange(at, at + last.length + 2);
}

async function submit(text) {
  showErrors(null);
  try {
    const job = await api("/v1/jobs", { method: "POST", headers: { "content-type": "application/json" }, body: text });
    await refreshJobs();
    openJob(job.id, job.name);
  } catch (err) {
    showErrors(err);
  }
}

$("submit-example").onclick = async () => {
  const text = await (await fetch(`/examples/${$("example").value}`)).text();
  $("spec-text").value = text;
  submit(text);
};
$("submit-text").onclick = () => submit($("spec-text").value);
$("spec-file").onchange = async (e) => {
  const f = e.target.files[0];
  if (f) $("spec-text").value = await f.text();
};
$("api-key").value = key();
$("api-key").onchange = (e) => { localStorage.setItem("drapery-key", e.target.value.trim()); refreshJobs(); };

// --- jobs -----------------------------------------------------------------

async function refreshJobs() {
  let list;
  try {
    list = await api("/v1/jobs?limit=50");
    $("server-note").textContent = "";
  } catch (err) {
    $("server-note").textContent = err.status === 401 ? "this server needs an API key" : err.message;
    return;
  }
  const rows = list.jobs.map((j) => {
    const tr = document.createElement("tr");
    tr.dataset.id = j.id;
    tr.className = j.id === player.id ? "open" : "";
    const bar = Object.assign(document.createElement("progress"), { max: 1, value: j.progress.fraction });
    const cancel = document.createElement("button");
    cancel.textContent = "cancel";
    cancel.hidden = !["queued", "running"].includes(j.status);
    cancel.onclick = async (e) => {
      e.stopPropagation();
      try { await api(`/v1/jobs/${j.id}`, { method: "DELETE" }); } catch (err) { showErrors(err); }
      refreshJobs();
    };
    const cells = [j.name, j.status, bar, cancel].map((c) => {
      const td = document.createElement("td");
      td.append(c);
      return td;
    });
    cells[1].className = `status-${j.status}`;
    tr.append(...cells);
    tr.onclick = () => openJob(j.id, j.name);
    return tr;
  });
  $("job-rows").replaceChildren(...rows);
  const open = list.jobs.find((j) => j.id === player.id);
  if (open) showDownloads(open);
}

function showDownloads(job) {
  const done = ["succeeded", "failed", "cancelled"].includes(job.status) && job.progress.frames_done > 0;
  $("downloads").hidden = !done;
  for (const f of ["obj", "pc2", "glb"]) $(`dl-${f}`).href = withKey(`/v1/jobs/${job.id}/result?format=${f}`);
}

// --- 3D view ----------------------------------------------------------------

const renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
renderer.setPixelRatio(window.devicePixelRatio);
$("view").append(renderer.domElement);
const scene = new THREE.Scene();
scene.background = new THREE.Color(0xdfe3e8);
const camera = new THREE.PerspectiveCamera(40, 1, 0.01, 100);
camera.up.set(0, 0, 1);
camera.position.set(1.6, -1.6, 1.2);
const controls = new OrbitControls(camera, renderer.domElement);
scene.add(new THREE.HemisphereLight(0xffffff, 0x667788, 1.6));
const sun = new THREE.DirectionalLight(0xffffff, 1.8);
sun.position.set(2, -3, 4);
scene.add(sun);

const clothMaterial = new THREE.MeshStandardMaterial({ color: 0xffffff, vertexColors: true, side: THREE.DoubleSide, roughness: 0.8 });
const obstacleMaterial = new THREE.MeshStandardMaterial({ color: 0x8c96a3, roughness: 0.6, metalness: 0.1, side: THREE.DoubleSide });
// Cloth, particles held by an obstacle, particles touching another part of
// the cloth (self contact): the legend under the view uses the same colours.
const CLOTH = new THREE.Color(0x3b7dd8), CONTACT = new THREE.Color(0xf08c2e), SELF_CONTACT = new THREE.Color(0xd6336c);

function resize() {
  const { clientWidth: w, clientHeight: h } = $("view");
  renderer.setSize(w, h, false);
  renderer.domElement.style.width = "100%";
  renderer.domElement.style.height = "100%";
  camera.aspect = w / Math.max(h, 1);
  camera.updateProjectionMatrix();
}
window.addEventListener("resize", resize);
resize();

// --- playback state ------------------------------------------------------------

const player = {
  id: null, ws: null, hello: null, frames: [], times: [], stats: [],
  current: 0, playing: false, clock: 0, speed: 1, ended: null,
  cloth: null, obstacles: [], plots: [], plotsDirty: false,
};

function reset() {
  player.ws?.close();
  for (const o of [player.cloth, ...player.obstacles]) if (o) { scene.remove(o); o.geometry.dispose(); }
  Object.assign(player, { ws: null, hello: null, frames: [], times: [], stats: [], current: 0, playing: false, clock: 0, ended: null, cloth: null, obstacles: [] });
  $("plots").replaceChildren();
  player.plots = [];
  Object.assign($("scrub"), { max: "0", value: "0" });
  updateCounter();
}

function openJob(id, name) {
  reset();
  player.id = id;
  $("title").textContent = `${name} — ${id}`;
  for (const tr of $("job-rows").children) tr.className = tr.dataset.id === id ? "open" : "";
  const proto = location.protocol === "https:" ? "wss" : "ws";
  const ws = new WebSocket(`${proto}://${location.host}${withKey(`/v1/jobs/${id}/stream`)}`);
  ws.binaryType = "arraybuffer";
  let pending = null;
  ws.onmessage = (m) => {
    if (player.ws !== ws) return;
    if (typeof m.data !== "string") return onFrame(m.data, pending);
    const msg = JSON.parse(m.data);
    if (msg.type === "hello") onHello(msg);
    else if (msg.type === "stats") pending = msg;
    else { player.ended = msg.type; updateCounter(); refreshJobs(); }
  };
  player.ws = ws;
  player.playing = true;
  $("play").textContent = "Pause";
}

function onHello(h) {
  player.hello = h;
  const n = h.vertices;
  const geometry = new THREE.BufferGeometry();
  geometry.setAttribute("position", new THREE.BufferAttribute(new Float32Array(3 * n), 3));
  const colors = new Float32Array(3 * n);
  for (let i = 0; i < n; i++) CLOTH.toArray(colors, 3 * i);
  geometry.setAttribute("color", new THREE.BufferAttribute(colors, 3));
  geometry.setIndex(h.triangles.flat());
  player.cloth = new THREE.Mesh(geometry, clothMaterial);
  scene.add(player.cloth);
  for (const o of h.obstacles) {
    const g = new THREE.BufferGeometry();
    g.setAttribute("position", new THREE.BufferAttribute(new Float32Array(o.vertices.flat()), 3));
    g.setIndex(o.triangles.flat());
    g.computeVertexNormals();
    const mesh = new THREE.Mesh(g, obstacleMaterial);
    scene.add(mesh);
    player.obstacles.push(mesh);
  }
  makePlots();
  $("play").disabled = false;
  $("scrub").disabled = false;
}

function onFrame(buffer, stats) {
  const view = new DataView(buffer);
  const index = view.getUint32(0, true), count = view.getUint32(4, true), time = view.getFloat64(8, true);
  player.frames[index] = new Float32Array(buffer.slice(16, 16 + 12 * count));
  player.times[index] = time;
  player.stats[index] = stats || {};
  $("scrub").max = String(player.frames.length - 1);
  if (index === 0) { show(0); frameCamera(); }
  player.plotsDirty = true;
  updateCounter();
}

function frameCamera() {
  const box = new THREE.Box3().setFromObject(player.cloth);
  for (const o of player.obstacles) box.union(new THREE.Box3().setFromObject(o));
  const center = box.getCenter(new THREE.Vector3());
  const size = box.getSize(new THREE.Vector3()).length();
  controls.target.copy(center);
  camera.position.copy(center).add(new THREE.Vector3(0.55, -0.75, 0.5).multiplyScalar(size));
  camera.near = size / 100;
  camera.far = size * 20;
  camera.updateProjectionMatrix();
  controls.update();
}

/** Puts frame `k` on screen: cloth positions, contacts and self contacts, obstacle poses. */
function show(k) {
  const x = player.frames[k];
  if (!x || !player.cloth) return;
  player.current = k;
  const g = player.cloth.geometry;
  g.attributes.position.array.set(x);
  g.attributes.position.needsUpdate = true;
  g.computeVertexNormals();
  g.computeBoundingSphere();
  const s = player.stats[k] || {};
  const colors = g.attributes.color.array;
  for (let i = 0; i < colors.length / 3; i++) CLOTH.toArray(colors, 3 * i);
  for (const p of s.contact_particles || []) CONTACT.toArray(colors, 3 * p);
  for (const p of s.self_contact_particles || []) SELF_CONTACT.toArray(colors, 3 * p);
  $("self-contacts").textContent = String((s.self_contact_particles || []).length);
  g.attributes.color.needsUpdate = true;
  (s.obstacles || []).forEach((pose, j) => {
    const m = player.obstacles[j];
    if (!m) return;
    m.position.fromArray(pose.translation);
    m.quaternion.fromArray(pose.rotation);
  });
  $("scrub").value = String(k);
  updateCounter();
  for (const u of player.plots) u.redraw(false);
}

function updateCounter() {
  const total = player.hello ? player.hello.frames : 0;
  const end = player.ended ? ` · ${player.ended}` : player.hello ? " · live" : "";
  $("frame-counter").textContent = player.hello ? `frame ${player.current} / ${total - 1}${end}` : "frame – / –";
}

$("play").onclick = () => {
  player.playing = !player.playing;
  if (player.playing && player.current >= player.frames.length - 1 && player.ended) player.current = 0;
  player.clock = player.times[player.current] || 0;
  $("play").textContent = player.playing ? "Pause" : "Play";
};
$("scrub").oninput = (e) => {
  player.playing = false;
  $("play").textContent = "Play";
  show(Number(e.target.value));
};
$("speed").onchange = (e) => { player.speed = Number(e.target.value); };
$("wireframe").onchange = (e) => { clothMaterial.wireframe = e.target.checked; };

// --- plots --------------------------------------------------------------------

const SERIES = [
  ["CG iterations", (s) => s.cg_iterations],
  ["contacts", (s) => s.contacts],
  ["kinetic energy (J)", (s) => s.kinetic_energy],
  ["collision time fraction", (s) => (s.step_seconds > 0 ? s.collision_seconds / s.step_seconds : 0)],
  ["step time (ms)", (s) => (s.steps > 0 ? (1000 * s.step_seconds) / s.steps : null)],
];

/** A uPlot hook that draws the playback position as a vertical line. */
const cursorLine = {
  hooks: {
    draw: [(u) => {
      const t = player.times[player.current];
      if (t === undefined) return;
      const x = u.valToPos(t, "x", true);
      const ctx = u.ctx;
      ctx.save();
      ctx.strokeStyle = "#f08c2e";
      ctx.lineWidth = 2;
      ctx.beginPath();
      ctx.moveTo(x, u.bbox.top);
      ctx.lineTo(x, u.bbox.top + u.bbox.height);
      ctx.stroke();
      ctx.restore();
    }],
  },
};

function makePlots() {
  const width = Math.max(280, Math.floor($("plots").clientWidth / 3) - 12);
  for (const [label] of SERIES) {
    const div = document.createElement("div");
    $("plots").append(div);
    const u = new uPlot({
      width, height: 150, title: label, legend: { show: false },
      scales: { x: { time: false } },
      axes: [{ label: "t (s)", size: 36 }, { size: 56 }],
      series: [{}, { label, stroke: "#3b7dd8", width: 1.5 }],
      plugins: [cursorLine],
    }, [[], []], div);
    u.root.dataset.series = label;
    player.plots.push(u);
  }
}

function updatePlots() {
  if (!player.plotsDirty || !player.plots.length) return;
  player.plotsDirty = false;
  const ks = player.stats.map((_, k) => k).filter((k) => player.frames[k]);
  const t = ks.map((k) => player.times[k]);
  SERIES.forEach(([, f], j) => player.plots[j].setData([t, ks.map((k) => f(player.stats[k]) ?? null)]));
}

// --- loop ---------------------------------------------------------------------

let last = performance.now();
let lastPlot = 0;
function tick(now) {
  const dt = (now - last) / 1000;
  last = now;
  if (player.playing && player.frames.length) {
    player.clock += dt * player.speed;
    let k = player.current;
    while (k + 1 < player.frames.length && player.frames[k + 1] && player.times[k + 1] <= player.clock) k++;
    if (k !== player.current) show(k);
    const atEnd = k >= player.frames.length - 1;
    if (atEnd) player.clock = Math.min(player.clock, player.times[k]);
    if (atEnd && player.ended) { player.playing = false; $("play").textContent = "Play"; }
  }
  if (now - lastPlot > 250) { updatePlots(); lastPlot = now; }
  controls.update();
  renderer.render(scene, camera);
  requestAnimationFrame(tick);
}
requestAnimationFrame(tick);

await loadExamples();
await refreshJobs();
setInterval(refreshJobs, 1000);
const wanted = new URLSearchParams(location.search).get("job");
if (wanted) openJob(wanted, wanted);
