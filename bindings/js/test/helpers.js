// Shared by the Node tests: the module's location, a phantom volume and the
// native tool's run on Colin27.
"use strict";
const path = require("path");
const fs = require("fs");
const ffseg = require("../ffseg.js");

const ROOT = path.join(__dirname, "..", "..", "..");
const WASM_DIR = process.env.FFSEG_WASM_DIR || path.join(ROOT, "build-wasm");

// A ball of radius r voxels (value 100) in a box of zeros, spacing 1 x 1 x 1.5
// mm, float32: a binary target with a known volume.
function ballPhantom({ nx = 40, ny = 36, nz = 30, r = 8, zSpacing = 1.5 } = {}) {
  const voxels = new Float32Array(nx * ny * nz);
  const c = [nx / 2, ny / 2, nz / 2];
  let inside = 0;
  for (let k = 0; k < nz; ++k)
    for (let j = 0; j < ny; ++j)
      for (let i = 0; i < nx; ++i) {
        const dx = i - c[0], dy = j - c[1], dz = (k - c[2]) * zSpacing;
        if (dx * dx + dy * dy + dz * dz < r * r) { voxels[i + nx * (j + ny * k)] = 100; ++inside; }
      }
  const affine = [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, zSpacing, 0, 0, 0, 0, 1];
  return { voxels, dims: [nx, ny, nz], affine, centre: [c[0], c[1], c[2] * zSpacing], inside };
}

function count(mask) {
  let n = 0;
  for (let i = 0; i < mask.length; ++i) n += mask[i] !== 0;
  return n;
}

const load = (name = "ffseg") => ffseg.load({ dir: WASM_DIR, name });

// A .nii.gz file as nifti.read gives it.
async function readNifti(file) {
  const nifti = require("../nifti.js");
  return nifti.read(await nifti.gunzip(fs.readFileSync(file)));
}

// The voxels where the binding's masks, written as the tool writes
// labels.nii.gz (object k as labels[k], a voxel inside two meshes as the
// first's), differ from the tool's label map.
function labelMapDiffers(native, masks, labels) {
  let differ = 0;
  for (let i = 0; i < native.length; ++i) {
    let mine = 0;
    for (let k = 0; k < labels.length && !mine; ++k) if (masks[k][i]) mine = labels[k];
    if (mine !== native[i]) ++differ;
  }
  return differ;
}

// One line on the binding's runs, for the test's diagnostics.
const runsText = (run) => run.runs.map((r) => `n = ${r.meshResolution} from the ${r.from}, ${r.steps} steps`).join("; ");

module.exports = { ROOT, WASM_DIR, ballPhantom, count, load, readNifti, labelMapDiffers, runsText, fs, path };
