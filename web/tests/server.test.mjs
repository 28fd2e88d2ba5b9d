// Server tests for `relief studio`: status codes and messages for bad requests, path traversal,
// size limits, the stage cache, superseding, exports, and concurrent requests — the server must
// answer each correctly, never crash, and serve the next good request. Run by CTest (label
// studio; RELIEF_BINARY names the binary).
import { test, before, after } from 'node:test';
import assert from 'node:assert/strict';
import net from 'node:net';
import { execFileSync } from 'node:child_process';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { startStudio, RELIEF, greyPng } from './harness.mjs';
import { decodeFrame } from '../src/api.js';

let server;
before(async () => {
  server = await startStudio(['--threads', '2']);
});
after(async () => {
  const code = await server.stop();
  // A clean exit on SIGTERM (and, in the sanitizer build, no leak or error report).
  assert.equal(code, 0, `relief studio exited with ${code}: ${server.stderr()}`);
});

const post = (p, body, headers = {}) =>
  fetch(server.url + p, {
    method: 'POST',
    headers: { 'Content-Type': 'application/json', ...headers },
    body: typeof body === 'string' ? body : JSON.stringify(body),
  });

async function preset(name = 'island', size = 65, seed = 7) {
  const doc = await (await fetch(`${server.url}/api/presets/${name}`)).json();
  doc.world.size = size;
  doc.seed = seed;
  return doc;
}

async function expectError(res, status, { path: field, match } = {}) {
  assert.equal(res.status, status, `expected ${status}, got ${res.status}`);
  assert.match(res.headers.get('content-type') || '', /application\/json/);
  const body = await res.json();
  assert.equal(typeof body.error, 'string');
  if (field !== undefined) assert.equal(body.path, field, `path of: ${body.error}`);
  if (match) assert.match(body.error, match);
  return body;
}

// A raw request line, so that nothing normalises the path before the server sees it.
function rawGet(target, host) {
  return new Promise((resolve, reject) => {
    const { hostname, port } = new URL(server.url);
    const sock = net.connect(Number(port), hostname, () => {
      sock.write(`GET ${target} HTTP/1.1\r\nHost: ${host || hostname + ':' + port}\r\nConnection: close\r\n\r\n`);
    });
    let data = '';
    sock.on('data', (d) => (data += d));
    sock.on('end', () => resolve({ status: Number(data.split(' ')[1]), text: data }));
    sock.on('error', reject);
  });
}

async function goodGenerate(headers = {}) {
  const res = await post('/api/generate', { recipe: await preset() }, headers);
  assert.equal(res.status, 200);
  return decodeFrame(await res.arrayBuffer());
}

test('a port or host it cannot use is a clear error with exit code 2', async () => {
  // The running test server's port is taken: a second studio there must not share it.
  const taken = new URL(server.url).port;
  for (const args of [['--host', '203.0.113.77', '--port', '0'], ['--port', '70000'], ['--port', taken]]) {
    let code = 0, stderr = '';
    try {
      execFileSync(RELIEF, ['studio', ...args], { encoding: 'utf8', stdio: ['ignore', 'pipe', 'pipe'], timeout: 10000 });
    } catch (e) {
      (code = e.status), (stderr = String(e.stderr));
    }
    assert.equal(code, 2, `${args}: ${stderr}`);
    assert.match(stderr, /--host|--port/);
    if (args[1] === taken) assert.match(stderr, /in use/);
  }
});

test('serves the page and its bundle', async () => {
  const html = await (await fetch(server.url + '/')).text();
  assert.match(html, /<script type="module" src="app.js">/);
  const js = await fetch(server.url + '/app.js');
  assert.equal(js.status, 200);
  assert.match(js.headers.get('content-type'), /javascript/);
  assert.ok((await js.text()).length > 100000, 'the bundle includes three.js');
});

test('presets and the parameter table come from the registries', async () => {
  const presets = await (await fetch(server.url + '/api/presets')).json();
  assert.ok(presets.some((p) => p.name === 'island' && p.origin === 'built-in'));
  const table = await (await fetch(server.url + '/api/params')).json();
  const cli = JSON.parse(execFileSync(RELIEF, ['explain', '--json'], { encoding: 'utf8' }));
  // The one addition: the parameters that name a file are marked `upload` (their bytes come by upload).
  const uploads = [];
  for (const st of table.stages)
    for (const p of st.params)
      if ('upload' in p) uploads.push(`${st.name}.${p.name}=${p.upload}`), delete p.upload;
  assert.deepEqual(uploads, ['image.path=true']);
  assert.deepEqual(table, cli, 'the studio serves exactly `relief explain --json` (plus the upload marks)');
  await expectError(await fetch(server.url + '/api/presets/islnd'), 404, { path: 'preset', match: /did you mean 'island'/ });
});

test('malformed JSON is a 400 that says so', async () => {
  await expectError(await post('/api/generate', '{"recipe": {'), 400, { match: /not valid JSON/ });
  await expectError(await post('/api/generate', ''), 400, { match: /not valid JSON/ });
  await expectError(await post('/api/generate', '[1, 2]'), 400, { match: /expected a JSON object, got/ });
  await expectError(await post('/api/generate', '{}'), 400, { path: 'recipe' });
  await expectError(await post('/api/generate', '{"recipe": 5}'), 400, { path: 'recipe', match: /must be a JSON object/ });
});

