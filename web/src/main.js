// The viewer page: NiiVue shows the volume, the spheres and the meshes; the
// engine runs in dist/worker.js. Bundled by esbuild into dist/viewer.js (an
// IIFE, so the page needs no module loader and nothing from the network).
import { Niivue, NVMesh, NVImage, SLICE_TYPE } from "@niivue/niivue";
import { colourOf } from "./colours.js";

const $ = (id) => document.getElementById(id);

const state = {
  volumeName: null,
  spheres: [],        // { centre: [x, y, z] mm, radius mm, mesh: NVMesh, disp }
  selected: -1,
  running: false,
  labels: null,       // the last run's label map (NIfTI bytes)
  meshes: [],         // the last step's { vertices, triangles } per object
  steps: 0,
  lastRun: null,      // { steps, status, stepMs }
  errors: [],
};

const nv = new Niivue({ backColor: [0.05, 0.05, 0.05, 1], show3Dcrosshair: true, dragAndDropEnabled: false,
  isColorbar: false, multiplanarForceRender: true });
const worker = new Worker("dist/worker.js");

function showError(text) {
  state.errors.push(text);
  const box = $("message");
  box.textContent = text;
  box.hidden = false;
  setStatus("error: see the message below");
}
function clearError() { $("message").hidden = true; }
function setStatus(text) { $("status").textContent = text; }
window.addEventListener("error", (ev) => showError(`unexpected error: ${ev.message}`));
window.addEventListener("unhandledrejection", (ev) => showError(`unexpected error: ${ev.reason && ev.reason.message ? ev.reason.message : ev.reason}`));
worker.onerror = (ev) => { ev.preventDefault(); showError(`the engine's worker failed: ${ev.message || "it could not start (is dist/ built?)"}`); state.running = false; refresh(); };

// ---- spheres -------------------------------------------------------------------
// A UV sphere for display only: the engine makes its own cube-sphere mesh.
function sphereMesh(c, r, rings = 12, segments = 20) {
  const pts = [], tris = [];
  for (let i = 0; i <= rings; ++i) {
    const th = (Math.PI * i) / rings;
    for (let j = 0; j < segments; ++j) {
      const ph = (2 * Math.PI * j) / segments;
      pts.push(c[0] + r * Math.sin(th) * Math.cos(ph), c[1] + r * Math.sin(th) * Math.sin(ph), c[2] + r * Math.cos(th));
    }
  }
  for (let i = 0; i < rings; ++i)
    for (let j = 0; j < segments; ++j) {
      const a = i * segments + j, b = i * segments + ((j + 1) % segments), c2 = a + segments, d = b + segments;
      tris.push(a, c2, b, b, c2, d);
    }
  return { vertices: new Float32Array(pts), triangles: new Uint32Array(tris) };
}

// Drawing is the slow part (a software renderer draws four views): every
// change asks for one draw at the next frame, and steps that arrive faster
// than frames are drawn once, with the latest meshes.
let drawPending = false;
function scheduleDraw() {
  if (drawPending) return;
  drawPending = true;
  requestAnimationFrame(() => { drawPending = false; nv.drawScene(); });
}

function setMesh(k, geometry) {
  const s = state.spheres[k];
  const colour = colourOf(k);
  if (s.mesh && s.mesh.pts.length === geometry.vertices.length && s.mesh.tris.length === geometry.triangles.length) {
    s.mesh.pts = geometry.vertices;
    s.mesh.tris = geometry.triangles;
    s.mesh.updateMesh(nv.gl);
  } else {
    if (s.mesh) nv.removeMesh(s.mesh);
    s.mesh = new NVMesh(geometry.vertices, geometry.triangles, `object ${k + 1}`, new Uint8Array([...colour, 255]), 1, true, nv.gl);
    nv.addMesh(s.mesh);
  }
  scheduleDraw();
}

function addSphere(centre, radius) {
  state.spheres.push({ centre: centre.map(Number), radius: Number(radius), mesh: null, disp: null });
  state.selected = state.spheres.length - 1;
  setMesh(state.selected, sphereMesh(centre, radius));
  refresh();
}

function updateSphere(k) {
  const s = state.spheres[k];
  setMesh(k, sphereMesh(s.centre, s.radius));
  refresh();
}

