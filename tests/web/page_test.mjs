#!/usr/bin/env node
// The web viewer in a real browser (docs/web-viewer.md): the Cornell box baked by
// `penumbra bake --method progressive`, shown by web/index.html in Debian's chromium (headless,
// WebGL 2 on SwiftShader through ANGLE, driven by puppeteer-core), against Penumbra's own view of
// the same lightmap, `penumbra render --method progressive`, tone mapped as the page does; and
// the Khronos glTF validator on the baked file.
//
//   node tests/web/page_test.mjs PENUMBRA_CLI REPO_ROOT WORK_DIR
//
// Exit code 0: passed; 1: failed; 77: skipped, only when /usr/bin/chromium or web/node_modules
// is missing and PENUMBRA_REQUIRE_BROWSER is not 1 (CI sets it: there a missing browser fails).
// Leaves in WORK_DIR: bake/ (the baked files and the deployed page), ref.pfm, reference.png (the
// reference tone mapped), page.png (the screenshot) and diff.png (|page - reference| x 8).

import { spawnSync } from 'node:child_process';
import fs from 'node:fs';
import { createRequire } from 'node:module';
import path from 'node:path';

import { decodePng, encodePngRgb } from './png.mjs';
import { serveDirectory } from './serve.mjs';

const PASS = 0;
const FAIL = 1;
const SKIP = 77;
const CHROMIUM = '/usr/bin/chromium';
const WIDTH = 256;
const HEIGHT = 256;  // square: the camera's field of view means the same whichever axis it spans
// Both runs solve the same lightmap: the same method, device, texel count and stopping rule (the
// CPU solver is deterministic, so the bake's lightmap is the one the render views).
const SOLVE = ['--method', 'progressive', '--device', 'cpu', '--elements', '40000',
               '--tolerance', '1e-3', '--quiet'];
// The screenshot against the reference, |page - reference| in 8-bit sRGB units, per channel:
//  - inside surfaces the two agree to the RGBM quantisation (below 0.4% of the brightest channel
//    of a texel) and float rounding: within 1 unit;
//  - along geometric edges they differ: Penumbra averages 4 stratified rays per pixel, WebGL's 4x
//    multisampling takes 4 fixed positions, so a pixel an edge crosses can differ by the contrast
//    across the edge (up to ~100 units at the boxes' silhouettes and the clipped light).
// Measured (Debian 12, chromium 156, SwiftShader, three 0.187, 256 x 256): mean 0.71 / 0.58 /
// 0.36 (R / G / B), 99th percentile 24 / 18 / 7; 96.3% of the pixels within 1 unit in every
// channel, the rest edge pixels. The limit of 2 leaves room for a different edge sampling and
// still fails what a mistake in the page does: three.js's MeshStandardMaterial taking its
// specular lobe's share out of the diffuse term (mean 2.3), the exposure 5% off (3.5), the
// lightmap upside down (119).
const MEAN_TOLERANCE = 2.0;
const TIME_LIMIT_MS = 240_000;

class Failure extends Error {}

function log(message) {
  process.stdout.write(`${message}\n`);
}

function run(command, args) {
  log(`$ ${[command, ...args].join(' ')}`);
  const started = Date.now();
  const result = spawnSync(command, args, { encoding: 'utf8', timeout: 180_000 });
  if (result.error) throw new Failure(`${command}: ${result.error.message}`);
  if (result.status !== 0) {
    throw new Failure(`${path.basename(command)} ${args[0]} exited with ${result.status}` +
                      `${result.signal ? ` (${result.signal})` : ''}:\n${result.stdout}${result.stderr}`);
  }
  log(`  ${((Date.now() - started) / 1000).toFixed(1)} s`);
  return result;
}

