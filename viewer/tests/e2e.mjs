// End-to-end test of the viewer in a real browser: starts `drapery serve`
// on a free port, drives Debian's Chromium with playwright-core, submits
// sphere-drape-30 through the page, watches it play live, checks the
// canvas is drawn and the frame counter advances, then reopens the
// finished job, scrubs, runs the self-collision example until self
// contacts are highlighted, and saves screenshots to $E2E_ARTIFACTS.
import { spawn } from "node:child_process";
import { mkdirSync, mkdtempSync, rmSync } from "node:fs";
import { tmpdir } from "node:os";
import { join, resolve } from "node:path";
import { createInterface } from "node:readline";
import { chromium } from "playwright-core";

const bin = resolve(process.env.DRAPERY_BIN || "../target/debug/drapery");
const artifacts = resolve(process.env.E2E_ARTIFACTS || "artifacts");
mkdirSync(artifacts, { recursive: true });
const data = mkdtempSync(join(tmpdir(), "drapery-e2e-"));
const started = Date.now();

/** Samples the view's canvas: pixels drawn (not background), lit blue
 * cloth, distinct colours, and self-contact pink. */
function canvasPixels(page) {
  return page.evaluate(() => {
    const c = document.querySelector("#view canvas");
    const t = Object.assign(document.createElement("canvas"), { width: c.width, height: c.height });
    const ctx = t.getContext("2d");
    ctx.drawImage(c, 0, 0);
    const d = ctx.getImageData(0, 0, t.width, t.height).data;
    let samples = 0, drawn = 0, cloth = 0, pink = 0;
    const colours = new Set();
    for (let i = 0; i < d.length; i += 4 * 13) {
      samples++;
      const [r, g, b] = [d[i], d[i + 1], d[i + 2]];
      if (Math.abs(r - 0xdf) + Math.abs(g - 0xe3) + Math.abs(b - 0xe8) > 24) {
        drawn++;
        colours.add(((r >> 4) << 8) | ((g >> 4) << 4) | (b >> 4));
        if (b > r + 40) cloth++;
        if (r > g + 80 && b > g + 20) pink++;
      }
    }
    return { samples, drawn, cloth, colours: colours.size, pink };
  });
}

function check(ok, message) {
  if (!ok) throw new Error(`check failed: ${message}`);
  console.log(`ok: ${message}`);
}

const server = spawn(bin, ["serve", "--addr", "127.0.0.1:0", "--data", data], {
  stdio: ["ignore", "pipe", "inherit"],
  env: { ...process.env, RUST_LOG: "warn" },
});
const base = await new Promise((resolveBase, reject) => {
  const lines = createInterface({ input: server.stdout });
  lines.once("line", (l) => resolveBase(l.replace("listening on ", "").trim()));
  server.once("exit", (code) => reject(new Error(`drapery serve exited with ${code}`)));
});

