// Renders a `shvis export` folder with the three.js page (view.html, view.mjs) in headless
// Chromium and writes what the page drew.
//
// Usage: node render_in_chromium.mjs EXPORT_DIR WIDTH HEIGHT OUT [manifest]
//
// `manifest`: the page shades from the manifest's value map instead of decode.glsl.
//
// Writes OUT.radiance.f32, OUT.position.f32, OUT.normal.f32 and OUT.bitangent.f32: the
// linear radiance, the world position, the vertex normal and the normal map's bitangent of
// each pixel, RGBA f32, the top row first.
//
// Serves this folder (the page and its npm packages) and EXPORT_DIR under /export/ on a
// local port, starts Chromium on the page (WebGL 2 through SwiftShader, no GPU needed) and
// waits for the page's /pixels and /done, or /error. Prints one JSON line on stdout: what
// the browser offered ({renderer, bptc, rgtc}). Exits 1 with the page's error, Chromium's
// console, or after two minutes without an answer.
import { createServer } from 'node:http';
import { readFile, writeFile, mkdtemp, rm } from 'node:fs/promises';
import { spawn, execFileSync } from 'node:child_process';
import { join, normalize, extname, dirname } from 'node:path';
import { tmpdir } from 'node:os';
import { fileURLToPath } from 'node:url';

const [exportDir, width, height, out, shading] = process.argv.slice(2);
if (!out) {
  console.error('usage: node render_in_chromium.mjs EXPORT_DIR WIDTH HEIGHT OUT');
  process.exit(2);
}
const here = dirname(fileURLToPath(import.meta.url));
const TYPES = {
  '.html': 'text/html',
  '.mjs': 'text/javascript',
  '.js': 'text/javascript',
  '.json': 'application/json',
  '.png': 'image/png',
};

function chromium() {
  for (const name of ['chromium', 'chromium-browser', 'google-chrome', 'google-chrome-stable']) {
    try {
      execFileSync('which', [name], { stdio: 'ignore' });
      return name;
    } catch {
      // next name
    }
  }
  console.error('error: headless Chromium not found: `make deps` installs it (as root: apt-get install chromium)');
  process.exit(1);
}

let browser = null;
let profile = null;
let console_ = '';
let finishing = false;
const finish = async (code, message) => {
  if (finishing) return;
  finishing = true;
  if (message) console.error(message);
  if (browser && browser.exitCode === null) {
    const exited = new Promise((resolve) => browser.once('exit', resolve));
    browser.kill('SIGKILL');
    await exited;
  }
  if (profile) {
    await rm(profile, { recursive: true, force: true, maxRetries: 5 }).catch(() => {});
  }
  process.exit(code);
};

let pixels = null;
const images = {};
const server = createServer(async (request, response) => {
  const url = new URL(request.url, 'http://localhost');
  if (request.method === 'POST') {
    const chunks = [];
    for await (const chunk of request) chunks.push(chunk);
    const body = Buffer.concat(chunks);
    response.end();
    const kinds = {
      '/pixels': 'radiance',
      '/positions': 'position',
      '/normals': 'normal',
      '/bitangents': 'bitangent',
    };
    if (kinds[url.pathname]) {
      images[kinds[url.pathname]] = body;
      if (url.pathname === '/pixels') pixels = body;
    } else if (url.pathname === '/done') {
      const expected = Number(width) * Number(height) * 16;
      for (const kind of Object.values(kinds)) {
        const image = images[kind];
        if (!image || image.length !== expected) {
          await finish(1, `error: the page sent ${image ? image.length : 0} bytes of ${kind}, not ${expected}`);
        }
        await writeFile(`${out}.${kind}.f32`, image);
      }
      process.stdout.write(body.toString() + '\n');
      await finish(0);
    } else {
      await finish(1, `error: the page failed: ${body.toString()}\n${console_}`);
    }
    return;
  }
  const root = url.pathname.startsWith('/export/') ? exportDir : here;
  const relative = url.pathname.startsWith('/export/') ? url.pathname.slice('/export/'.length) : url.pathname;
  const file = normalize(join(root, decodeURIComponent(relative)));
  if (!file.startsWith(normalize(root))) {
    response.statusCode = 403;
    response.end();
    return;
  }
  try {
    const data = await readFile(file);
    response.setHeader('Content-Type', TYPES[extname(file)] ?? 'application/octet-stream');
    response.end(data);
  } catch {
    response.statusCode = 404;
    response.end();
  }
});

server.listen(0, '127.0.0.1', async () => {
  const { port } = server.address();
  profile = await mkdtemp(join(tmpdir(), 'shvis-chromium-'));
  const mode = shading === 'manifest' ? '&shading=manifest' : '';
  const page = `http://127.0.0.1:${port}/view.html?export=/export&width=${width}&height=${height}${mode}`;
  browser = spawn(chromium(), [
    '--headless',
    '--no-sandbox',
    '--disable-gpu-sandbox',
    '--use-angle=swiftshader',
    '--enable-unsafe-swiftshader',
    '--no-first-run',
    '--no-default-browser-check',
    `--user-data-dir=${profile}`,
    '--enable-logging=stderr',
    '--v=0',
    `--window-size=${width},${height}`,
    '--remote-debugging-port=0',
    page,
  ], { stdio: ['ignore', 'ignore', 'pipe'] });
  browser.stderr.on('data', (d) => {
    for (const line of d.toString().split('\n')) {
      if (line.includes('CONSOLE')) console_ += line + '\n';
    }
  });
  browser.on('exit', (code) => {
    if (pixels === null) finish(1, `error: Chromium exited (${code}) before the page answered\n${console_}`);
  });
});

setTimeout(() => finish(1, `error: the page did not answer in two minutes\n${console_}`), 120_000);