// What `penumbra bake --web DIR` will do: the page from <dir of penumbra>/../share/penumbra/web,
// and bake.json naming the glTF.
// A PFM file as { width, height, data: Float32Array RGB, rows top to bottom }.
function readPfm(file) {
  const bytes = fs.readFileSync(file);
  const tokens = [];
  let offset = 0;
  while (tokens.length < 4) {
    while (/\s/.test(String.fromCharCode(bytes[offset]))) ++offset;
    const start = offset;
    while (!/\s/.test(String.fromCharCode(bytes[offset]))) ++offset;
    tokens.push(bytes.toString('latin1', start, offset));
  }
  ++offset;  // the single whitespace character after the scale
  const [magic, w, h, s] = tokens;
  if (magic !== 'PF') throw new Failure(`${file}: not a colour PFM (${magic})`);
  const width = Number(w);
  const height = Number(h);
  const littleEndian = Number(s) < 0;
  const data = new Float32Array(width * height * 3);
  const view = new DataView(bytes.buffer, bytes.byteOffset + offset);
  if (view.byteLength < data.length * 4) throw new Failure(`${file}: truncated`);
  for (let y = 0; y < height; ++y) {
    const row = height - 1 - y;  // PFM rows run bottom to top
    for (let i = 0; i < width * 3; ++i) {
      data[row * width * 3 + i] = view.getFloat32((y * width * 3 + i) * 4, littleEndian);
    }
  }
  return { width, height, data };
}

// What the page does to a radiance: LinearToneMapping (saturate(exposure * L)), then the sRGB
// transfer function, then the canvas's 8 bits.
function toneMap(radiance, exposure) {
  const v = Math.min(1, Math.max(0, radiance * exposure));
  const encoded = v <= 0.0031308 ? 12.92 * v : 1.055 * v ** (1 / 2.4) - 0.055;
  return Math.round(encoded * 255);
}

// An exposure that puts the 95th percentile of the reference's brightest channel at 0.8: the
// walls well inside [0, 1], only the light and the brightest ceiling spots clipped.
function chooseExposure(reference) {
  const peaks = [];
  for (let p = 0; p < reference.width * reference.height; ++p) {
    const d = reference.data;
    peaks.push(Math.max(d[3 * p], d[3 * p + 1], d[3 * p + 2]));
  }
  peaks.sort((a, b) => a - b);
  const p95 = peaks[Math.floor(0.95 * (peaks.length - 1))];
  if (!(p95 > 0)) throw new Failure('the reference image is black');
  return 0.8 / p95;
}

async function validateGltf(validator, file) {
  const dir = path.dirname(file);
  const report = await validator.validateBytes(new Uint8Array(fs.readFileSync(file)), {
    uri: path.basename(file),
    maxIssues: 0,  // no limit
    externalResourceFunction: (uri) => fs.promises.readFile(path.join(dir, decodeURIComponent(uri)))
      .then((data) => new Uint8Array(data)),
  });
  const { numErrors, numWarnings, numInfos, numHints, messages } = report.issues;
  log(`glTF validator ${report.validatorVersion}: ${numErrors} errors, ${numWarnings} warnings, ` +
      `${numInfos} infos, ${numHints} hints`);
  for (const m of messages.filter((m) => m.severity <= 1).slice(0, 20)) {
    log(`  ${m.severity === 0 ? 'error' : 'warning'} ${m.code} at ${m.pointer ?? '-'}: ${m.message}`);
  }
  const codes = new Map();
  for (const m of messages.filter((m) => m.severity >= 2)) codes.set(m.code, (codes.get(m.code) ?? 0) + 1);
  if (codes.size) log(`  infos and hints: ${[...codes].map(([c, n]) => `${c} x${n}`).join(', ')}`);
  if (numErrors > 0) throw new Failure(`the Khronos validator finds ${numErrors} errors in ${file}`);
}

// |page - reference| per channel in 8-bit units: mean and 99th percentile over the pixels.
function compare(page, reference, exposure, workDir) {
  if (page.width !== reference.width || page.height !== reference.height) {
    throw new Failure(`screenshot ${page.width}x${page.height}, reference ` +
                      `${reference.width}x${reference.height}`);
  }
  const pixels = page.width * page.height;
  const expected = new Uint8Array(pixels * 3);
  const diffImage = new Uint8Array(pixels * 3);
  const histograms = [0, 1, 2].map(() => new Array(256).fill(0));
  const sums = [0, 0, 0];
  let referenceSum = 0;
  for (let p = 0; p < pixels; ++p) {
    for (let c = 0; c < 3; ++c) {
      const want = toneMap(reference.data[3 * p + c], exposure);
      const got = page.data[4 * p + c];
      const d = Math.abs(got - want);
      expected[3 * p + c] = want;
      diffImage[3 * p + c] = Math.min(255, d * 8);
      histograms[c][d] += 1;
      sums[c] += d;
      referenceSum += want;
    }
  }
  fs.writeFileSync(path.join(workDir, 'reference.png'),
                   encodePngRgb(page.width, page.height, expected));
  fs.writeFileSync(path.join(workDir, 'diff.png'), encodePngRgb(page.width, page.height, diffImage));
  const percentile = (histogram, q) => {
    let seen = 0;
    for (let d = 0; d < 256; ++d) {
      seen += histogram[d];
      if (seen >= q * pixels) return d;
    }
    return 255;
  };
  return {
    mean: sums.map((s) => s / pixels),
    p99: histograms.map((h) => percentile(h, 0.99)),
    over8: histograms.map((h) => h.slice(9).reduce((a, b) => a + b, 0) / pixels),
    referenceMean: referenceSum / (3 * pixels),
  };
}