test('wrong types name the field', async () => {
  const r = await preset();
  await expectError(await post('/api/generate', { recipe: { ...r, seed: 'abc' } }), 400, { path: 'seed' });
  const bad = structuredClone(r);
  bad.stages[0].octaves = 'many';
  await expectError(await post('/api/generate', { recipe: bad }), 400, { path: 'stages[0].octaves', match: /expected an integer/ });
  const range = structuredClone(r);
  range.stages[0].octaves = 40;
  await expectError(await post('/api/generate', { recipe: range }), 400, { path: 'stages[0].octaves', match: /1\.\.16, got 40/ });
  await expectError(await post('/api/generate', { recipe: r, layers: 5 }), 400, { path: 'layers' });
  await expectError(await post('/api/generate', { recipe: r, layers: ['height', 3] }), 400, { path: 'layers[1]' });
  await expectError(await post('/api/generate', { recipe: r, colour: true }), 400, { path: 'colour', match: /unknown request field/ });
  await expectError(await post('/api/export', { recipe: r, format: 3 }), 400, { path: 'format' });
  await expectError(await post('/api/generate', { recipe: r }, { 'X-Relief-Client': 'no spaces allowed' }), 400, { path: 'X-Relief-Client' });
});

test('huge sizes and bodies are refused', async () => {
  const r = await preset();
  await expectError(await post('/api/generate', { recipe: { ...r, world: { ...r.world, size: 100000 } } }), 400, { path: 'world.size' });
  await expectError(await post('/api/generate', { recipe: { ...r, world: { ...r.world, size: 4097 } } }), 400, {
    path: 'world.size',
    match: /at most 1025 samples per axis here, got 4097x4097/,
  });
  await expectError(await post('/api/steps', { recipe: { ...r, world: { ...r.world, size: [2000, 65] } } }), 400, { path: 'world.size' });
  await expectError(await post('/api/export', { recipe: { ...r, world: { ...r.world, size: 4097 } }, format: 'heightmap' }), 400, {
    path: 'world.size',
    match: /at most 2049/,
  });
  const big = JSON.stringify({ recipe: r, pad: 'x'.repeat(2 << 20) });
  await expectError(await post('/api/generate', big), 413);
});

test('static paths cannot escape the web root', async () => {
  for (const target of [
    '/../../../../etc/passwd', '/%2e%2e/%2e%2e/%2e%2e/etc/passwd', '/..%2f..%2f..%2fetc%2fpasswd', '//etc/passwd',
    '/app.js/../../../etc/passwd', '/..\\..\\..\\etc\\passwd', '/%00', '/index.html%00.png', '/.git/config',
  ]) {
    const r = await rawGet(target);
    assert.ok(r.status === 400 || r.status === 404, `${target}: status ${r.status}`);
    assert.doesNotMatch(r.text, /root:|\[core\]/, target);
  }
  await expectError(await fetch(server.url + '/no/such/page'), 404, { match: /no such page/ });
});

test('wrong methods and foreign origins are refused', async () => {
  const res = await fetch(server.url + '/api/generate');
  await expectError(res, 405, { match: /use POST/ });
  assert.equal(res.headers.get('allow'), 'POST');
  await expectError(await post('/api/generate', { recipe: await preset() }, { Origin: 'http://evil.example' }), 403, { path: 'Origin' });
  const rebound = await rawGet('/api/params', 'evil.example:8080');
  assert.equal(rebound.status, 403);
  assert.match(rebound.text, /serves only 127\.0\.0\.1, localhost and \[::1\]/);
  assert.equal((await rawGet('/api/params', `localhost:${new URL(server.url).port}`)).status, 200);
});

test('generate returns every layer and per-stage timings as a binary frame', async () => {
  const r = await preset('island', 65, 11);
  const f = await goodGenerate();
  const { header, layers } = f;
  assert.equal(header.frame.nx, 65);
  assert.equal(header.timings.length, r.stages.length);
  assert.deepEqual(header.timings.map((t) => t.label), r.stages.map((s) => s.label));
  assert.equal(layers.height.type, 'f32');
  assert.equal(layers.height.data.length, 65 * 65);
  assert.ok(layers.height.data.every((v) => v >= 0 && v <= 1));
  assert.equal(layers.color.type, 'rgb8');
  assert.equal(layers.color.data.length, 65 * 65 * 3);
  assert.deepEqual(Object.keys(header.available).sort(), Object.keys(layers).sort());
  // Only the layers asked for.
  const res = await post('/api/generate', { recipe: r, layers: ['height'] });
  const only = decodeFrame(await res.arrayBuffer());
  assert.deepEqual(Object.keys(only.layers), ['height']);
});

test('the same frame comes back for the same recipe and seed', async () => {
  const r = await preset('hills', 65, 123);
  const a = decodeFrame(await (await post('/api/generate', { recipe: r })).arrayBuffer());
  const b = decodeFrame(await (await post('/api/generate', { recipe: r })).arrayBuffer());
  assert.deepEqual(Buffer.from(a.layers.height.data.buffer, a.layers.height.offset, a.layers.height.bytes),
    Buffer.from(b.layers.height.data.buffer, b.layers.height.offset, b.layers.height.bytes));
});

