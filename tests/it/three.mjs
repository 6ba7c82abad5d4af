// Loads a glTF file in three.js (npm `three`, GLTFLoader) in headless Chromium, served from a
// local server of its own, and writes what three made of it into OUT for tests/it/gltf.rs to
// check: the InstancedMeshes, each one's instance count, and the listed instances' places,
// scales and colours.
//
//   node three.mjs FILE.glb OUT.json I,J,K...
//
// puppeteer-core and three are found through NODE_PATH (.ci/run installs both).
import fs from "node:fs";
import http from "node:http";
import { createRequire } from "node:module";
import path from "node:path";

// NODE_PATH is not read by `import`: resolve through it.
const require = createRequire(path.join(process.cwd(), "noop.js"));
const puppeteer = require("puppeteer-core");
// three's package root (its `exports` do not include package.json): build/three.cjs's parent's.
const three = path.dirname(path.dirname(require.resolve("three")));

const [file, out, list] = process.argv.slice(2);
const sample = list.split(",").map(Number);

const page = `<!doctype html>
<script type="importmap">
{"imports": {"three": "/three/build/three.module.js", "three/addons/": "/three/examples/jsm/"}}
</script>
<script type="module">
import * as THREE from "three";
import { GLTFLoader } from "three/addons/loaders/GLTFLoader.js";
const sample = ${JSON.stringify(sample)};
new GLTFLoader().load("/shot.glb", (gltf) => {
  const meshes = [];
  gltf.scene.traverse((o) => { if (o.isInstancedMesh) meshes.push(o); });
  const m = new THREE.Matrix4(), p = new THREE.Vector3(), q = new THREE.Quaternion();
  const s = new THREE.Vector3(), c = new THREE.Color();
  const first = meshes[0];
  const instances = first ? sample.map((i) => {
    first.getMatrixAt(i, m);
    m.decompose(p, q, s);
    first.getColorAt(i, c);
    return { place: p.toArray(), scale: s.toArray(), colour: [c.r, c.g, c.b] };
  }) : [];
  window.result = { counts: meshes.map((o) => o.count), instances, cameras: gltf.cameras.length,
                    revision: THREE.REVISION };
}, undefined, (e) => { window.result = { error: String(e) }; });
</script>`;

// Only the page, the shot and three's own files, from loopback.
const server = http.createServer((req, res) => {
  const url = new URL(req.url, "http://localhost");
  let body = null, type = "text/javascript";
  if (url.pathname === "/") {
    body = page;
    type = "text/html";
  } else if (url.pathname === "/shot.glb") {
    body = fs.readFileSync(file);
    type = "model/gltf-binary";
  } else if (/^\/three\/(build|examples\/jsm)\/[\w./-]+\.js$/.test(url.pathname) && !url.pathname.includes("..")) {
    const local = path.join(three, url.pathname.slice("/three/".length));
    if (fs.existsSync(local)) body = fs.readFileSync(local);
  }
  if (body === null) {
    res.writeHead(404);
    res.end();
    return;
  }
  res.writeHead(200, { "content-type": type });
  res.end(body);
});
await new Promise((resolve) => server.listen(0, "127.0.0.1", resolve));
const browser = await puppeteer.launch({
  executablePath: process.env.CHROMIUM || "/usr/bin/chromium",
  headless: true,
  args: ["--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
    "--disable-background-networking", "--disable-component-update", "--disable-sync"],
});
const errors = [];
try {
  const tab = await browser.newPage();
  tab.on("pageerror", (e) => errors.push(e.message));
  await tab.goto(`http://127.0.0.1:${server.address().port}/`);
  await tab.waitForFunction(() => window.result !== undefined, { timeout: 120000 });
  const result = await tab.evaluate(() => window.result);
  result.pageErrors = errors;
  fs.writeFileSync(out, JSON.stringify(result));
} finally {
  await browser.close();
  server.close();
}
