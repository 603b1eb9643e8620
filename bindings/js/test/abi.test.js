// The binding's wasm32 struct layout against the C compiler's (abi_layout.js is
// abi/layout.c built by emscripten, the program the Rust and C# bindings'
// tests read too): a field appended to ffseg.h, or a layout rule the binding
// gets wrong, fails here. The constants it repeats are read from ffseg.h.
"use strict";
const test = require("node:test");
const assert = require("node:assert");
const { spawnSync } = require("child_process");
const { ROOT, WASM_DIR, fs, path } = require("./helpers.js");
const ffseg = require("../ffseg.js");

test("every struct's size and every field's offset match the C compiler's wasm32 layout", () => {
  const run = spawnSync(process.execPath, [path.join(WASM_DIR, "abi_layout.js")], { encoding: "utf8" });
  // layout.c refuses implicit padding, which 64-bit targets never have; on
  // wasm32 the 4-byte data pointer of ffseg_volume is followed by 4 bytes of it.
  assert.deepStrictEqual(run.stderr.trim().split("\n"),
    ["layout: ffseg_volume.data_bytes at 16, previous field ends at 12 (implicit padding)"]);
  const seen = {};
  let structs = 0, fields = 0;
  for (const line of run.stdout.trim().split("\n")) {
    const w = line.split(" ");
    const lay = ffseg.LAYOUTS[w[1]];
    assert.ok(lay, `the binding has no layout for ${w[1]}`);
    if (w[0] === "struct") { assert.strictEqual(lay.size, Number(w[2]), `sizeof(${w[1]})`); ++structs; continue; }
    const f = lay.fields[w[2]];
    assert.ok(f, `${w[1]}.${w[2]} is missing from the binding`);
    assert.deepStrictEqual([f.offset, f.size], [Number(w[3]), Number(w[4])], `${w[1]}.${w[2]} offset and size`);
    (seen[w[1]] = seen[w[1]] || []).push(w[2]);
    ++fields;
  }
  assert.strictEqual(structs, 4);
  for (const [name, lay] of Object.entries(ffseg.LAYOUTS))
    assert.deepStrictEqual(seen[name], Object.keys(lay.fields), `${name}: the binding's fields in the header's order`);
  assert.ok(fields > 50);
});

test("the constants the binding repeats are the header's", () => {
  const h = fs.readFileSync(path.join(ROOT, "include", "ffseg.h"), "utf8");
  const c = {};
  for (const m of h.matchAll(/#define (FFSEG_\w+) \(?(-?\d+)u?\)?/g)) c[m[1]] = Number(m[2]);
  assert.strictEqual(c.FFSEG_STAGE_COUNT, ffseg.STAGE_NAMES.length);
  assert.strictEqual(c.FFSEG_OK, ffseg.OK);
  assert.strictEqual(c.FFSEG_CONVERGED, ffseg.CONVERGED);
  assert.strictEqual(c.FFSEG_DEGENERATE, ffseg.DEGENERATE);
  assert.strictEqual(c.FFSEG_OBJECT_NO_BOUNDARY, ffseg.OBJECT_NO_BOUNDARY);
  assert.strictEqual(c.FFSEG_OBJECT_FILLS_GRID, ffseg.OBJECT_FILLS_GRID);
  assert.strictEqual(c.FFSEG_OBJECT_STALLED, ffseg.OBJECT_STALLED);
  assert.strictEqual(ffseg.LAYOUTS.ffseg_step_info.fields.mean_displacement_mm.count, c.FFSEG_REPORT_OBJECTS);
  // every FFSEG_ERR_* status has its name in the binding
  const errors = Object.entries(c).filter(([k]) => k.startsWith("FFSEG_ERR_"));
  assert.ok(errors.length >= 14);
  for (const [name, value] of errors) assert.strictEqual(ffseg.STATUS_CODES[value], name.slice("FFSEG_ERR_".length));
});
