// What `relief studio` bounds (issue 16, item 2; studio.hpp "What the studio bounds"): the stage
// count, a per-request time budget, work whose client went away, admission by memory estimate
// (503 + Retry-After), and a prompt shutdown with work running. Each test starts its own server on
// 127.0.0.1 (port 0) with one generation thread and waits in bounded loops. Run by CTest (label
// studio; RELIEF_BINARY names the binary).
import { test } from 'node:test';
import assert from 'node:assert/strict';
import fs from 'node:fs';
import { startStudio, greyPng } from './harness.mjs';

// A recipe that runs for many seconds at 1025² on one thread: `n` simplex noise stages of 16 warped
// octaves each (about 0.3 s a stage here; a long chain of them is run unfused, so it is checked
// between stages).
function heavyRecipe(n = 60, size = 1025) {
  const stage = { stage: 'noise', basis: 'simplex', octaves: 16, warp: 1, blend: 'add', amplitude: 0.01 };
  return { name: 'heavy', seed: 1, world: { size }, stages: Array.from({ length: n }, () => stage) };
}
const smallRecipe = () => ({ name: 'small', seed: 1, world: { size: 33 }, stages: [{ stage: 'noise' }] });

const post = (server, p, body, init = {}) =>
  fetch(server.url + p, {
    method: 'POST',
    headers: { 'Content-Type': 'application/json' },
    body: JSON.stringify(body),
    ...init,
  });
const stats = async (server) => (await fetch(server.url + '/api/stats')).json();
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

// Polls /api/stats until `pred` holds; fails after `ms`.
async function waitStats(server, pred, ms, what) {
  const t0 = Date.now();
  let s;
  while (Date.now() - t0 < ms) {
    s = await stats(server);
    if (pred(s)) return s;
    await sleep(25);
  }
  assert.fail(`${what}: not within ${ms} ms; last /api/stats ${JSON.stringify(s)}`);
}

// CPU seconds the process has used (user + system, /proc/PID/stat; clock ticks of 1/100 s).
function cpuSeconds(pid) {
  const fields = fs.readFileSync(`/proc/${pid}/stat`, 'utf8').split(') ')[1].split(' ');
  return (Number(fields[11]) + Number(fields[12])) / 100;
}

async function stopClean(server) {
  const code = await server.stop();
  assert.equal(code, 0, `relief studio exited with ${code}: ${server.stderr()}`);
}

test('a recipe with more stages than --max-stages is a 400 naming stages and the limit', async () => {
  // The default is 64 (the presets have at most 10 stages).
  const dflt = await startStudio(['--threads', '1']);
  try {
    const big = { name: 'many', seed: 1, world: { size: 17 }, stages: Array.from({ length: 65 }, () => ({ stage: 'noise' })) };
    const res = await post(dflt, '/api/generate', { recipe: big });
    assert.equal(res.status, 400);
    const body = await res.json();
    assert.equal(body.path, 'stages', body.error);
    assert.match(body.error, /at most 64 stages.*got 65/);
  } finally {
    await stopClean(dflt);
  }
  const server = await startStudio(['--threads', '1', '--max-stages', '8']);
  try {
    const many = { name: 'many', seed: 1, world: { size: 17 }, stages: Array.from({ length: 9 }, () => ({ stage: 'noise' })) };
    for (const p of ['/api/generate', '/api/steps', '/api/resolve']) {
      const res = await post(server, p, { recipe: many });
      assert.equal(res.status, 400, p);
      const body = await res.json();
      assert.equal(body.path, 'stages', body.error);
      assert.match(body.error, /at most 8 stages.*got 9/);
    }
    many.stages.pop();
    assert.equal((await post(server, '/api/generate', { recipe: many })).status, 200);
  } finally {
    await stopClean(server);
  }
});

test('a request running longer than --time-budget is stopped with a 503 naming the limit', async () => {
  const server = await startStudio(['--threads', '1', '--time-budget', '1']);
  try {
    const t0 = Date.now();
    const res = await post(server, '/api/generate', { recipe: heavyRecipe() });
    const ms = Date.now() - t0;
    assert.equal(res.status, 503);
    assert.equal(res.headers.get('retry-after'), null);
    const body = await res.json();
    assert.equal(body.limit, 'time_budget', body.error);
    assert.match(body.error, /time budget of 1 s/);
    assert.ok(ms < 6000, `answered after ${ms} ms`);
    assert.equal((await stats(server)).cancelled.time_budget, 1);
    // The server keeps serving.
    assert.equal((await post(server, '/api/generate', { recipe: smallRecipe() })).status, 200);
  } finally {
    await stopClean(server);
  }
});