test('stage outputs are cached: a colour change re-runs only the colour stages', async () => {
  const r = await preset('island', 129, 4242);
  const first = decodeFrame(await (await post('/api/generate', { recipe: r })).arrayBuffer());
  assert.equal(first.header.first_stage, 0);
  assert.ok(first.header.timings.every((t) => !t.cached));
  const again = decodeFrame(await (await post('/api/generate', { recipe: r })).arrayBuffer());
  assert.equal(again.header.first_stage, r.stages.length, 'nothing re-runs for an identical request');
  const colourIndex = r.stages.findIndex((s) => s.stage === 'color');
  assert.ok(colourIndex > 0);
  const recoloured = structuredClone(r);
  recoloured.stages[colourIndex].rock_slope_deg = 10;
  const third = decodeFrame(await (await post('/api/generate', { recipe: recoloured })).arrayBuffer());
  assert.equal(third.header.first_stage, colourIndex);
  assert.deepEqual(third.header.timings.map((t) => t.cached), r.stages.map((_, i) => i < colourIndex));
  assert.notDeepEqual([...third.layers.albedo.data], [...first.layers.albedo.data], 'the colours did change');
  assert.deepEqual([...third.layers.height.data], [...first.layers.height.data]);
  // A different seed shares nothing.
  const reseeded = decodeFrame(await (await post('/api/generate', { recipe: { ...r, seed: 4243 } })).arrayBuffer());
  assert.equal(reseeded.header.first_stage, 0);
});

test('steps returns each stage with its height and colour', async () => {
  const r = await preset('island', 65, 5);
  const res = await post('/api/steps', { recipe: r });
  assert.equal(res.status, 200);
  const f = decodeFrame(await res.arrayBuffer());
  assert.equal(f.steps.length, r.stages.length);
  f.steps.forEach((s, i) => {
    assert.equal(s.index, i);
    assert.equal(s.stage, r.stages[i].stage);
    assert.ok(s.summary.length > 0);
    assert.equal(s.layers.height.data.length, 65 * 65);
  });
  assert.ok(!f.steps[0].layers.color && !f.steps[0].layers.albedo, 'no colour before the colour stage');
  assert.ok(f.steps.at(-1).layers.color, 'the shaded colour at the end');
  assert.notDeepEqual([...f.steps[0].layers.height.data], [...f.steps[1].layers.height.data], 'the island stage changes the heights');
});

test('a newer request from the same client supersedes an older one (409)', async () => {
  const slow = await preset('eroded-mountains', 1025, 777001);  // erosion: several slow stages
  const headers = { 'X-Relief-Client': 'supersede-test' };
  const older = post('/api/generate', { recipe: slow }, headers);
  await new Promise((r) => setTimeout(r, 150));
  const newer = post('/api/generate', { recipe: await preset('island', 65, 777002) }, headers);
  const [a, b] = await Promise.all([older, newer]);
  await expectError(a, 409, { match: /superseded/ });
  assert.equal(b.status, 200);
  // Other clients are not affected.
  const other = await post('/api/generate', { recipe: await preset() }, { 'X-Relief-Client': 'someone-else' });
  assert.equal(other.status, 200);
});

test('exports go through the writers: one file, or a zip with companions', async () => {
  const r = await preset('island', 65, 9);
  const png = await post('/api/export', { recipe: r, format: 'heightmap', file: 'height.png' });
  assert.equal(png.status, 200);
  assert.equal(png.headers.get('content-type'), 'image/png');
  const bytes = Buffer.from(await png.arrayBuffer());
  assert.equal(bytes.subarray(1, 4).toString(), 'PNG');
  assert.equal(bytes.readUInt32BE(16), 65, 'width');
  assert.equal(bytes.readUInt32BE(20), 65, 'height');
  assert.equal(bytes[24], 16, '16-bit');

  const obj = await post('/api/export', { recipe: r, format: 'obj' });
  assert.equal(obj.status, 200);
  assert.equal(obj.headers.get('content-type'), 'application/zip');
  assert.match(obj.headers.get('content-disposition'), /attachment; filename="island-9-65-obj\.zip"/);
  const dir = fs.mkdtempSync(path.join(os.tmpdir(), 'relief-export-'));
  const zip = path.join(dir, 'obj.zip');
  fs.writeFileSync(zip, Buffer.from(await obj.arrayBuffer()));
  // Python's zipfile is the independent reader; it checks every CRC.
  const listing = JSON.parse(execFileSync('/usr/bin/python3', ['-c', `
import json, sys, zipfile
z = zipfile.ZipFile(sys.argv[1])
assert z.testzip() is None
obj = z.read('terrain.obj').decode()
print(json.dumps({'names': sorted(z.namelist()), 'v': sum(1 for l in obj.splitlines() if l.startswith('v '))}))
`, zip], { encoding: 'utf8' }));
  fs.rmSync(dir, { recursive: true, force: true });
  assert.deepEqual(listing.names, ['albedo.png', 'terrain.mtl', 'terrain.obj'], 'the MTL names albedo.png, so it comes along');
  assert.equal(listing.v, 65 * 65);

  // A zip of files larger than the 1 MiB chunks it is compressed in (the time budget is checked
  // between chunks) is whole as well.
  const big = await post('/api/export', { recipe: await preset('island', 257, 9), format: 'obj' });
  assert.equal(big.status, 200);
  const dir2 = fs.mkdtempSync(path.join(os.tmpdir(), 'relief-export-'));
  const zip2 = path.join(dir2, 'obj.zip');
  fs.writeFileSync(zip2, Buffer.from(await big.arrayBuffer()));
  const sizes = JSON.parse(execFileSync('/usr/bin/python3', ['-c', `
import json, sys, zipfile
z = zipfile.ZipFile(sys.argv[1])
assert z.testzip() is None
print(json.dumps({i.filename: i.file_size for i in z.infolist()}))
`, zip2], { encoding: 'utf8' }));
  fs.rmSync(dir2, { recursive: true, force: true });
  assert.ok(sizes['terrain.obj'] > 4 << 20, JSON.stringify(sizes));

  // The library's refusals of bad input are 4xx naming the field (issue 15 §5), never a 500.
  await expectError(await post('/api/export', { recipe: r, format: 'rivers' }), 400, { path: 'format', match: /rivers needs/ });
  const odd = { ...r, world: { ...r.world, size: 100 }, export: { engine: 'unity' } };
  await expectError(await post('/api/export', { recipe: odd, format: 'engine' }), 400, { path: 'export.engine', match: /unity needs/ });
  await expectError(await post('/api/export', { recipe: r, format: 'heigthmap' }), 400, { path: 'format', match: /did you mean 'heightmap'/ });
  await expectError(await post('/api/export', { recipe: r, format: 'color', file: 'nope.png' }), 400, { path: 'file', match: /wrote color\.png/ });
});