function removeSphere(k) {
  const s = state.spheres[k];
  if (s.mesh) nv.removeMesh(s.mesh);
  state.spheres.splice(k, 1);
  state.selected = Math.min(state.selected, state.spheres.length - 1);
  state.spheres.forEach((_, i) => updateSphere(i));
  refresh();
}

function refresh() {
  const body = $("spheres").querySelector("tbody");
  body.innerHTML = "";
  state.spheres.forEach((s, k) => {
    const tr = document.createElement("tr");
    tr.className = k === state.selected ? "selected" : "";
    tr.dataset.index = k;
    const cell = (content) => { const td = document.createElement("td"); td.append(content); tr.append(td); return td; };
    cell(String(k + 1)).style.color = `rgb(${colourOf(k).join(",")})`;
    [0, 1, 2, 3].forEach((a) => {
      const inp = document.createElement("input");
      inp.type = "number";
      inp.step = "any";
      inp.className = a < 3 ? `c${a}` : "r";
      inp.value = a < 3 ? s.centre[a] : s.radius;
      inp.disabled = state.running;
      inp.addEventListener("change", () => {
        const v = Number(inp.value);
        if (!Number.isFinite(v) || (a === 3 && !(v > 0))) { showError(`sphere ${k + 1}: ${a < 3 ? "a coordinate" : "the radius"} must be a ${a < 3 ? "" : "positive "}number`); inp.value = a < 3 ? s.centre[a] : s.radius; return; }
        if (a < 3) s.centre[a] = v; else s.radius = v;
        state.selected = k;
        updateSphere(k);
      });
      cell(inp);
    });
    cell(s.disp === null ? "" : s.disp.toFixed(3));
    const del = document.createElement("button");
    del.textContent = "×";
    del.title = "remove this sphere";
    del.disabled = state.running;
    del.addEventListener("click", () => removeSphere(k));
    cell(del);
    tr.addEventListener("click", (ev) => { if (ev.target.tagName !== "INPUT" && ev.target.tagName !== "BUTTON") { state.selected = k; syncRadius(); refresh(); } });
    body.append(tr);
  });
  const have = state.volumeName !== null;
  $("segment").disabled = !have || state.running || state.spheres.length === 0;
  $("stop").disabled = !state.running;
  $("save-labels").disabled = state.running || !state.labels;
  $("save-mesh").disabled = state.running || state.meshes.length === 0;
  document.body.dataset.state = state.running ? "running" : state.labels ? "done" : have ? "ready" : "empty";
  scheduleDraw();
}

function syncRadius() {
  const s = state.spheres[state.selected];
  if (s) { $("radius").value = s.radius; $("radius-value").textContent = s.radius.toFixed(1); }
}

// ---- the volume ----------------------------------------------------------------
async function openFile(file) {
  clearError();
  if (state.running) { showError("a segmentation is running: stop it before opening another volume"); return; }
  setStatus(`reading ${file.name}…`);
  const bytes = await file.arrayBuffer();
  // The worker checks the file with the engine's reader first: a file it
  // refuses never reaches the display.
  worker.postMessage({ type: "volume", bytes: bytes.slice(0), name: file.name });
  state.pendingFile = { file, bytes };
}

async function showVolume(msg) {
  const { file } = state.pendingFile;
  for (const s of state.spheres) if (s.mesh) nv.removeMesh(s.mesh);
  state.spheres = [];
  state.labels = null;
  state.meshes = [];
  while (nv.volumes.length) nv.removeVolume(nv.volumes[0]);
  try {
    const img = await NVImage.loadFromFile({ file, name: file.name });
    nv.addVolume(img);
  } catch (ex) {
    showError(`NiiVue cannot show ${file.name}: ${ex.message || ex}`);
    return;
  }
  state.volumeName = file.name;
  state.volumeInfo = msg;
  nv.setSliceType(SLICE_TYPE.MULTIPLANAR);
  nv.setMeshThicknessOn2D(0.5);
  setStatus(`${file.name}: ${msg.dims.join(" × ")} voxels (${msg.datatype}, ${msg.which}); click a slice to place a sphere`);
  refresh();
}

