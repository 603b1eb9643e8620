// One run as `ffseg segment` does it with --mesh-resolution N: grey-level
// target, the crop budget min(voxels, 2^26), at most 200 steps.
"use strict";

function segmentLikeTool(lib, img, spheres, { meshResolution = 33, maxSteps = 200, targetMode = "intensity", onStep } = {}) {
  const voxels = img.dims[0] * img.dims[1] * img.dims[2];
  const e = new lib.Engine({ maxObjects: spheres.length, meshResolution, maxRoiVoxels: Math.min(voxels, 2 ** 26), targetMode });
  try {
    e.setParams({ targetMode });
    e.setVolume(img.voxels, img.dims, img.affine, { rescaleSlope: img.sclSlope, rescaleIntercept: img.sclInter });
    spheres.forEach((s, k) => e.initSphere(k, s.centre, s.radius));
    let last, steps = 0;
    const stepMs = [];
    while (steps < maxSteps) {
      const t0 = performance.now();
      last = e.step();
      stepMs.push(performance.now() - t0);
      ++steps;
      if (onStep) onStep(last, e);
      if (last.atRest) break;
    }
    return { steps, last, stepMs, masks: spheres.map((_, k) => e.rasterize(k)) };
  } finally {
    e.close();
  }
}

module.exports = { segmentLikeTool };
