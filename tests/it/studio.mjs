// Drives `campath studio`'s page in headless Chromium through the DevTools protocol
// (puppeteer-core, found through NODE_PATH), as a user would, and writes what it saw into OUT
// for tests/it/studio.rs to check against independent values:
//
//   node studio.mjs flow URL FILE OUT FRAME   scrub, read the view's pixels, fly, set a key,
//                                              undo, and set a key after an edit behind the page
//   node studio.mjs warnings URL OUT          the timeline's warning markers
//   node studio.mjs screenshot URL OUT.png    the page as a user sees it
//   node studio.mjs bench URL OUT.json N      N scrubs, each timed from the input event to the
//                                              new picture on screen
//   node studio.mjs bench-file CAMPATH FILE N [S]  the same, of a studio it starts on FILE with
//                                              the binary CAMPATH, after S seconds (default 0:
//                                              the render cache still filling); prints the numbers
import { spawn } from "node:child_process";
import fs from "node:fs";
import { createRequire } from "node:module";
import path from "node:path";

// NODE_PATH is not read by `import`: resolve through it.
const require = createRequire(path.join(process.cwd(), "noop.js"));
const puppeteer = require("puppeteer-core");

let [mode, url, ...rest] = process.argv.slice(2);
let studio = null;
if (mode === "bench-file") {
  const [file, count, settle] = rest;
  studio = spawn(url, ["studio", file], { stdio: ["ignore", "pipe", "inherit"] });
  url = await new Promise((resolve, reject) => {
    let text = "";
    studio.stdout.on("data", d => {
      text += d;
      const m = text.match(/open (http\S+)/);
      if (m) resolve(m[1]);
    });
    studio.on("exit", code => reject(new Error("the studio exited: " + code)));
  });
  mode = "bench";
  rest = ["/dev/stdout", count, settle || "0"];
}
const browser = await puppeteer.launch({
  executablePath: process.env.CHROMIUM || "/usr/bin/chromium",
  headless: true,
  args: ["--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
    "--disable-background-networking", "--disable-component-update", "--disable-sync"],
});
const errors = [];
try {
  const page = await browser.newPage();
  page.on("pageerror", e => errors.push(e.message));
  await page.setViewport({ width: 1400, height: 1000 });
  await page.goto(url);
  const wait = (f, ...args) => page.waitForFunction(f, { timeout: 120000, polling: "mutation" }, ...args);
  // The view of `frame` of the given kind, its pixels read in the same task that drew them.
  const pixels = (frame, kind) => page.evaluate((frame, kind) => new Promise(resolve => {
    const canvas = document.querySelector("[data-testid=view]");
    const read = () => {
      if (canvas.dataset.frame !== String(frame) || canvas.dataset.kind !== kind || canvas.dataset.flown !== "0") return false;
      const data = canvas.getContext("2d").getImageData(0, 0, canvas.width, canvas.height).data;
      let rgb = "";
      for (let i = 0; i < data.length; i += 4) rgb += String.fromCharCode(data[i], data[i + 1], data[i + 2]);
      resolve({ width: canvas.width, height: canvas.height, rgb: btoa(rgb) });
      return true;
    };
    if (read()) return;
    const seen = new MutationObserver(() => { if (read()) seen.disconnect(); });
    seen.observe(canvas, { attributes: true });
  }), frame, kind);
  const version = () => page.evaluate(() => +document.body.dataset.version);
  const nextVersion = async after => wait(v => +document.body.dataset.version > v, after);
  await wait(() => document.querySelector("[data-testid=view]").dataset.kind === "full");

  if (mode === "flow") {
    const [file, out, frame] = rest;
    fs.mkdirSync(out, { recursive: true });
    const save = (name, p) => fs.writeFileSync(path.join(out, name), JSON.stringify({ width: p.width, height: p.height }) + "\n" + p.rgb);
    // Scrub: the scrubber's input event, as a drag of it gives.
    const preview = pixels(+frame, "preview");
    await page.$eval("[data-testid=scrubber]", (s, f) => { s.value = f; s.dispatchEvent(new Event("input", { bubbles: true })); }, frame);
    save("preview.json", await preview);
    save("full.json", await pixels(+frame, "full"));
    const label = await page.$eval("[data-testid=frame-label]", e => e.textContent);

    // Fly: drag on the view to look around, then three steps forward (W).
    const box = await (await page.$("[data-testid=view]")).boundingBox();
    await page.mouse.move(box.x + box.width / 2, box.y + box.height / 2);
    await page.mouse.down();
    await page.mouse.move(box.x + box.width / 2 + 60, box.y + box.height / 2 + 15, { steps: 6 });
    await page.mouse.up();
    for (let i = 0; i < 3; i++) await page.keyboard.press("w");
    await wait(() => { const c = document.querySelector("[data-testid=view]"); return c.dataset.flown === "1" && c.dataset.kind === "full"; });
    const flown = await page.evaluate(() => window.campathStudio.fly);
    await page.select("[data-testid=track-select]", "Observer");
    let v = await version();
    await page.click("[data-testid=set-key]");
    await nextVersion(v);
    fs.copyFileSync(file, path.join(out, "after-set.ron"));
    const afterSet = await page.$eval("[data-testid=notice]", e => e.textContent);

    v = await version();
    await page.click("[data-testid=undo]");
    await nextVersion(v);
    fs.copyFileSync(file, path.join(out, "after-undo.ron"));

    // An edit behind the page: the page does not hear of it (its state requests held) before
    // the user sets a key.
    await page.setRequestInterception(true);
    const held = [];
    let holding = true;
    page.on("request", r => (holding && r.url().includes("/api/state") ? held.push(r) : r.continue()));
    // The state request in flight when holding began was sent before it: it answers at the
    // latest when its long poll ends (10 s), and the page's next one is held, its only way to
    // hear of the edit.
    await new Promise(res => { const t = setInterval(() => { if (held.length) { clearInterval(t); res(); } }, 50); });
    const edited = fs.readFileSync(file, "utf8").replace("// ", "// edited in the editor: ");
    fs.writeFileSync(file, edited);
    await new Promise(res => setTimeout(res, 1500));
    await page.click("[data-testid=set-key]");
    await wait(() => document.querySelector("[data-testid=notice]").textContent.startsWith("not done"));
    const refused = await page.$eval("[data-testid=notice]", e => e.textContent);
    holding = false;
    held.forEach(r => r.continue());
    await wait(() => document.querySelector("[data-testid=file-text]").textContent.includes("edited in the editor"));
    fs.copyFileSync(file, path.join(out, "after-refusal.ron"));
    const shown = await page.$eval("[data-testid=file-text]", e => e.textContent);
    fs.writeFileSync(path.join(out, "flow.json"), JSON.stringify({ label, flown, afterSet, refused, shown, errors }));
  } else if (mode === "warnings") {
    const [out] = rest;
    const markers = await page.$$eval("[data-testid^=warning-]:not([data-testid=warning-text])",
      bs => bs.map(b => ({ frame: +b.dataset.frame, text: b.title })));
    // A click shows the warning's text under the timeline.
    await page.click("[data-testid=warning-0]");
    const shown = await page.$eval("[data-testid=warning-text]", e => e.textContent);
    fs.writeFileSync(out, JSON.stringify({ markers, shown, errors }));
  } else if (mode === "screenshot") {
    const [out] = rest;
    await page.screenshot({ path: out });
  } else if (mode === "bench") {
    const [out, count, settle] = rest;
    await new Promise(res => setTimeout(res, +(settle || 0) * 1000));
    const frames = await page.evaluate(() => window.campathStudio.shot.frames);
    const times = [];
    for (let i = 0; i < +count; i++) {
      const frame = (i * 7 + 1) % frames;
      // From the scrubber's input event to the picture of that frame on screen (the next
      // animation frame after it is drawn).
      const ms = await page.evaluate(frame => new Promise(resolve => {
        const canvas = document.querySelector("[data-testid=view]");
        const scrubber = document.querySelector("[data-testid=scrubber]");
        const started = performance.now();
        const seen = new MutationObserver(() => {
          if (canvas.dataset.frame === String(frame) && canvas.dataset.kind === "preview") {
            seen.disconnect();
            requestAnimationFrame(() => resolve(performance.now() - started));
          }
        });
        seen.observe(canvas, { attributes: true });
        scrubber.value = frame;
        scrubber.dispatchEvent(new Event("input", { bubbles: true }));
      }), frame);
      times.push(ms);
    }
    const sorted = times.slice().sort((a, b) => a - b);
    const total = times.reduce((a, b) => a + b, 0);
    fs.writeFileSync(out, JSON.stringify({ count: times.length, median_ms: sorted[sorted.length >> 1],
      p90_ms: sorted[Math.floor(sorted.length * 0.9)], updates_per_s: times.length / total * 1000, errors }));
  } else {
    throw new Error("mode: flow, warnings, screenshot or bench");
  }
} finally {
  await browser.close();
  if (studio) studio.kill();
}
if (errors.length) {
  console.error("errors on the page: " + errors.join("; "));
  process.exit(1);
}