test('the time budget covers an export: its stages, writers and zip stop, answered 503', async () => {
  const server = await startStudio(['--threads', '1', '--time-budget', '1']);
  try {
    const doc = await (await fetch(server.url + '/api/presets/island')).json();
    doc.world.size = 2049;
    doc.seed = 3;
    const t0 = Date.now();
    const res = await post(server, '/api/export', { recipe: doc, format: 'obj' });
    const ms = Date.now() - t0;
    assert.equal(res.status, 503);
    assert.equal((await res.json()).limit, 'time_budget');
    assert.ok(ms < 6000, `answered after ${ms} ms`);
    const s = await stats(server);
    assert.equal(s.running, 0);
    assert.equal(s.admitted_bytes, 0);
  } finally {
    await stopClean(server);
  }
});

// A volume request (POST /api/volume) meshes the recipe's volume after running it: the time budget
// covers the meshing (checked between chunks), and admission counts its estimate (mesh bytes too).
test('the time budget and admission cover a volume request: 503 naming the limit; the server serves on', async () => {
  const server = await startStudio(['--threads', '1', '--time-budget', '1', '--work-mib', '1']);
  try {
    const doc = await (await fetch(server.url + '/api/presets/sea-cliff')).json();
    doc.world.size = 1025;  // about 5 s of stages and meshing on one thread
    doc.seed = 5;
    const t0 = Date.now();
    const ctl = new AbortController();
    const pending = post(server, '/api/volume', { recipe: doc }, { signal: ctl.signal });
    await waitStats(server, (s) => s.running === 1, 10000, 'the volume request to start');
    // While it runs, another volume request (another client: its own lane) is refused by admission.
    const busy = await post(server, '/api/volume', { recipe: { ...doc, world: { ...doc.world, size: 65 } } },
      { headers: { 'Content-Type': 'application/json', 'X-Relief-Client': 'other' } });
    assert.equal(busy.status, 503);
    assert.equal((await busy.json()).limit, 'memory');
    const res = await pending;
    const ms = Date.now() - t0;
    assert.equal(res.status, 503);
    const body = await res.json();
    assert.equal(body.limit, 'time_budget', body.error);
    assert.match(body.error, /time budget of 1 s/);
    assert.ok(ms < 6000, `answered after ${ms} ms`);
    const s = await waitStats(server, (x) => x.running === 0, 5000, 'the volume request to end');
    assert.equal(s.cancelled.time_budget, 1);
    assert.equal(s.refused.memory, 1);
    assert.equal(s.admitted_bytes, 0);
    // The server keeps serving volumes.
    const small = await post(server, '/api/volume', { recipe: { ...doc, world: { ...doc.world, size: 65 } } });
    assert.equal(small.status, 200, await small.clone().text());
    assert.equal(small.headers.get('content-type'), 'model/gltf-binary');
  } finally {
    await stopClean(server);
  }
});

test('a generation whose client disconnects is cancelled, and the next request is served', async () => {
  const server = await startStudio(['--threads', '1']);
  try {
    const ctl = new AbortController();
    const pending = post(server, '/api/generate', { recipe: heavyRecipe() }, { signal: ctl.signal }).catch((e) => e);
    await sleep(500);
    ctl.abort();
    assert.equal((await pending).name, 'AbortError');
    const t0 = Date.now();
    // Within about a second (one stage) the server stops computing: it then uses (almost) no CPU.
    await sleep(1500);
    const c0 = cpuSeconds(server.proc.pid);
    await sleep(1500);
    const busy = cpuSeconds(server.proc.pid) - c0;
    assert.ok(busy < 0.15, `the server still used ${busy} CPU seconds in the 1.5 s after its client left`);
    const s = await stats(server);
    assert.equal(s.running, 0);
    assert.equal(s.cancelled.disconnected, 1);
    assert.equal(s.admitted_bytes, 0);
    const res = await post(server, '/api/generate', { recipe: smallRecipe() });
    assert.equal(res.status, 200);
    assert.ok(Date.now() - t0 < 6000);
  } finally {
    await stopClean(server);
  }
});

