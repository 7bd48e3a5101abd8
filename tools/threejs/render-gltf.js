#!/usr/bin/env node
// Renders a glTF/GLB with three.js's GLTFLoader in headless Chromium and reports what the pixels
// show, so tests can check that a real consumer draws an exported file: non-empty, coloured, the
// right way up, and (animations) different at different times.
//
//   node tools/threejs/render-gltf.js MODEL.glb --out DIR [--name NAME] [--size 800x600]
//        [--yaw DEG] [--pitch DEG] [--times first,last|SECONDS,...] [--section] [--timeout S]
//
// --section cuts the model open along the sagittal plane (page/render.mjs).
// Writes DIR/NAME-<i>.png for the i-th time and prints one JSON report on stdout: three.js
// revision, the loaded scene's nodes, materials (colour, roughness, metalness, vertexColors) and
// animations, the model's bounds, and per time the PNG and pixel statistics (page/render.mjs).
// Exit status 0 when the page reported, 1 when it reported an error, 2 on a usage or launch
// problem (no Chromium, three.js not installed: tools/threejs/install.sh, a timeout).
//
// Chromium (Debian package `chromium`, or $TSF_CHROMIUM) runs headless with software WebGL
// (SwiftShader), a fresh profile and no network besides this script's own server on 127.0.0.1.
'use strict';
const fs = require('fs');
const http = require('http');
const os = require('os');
const path = require('path');
const { spawn } = require('child_process');

const HERE = __dirname;
const THREE_DIR = path.join(HERE, 'node_modules', 'three');

function fail(message, status = 2) {
  process.stderr.write(`render-gltf: ${message}\n`);
  process.exit(status);
}

function parseArgs(argv) {
  const a = { size: '800x600', yaw: 0, pitch: 0, times: 'first', timeout: 240, name: null,
              section: false };
  const rest = [];
  for (let i = 0; i < argv.length; ++i) {
    const k = argv[i];
    const value = () => {
      if (i + 1 >= argv.length) fail(`${k} needs a value`);
      return argv[++i];
    };
    if (k === '--out') a.out = value();
    else if (k === '--name') a.name = value();
    else if (k === '--size') a.size = value();
    else if (k === '--yaw') a.yaw = Number(value());
    else if (k === '--pitch') a.pitch = Number(value());
    else if (k === '--times') a.times = value();
    else if (k === '--section') a.section = true;
    else if (k === '--timeout') a.timeout = Number(value());
    else if (k === '--help' || k === '-h') {
      process.stdout.write(fs.readFileSync(__filename, 'utf8').split('\n').slice(1, 17)
        .map((l) => l.replace(/^\/\/ ?/, '')).join('\n') + '\n');
      process.exit(0);
    } else rest.push(k);
  }
  if (rest.length !== 1 || !a.out) fail('usage: render-gltf.js MODEL.glb --out DIR [options] (--help)');
  a.model = rest[0];
  const m = /^(\d+)x(\d+)$/.exec(a.size);
  if (!m) fail(`--size '${a.size}': expected WxH, e.g. 800x600`);
  [a.w, a.h] = [Number(m[1]), Number(m[2])];
  if (!Number.isFinite(a.yaw) || !Number.isFinite(a.pitch)) fail('--yaw and --pitch take degrees');
  if (!(a.timeout > 0)) fail('--timeout takes seconds > 0');
  a.name = a.name || path.basename(a.model).replace(/\.[^.]*$/, '');
  return a;
}

function findChromium() {
  const candidates = [process.env.TSF_CHROMIUM, 'chromium', 'chromium-browser', 'google-chrome'];
  for (const c of candidates) {
    if (!c) continue;
    if (c.includes('/')) {
      if (fs.existsSync(c)) return c;
      continue;
    }
    for (const dir of (process.env.PATH || '').split(':')) {
      const p = path.join(dir, c);
      if (dir && fs.existsSync(p)) return p;
    }
  }
  return null;
}

const TYPES = { '.html': 'text/html', '.mjs': 'text/javascript', '.js': 'text/javascript',
                '.glb': 'model/gltf-binary', '.gltf': 'model/gltf+json' };

