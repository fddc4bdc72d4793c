#!/usr/bin/env node
// Screenshots vkrad glTF exports drawn by three.js (render.html) in headless
// Chromium (puppeteer-core; WebGL 2 on SwiftShader when there is no GPU).
//
//   node render.mjs MODEL.glb OUT.png --size 256x256 --eye X,Y,Z --look-at X,Y,Z \
//       --up X,Y,Z --fov DEG [--samples 16] [--coverage COVERAGE.png] [--normal NORMAL.png] [--antialias]
//       [--vertex-colours]   (the glTF's vertex colours instead of its lightmap)
//   node render.mjs --jobs JOBS.json     (a list of {glb, out, coverage?, normal?,
//       width, height, eye, look_at, up, fov, samples, antialias?, vertex?}: one browser for all)
//
// Prints one JSON line per job: what three.js made of the file (material,
// texture settings), the browser and GPU, and whether the screenshot equals
// the canvas's own pixels. CHROMIUM overrides /usr/bin/chromium.

import fs from 'node:fs';
import http from 'node:http';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import puppeteer from 'puppeteer-core';

const HERE = path.dirname(fileURLToPath(import.meta.url));
export const CHROMIUM_FLAGS = [
  '--no-sandbox',
  '--use-gl=angle',
  '--use-angle=swiftshader',
  '--enable-unsafe-swiftshader',
  '--force-color-profile=srgb',
];

function parseArgs(argv) {
  const a = { samples: 1 };
  const rest = [];
  for (let i = 0; i < argv.length; i++) {
    const k = argv[i];
    const v = () => argv[++i];
    const xyz = () => v().split(',').map(Number);
    if (k === '--jobs') a.jobs = v();
    else if (k === '--size') [a.width, a.height] = v().split('x').map(Number);
    else if (k === '--eye') a.eye = xyz();
    else if (k === '--look-at') a.look_at = xyz();
    else if (k === '--up') a.up = xyz();
    else if (k === '--fov') a.fov = Number(v());
    else if (k === '--samples') a.samples = Number(v());
    else if (k === '--coverage') a.coverage = v();
    else if (k === '--antialias') a.antialias = true;
    else if (k === '--normal') a.normal = v();
    else if (k === '--vertex-colours') a.vertex = true;
    else rest.push(k);
  }
  if (a.jobs) return JSON.parse(fs.readFileSync(a.jobs, 'utf8'));
  [a.glb, a.out] = rest;
  if (!a.glb || !a.out || !a.width || !a.eye || !a.look_at || !a.up || !a.fov) {
    throw new Error('usage: render.mjs MODEL.glb OUT.png --size WxH --eye X,Y,Z --look-at X,Y,Z --up X,Y,Z --fov DEG [--samples N] [--coverage FILE.png] [--normal FILE.png] [--antialias] [--vertex-colours]');
  }
  return [a];
}

const TYPES = { '.html': 'text/html', '.js': 'text/javascript', '.glb': 'model/gltf-binary' };

// Serves this folder, and job k's model at /model/k.glb.
function serve(jobs) {
  const server = http.createServer((req, res) => {
    const url = decodeURIComponent(new URL(req.url, 'http://x').pathname);
    const m = url.match(/^\/model\/(\d+)\.glb$/);
    const file = m ? path.resolve(jobs[Number(m[1])].glb) : path.join(HERE, path.normalize(url));
    if (!m && !file.startsWith(HERE)) { res.writeHead(403).end(); return; }
    fs.readFile(file, (err, data) => {
      if (err) { res.writeHead(404).end(); return; }
      res.writeHead(200, { 'Content-Type': TYPES[path.extname(file)] || 'application/octet-stream' });
      res.end(data);
    });
  });
  return new Promise((ok) => server.listen(0, '127.0.0.1', () => ok(server)));
}

async function main() {
  const jobs = parseArgs(process.argv.slice(2));
  const server = await serve(jobs);
  const port = server.address().port;
  const browser = await puppeteer.launch({
    executablePath: process.env.CHROMIUM || '/usr/bin/chromium',
    headless: true,
    args: CHROMIUM_FLAGS,
  });
  const version = await browser.version();
  try {
    for (const [k, job] of jobs.entries()) {
      const t0 = Date.now();
      const page = await browser.newPage();
      const log = [];
      page.on('console', (m) => log.push(m.text()));
      page.on('pageerror', (e) => log.push(String(e)));
      await page.setViewport({ width: job.width, height: 3 * job.height, deviceScaleFactor: 1 });
      const qs = new URLSearchParams({
        model: `/model/${k}.glb`, w: job.width, h: job.height,
        eye: job.eye.join(','), look_at: job.look_at.join(','), up: job.up.join(','),
        fov: job.fov, samples: job.samples || 1, antialias: job.antialias ? 1 : 0,
        vertex: job.vertex ? 1 : 0,
      });
      await page.goto(`http://127.0.0.1:${port}/render.html?${qs}`);
      await page.waitForFunction('window.vkradDone', { timeout: 600000, polling: 100 });
      const done = await page.evaluate('window.vkradDone');
      if (!done.ok) throw new Error(`${job.glb}: ${done.error}\n${log.join('\n')}`);
      const shot = await (await page.$('#out')).screenshot({ type: 'png', omitBackground: false });
      fs.writeFileSync(job.out, shot);
      if (job.coverage) fs.writeFileSync(job.coverage, await (await page.$('#coverage')).screenshot({ type: 'png' }));
      if (job.normal) fs.writeFileSync(job.normal, await (await page.$('#normal')).screenshot({ type: 'png' }));
      // The canvas's own pixels, to check that the screenshot is them.
      const canvas = await page.evaluate(() => {
        const c = document.getElementById('out');
        return Array.from(c.getContext('2d').getImageData(0, 0, c.width, c.height).data);
      });
      const page2 = await browser.newPage();
      const fromShot = await page2.evaluate(async (b64, w, h) => {
        const img = await createImageBitmap(await (await fetch(`data:image/png;base64,${b64}`)).blob(),
                                            { colorSpaceConversion: 'none', premultiplyAlpha: 'none' });
        const c = new OffscreenCanvas(w, h);
        const x = c.getContext('2d');
        x.drawImage(img, 0, 0);
        return Array.from(x.getImageData(0, 0, w, h).data);
      }, Buffer.from(shot).toString('base64'), job.width, job.height);
      await page2.close();
      let differ = 0;
      for (let i = 0; i < canvas.length; i++) if (canvas[i] !== fromShot[i]) differ++;
      console.log(JSON.stringify({
        glb: job.glb, out: job.out, browser: version, flags: CHROMIUM_FLAGS, samples: job.samples || 1,
        antialias: !!job.antialias, vertex_colours: !!job.vertex,
        screenshot_values_differing_from_canvas: differ, seconds: (Date.now() - t0) / 1000,
        console: log, ...done.info,
      }));
      await page.close();
    }
  } finally {
    await browser.close();
    server.close();
  }
}

main().catch((e) => { console.error(e.stack || String(e)); process.exit(1); });