test('many concurrent requests get the right answers and the server keeps serving', async () => {
  const r = await preset('island', 65, 31337);
  const kinds = [
    async () => [await post('/api/generate', { recipe: r }), 200],
    async () => [await post('/api/generate', '{"recipe": [}'), 400],
    async () => [await post('/api/generate', { recipe: { ...r, seed: -1 } }), 400],
    async () => [await fetch(server.url + '/api/params'), 200],
    async () => [await fetch(server.url + '/api/presets/hills'), 200],
    async () => [await fetch(server.url + '/%2e%2e/etc/passwd'), 404],
    async () => [await post('/api/export', { recipe: r, format: 'heightmap' }), 200],
    async () => [await post('/api/steps', { recipe: { ...r, world: { ...r.world, size: 33 } } }), 200],
  ];
  const jobs = [];
  for (let k = 0; k < 48; k++) jobs.push(kinds[k % kinds.length]());
  const results = await Promise.all(jobs);
  for (const [res, want] of results) {
    assert.equal(res.status, want, `${res.url}: ${res.status}`);
    await res.arrayBuffer();
  }
  assert.equal(server.proc.exitCode, null, 'still running');
  const f = await goodGenerate();
  assert.equal(f.layers.height.data.length, 65 * 65);
});

test('hostile requests (issue 16): nesting, content types, methods, layers, engine paths, hosts', async () => {
  const r = await preset();
  // 100,000 nested arrays (200 KB, under the body limit) are refused, and the server keeps serving.
  const deep = '{"recipe": ' + '['.repeat(100000) + ']'.repeat(100000) + '}';
  await expectError(await post('/api/resolve', deep), 400, { match: /deeper than 128 levels/ });
  // The documented JSON bodies are accepted whatever the content type says, up to the one limit.
  const padded = { recipe: { ...r, description: 'x'.repeat(20000) } };
  for (const type of ['application/x-www-form-urlencoded', 'text/plain', 'multipart/form-data; boundary=x']) {
    const res = await post('/api/resolve', padded, { 'Content-Type': type });
    assert.equal(res.status, 200, `${type}: ${await res.text()}`);
  }
  // Every other method on an API path is a 405 naming the one that works.
  for (const method of ['PUT', 'DELETE', 'OPTIONS', 'PATCH']) {
    const res = await fetch(server.url + '/api/generate', { method });
    await expectError(res, 405, { match: /use POST/ });
    assert.equal(res.headers.get('allow'), 'POST');
  }
  const get = await fetch(server.url + '/api/params', { method: 'POST' });
  await expectError(get, 405, { match: /use GET/ });
  assert.equal(get.headers.get('allow'), 'GET');
  // Unknown layer names are 400s; known ones a terrain lacks are simply not sent.
  await expectError(await post('/api/generate', { recipe: r, layers: ['height', 'heigth'] }), 400, {
    path: 'layers[1]',
    match: /unknown layer "heigth" \(did you mean 'height'\?\)/,
  });
  assert.equal((await post('/api/generate', { recipe: r, layers: ['height', 'volcano'] })).status, 200);
  // Engine errors name the recipe's fields, not the command line's flags.
  const engine = { ...r, world: { ...r.world, size: 40 }, export: { engine: 'unity' } };
  const body = await expectError(await post('/api/export', { recipe: engine, format: 'engine' }), 400, { path: 'export.engine' });
  assert.doesNotMatch(body.error, /--/);
  assert.match(body.error, /world\.size/);
  // A recipe name with a quote, CR/LF and non-ASCII letters cannot inject or drop headers: one
  // Content-Disposition, a safe ASCII filename and the exact name in RFC 5987 filename*.
  const evil = { ...r, name: 'a"b\r\nX-Evil: 1 île' };
  const dl = await post('/api/export', { recipe: evil, format: 'heightmap', file: 'height.png' });
  assert.equal(dl.status, 200);
  assert.equal(dl.headers.get('x-evil'), null);
  const cd = dl.headers.get('content-disposition');
  assert.match(cd, /^attachment; filename="[^"\r\n]*height\.png"; filename\*=UTF-8''[A-Za-z0-9%._~-]+height\.png$/);
  assert.match(cd, /%C3%AEle/);
  // A host that does not resolve says so.
  let stderr = '';
  try {
    execFileSync(RELIEF, ['studio', '--host', 'nosuchhost.invalid', '--port', '0'], { encoding: 'utf8', stdio: ['ignore', 'pipe', 'pipe'], timeout: 10000 });
  } catch (e) {
    stderr = String(e.stderr);
  }
  assert.match(stderr, /relief: error: --host: .*"nosuchhost\.invalid": it does not resolve/);
  assert.equal((await post('/api/resolve', { recipe: r })).status, 200);
});

