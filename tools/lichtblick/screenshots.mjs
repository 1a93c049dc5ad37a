// Screenshots of a run's MCAP file opened in Lichtblick (the open-source fork of Foxglove
// Studio), as a new user sees it: docs/MCAP.md, "Seen in Lichtblick".
//
// Not part of `make test`: it needs a Lichtblick web build (1.6 GB with its node_modules).
//
//   node tools/lichtblick/screenshots.mjs LICHTBLICK_DIR RUN.mcap OUT_DIR [WHEN ...]
//
// LICHTBLICK_DIR is a Lichtblick checkout whose web target is built (`yarn web:build:prod`
// leaves it in web/.webpack); its node_modules give playwright-core. The script serves the
// build, the MCAP file (with HTTP range requests, which Lichtblick's remote-file source reads)
// and tools/lichtblick/layout.json on 127.0.0.1, and opens
// `/?ds=remote-file&ds.url=.../run.mcap&layoutUrl=.../layout.json&time=T` in Debian's headless
// Chromium (/usr/bin/chromium, or $CHROMIUM). Each WHEN is one screenshot, OUT_DIR/lichtblick-
// WHEN.png:
//   SECONDS  the file opened at that mission time (a jump: each panel gets the latest message
//            of each topic, as after dragging the time slider);
//   play     the file played from the start to its end, at LICHTBLICK_SPEED times real time
//            (default 20), so that the Log panel holds every line; play:SECONDS up to that
//            mission time (the file lichtblick-play-SECONDS.png);
//   serve    no screenshot: print the page's address and serve until Ctrl-C.
// The default is `play:240 1200`.
//
//   node tools/lichtblick/screenshots.mjs LICHTBLICK_DIR ws://HOST:PORT OUT_DIR [SECONDS ...]
//
// follows a running server live instead (`mcl run MISSION.mcl --realtime --foxglove HOST:PORT`,
// docs/MCAP.md "Live"): the page `/?ds=foxglove-websocket&ds.url=ws://HOST:PORT&layoutUrl=...`
// connects to it with Lichtblick's Foxglove WebSocket source, and each SECONDS is one
// screenshot that long (wall time) after the page opened, OUT_DIR/lichtblick-live-SECONDS.png
// (default `20 60`); serve as above. Bad arguments: one line, exit 2. Environment: CHROMIUM (the
// browser), LICHTBLICK_SPEED, LICHTBLICK_PORT (default: a free one), LICHTBLICK_SETTLE_MS
// (the wait before each screenshot, default 5000), LICHTBLICK_DEBUG=1 (the page's console).

import { createReadStream, existsSync, mkdirSync, readFileSync, statSync } from "node:fs";
import { createServer } from "node:http";
import { createRequire } from "node:module";
import path from "node:path";
import { fileURLToPath } from "node:url";

const HERE = path.dirname(fileURLToPath(import.meta.url));
const FLAGS = ["--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
  "--disable-background-networking", "--disable-component-update", "--disable-sync",
  "--hide-scrollbars", "--use-gl=angle", "--use-angle=swiftshader",
  "--enable-unsafe-swiftshader"];
const TYPES = { ".html": "text/html", ".js": "text/javascript", ".css": "text/css",
  ".json": "application/json", ".png": "image/png", ".svg": "image/svg+xml",
  ".wasm": "application/wasm", ".woff2": "font/woff2", ".ttf": "font/ttf" };

function refuse(message) {
  process.stderr.write(`lichtblick screenshots: ${message}\n`);
  process.exit(2);
}

function parseArguments(argv) {
  const [lichtblick, mcap, out, ...whens] = argv;
  if (!lichtblick || !mcap || !out) {
    refuse("usage: node tools/lichtblick/screenshots.mjs LICHTBLICK_DIR RUN.mcap|ws://HOST:PORT "
      + "OUT_DIR [SECONDS|play|serve ...]");
  }
  const site = path.resolve(lichtblick, "web", ".webpack");
  if (!existsSync(path.join(site, "index.html"))) {
    refuse(`${site}/index.html: no Lichtblick web build there; build it with `
      + "`yarn web:build:prod` in the checkout (docs/MCAP.md, \"Seen in Lichtblick\")");
  }
  if (/^wss?:/.test(mcap)) {
    return parseLive(lichtblick, site, mcap, out, whens);
  }
  if (!existsSync(mcap) || !statSync(mcap).isFile()) {
    refuse(`${mcap}: no such MCAP file; write one with mcl run MISSION.mcl --mcap FILE`);
  }
  for (const when of whens) {
    if (!/^(\d+(\.\d+)?|play(:\d+(\.\d+)?)?|serve)$/.test(when)) {
      refuse(`${when}: say a mission time in seconds (600), play, play:SECONDS or serve`);
    }
  }
  const speed = Number(process.env.LICHTBLICK_SPEED ?? 20);
  if (!(speed > 0)) {
    refuse(`LICHTBLICK_SPEED=${process.env.LICHTBLICK_SPEED}: a positive number, e.g. 20`);
  }
  return { lichtblick, site, mcap: path.resolve(mcap), out,
    whens: whens.length ? whens : ["play:240", "1200"], speed };
}