// ---- the engine ----------------------------------------------------------------
function segment() {
  clearError();
  if (!state.spheres.length) { showError("place a sphere first (click a slice)"); return; }
  const n = Number($("mesh-n").value);
  if (!Number.isInteger(n) || n < 2 || n > 1024) { showError("the mesh resolution n must be an integer in 2..1024"); return; }
  state.running = true;
  state.labels = null;
  state.steps = 0;
  if (state.labelImage) { nv.removeVolume(state.labelImage); state.labelImage = null; }
  refresh();
  setStatus("segmenting…");
  worker.postMessage({ type: "segment", target: $("target").value, meshResolution: n,
    spheres: state.spheres.map((s) => ({ centre: s.centre, radius: s.radius })) });
}

// Mesh uploads wait for the next frame too, so a burst of steps uploads once.
let meshesToShow = null;
function showMeshesSoon(meshes) {
  const first = meshesToShow === null;
  meshesToShow = meshes;
  if (first) requestAnimationFrame(() => { const m = meshesToShow; meshesToShow = null; m.forEach((g, k) => setMesh(k, g)); });
}

worker.onmessage = async (ev) => {
  const m = ev.data;
  if (m.type === "volume") await showVolume(m);
  else if (m.type === "step") {
    state.steps = m.report.stepIndex;
    state.meshes = m.meshes;
    showMeshesSoon(m.meshes);
    m.meshes.forEach((g, k) => { state.spheres[k].disp = m.report.meanDisplacementMm[k]; });
    const mean = m.report.meanDisplacementMm;
    setStatus(`step ${m.report.stepIndex} at n = ${m.meshResolution}: mean displacement ${mean.map((d) => d.toFixed(3)).join(", ")} mm`);
    $("steps").textContent = `run ${m.run + 1} (n = ${m.meshResolution}): step ${m.report.stepIndex}, ${m.report.status}`;
    refresh();
  } else if (m.type === "done") {
    state.running = false;
    state.labels = m.labels;
    state.meshes = m.meshes;
    m.meshes.forEach((g, k) => setMesh(k, g));
    state.lastRun = { steps: m.steps, status: m.status, stepMs: m.stepMs, stopped: m.stopped, objectFlags: m.objectFlags, runs: m.runs };
    const total = m.stepMs.reduce((a, b) => a + b, 0);
    setStatus(`${m.stopped ? "stopped" : m.status} after ${m.steps} steps (${(total / Math.max(1, m.steps)).toFixed(0)} ms a step)`);
    $("steps").textContent = m.runs.map((r) => `n = ${r.meshResolution} from the ${r.from}: ${r.steps} steps`).join("; ");
    if (m.status === "degenerate") showError(flagText(m.objectFlags));
    try {
      const img = await NVImage.loadFromFile({ file: new File([m.labels], "labels.nii"), name: "labels.nii", colormap: "red", opacity: 0.35 });
      state.labelImage = img;
      nv.addVolume(img);
      // the slices through the first object, so that its outline shows on them
      nv.scene.crosshairPos = nv.mm2frac(state.spheres[0].centre);
    } catch (ex) {
      showError(`cannot overlay the label map: ${ex.message || ex}`);
    }
    refresh();
  } else if (m.type === "error") {
    if (m.during === "segment") state.running = false;
    if (m.during === "volume") state.pendingFile = null;
    showError(m.during === "volume" ? `cannot open the volume: ${m.message}` : m.message);
    refresh();
  }
};

// What the engine's object flags (FFSEG_OBJECT_*) say, object by object.
function flagText(flags) {
  const why = [];
  flags.forEach((f, k) => {
    const said = [];
    if (f & 1) said.push("no vertex found a boundary: the sphere is not in or near an object of this target");
    if (f & 2) said.push("it fills most of the volume: it leaked into the background");
    if (f & 4) said.push("it stalled short of its boundary: a partial result");
    if (said.length) why.push(`object ${k + 1}: ${said.join("; ")}`);
  });
  return `the result is not a full segmentation (move or resize the sphere, or change the target):\n${why.join("\n")}`;
}

// ---- saving ----------------------------------------------------------------------
function download(bytes, name, type) {
  const url = URL.createObjectURL(new Blob([bytes], { type }));
  const a = document.createElement("a");
  a.href = url;
  a.download = name;
  document.body.append(a);
  a.click();
  a.remove();
  setTimeout(() => URL.revokeObjectURL(url), 10000);
}