// ---- uploads (issue 19): an image stage reads an uploaded file from memory; the server never
// reads a path the client names. Limits: limits.test.mjs.
const upload = (name, bytes, client) =>
  fetch(`${server.url}/api/upload?name=${encodeURIComponent(name)}`, {
    method: 'POST',
    headers: client ? { 'X-Relief-Client': client } : {},
    body: bytes,
  });
const imageRecipe = (p, extra = {}) => ({ name: 'sketch', seed: 5, world: { size: 65 }, stages: [{ stage: 'image', path: p, ...extra }] });

// A 16-bit greyscale PNG written by the CLI (the island's height.png), alone in a folder.
function cliHeightPng() {
  const dir = fs.mkdtempSync(path.join(os.tmpdir(), 'relief-upload-'));
  execFileSync(RELIEF, ['generate', '--preset', 'island', '--size', '65', '--seed', '3', '--formats', 'heightmap', '-o', path.join(dir, 'gen')]);
  const png = fs.readFileSync(path.join(dir, 'gen', 'height.png'));
  assert.equal(png[24], 16, '16-bit');
  fs.mkdirSync(path.join(dir, 'in'));
  fs.writeFileSync(path.join(dir, 'in', 'sketch.png'), png);
  return { dir, png, r16: fs.readFileSync(path.join(dir, 'gen', 'height.r16')) };
}

test('uploads: non-image bytes, paths instead of uploads, other sessions: 4xx naming the field; the server serves on', async () => {
  const client = { 'X-Relief-Client': 'uploader-1' };
  // Bytes that are no image: 415 naming the body, and nothing kept.
  for (const [name, bytes] of [
    ['notes.png', Buffer.from('just some text, not a PNG\n')],
    ['empty.png', Buffer.alloc(0)],
    ['broken.png', Buffer.concat([Buffer.from([0x89, 0x50, 0x4e, 0x47, 0x0d, 0x0a, 0x1a, 0x0a]), Buffer.alloc(40, 7)])],
    ['virtual.vrt', Buffer.from('<VRTDataset rasterXSize="2" rasterYSize="2"><VRTRasterBand band="1"><SimpleSource><SourceFilename>/etc/passwd</SourceFilename></SimpleSource></VRTRasterBand></VRTDataset>')],
  ]) {
    const body = await expectError(await upload(name, bytes, 'uploader-1'), 415, { path: 'body' });
    assert.match(body.error, /not an image the studio reads|not a PNG image that can be decoded/, body.error);
    await goodGenerate(client);
  }
  // Without a session there is nowhere to keep it; without a name it cannot be referred to.
  const { dir, png } = cliHeightPng();
  await expectError(await upload('a.png', png), 400, { path: 'X-Relief-Client' });
  await expectError(await fetch(`${server.url}/api/upload`, { method: 'POST', headers: client, body: png }), 400, { path: 'name' });
  await expectError(await fetch(`${server.url}/api/upload?name=${encodeURIComponent('../..')}`, { method: 'POST', headers: client, body: png }), 400, { path: 'name' });
  await goodGenerate(client);
  // A file-system path, even one that exists, is refused before anything is read: a 400 naming
  // stages[i].path, on every endpoint that takes a recipe.
  const file = path.join(dir, 'in', 'sketch.png');
  for (const p of [file, '/etc/passwd', 'sketch.png', 'memory:upload-1/sketch.png', '../in/sketch.png']) {
    for (const [ep, extra] of [['/api/resolve', {}], ['/api/generate', {}], ['/api/steps', {}], ['/api/export', { format: 'heightmap' }], ['/api/save', {}]]) {
      const recipe = { ...imageRecipe(p), stages: [{ stage: 'noise' }, { stage: 'image', path: p }] };
      await expectError(await post(ep, { recipe, ...extra }, client), 400, { path: 'stages[1].path', match: /does not read files named by a request/ });
    }
    await goodGenerate(client);
  }
  // An upload is its session's: another client (or none) cannot name it.
  const ok = await upload('sketch.png', png, 'uploader-1');
  assert.equal(ok.status, 200, await ok.clone().text());
  assert.equal((await ok.json()).path, 'upload:sketch.png');
  assert.equal((await post('/api/generate', { recipe: imageRecipe('upload:sketch.png') }, client)).status, 200);
  await expectError(await post('/api/generate', { recipe: imageRecipe('upload:sketch.png') }, { 'X-Relief-Client': 'uploader-2' }), 400, {
    path: 'stages[0].path',
    match: /no upload named "sketch.png" in this session/,
  });
  await expectError(await post('/api/generate', { recipe: imageRecipe('upload:sketch.png') }), 400, { path: 'stages[0].path' });
  await expectError(await post('/api/generate', { recipe: imageRecipe('upload:other.png') }, client), 400, {
    path: 'stages[0].path',
    match: /uploaded: sketch\.png/,
  });
  // Errors about an upload name it as the client does, not by the server's in-memory name.
  await expectError(await post('/api/generate', { recipe: imageRecipe('upload:sketch.png', { placement: 'georeference' }) }, client), 400, {
    path: 'stages[0].placement',
    match: /'upload:sketch\.png' has no georeference/,
  });
  await goodGenerate(client);
  fs.rmSync(dir, { recursive: true, force: true });
});