/** The arguments of the live mode: a server's ws:// URL, wall seconds after the page opened. */
function parseLive(lichtblick, site, url, out, whens) {
  if (!/^wss?:\/\/[^/:\s]+:\d+\/?$/.test(url)) {
    refuse(`${url}: say the server's address as ws://HOST:PORT (mcl run --foxglove HOST:PORT)`);
  }
  for (const when of whens) {
    if (!/^(\d+(\.\d+)?|serve)$/.test(when)) {
      refuse(`${when}: live, say seconds after the page opened (20) or serve`);
    }
  }
  return { lichtblick, site, live: url, out, whens: whens.length ? whens : ["20", "60"] };
}

/** The build's files, the MCAP file and the layout, with HTTP range requests (Lichtblick reads
 * an MCAP file by ranges: its summary first, then the chunks each panel needs). */
function serve(site, mcap, layout) {
  const server = createServer((request, response) => {
    const name = new URL(request.url, "http://127.0.0.1").pathname;
    if (name === "/layout.json") {
      response.writeHead(200, { "Content-Type": "application/json" }).end(layout);
      return;
    }
    const file = name === "/run.mcap" && mcap ? mcap
      : path.join(site, path.normalize(name === "/" ? "/index.html" : name));
    if ((file !== mcap && !file.startsWith(site)) || !existsSync(file)
        || !statSync(file).isFile()) {
      response.writeHead(404).end();
      return;
    }
    const size = statSync(file).size;
    const headers = { "Content-Type": TYPES[path.extname(file)] ?? "application/octet-stream",
      "Accept-Ranges": "bytes", "Cache-Control": "no-store" };
    const range = /^bytes=(\d*)-(\d*)$/.exec(request.headers.range ?? "");
    if (range) {
      const start = range[1] ? Number(range[1]) : size - Number(range[2]);
      const end = range[1] && range[2] ? Math.min(Number(range[2]), size - 1) : size - 1;
      response.writeHead(206, { ...headers, "Content-Range": `bytes ${start}-${end}/${size}`,
        "Content-Length": end - start + 1 });
      createReadStream(file, { start, end }).pipe(response);
      return;
    }
    response.writeHead(200, { ...headers, "Content-Length": size });
    if (request.method === "HEAD") {
      response.end();
    } else {
      createReadStream(file).pipe(response);
    }
  });
  return new Promise((resolve) => server.listen(Number(process.env.LICHTBLICK_PORT ?? 0),
    "127.0.0.1", () => resolve(server)));
}

/** Resolves once the page has asked for nothing new for `quiet` ms (the file's summary, then
 * the chunks each panel needs, the Plot's whole range too), or after `limit` ms. */
function idle(page, quiet, limit) {
  return new Promise((resolve) => {
    let pending = 0;
    let timer;
    const settle = () => {
      clearTimeout(timer);
      timer = setTimeout(done, quiet);
    };
    const started = () => { pending += 1; clearTimeout(timer); };
    const ended = () => { pending -= 1; if (pending <= 0) settle(); };
    const cap = setTimeout(done, limit);
    function done() {
      clearTimeout(cap);
      page.off("request", started).off("requestfinished", ended).off("requestfailed", ended);
      resolve();
    }
    page.on("request", started).on("requestfinished", ended).on("requestfailed", ended);
    settle();
  });
}

/** The page that opens the MCAP file with the layout at mission time `seconds`. */
function pageUrl(base, seconds) {
  return `${base}/?ds=remote-file&ds.url=${encodeURIComponent(`${base}/run.mcap`)}`
    + `&layoutUrl=${encodeURIComponent(`${base}/layout.json`)}&time=${seconds}`;
}

/** The page that connects to a running Foxglove WebSocket server with the layout. */
function livePageUrl(base, url) {
  return `${base}/?ds=foxglove-websocket&ds.url=${encodeURIComponent(url)}`
    + `&layoutUrl=${encodeURIComponent(`${base}/layout.json`)}`;
}

/** Opens `address` (the file at `seconds`, or a live server), waits for the panels to have
 * read what they need, and hides the left sidebar (Lichtblick keeps that choice). */