async function showPage(puppeteer, bakeDir, exposure, workDir) {
  const server = await serveDirectory(bakeDir);
  const problems = [];
  const abortedWhileStreaming = [];
  const browser = await puppeteer.launch({
    executablePath: CHROMIUM,
    headless: true,  // the new headless mode (--headless=new)
    args: ['--no-sandbox', '--use-angle=swiftshader', '--enable-unsafe-swiftshader',
           '--force-color-profile=srgb', '--disable-dev-shm-usage'],
  });
  try {
    const page = await browser.newPage();
    page.on('console', (message) => {
      const text = `console.${message.type()}: ${message.text()}`;
      log(`  ${text}`);
      if (message.type() === 'error' || message.type() === 'assert') problems.push(text);
    });
    page.on('pageerror', (error) => problems.push(`page error: ${error.message}`));
    page.on('response', (response) => {
      if (response.status() >= 400) problems.push(`HTTP ${response.status()}: ${response.url()}`);
    });
    page.on('requestfailed', (request) => {
      const reason = request.failure()?.errorText ?? 'failed';
      // Chromium reports a fetch whose body the page read through a stream reader (three.js's
      // FileLoader does, for progress events) as net::ERR_ABORTED now and then, though every
      // byte arrived; such a request counts only if the server did not send it whole.
      if (reason === 'net::ERR_ABORTED' && request.response()?.status() === 200) {
        abortedWhileStreaming.push(request.url());
      } else {
        problems.push(`request failed (${reason}): ${request.url()}`);
      }
    });
    await page.setViewport({ width: WIDTH, height: HEIGHT, deviceScaleFactor: 1 });

    const webgl = await page.evaluate(() => {
      const gl = document.createElement('canvas').getContext('webgl2');
      if (!gl) return null;
      const info = gl.getExtension('WEBGL_debug_renderer_info');
      return gl.getParameter(info ? info.UNMASKED_RENDERER_WEBGL : gl.RENDERER);
    });
    if (!webgl) throw new Failure('headless chromium gives no WebGL 2 context');
    log(`${await browser.version()}, WebGL 2: ${webgl}`);

    // No ?gltf=: the page takes the file from bake.json, as a user opening the folder would.
    await page.goto(`${server.url}index.html?ui=0`, { waitUntil: 'load', timeout: 30_000 });
    await page.waitForFunction(() => window.penumbraReady === true || window.penumbraError,
                               { timeout: 60_000 });
    const state = await page.evaluate(() => ({ error: window.penumbraError,
                                               info: window.penumbraInfo }));
    if (state.error) throw new Failure(`the page: ${state.error}`);
    log(`page: ${JSON.stringify(state.info)}`);
    if (!(state.info.lightmappedMaterials > 0)) throw new Failure('no lightmapped material shown');
    if (!(await page.evaluate(() => window.penumbraUseFileCamera()))) {
      throw new Failure('the baked glTF has no camera');
    }
    await page.evaluate((x) => window.penumbraSetExposure(x), exposure);
    const png = Buffer.from(await page.screenshot({ type: 'png' }));
    fs.writeFileSync(path.join(workDir, 'page.png'), png);

    await server.close();  // waits for every response to finish
    for (const url of abortedWhileStreaming) {
      const pathname = decodeURIComponent(new URL(url).pathname);
      if (!server.completed.has(pathname)) problems.push(`request failed (net::ERR_ABORTED): ${url}`);
    }
    if (problems.length) {
      throw new Failure(`the page logged errors or lost requests:\n  ${problems.join('\n  ')}`);
    }
    return decodePng(png);
  } catch (error) {
    // What the page logged explains most failures (a timeout waiting for it, say).
    if (problems.length && !error.message.includes(problems[0])) {
      error.message += `\n  the page logged:\n  ${problems.join('\n  ')}`;
    }
    throw error;
  } finally {
    await browser.close();
    await server.close();
  }
}