test('an uploaded 16-bit PNG gives the heights `relief generate` reads from the file', async () => {
  const { dir, png, r16 } = cliHeightPng();
  const client = { 'X-Relief-Client': 'uploader-3' };
  const up = await upload('sketch.png', png, 'uploader-3');
  assert.equal(up.status, 200, await up.clone().text());
  const info = await up.json();
  assert.deepEqual([info.name, info.path, info.width, info.height, info.format], ['sketch.png', 'upload:sketch.png', 65, 65, 'png']);
  // The recipe the page gets back keeps the upload's name.
  const resolved = (await (await post('/api/resolve', { recipe: imageRecipe('upload:sketch.png') }, client)).json()).recipe;
  assert.equal(resolved.stages[0].path, 'upload:sketch.png');
  const res = await post('/api/generate', { recipe: imageRecipe('upload:sketch.png'), layers: ['height'] }, client);
  assert.equal(res.status, 200);
  const frame = decodeFrame(await res.arrayBuffer());
  assert.equal(frame.header.recipe.stages[0].path, 'upload:sketch.png');
  const h = frame.layers.height.data;
  // The CLI on the same file, beside its recipe.
  fs.writeFileSync(path.join(dir, 'in', 'recipe.json'), JSON.stringify(imageRecipe('sketch.png')));
  execFileSync(RELIEF, ['generate', path.join(dir, 'in', 'recipe.json'), '--formats', 'heightmap', '-o', path.join(dir, 'cli')]);
  const cli = fs.readFileSync(path.join(dir, 'cli', 'height.r16'));
  assert.equal(h.length, 65 * 65);
  let worst = 0;
  for (let k = 0; k < h.length; k++) worst = Math.max(worst, Math.abs(h[k] * 65535 - cli.readUInt16LE(2 * k)));
  assert.ok(worst <= 0.5, `studio heights differ from the CLI's by ${worst} codes`);
  assert.ok(cli.equals(r16), 'the image stage reads back the island exactly');
  // An export of the same recipe writes the CLI's bytes.
  const ex = await post('/api/export', { recipe: imageRecipe('upload:sketch.png'), format: 'heightmap', file: 'height.r16' }, client);
  assert.equal(ex.status, 200);
  assert.ok(Buffer.from(await ex.arrayBuffer()).equals(cli), 'export height.r16 = the CLI run on the file');
  // A new upload under the same name replaces it, and the stage cache does not serve the old one.
  const ramp = await greyPng(65, 65, 16, (x) => x * 1000);
  assert.equal((await upload('sketch.png', ramp, 'uploader-3')).status, 200);
  const res2 = await post('/api/generate', { recipe: imageRecipe('upload:sketch.png'), layers: ['height'] }, client);
  assert.equal(res2.status, 200);
  const h2 = decodeFrame(await res2.arrayBuffer()).layers.height.data;
  for (let k = 0; k < h2.length; k += 97) assert.equal(Math.round(h2[k] * 65535), (k % 65) * 1000, `sample ${k}`);
  fs.rmSync(dir, { recursive: true, force: true });
});

