// Talking to `relief studio`: JSON endpoints and the binary "RLF1" frames (layout documented at
// the top of apps/relief/studio.cpp).

// One id per page load: the server lets each client have one generation in flight and cancels
// an older one when a newer one arrives.
export const clientId = 'page-' + Math.random().toString(36).slice(2, 12);

export class ApiError extends Error {
  constructor(status, message, path) {
    super(message);
    this.status = status;
    this.path = path || '';
  }
}

async function failure(res) {
  let message = `HTTP ${res.status}`;
  let path = '';
  try {
    const body = await res.json();
    if (body && body.error) message = body.error;
    if (body && body.path) path = body.path;
  } catch (_) {
    /* not JSON: keep the status line */
  }
  return new ApiError(res.status, message, path);
}

export async function getJson(url) {
  const res = await fetch(url);
  if (!res.ok) throw await failure(res);
  return res.json();
}

export async function postJson(url, body, { signal } = {}) {
  const res = await fetch(url, {
    method: 'POST',
    headers: { 'Content-Type': 'application/json', 'X-Relief-Client': clientId },
    body: JSON.stringify(body),
    signal,
  });
  if (!res.ok) throw await failure(res);
  return res;
}

// Decodes a frame: {header, layers: {name: {type, channels, data}}, points}.
export function decodeFrame(buffer) {
  const bytes = new Uint8Array(buffer);
  const magic = String.fromCharCode(bytes[0], bytes[1], bytes[2], bytes[3]);
  if (magic !== 'RLF1') throw new Error('unexpected response from the server (not an RLF1 frame)');
  const headerLength = new DataView(buffer).getUint32(4, true);
  const header = JSON.parse(new TextDecoder().decode(bytes.subarray(8, 8 + headerLength)));
  const view = (d) => {
    if (!d) return null;
    if (d.type === 'rgb8') return { ...d, data: new Uint8Array(buffer, d.offset, d.bytes) };
    return { ...d, data: new Float32Array(buffer, d.offset, d.bytes / 4) };
  };
  const layersOf = (obj) => Object.fromEntries(Object.entries(obj || {}).map(([k, d]) => [k, view(d)]));
  const out = { header, layers: layersOf(header.layers) };
  if (header.points) {
    out.points = { ...header.points, data: new Float32Array(buffer, header.points.offset, header.points.bytes / 4) };
  }
  if (header.steps) {
    out.steps = header.steps.map((s) => ({ ...s, layers: layersOf(s.layers) }));
  }
  return out;
}

export async function generate(recipe, { layers, signal } = {}) {
  const body = { recipe };
  if (layers) body.layers = layers;
  const res = await postJson('api/generate', body, { signal });
  return decodeFrame(await res.arrayBuffer());
}

// The recipe's volume (caves, overhangs, arches) as caves.glb bytes: {buffer, timings: {generate_ms,
// first_stage, mesh_ms, server_ms}}. Throws ApiError (400 naming "stages" when the recipe has no
// volume stage; 409 when a newer volume request of this page replaced it).
export async function volume(recipe, { signal } = {}) {
  const res = await postJson('api/volume', { recipe }, { signal });
  let timings = {};
  try {
    timings = JSON.parse(res.headers.get('X-Relief-Timings') || '{}');
  } catch (_) {
    timings = {};
  }
  return { buffer: await res.arrayBuffer(), timings };
}

export async function steps(recipe, { signal } = {}) {
  const res = await postJson('api/steps', { recipe }, { signal });
  return decodeFrame(await res.arrayBuffer());
}

export async function resolve(recipe) {
  const res = await postJson('api/resolve', { recipe });
  return (await res.json()).recipe;
}

// Returns {blob, filename, files}.
export async function exportFormat(recipe, format, file) {
  const body = { recipe, format };
  if (file) body.file = file;
  const res = await postJson('api/export', body);
  const disposition = res.headers.get('Content-Disposition') || '';
  const m = /filename="([^"]+)"/.exec(disposition);
  let files = [];
  try {
    files = JSON.parse(res.headers.get('X-Relief-Files') || '[]');
  } catch (_) {
    files = [];
  }
  return { blob: await res.blob(), filename: m ? m[1] : `${format}.bin`, files };
}

// Uploads a file for an image stage (kept in memory by the server for this page's session).
// Returns {name, path: "upload:NAME", width, height, format, bytes, session_bytes, limits}.
export async function upload(file, name = file.name) {
  const res = await fetch(`api/upload?name=${encodeURIComponent(name)}`, {
    method: 'POST',
    headers: { 'X-Relief-Client': clientId },
    body: file,
  });
  if (!res.ok) throw await failure(res);
  return res.json();
}

// A zip of recipe.json and the uploads it names (paths relative to recipe.json). Returns {blob, filename}.
export async function saveZip(recipe) {
  const res = await postJson('api/save', { recipe });
  const m = /filename="([^"]+)"/.exec(res.headers.get('Content-Disposition') || '');
  return { blob: await res.blob(), filename: m ? m[1] : 'recipe.zip' };
}

// Whether a recipe names an upload ("upload:NAME" in any image path).
export function namesUpload(recipe) {
  let found = false;
  const walk = (v) => {
    if (found || !v || typeof v !== 'object') return;
    if (Array.isArray(v)) return v.forEach(walk);
    for (const [k, x] of Object.entries(v)) {
      if (k === 'path' && typeof x === 'string' && x.startsWith('upload:')) found = true;
      else walk(x);
    }
  };
  walk(recipe && recipe.stages);
  return found;
}