async function main() {
  const [cli, root, workDir] = process.argv.slice(2).map((a) => (a ? path.resolve(a) : a));
  if (!cli || !root || !workDir) {
    log('usage: node page_test.mjs PENUMBRA_CLI REPO_ROOT WORK_DIR');
    return FAIL;
  }
  const webDir = path.join(root, 'web');
  const missing = [];
  if (!fs.existsSync(CHROMIUM)) missing.push(`${CHROMIUM} (Debian package chromium)`);
  for (const module of ['puppeteer-core', 'gltf-validator']) {
    if (!fs.existsSync(path.join(webDir, 'node_modules', module, 'package.json'))) {
      missing.push(`web/node_modules/${module}`);
    }
  }
  if (missing.length) {
    const message = `missing ${missing.join(', ')}: run scripts/install-deps.sh`;
    if (process.env.PENUMBRA_REQUIRE_BROWSER === '1') {
      log(`FAIL: ${message} (PENUMBRA_REQUIRE_BROWSER=1)`);
      return FAIL;
    }
    log(`SKIP: ${message}`);
    return SKIP;
  }
  const require = createRequire(path.join(webDir, 'package.json'));
  const puppeteer = require('puppeteer-core');
  const validator = require('gltf-validator');

  const scene = path.join(root, 'scenes', 'cornell.json');
  const stem = path.basename(scene, '.json');
  const bakeDir = path.join(workDir, 'bake');
  fs.mkdirSync(workDir, { recursive: true });
  fs.rmSync(bakeDir, { recursive: true, force: true });

  run(cli, ['bake', scene, ...SOLVE, '-o', bakeDir, '--web', bakeDir]);
  const gltf = path.join(bakeDir, `${stem}.gltf`);
  for (const file of [gltf, path.join(bakeDir, 'index.html'), path.join(bakeDir, 'bake.json')]) {
    if (!fs.existsSync(file)) throw new Failure(`the bake wrote no ${path.relative(workDir, file)}`);
  }
  await validateGltf(validator, gltf);

  const pfm = path.join(workDir, 'ref.pfm');
  run(cli, ['render', scene, ...SOLVE, '--width', String(WIDTH), '--height', String(HEIGHT),
            '-o', pfm]);
  const reference = readPfm(pfm);
  const exposure = chooseExposure(reference);
  log(`exposure ${exposure.toPrecision(6)} (2^${Math.log2(exposure).toFixed(2)})`);

  const page = await showPage(puppeteer, bakeDir, exposure, workDir);
  const result = compare(page, reference, exposure, workDir);
  const fmt = (values, digits) => values.map((v) => v.toFixed(digits)).join(' / ');
  log(`page against reference, R / G / B in 8-bit units: mean |diff| ${fmt(result.mean, 3)}, ` +
      `99th percentile ${fmt(result.p99, 0)}, pixels off by more than 8: ` +
      `${fmt(result.over8.map((f) => 100 * f), 2)} %; reference mean ${result.referenceMean.toFixed(1)}`);
  log(`screenshot, reference and diff (x8): ${path.join(workDir, 'page.png')}, reference.png, diff.png`);
  if (result.referenceMean < 20) throw new Failure('the reference is too dark to compare');
  const worst = Math.max(...result.mean);
  if (worst > MEAN_TOLERANCE) {
    throw new Failure(`mean |page - reference| ${worst.toFixed(3)} > ${MEAN_TOLERANCE} (8-bit units)`);
  }
  return PASS;
}

const timer = setTimeout(() => {
  log(`FAIL: no result after ${TIME_LIMIT_MS / 1000} s`);
  process.exit(FAIL);
}, TIME_LIMIT_MS);
timer.unref();

let code = FAIL;
try {
  const started = Date.now();
  code = await main();
  if (code === PASS) log(`PASS (${((Date.now() - started) / 1000).toFixed(1)} s)`);
} catch (error) {
  log(`FAIL: ${error instanceof Failure ? error.message : error.stack}`);
  code = FAIL;
}
process.exit(code);