function serve(args, onResult) {
  const model = path.resolve(args.model);
  return http.createServer((req, res) => {
    const url = new URL(req.url, 'http://127.0.0.1');
    if (req.method === 'POST' && url.pathname === '/result') {
      const chunks = [];
      req.on('data', (c) => chunks.push(c));
      req.on('end', () => {
        res.end('ok');
        onResult(Buffer.concat(chunks).toString('utf8'));
      });
      return;
    }
    let file = null;
    if (url.pathname === '/render.html' || url.pathname === '/render.mjs')
      file = path.join(HERE, 'page', url.pathname.slice(1));
    else if (url.pathname.startsWith('/three/'))
      file = path.join(THREE_DIR, path.normalize(url.pathname.slice('/three/'.length)));
    else if (url.pathname === '/model' + path.extname(model))
      file = model;
    if (!file || !file.startsWith(file === model ? model : HERE) || !fs.existsSync(file)) {
      res.statusCode = 404;
      res.end();
      return;
    }
    res.setHeader('Content-Type', TYPES[path.extname(file)] || 'application/octet-stream');
    fs.createReadStream(file).pipe(res);
  });
}

function main() {
  const args = parseArgs(process.argv.slice(2));
  if (!fs.existsSync(args.model)) fail(`model '${args.model}' does not exist`);
  if (!fs.existsSync(path.join(THREE_DIR, 'build', 'three.module.js')))
    fail(`three.js is not installed in ${THREE_DIR}: run tools/threejs/install.sh`);
  const chromium = findChromium();
  if (!chromium) fail('Chromium is not installed (Debian package chromium; or set TSF_CHROMIUM)');
  fs.mkdirSync(args.out, { recursive: true });

  const profile = fs.mkdtempSync(path.join(os.tmpdir(), 'tsf-chromium-'));
  let browser = null;
  let done = false;
  const finish = (status, text) => {
    if (done) return;
    done = true;
    if (text) process.stdout.write(text + '\n');
    server.close();
    const cleanUp = () => {
      try {
        fs.rmSync(profile, { recursive: true, force: true, maxRetries: 5, retryDelay: 100 });
      } catch (e) {
        process.stderr.write(`render-gltf: could not remove ${profile}: ${e.message}\n`);
      }
      process.exit(status);
    };
    if (!browser || browser.exitCode !== null) return cleanUp();
    browser.removeAllListeners('exit');
    browser.on('exit', cleanUp);
    try {
      process.kill(-browser.pid, 'SIGKILL');  // Chromium and every process it started
    } catch (e) {
      browser.kill('SIGKILL');
    }
    setTimeout(cleanUp, 5000).unref();
  };

  const server = serve(args, (body) => {
    let report;
    try {
      report = JSON.parse(body);
    } catch (e) {
      return finish(1, JSON.stringify({ error: `page sent invalid JSON: ${e}` }));
    }
    if (report.error) return finish(1, JSON.stringify({ model: args.model, error: report.error }));
    report.frames.forEach((f, i) => {
      const file = path.join(args.out, `${args.name}-${i}.png`);
      fs.writeFileSync(file, Buffer.from(f.png.replace(/^data:image\/png;base64,/, ''), 'base64'));
      f.png = file;
    });
    report.model = args.model;
    report.chromium = chromium;
    finish(0, JSON.stringify(report));
  });
  server.listen(0, '127.0.0.1', () => {
    const port = server.address().port;
    const query = new URLSearchParams({ model: '/model' + path.extname(args.model), w: args.w,
                                        h: args.h, yaw: args.yaw, pitch: args.pitch,
                                        times: args.times, section: args.section ? 1 : 0 });
    const flags = ['--headless', '--no-sandbox', '--disable-gpu', '--use-angle=swiftshader',
                   '--enable-unsafe-swiftshader', '--disable-background-networking',
                   '--disable-component-update', '--disable-sync', '--no-first-run',
                   '--disable-default-apps', '--mute-audio', `--user-data-dir=${profile}`,
                   `--window-size=${args.w},${args.h}`,
                   `http://127.0.0.1:${port}/render.html?${query}`];
    let log = '';
    browser = spawn(chromium, flags, { stdio: ['ignore', 'ignore', 'pipe'], detached: true });
    browser.stderr.on('data', (d) => { log = (log + d).slice(-4000); });
    browser.on('exit', (code) => {
      if (!done) finish(2, JSON.stringify({ error: `Chromium exited (${code}) before the page ` +
                                                   `reported`, chromium_log: log }));
    });
    browser.on('error', (e) => finish(2, JSON.stringify({ error: `cannot start ${chromium}: ${e}` })));
  });
  setTimeout(() => finish(2, JSON.stringify({ error: `no report within ${args.timeout} s` })),
             args.timeout * 1000).unref();
}

main();