test('admission: past the memory budget a request gets 503 with Retry-After; the server serves on', async () => {
  const server = await startStudio(['--threads', '1', '--work-mib', '1']);
  try {
    const s0 = await stats(server);
    assert.equal(s0.work_budget_bytes, 1 << 20);
    // The first request is admitted though its estimate exceeds the budget: nothing else runs.
    const ctl = new AbortController();
    const first = post(server, '/api/generate', { recipe: heavyRecipe() }, { signal: ctl.signal }).catch((e) => e);
    await waitStats(server, (s) => s.running === 1, 10000, 'the first generation to start');
    for (const [p, body] of [['/api/generate', { recipe: smallRecipe() }], ['/api/export', { recipe: smallRecipe(), format: 'heightmap' }]]) {
      const res = await post(server, p, body);
      assert.equal(res.status, 503, p);
      const retry = Number(res.headers.get('retry-after'));
      assert.ok(retry >= 1 && retry <= 60, `Retry-After: ${res.headers.get('retry-after')}`);
      const answer = await res.json();
      assert.equal(answer.limit, 'memory', answer.error);
      assert.match(answer.error, /busy.*--work-mib/);
    }
    assert.equal((await stats(server)).refused.memory, 2);
    ctl.abort();
    await first;
    await waitStats(server, (s) => s.running === 0, 5000, 'the first generation to stop');
    assert.equal((await post(server, '/api/generate', { recipe: smallRecipe() })).status, 200);
    const res = await post(server, '/api/export', { recipe: smallRecipe(), format: 'heightmap' });
    assert.equal(res.status, 200);
  } finally {
    await stopClean(server);
  }
});

test('SIGTERM with a long generation running stops the server within 2.5 s', async () => {
  const server = await startStudio(['--threads', '1']);
  const pending = post(server, '/api/generate', { recipe: heavyRecipe() }).then(
    async (r) => ({ status: r.status, body: await r.text() }),
    (e) => ({ error: e }),
  );
  await sleep(700);  // the generation runs (seconds of work left)
  const t0 = Date.now();
  const code = await server.stop();
  const ms = Date.now() - t0;
  assert.equal(code, 0, server.stderr());
  assert.ok(ms < 2500, `the server took ${ms} ms to stop`);
  const r = await pending;
  // The running request is answered 503 (shutting down), or its connection closes.
  if (r.status !== undefined) {
    assert.equal(r.status, 503, r.body);
    assert.match(r.body, /shutting down/);
  }
});

test('uploads: a file over the size or pixel limit, or past the session limit, is a 413 naming the limit; the server serves on', async () => {
  const server = await startStudio(['--threads', '1']);
  const upload = (name, bytes, client = 'up-1') =>
    fetch(`${server.url}/api/upload?name=${encodeURIComponent(name)}`, { method: 'POST', headers: { 'X-Relief-Client': client }, body: bytes });
  const expect413 = async (res, limit, match) => {
    const body = await res.json();
    assert.equal(res.status, 413, body.error);
    assert.equal(body.limit, limit, body.error);
    assert.equal(body.path, 'body', body.error);
    assert.match(body.error, match);
  };
  const served = async () => assert.equal((await post(server, '/api/generate', { recipe: smallRecipe() })).status, 200);
  try {
    // Bytes: at most 32 MiB per file (refused without decoding: these bytes are no image at all).
    await expect413(await upload('huge.png', Buffer.alloc((32 << 20) + 1)), 'upload_bytes', /33554433 bytes; the studio takes at most 32 MiB per file/);
    await served();
    // Pixels: at most 4097x4097, read from the header before anything is decoded (this 4098² PNG
    // is 17 KB and would decode to 64 MiB of floats).
    const wide = await greyPng(4098, 4098, 8);
    assert.ok(wide.length < 100000);
    await expect413(await upload('wide.png', wide), 'upload_pixels', /4098x4098 pixels; the studio takes at most 16785409 pixels per file/);
    await served();
    // A session holds at most 256 MiB (files plus 4 bytes per decoded pixel): three 4097² images
    // fit (64 MiB each), a fourth does not; the same name again replaces, and another session has
    // its own allowance.
    const big = await greyPng(4097, 4097, 8, (x, y) => (x === y ? 200 : 0));
    for (const n of ['a.png', 'b.png', 'c.png']) assert.equal((await upload(n, big)).status, 200, n);
    await expect413(await upload('d.png', big), 'session_uploads', /at most 256 MiB per session/);
    assert.equal((await upload('c.png', big)).status, 200, 'replacing c.png');
    assert.equal((await upload('d.png', big, 'up-2')).status, 200, 'another session');
    // What was refused is not there; what was kept is.
    const recipe = (p) => ({ name: 'u', seed: 1, world: { size: 33 }, stages: [{ stage: 'image', path: p }] });
    const refused = await post(server, '/api/generate', { recipe: recipe('upload:d.png') }, { headers: { 'Content-Type': 'application/json', 'X-Relief-Client': 'up-1' } });
    assert.equal(refused.status, 400);
    assert.equal((await refused.json()).path, 'stages[0].path');
    const kept = await post(server, '/api/generate', { recipe: recipe('upload:a.png') }, { headers: { 'Content-Type': 'application/json', 'X-Relief-Client': 'up-1' } });
    assert.equal(kept.status, 200);
    await served();
  } finally {
    await stopClean(server);
  }
});
