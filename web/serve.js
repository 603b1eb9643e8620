// A static file server for web/ on 127.0.0.1 (make web, make check-browser).
// Usage: node serve.js [port]; port 0 picks a free one. Prints the URL.
"use strict";
const http = require("http");
const path = require("path");
const fs = require("fs");

const root = __dirname;
const TYPES = { ".html": "text/html; charset=utf-8", ".js": "text/javascript; charset=utf-8", ".css": "text/css",
  ".wasm": "application/wasm", ".json": "application/json", ".png": "image/png" };

function start(port = 0) {
  const server = http.createServer((req, res) => {
    let rel;
    try { rel = decodeURIComponent(new URL(req.url, "http://127.0.0.1").pathname); } catch { rel = null; }
    if (rel === "/") rel = "/index.html";
    const file = rel && path.join(root, path.normalize(rel));
    // web/ only, and not its node_modules: the page gets NiiVue from dist/.
    if (!file || !file.startsWith(root + path.sep) || file.startsWith(path.join(root, "node_modules"))) {
      res.writeHead(403).end("forbidden");
      return;
    }
    fs.readFile(file, (err, data) => {
      if (err) { res.writeHead(404, { "Content-Type": "text/plain" }).end(`not found: ${rel}`); return; }
      res.writeHead(200, { "Content-Type": TYPES[path.extname(file)] || "application/octet-stream", "Cache-Control": "no-store" });
      res.end(data);
    });
  });
  return new Promise((resolve) => server.listen(port, "127.0.0.1", () => resolve(server)));
}

if (require.main === module) {
  const port = Number(process.argv[2] || 8032);
  start(port).then((s) => console.log(`ffseg viewer: http://127.0.0.1:${s.address().port}/  (Ctrl-C stops it)`));
}
module.exports = { start };