// Every object's mesh in one binary little-endian PLY (world mm).
function plyBytes(meshes) {
  const nv0 = meshes.reduce((a, m) => a + m.vertices.length / 3, 0);
  const nt = meshes.reduce((a, m) => a + m.triangles.length / 3, 0);
  const head = new TextEncoder().encode(`ply\nformat binary_little_endian 1.0\ncomment ffseg viewer: ${meshes.length} object(s), world mm\n` +
    `element vertex ${nv0}\nproperty float x\nproperty float y\nproperty float z\n` +
    `element face ${nt}\nproperty list uchar int vertex_indices\nend_header\n`);
  const out = new Uint8Array(head.length + nv0 * 12 + nt * 13);
  out.set(head);
  const dv = new DataView(out.buffer);
  let at = head.length, base = 0;
  for (const m of meshes) for (const x of m.vertices) { dv.setFloat32(at, x, true); at += 4; }
  for (const m of meshes) {
    for (let t = 0; t < m.triangles.length; t += 3) {
      dv.setUint8(at, 3); at += 1;
      for (let c = 0; c < 3; ++c) { dv.setInt32(at, m.triangles[t + c] + base, true); at += 4; }
    }
    base += m.vertices.length / 3;
  }
  return out;
}

// ---- wiring -----------------------------------------------------------------------
$("file").addEventListener("change", (ev) => { if (ev.target.files[0]) openFile(ev.target.files[0]); ev.target.value = ""; });
$("segment").addEventListener("click", segment);
$("stop").addEventListener("click", () => worker.postMessage({ type: "stop" }));
$("save-labels").addEventListener("click", () => download(state.labels, "labels.nii", "application/octet-stream"));
$("save-mesh").addEventListener("click", () => download(plyBytes(state.meshes), "meshes.ply", "application/octet-stream"));
const radius = $("radius");
function setRadius(v) {
  v = Math.min(Number(radius.max), Math.max(Number(radius.min), v));
  radius.value = v;
  $("radius-value").textContent = Number(v).toFixed(1);
  const s = state.spheres[state.selected];
  if (s && !state.running) { s.radius = Number(v); updateSphere(state.selected); }
}
radius.addEventListener("input", () => setRadius(Number(radius.value)));
radius.addEventListener("wheel", (ev) => { ev.preventDefault(); setRadius(Number(radius.value) * (ev.deltaY < 0 ? 1.1 : 1 / 1.1)); }, { passive: false });

let dragging = 0;
document.addEventListener("dragenter", (ev) => { ev.preventDefault(); ++dragging; $("drop").hidden = false; });
document.addEventListener("dragleave", () => { if (--dragging <= 0) { dragging = 0; $("drop").hidden = true; } });
document.addEventListener("dragover", (ev) => ev.preventDefault());
document.addEventListener("drop", (ev) => {
  ev.preventDefault();
  dragging = 0;
  $("drop").hidden = true;
  const f = ev.dataTransfer.files[0];
  if (f) openFile(f); else showError("drop a NIfTI file (.nii or .nii.gz)");
});

// A click (not a drag) on a 2D slice places a sphere where NiiVue put the crosshair.
const canvas = $("gl");
let down = null;
canvas.addEventListener("pointerdown", (ev) => { down = [ev.clientX, ev.clientY]; });
canvas.addEventListener("pointerup", (ev) => {
  if (!down || !state.volumeName || state.running) return;
  const moved = Math.hypot(ev.clientX - down[0], ev.clientY - down[1]);
  down = null;
  if (moved > 4) return;
  // NiiVue moves the crosshair on the same click; read it once it has.
  requestAnimationFrame(() => {
    const mm = nv.frac2mm(nv.scene.crosshairPos);
    addSphere([mm[0], mm[1], mm[2]].map((x) => Math.round(x * 10) / 10), Number(radius.value));
    syncRadius();
  });
});

nv.attachToCanvas(canvas).then(() => {
  nv.setSliceType(SLICE_TYPE.MULTIPLANAR);
  refresh();
});

// For scripts (make check-browser) and the console: the page's state.
window.ffsegViewer = { state, nv, addSphere, removeSphere, segment };
