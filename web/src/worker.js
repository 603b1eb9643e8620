/* The engine's thread: the page hands it the file's bytes and the spheres; it
 * steps the engine and posts every step's report and meshes back, so the page
 * stays responsive. Classic worker: the emscripten glue (ffseg.js), the
 * binding and the NIfTI reader are plain scripts beside it in dist/. */
/* global importScripts, ffseg, ffsegNifti, createFfsegModule */
"use strict";
importScripts("ffseg.js", "ffseg-binding.js", "nifti.js");

let lib = null;
let image = null;
// The engines (one per mesh resolution a run uses) and their workspaces
// outlive a run: the next Segment of one object with the same target reuses
// them (several objects get a new engine each run: an engine cannot take its
// objects away, and the last run's meshes would stand in the new spheres' way).
const engines = new Map();
let stopRequested = false;
let busy = false;

async function library() {
  if (!lib) {
    const response = await fetch("ffseg.wasm");
    if (!response.ok) throw new Error(`cannot load ffseg.wasm (HTTP ${response.status})`);
    lib = await ffseg.load({ factory: createFfsegModule, wasmBinary: await response.arrayBuffer() });
  }
  return lib;
}

const yieldToMessages = () => new Promise((resolve) => setTimeout(resolve, 0));

async function openVolume(bytes, name) {
  const raw = new Uint8Array(bytes);
  image = null;
  image = ffsegNifti.read(await ffsegNifti.gunzip(raw));
  await library();
  postMessage({ type: "volume", name, dims: image.dims, affine: image.affine, which: image.which,
    datatype: image.datatypeName, spacing: image.spacing });
}

async function segment({ spheres, target = "intensity", meshResolution = 33, maxSteps = 200 }) {
  if (!image) throw new Error("open a volume first");
  if (!spheres.length) throw new Error("place a sphere first (click a slice)");
  const L = await library();
  busy = true;
  stopRequested = false;
  try {
    const result = await L.segment(image, spheres, {
      meshResolution, maxSteps, targetMode: target, engines,
      shouldStop: () => stopRequested,
      onStep: async (report, { meshResolution: n, engine, run }) => {
        const meshes = spheres.map((_, k) => engine.extractMesh(k));
        postMessage({ type: "step", report: { ...report }, meshes, meshResolution: n, run },
          meshes.flatMap((m) => [m.vertices.buffer, m.triangles.buffer]));
        await yieldToMessages();
      },
    });
    // The label map: object k's voxels get label k + 1 (a voxel two meshes
    // share keeps the lower label).
    const n = image.dims[0] * image.dims[1] * image.dims[2];
    const labels = new Uint8Array(n);
    for (let k = spheres.length - 1; k >= 0; --k) {
      const m = result.masks[k];
      for (let i = 0; i < n; ++i) if (m[i]) labels[i] = k + 1;
    }
    const file = ffsegNifti.writeLabels(image, labels, "ffseg " + spheres.length + " object(s)");
    postMessage({ type: "done", steps: result.steps, stopped: result.stopped, status: result.last ? result.last.status : "none",
      objectFlags: result.last ? result.last.objectFlags : [], stepMs: result.stepMs,
      runs: result.runs.map((r) => ({ meshResolution: r.meshResolution, from: r.from, steps: r.steps })),
      meshes: result.meshes, labels: file }, [file.buffer]);
  } finally {
    busy = false;
  }
}

onmessage = async (ev) => {
  const m = ev.data;
  try {
    if (m.type === "volume") await openVolume(m.bytes, m.name);
    else if (m.type === "segment") {
      if (busy) throw new Error("a segmentation is running; stop it first");
      await segment(m);
    } else if (m.type === "stop") stopRequested = true;
  } catch (ex) {
    postMessage({ type: "error", during: m.type, message: ex && ex.message ? ex.message : String(ex) });
  }
};
