// The binding's wasm32 struct layout against the C compiler's (abi_layout.js is
// bindings/python/abi_layout.c built by emscripten): a field appended to
// ffseg.h, or a layout rule the binding gets wrong, fails here.
"use strict";
const test = require("node:test");
const assert = require("node:assert");
const { execFileSync } = require("child_process");
const { WASM_DIR, path } = require("./helpers.js");
const ffseg = require("../ffseg.js");

test("every struct's size and every field's offset match the C compiler's wasm32 layout", () => {
  const out = execFileSync(process.execPath, [path.join(WASM_DIR, "abi_layout.js")], { encoding: "utf8" });
  let structs = 0, fields = 0;
  const seen = {};
  for (const line of out.trim().split("\n")) {
    const w = line.split(" ");
    if (w[0] === "const") continue;
    const lay = ffseg.LAYOUTS[w[0]];
    assert.ok(lay, `the binding has no layout for ${w[0]}`);
    if (w[1] === "sizeof") { assert.strictEqual(lay.size, Number(w[2]), `sizeof(${w[0]})`); ++structs; continue; }
    const f = lay.fields[w[1]];
    assert.ok(f, `${w[0]}.${w[1]} is missing from the binding`);
    assert.deepStrictEqual([f.offset, f.size], [Number(w[2]), Number(w[3])], `${w[0]}.${w[1]} offset and size`);
    (seen[w[0]] = seen[w[0]] || new Set()).add(w[1]);
    ++fields;
  }
  assert.strictEqual(structs, 4);
  for (const [name, lay] of Object.entries(ffseg.LAYOUTS))
    assert.deepStrictEqual([...seen[name]].sort(), Object.keys(lay.fields).sort(), `${name}: fields the C layout does not list`);
  assert.ok(fields > 50);
});

test("the constants the binding repeats are the header's", () => {
  const out = execFileSync(process.execPath, [path.join(WASM_DIR, "abi_layout.js")], { encoding: "utf8" });
  const c = {};
  for (const line of out.split("\n")) { const w = line.split(" "); if (w[0] === "const") c[w[1]] = Number(w[2]); }
  assert.strictEqual(c.FFSEG_STAGE_COUNT, ffseg.STAGE_NAMES.length);
  assert.strictEqual(c.FFSEG_CONVERGED, ffseg.CONVERGED);
  assert.strictEqual(c.FFSEG_DEGENERATE, ffseg.DEGENERATE);
  assert.strictEqual(c.FFSEG_OBJECT_NO_BOUNDARY, ffseg.OBJECT_NO_BOUNDARY);
  assert.strictEqual(c.FFSEG_OBJECT_FILLS_GRID, ffseg.OBJECT_FILLS_GRID);
  assert.strictEqual(ffseg.LAYOUTS.ffseg_step_info.fields.mean_displacement_mm.count, c.FFSEG_REPORT_OBJECTS);
});
