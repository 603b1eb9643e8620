// report.html's script (`ffseg segment --html`): the page carries its data in
// <script> elements (report.json's text, and the volume, label map and meshes
// in base64), so it opens from disk with nothing fetched. Bundled with NiiVue
// into dist/report-viewer.js (an IIFE the tool inlines).
import { Niivue, NVImage, NVMesh, SLICE_TYPE } from "@niivue/niivue";
import { colourOf } from "./colours.js";

const STYLE = `
body { margin: 0; font: 14px system-ui, sans-serif; background: #111; color: #ddd; }
header { padding: 0.6em 1em; background: #222; }
#view { height: 62vh; } canvas { width: 100%; height: 100%; display: block; }
table { border-collapse: collapse; margin: 1em; } td, th { padding: 0.2em 0.7em; text-align: right; border-bottom: 1px solid #333; }
th:first-child, td:first-child { text-align: left; } .swatch { display: inline-block; width: 0.9em; height: 0.9em; margin-right: 0.4em; }
#message { margin: 1em; padding: 0.6em 1em; background: #622; color: #fff; white-space: pre-wrap; }`;

function bytesOf(el) {
  const s = atob(el.textContent.trim());
  const out = new Uint8Array(s.length);
  for (let i = 0; i < s.length; ++i) out[i] = s.charCodeAt(i);
  return out;
}

function element(tag, attrs = {}, text) {
  const el = document.createElement(tag);
  Object.assign(el, attrs);
  if (text !== undefined) el.textContent = text;
  return el;
}

function fmt(v, digits = 3) {
  if (v === undefined || v === null) return "";
  return typeof v === "number" ? (Number.isInteger(v) ? String(v) : v.toFixed(digits)) : String(v);
}

function table(report) {
  const objects = report.objects || [];
  const hasMetrics = objects.some((o) => o.metrics);
  const cols = [["object", (o, k) => o.name], ["label", (o) => o.label], ["voxels", (o) => o.voxels],
    ["volume ml", (o) => o.volume_ml], ["vertices", (o) => o.vertices], ["centre mm", (o) => (o.sphere ? o.sphere.center_mm.map((x) => fmt(x, 1)).join(", ") : "")],
    ["radius mm", (o) => (o.sphere ? o.sphere.radius_mm : "")], ["final mean disp. mm", (o) => o.final_mean_displacement_mm]];
  if (hasMetrics) cols.push(["Dice", (o) => o.metrics && o.metrics.dice], ["HD95 mm", (o) => o.metrics && o.metrics.hd95_mm]);
  const t = element("table");
  const head = element("tr");
  for (const [name] of cols) head.append(element("th", {}, name));
  t.append(head);
  objects.forEach((o, k) => {
    const tr = element("tr");
    cols.forEach(([, get], c) => {
      const td = element("td", {}, fmt(get(o, k)));
      if (c === 0) { const sw = element("span", { className: "swatch" }); sw.style.background = `rgb(${colourOf(k).join(",")})`; td.prepend(sw); }
      tr.append(td);
    });
    t.append(tr);
  });
  return t;
}

async function main() {
  const style = element("style", {}, STYLE);
  document.head.append(style);
  const report = JSON.parse(document.getElementById("ffseg-report").textContent);
  const header = element("header");
  const steps = `${report.steps} steps, ${report.converged ? "converged" : "not converged"}`;
  header.append(element("strong", {}, "ffseg report"), ` — ${report.input ? report.input.path : ""}: ${steps}`);
  const view = element("div", { id: "view" });
  const canvas = element("canvas");
  view.append(canvas);
  document.body.append(header, view, table(report));
  const fail = (text) => document.body.append(element("div", { id: "message" }, text));

  const data = [...document.querySelectorAll('script[type="application/octet-stream"]')];
  const nv = new Niivue({ backColor: [0.05, 0.05, 0.05, 1], isColorbar: false, dragAndDropEnabled: false, multiplanarForceRender: true });
  window.ffsegReport = { nv, report };
  await nv.attachToCanvas(canvas);
  nv.setSliceType(SLICE_TYPE.MULTIPLANAR);
  nv.setMeshThicknessOn2D(0.5);
  const volume = data.find((d) => d.dataset.role === "volume");
  if (!volume) fail("The volume is not embedded (a DICOM series or a format the viewer does not read): the labels and meshes are shown alone.");
  for (const d of data.filter((x) => x.dataset.role !== "mesh")) {
    const file = new File([bytesOf(d)], d.dataset.name);
    const labels = d.dataset.role === "labels";
    try {
      nv.addVolume(await NVImage.loadFromFile({ file, name: d.dataset.name, colormap: labels ? "red" : "gray", opacity: labels ? 0.35 : 1 }));
    } catch (ex) {
      fail(`cannot show ${d.dataset.name}: ${ex.message || ex}`);
    }
  }
  const meshes = data.filter((x) => x.dataset.role === "mesh");
  for (const [k, d] of meshes.entries()) {
    try {
      const m = await NVMesh.readMesh(bytesOf(d).buffer, d.dataset.name, nv.gl, 1, new Uint8Array([...colourOf(k), 255]));
      nv.addMesh(m);
    } catch (ex) {
      fail(`cannot show the mesh ${d.dataset.name}: ${ex.message || ex}`);
    }
  }
  const first = report.objects && report.objects[0];
  if (first && first.sphere && nv.volumes.length) nv.scene.crosshairPos = nv.mm2frac(first.sphere.center_mm);
  nv.drawScene();
  document.body.dataset.state = "shown";
}

main().catch((ex) => {
  document.body.append(element("div", { id: "message" }, `report.html cannot be shown: ${ex.message || ex}`));
  document.body.dataset.state = "error";
});