test('saving a recipe with an upload: a zip of recipe.json and the image, which `relief generate` reads', async () => {
  const { dir, png } = cliHeightPng();
  const client = { 'X-Relief-Client': 'uploader-4' };
  assert.equal((await upload('my sketch.png', png, 'uploader-4')).status, 200);
  const recipe = { ...imageRecipe('upload:my_sketch.png'), name: 'saved' };
  recipe.stages.push({ stage: 'color' });
  const res = await post('/api/save', { recipe }, client);
  assert.equal(res.status, 200, await res.clone().text());
  assert.equal(res.headers.get('content-type'), 'application/zip');
  assert.match(res.headers.get('content-disposition'), /filename="saved-5\.zip"/);
  const zip = path.join(dir, 'saved.zip');
  fs.writeFileSync(zip, Buffer.from(await res.arrayBuffer()));
  const out = path.join(dir, 'unpacked');
  const names = JSON.parse(execFileSync('/usr/bin/python3', ['-c', `
import json, sys, zipfile
z = zipfile.ZipFile(sys.argv[1])
assert z.testzip() is None
z.extractall(sys.argv[2])
print(json.dumps(sorted(z.namelist())))
`, zip, out], { encoding: 'utf8' }));
  assert.deepEqual(names, ['my_sketch.png', 'recipe.json']);
  assert.ok(fs.readFileSync(path.join(out, 'my_sketch.png')).equals(png), 'the uploaded bytes, unchanged');
  const saved = JSON.parse(fs.readFileSync(path.join(out, 'recipe.json'), 'utf8'));
  assert.equal(saved.stages[0].path, 'my_sketch.png', 'the path is the file beside the recipe');
  assert.equal(saved.seed, 5);
  // The unpacked folder runs as it is, from any working directory, with the studio's heights.
  execFileSync(path.resolve(RELIEF), ['generate', path.join(out, 'recipe.json'), '--formats', 'heightmap', '-o', path.join(dir, 'cli')], { cwd: os.tmpdir() });
  const ex = await post('/api/export', { recipe, format: 'heightmap', file: 'height.r16' }, client);
  assert.ok(Buffer.from(await ex.arrayBuffer()).equals(fs.readFileSync(path.join(dir, 'cli', 'height.r16'))));
  // A recipe without uploads saves as recipe.json alone.
  const plain = await post('/api/save', { recipe: await preset() }, client);
  assert.equal(plain.status, 200);
  fs.rmSync(dir, { recursive: true, force: true });
});

// ---- volumes (issue 21): POST /api/volume gives the caves writer's caves.glb for the terrain the
// page shows (the cached one); a recipe without a volume is refused naming its stages.

// The chunks of a GLB: {json, bin} after checking its container (glTF 2.0 binary: 12-byte header,
// a JSON chunk, then a BIN chunk).
function parseGlb(buf) {
  assert.equal(buf.subarray(0, 4).toString('latin1'), 'glTF', 'magic');
  assert.equal(buf.readUInt32LE(4), 2, 'version');
  assert.equal(buf.readUInt32LE(8), buf.length, 'length');
  const jsonLength = buf.readUInt32LE(12);
  assert.equal(buf.readUInt32LE(16), 0x4e4f534a, 'the first chunk is JSON');
  const json = JSON.parse(buf.subarray(20, 20 + jsonLength).toString('utf8'));
  let bin = Buffer.alloc(0);
  if (20 + jsonLength < buf.length) {
    const at = 20 + jsonLength;
    assert.equal(buf.readUInt32LE(at + 4), 0x004e4942, 'the second chunk is BIN');
    bin = buf.subarray(at + 8, at + 8 + buf.readUInt32LE(at));
  }
  return { json, bin };
}

// The chunk nodes of caves.glb and their triangles (indices / 3; every primitive is TRIANGLES).
function volumeCounts({ json }) {
  const chunks = (json.nodes || []).filter((n) => /^caves_x-?\d+_y-?\d+_z-?\d+$/.test(n.name || ''));
  let triangles = 0;
  for (const n of chunks)
    for (const p of json.meshes[n.mesh].primitives) {
      assert.equal(p.mode ?? 4, 4);
      triangles += json.accessors[p.indices].count / 3;
    }
  return { chunks, triangles };
}