async function open(page, address) {
  const loaded = idle(page, 4_000, 120_000);
  await page.goto(address);
  await loaded;
  const hide = page.locator('[aria-label="Hide left sidebar"]');
  await page.keyboard.press("Escape");  // the data source dialog of a page with no source
  if (await hide.isVisible()) {
    await hide.click({ timeout: 10_000 }).catch(() => undefined);
  }
  await page.mouse.move(800, 500);  // no tooltip left over the panels
}

/** The mission time (s) the playback bar shows: a clock time since 1970-01-01 00:00 GMT. */
async function shown(page) {
  const text = await page.locator("body").innerText();
  const clock = /1970-01-01 (\d{1,2}):(\d{2}):(\d{2}(?:\.\d+)?) ([AP]M)/.exec(text);
  if (!clock) {
    return -1;
  }
  const hours = (Number(clock[1]) % 12) + (clock[4] === "PM" ? 12 : 0);
  return hours * 3600 + Number(clock[2]) * 60 + Number(clock[3]);
}

/** Plays the file from where it is up to mission time `until` (s; Infinity: to its end, where
 * the play button says "Play" again), then pauses. */
async function play(page, until, speed) {
  const button = page.getByTestId("play-button");
  await button.click();
  const limit = Date.now() + 3_600_000 / speed;
  while (Date.now() < limit && (await shown(page)) < until
         && (await button.getAttribute("title")) === "Pause") {
    await page.waitForTimeout(500);
  }
  if ((await button.getAttribute("title")) === "Pause") {
    await button.click();
  }
}

async function shoot(page, base, when, speed, file) {
  const [mode, until] = when.split(":");
  await open(page, pageUrl(base, mode === "play" ? 0 : when));
  if (mode === "play") {
    await play(page, until === undefined ? Infinity : Number(until), speed);
  }
  await page.waitForTimeout(Number(process.env.LICHTBLICK_SETTLE_MS ?? 5_000));
  await page.mouse.move(800, 500);
  await page.screenshot({ path: file });
  process.stdout.write(`${file}\n`);
}

/** Follows a live server: one page, a screenshot at each of `whens` (wall seconds after the
 * page opened, in increasing order). */
async function shootLive(page, base, url, whens, out) {
  const opened = Date.now();
  await open(page, livePageUrl(base, url));
  for (const when of whens.map(Number).sort((a, b) => a - b)) {
    await page.waitForTimeout(Math.max(0, opened + when * 1000 - Date.now()));
    const bottom = page.getByTestId("scroll-to-bottom-button");  // the Log's latest lines
    if (await bottom.isVisible()) {
      await bottom.click({ timeout: 5_000 }).catch(() => undefined);
      await page.waitForTimeout(1_000);
    }
    await page.mouse.move(800, 500);
    const file = path.join(out, `lichtblick-live-${when}.png`);
    await page.screenshot({ path: file });
    process.stdout.write(`${file}\n`);
  }
}

async function main() {
  const { lichtblick, site, mcap, live, out, whens, speed } = parseArguments(
    process.argv.slice(2));
  const layout = JSON.parse(readFileSync(path.join(HERE, "layout.json"), "utf-8"));
  if (speed !== undefined) {  // a live source plays at the server's pace
    layout.playbackConfig = { ...layout.playbackConfig, speed };
  }
  const server = await serve(site, mcap, JSON.stringify(layout));
  const base = `http://127.0.0.1:${server.address().port}`;
  if (whens.includes("serve")) {  // open it in any browser; Ctrl-C ends
    process.stdout.write(`${live ? livePageUrl(base, live) : pageUrl(base, 0)}\n`);
    return;
  }
  mkdirSync(out, { recursive: true });
  const require = createRequire(path.join(path.resolve(lichtblick), "package.json"));
  const { chromium } = require("playwright-core");
  const browser = await chromium.launch({
    executablePath: process.env.CHROMIUM ?? "/usr/bin/chromium", args: FLAGS });
  try {
    const page = await browser.newPage({ viewport: { width: 1600, height: 1000 } });
    if (process.env.LICHTBLICK_DEBUG) {
      page.on("console", (m) => console.error(m.text()));
      page.on("request", (r) => console.error(`request ${r.url().slice(0, 160)}`));
    }
    if (live) {
      await shootLive(page, base, live, whens, out);
    }
    for (const when of live ? [] : whens) {
      const name = `lichtblick-${when.replace(":", "-")}.png`;
      await shoot(page, base, when, speed, path.join(out, name));
    }
  } finally {
    await browser.close();
    server.close();
  }
}

main().catch((error) => {
  process.stderr.write(`lichtblick screenshots: ${error.message.split("\n")[0]}\n`);
  process.exit(1);
});