const browser = await chromium.launch({
  executablePath: process.env.CHROMIUM || "/usr/bin/chromium",
  headless: true,
  args: [
    "--no-sandbox", "--disable-gpu", "--disable-background-networking",
    "--disable-component-update", "--disable-sync", "--no-first-run",
    "--use-angle=swiftshader", "--enable-unsafe-swiftshader",
  ],
});
const pageErrors = [];
try {
  const page = await browser.newPage({ viewport: { width: 1400, height: 1000 } });
  page.on("pageerror", (e) => pageErrors.push(e.message));
  page.on("console", (m) => { if (m.type() === "error") pageErrors.push(m.text()); });
  const counter = async () => {
    const text = await page.textContent("#frame-counter");
    const m = text.match(/frame (\d+) \/ (\d+)/);
    return m ? { frame: Number(m[1]), last: Number(m[2]), text } : { frame: -1, last: -1, text };
  };

  const response = await page.goto(`${base}/`);
  check(response.ok(), `GET / answers ${response.status()}`);
  await page.waitForFunction(() => document.querySelectorAll("#example option").length > 0);
  await page.selectOption("#example", "sphere-drape-30");
  await page.click("#submit-example");

  await page.waitForFunction(() => /frame ([5-9]|\d\d+) /.test(document.querySelector("#frame-counter").textContent), null, { timeout: 60_000 });
  const first = await counter();
  await page.waitForTimeout(1500);
  const second = await counter();
  check(second.frame > first.frame, `the frame counter advances while live (${first.frame} -> ${second.frame})`);
  check(first.last === 120, `the counter knows the job's 121 frames (${first.text})`);

  const pixels = await canvasPixels(page);
  check(pixels.drawn / pixels.samples > 0.03, `the canvas is not blank (${pixels.drawn} of ${pixels.samples} samples drawn)`);
  check(pixels.cloth > 50 && pixels.colours > 20, `the lit blue cloth shows (${pixels.cloth} cloth samples, ${pixels.colours} colours)`);
  await page.screenshot({ path: join(artifacts, "viewer-live.png") });

  await page.waitForFunction(() => document.querySelector("#frame-counter").textContent.includes("done"), null, { timeout: 120_000 });
  check(true, "the job finished and the stream said done");
  const plots = await page.$$eval(".uplot", (els) => els.map((e) => e.querySelectorAll("canvas").length));
  check(plots.length === 5, `five plots under the view (${plots.length})`);

  // Open the finished job from the list: it replays from the store.
  await page.click("#job-rows tr:first-child td:first-child");
  await page.waitForFunction(() => document.querySelector("#frame-counter").textContent.includes("done")
    && document.querySelector("#scrub").max === "120", null, { timeout: 30_000 });
  await page.$eval("#scrub", (el) => { el.value = "60"; el.dispatchEvent(new Event("input")); });
  const scrubbed = await counter();
  check(scrubbed.frame === 60, `scrubbing shows frame 60 (${scrubbed.text})`);
  await page.waitForTimeout(300);
  const still = await counter();
  check(still.frame === 60, "scrubbing pauses playback");
  await page.screenshot({ path: join(artifacts, "viewer-scrubbed.png") });

  const hidden = await page.$eval("#downloads", (el) => el.hidden);
  check(!hidden, "download links show for the finished job");
  const glb = await page.evaluate(async () => {
    const r = await fetch(document.querySelector("#dl-glb").href);
    const b = new Uint8Array(await r.arrayBuffer());
    return { status: r.status, magic: String.fromCharCode(...b.slice(0, 4)), bytes: b.length };
  });
  check(glb.status === 200 && glb.magic === "glTF", `the glTF download works (${glb.bytes} bytes)`);
  const size = await page.evaluate(() => performance.getEntriesByType("resource").concat(performance.getEntriesByType("navigation"))
    .filter((e) => !e.name.includes("/v1/") && !e.name.includes("/examples"))
    .reduce((n, e) => n + (e.transferSize || e.encodedBodySize || 0), 0));
  console.log(`page load size: ${size} bytes`);
  // Self contacts: the example with self-collision on lists the particles
  // touching another part of the cloth, and the view paints them pink.
  await page.selectOption("#example", "sphere-drape-30-self-collision");
  await page.click("#submit-example");
  await page.waitForFunction(() => Number(document.querySelector("#self-contacts").textContent) > 0, null, { timeout: 120_000 });
  const touching = await page.textContent("#self-contacts");
  // The count arrives with a frame's stats; its particles are painted
  // when that frame is drawn, an animation frame or more later.
  let pink = 0;
  for (let tries = 0; tries < 50 && pink === 0; tries++) {
    if (tries > 0) await page.waitForTimeout(100);
    ({ pink } = await canvasPixels(page));
  }
  check(pink > 0, `self contacts are highlighted (${touching} particles listed, ${pink} pink samples)`);
  await page.screenshot({ path: join(artifacts, "viewer-self-contacts.png") });
  check(pageErrors.length === 0, `no page errors (${pageErrors.join("; ")})`);
} finally {
  await browser.close();
  server.kill("SIGTERM");
  await new Promise((r) => server.once("exit", r));
  rmSync(data, { recursive: true, force: true });
}
console.log(`e2e passed in ${((Date.now() - started) / 1000).toFixed(1)} s; screenshots in ${artifacts}`);