test('volume: caves.glb of the cached terrain, one node per chunk, the bytes of `relief generate`', async () => {
  const r = await preset('sea-cliff', 129, 7);
  const gen = decodeFrame(await (await post('/api/generate', { recipe: r })).arrayBuffer());
  assert.equal(gen.header.volume, true, 'the generate header says the terrain has a volume');
  const res = await post('/api/volume', { recipe: r });
  assert.equal(res.status, 200, await res.clone().text());
  assert.equal(res.headers.get('content-type'), 'model/gltf-binary');
  const timings = JSON.parse(res.headers.get('x-relief-timings'));
  assert.equal(timings.first_stage, r.stages.length, 'the stages came from the cache (generate ran them)');
  const bytes = Buffer.from(await res.arrayBuffer());
  const glb = parseGlb(bytes);
  const { chunks, triangles } = volumeCounts(glb);
  assert.ok(chunks.length > 0, 'chunk nodes caves_x*_y*_z*');
  assert.ok(triangles > 0, 'the volume has a surface');
  assert.deepEqual(glb.json.nodes.find((n) => n.name === 'caves').children.sort((a, b) => a - b),
    chunks.map((n) => glb.json.nodes.indexOf(n)).sort((a, b) => a - b), 'the root node holds every chunk');
  // Every chunk's vertices lie in the world's box (metres, one voxel of air beyond each side) and
  // carry normals and colours.
  const voxel = r.world.width_m / 128;
  for (const n of chunks)
    for (const p of glb.json.meshes[n.mesh].primitives) {
      assert.ok(p.attributes.NORMAL !== undefined && p.attributes.COLOR_0 !== undefined, n.name);
      const a = glb.json.accessors[p.attributes.POSITION];
      assert.ok(a.min[0] >= -voxel - 1e-3 && a.max[0] <= r.world.width_m + voxel + 1e-3, `${n.name} x ${a.min[0]}..${a.max[0]}`);
      assert.ok(a.min[2] >= -voxel - 1e-3 && a.max[2] <= r.world.width_m + voxel + 1e-3, `${n.name} z ${a.min[2]}..${a.max[2]}`);
    }
  const validator = await import('gltf-validator');
  const report = await validator.default.validateBytes(new Uint8Array(bytes));
  assert.equal(report.issues.numErrors, 0, JSON.stringify(report.issues.messages.slice(0, 5)));
  // The same bytes as the command line's caves.glb of the same recipe and seed, and again from
  // the cache.
  const dir = fs.mkdtempSync(path.join(os.tmpdir(), 'relief-volume-'));
  fs.writeFileSync(path.join(dir, 'recipe.json'), JSON.stringify(r));
  execFileSync(RELIEF, ['generate', path.join(dir, 'recipe.json'), '--formats', 'caves', '-o', path.join(dir, 'cli')]);
  assert.ok(bytes.equals(fs.readFileSync(path.join(dir, 'cli', 'caves.glb'))), 'the CLI writes the same caves.glb');
  fs.rmSync(dir, { recursive: true, force: true });
  const again = Buffer.from(await (await post('/api/volume', { recipe: r })).arrayBuffer());
  assert.ok(again.equals(bytes));
  // The recipe's engine is not the volume's business: no engine writer runs, no engine size rule
  // refuses the preview size.
  const engine = await post('/api/volume', { recipe: { ...r, world: { ...r.world, size: 100 }, export: { engine: 'unity' } } });
  assert.equal(engine.status, 200, await engine.clone().text());
  assert.ok(volumeCounts(parseGlb(Buffer.from(await engine.arrayBuffer()))).triangles > 0);
});

test('volume: a recipe without a volume is a 400 naming stages; bad bodies and methods are refused', async () => {
  const island = await preset('island', 65, 3);
  const gen = decodeFrame(await (await post('/api/generate', { recipe: island })).arrayBuffer());
  assert.equal(gen.header.volume, false);
  await expectError(await post('/api/volume', { recipe: island }), 400, { path: 'stages', match: /caves needs a volume, overhangs or caves stage/ });
  await expectError(await post('/api/volume', { recipe: island, format: 'caves' }), 400, { path: 'format', match: /unknown request field/ });
  const big = await preset('sea-cliff', 129, 7);
  big.world.size = 2049;
  await expectError(await post('/api/volume', { recipe: big }), 400, { path: 'world.size' });
  await expectError(await post('/api/volume', '{"recipe": '), 400);
  const get = await fetch(server.url + '/api/volume');
  await expectError(get, 405, { match: /use POST/ });
  assert.equal(get.headers.get('allow'), 'POST');
  await goodGenerate();
});

test('volume: its requests run beside the same client\'s generate requests (their own lane)', async () => {
  const headers = { 'X-Relief-Client': 'volume-lane' };
  const r = await preset('sea-cliff', 257, 8);
  // Started together: a generate of the same client does not supersede the volume, nor the
  // volume the generate.
  const [vol, gen] = await Promise.all([post('/api/volume', { recipe: r }, headers), post('/api/generate', { recipe: await preset('island', 129, 8) }, headers)]);
  assert.equal(vol.status, 200, await vol.clone().text());
  assert.equal(gen.status, 200, await gen.clone().text());
  assert.ok(volumeCounts(parseGlb(Buffer.from(await vol.arrayBuffer()))).triangles > 0);
});

test('an idle studio frees its spare layer buffers (--cache-idle), held to the stage cache\'s budget', async () => {
  const own = await startStudio(['--threads', '2', '--cache-mib', '16', '--cache-idle', '2']);
  try {
    const stats = async () => (await (await fetch(own.url + '/api/stats')).json()).buffer_cache;
    const doc = await (await fetch(`${own.url}/api/presets/island`)).json();
    doc.world.size = 1025;  // layers of 4.2 MB: above the buffer cache's 4 MiB floor
    for (const seed of [1, 2]) {
      doc.seed = seed;
      const res = await fetch(own.url + '/api/generate', {
        method: 'POST', headers: { 'Content-Type': 'application/json' }, body: JSON.stringify({ recipe: doc, layers: ['height'] }),
      });
      assert.equal(res.status, 200, await res.clone().text());
      await res.arrayBuffer();
    }
    const busy = await stats();
    assert.equal(busy.limit, 16 * 1024 * 1024);
    assert.equal(busy.idle_s, 2);
    assert.ok(busy.bytes > 0 && busy.bytes <= busy.limit, JSON.stringify(busy));
    let idle = busy;
    for (let k = 0; k < 100 && !(idle.bytes === 0 && idle.releases >= 1); ++k) {
      await new Promise((r) => setTimeout(r, 100));
      idle = await stats();
    }
    assert.equal(idle.bytes, 0, JSON.stringify(idle));
    assert.ok(idle.releases >= 1, JSON.stringify(idle));
  } finally {
    assert.equal(await own.stop(), 0, own.stderr());
  }
});
