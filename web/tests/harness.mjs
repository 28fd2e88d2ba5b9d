// Shared by the studio's node tests: start `relief studio --port 0` and a headless Debian
// Chromium through playwright-core (never a downloaded browser).
import { spawn } from 'node:child_process';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';

export const RELIEF = process.env.RELIEF_BINARY || path.resolve('build/relief');
export const CHROMIUM = process.env.RELIEF_CHROMIUM || '/usr/bin/chromium';

// Starts the server; resolves to {url, proc, stop(): Promise<exit code>, stderr()}.
export function startStudio(extraArgs = []) {
  return new Promise((resolve, reject) => {
    const proc = spawn(RELIEF, ['studio', '--port', '0', ...extraArgs], { stdio: ['ignore', 'pipe', 'pipe'] });
    let out = '', err = '';
    const timer = setTimeout(() => reject(new Error(`relief studio did not start in 20 s: ${out}${err}`)), 20000);
    proc.stderr.on('data', (d) => (err += d));
    proc.stdout.on('data', (d) => {
      out += d;
      const m = /(http:\/\/[^\s]+)/.exec(out);
      if (m) {
        clearTimeout(timer);
        resolve({
          url: m[1].replace(/\/$/, ''),
          proc,
          stderr: () => err,
          stop: () =>
            new Promise((done) => {
              if (proc.exitCode !== null) return done(proc.exitCode);
              proc.once('exit', (code, signal) => done(code ?? signal));
              proc.kill('SIGTERM');
            }),
        });
      }
    });
    proc.once('exit', (code) => {
      clearTimeout(timer);
      reject(new Error(`relief studio exited with ${code}: ${out}${err}`));
    });
  });
}

export const CHROMIUM_ARGS = [
  '--headless', '--no-sandbox', '--use-angle=swiftshader', '--enable-unsafe-swiftshader',
  '--disable-background-networking', '--disable-component-update', '--disable-sync', '--no-first-run',
];

// A persistent context on a fresh, empty user data dir; returns {context, page, close()}.
export async function launchBrowser({ width = 1400, height = 860 } = {}) {
  const { chromium } = await import('playwright-core');
  const userDir = fs.mkdtempSync(path.join(os.tmpdir(), 'relief-chromium-'));
  const context = await chromium.launchPersistentContext(userDir, {
    executablePath: CHROMIUM,
    headless: true,
    args: CHROMIUM_ARGS,
    viewport: { width, height },
    acceptDownloads: true,
  });
  const page = context.pages()[0] || (await context.newPage());
  return {
    context,
    page,
    close: async () => {
      await context.close();
      fs.rmSync(userDir, { recursive: true, force: true });
    },
  };
}

// Waits until the page has applied at least `count` results and has nothing in flight.
export async function waitIdle(page, count = 1, timeout = 60000) {
  await page.waitForFunction(
    (n) => window.studio && window.studio.state.ready && window.studio.state.generations >= n && window.studio.idle,
    count,
    { timeout, polling: 50 },
  );
}

// A greyscale PNG (8- or 16-bit) of `value(x, y)` (codes), for upload tests; deflate from node's zlib.
export async function greyPng(width, height, bits, value = () => 0) {
  const zlib = await import('node:zlib');
  const crcTable = Array.from({ length: 256 }, (_, n) => {
    let c = n;
    for (let k = 0; k < 8; k++) c = c & 1 ? 0xedb88320 ^ (c >>> 1) : c >>> 1;
    return c >>> 0;
  });
  const crc32 = (buf) => {
    let c = 0xffffffff;
    for (const b of buf) c = crcTable[(c ^ b) & 0xff] ^ (c >>> 8);
    return (c ^ 0xffffffff) >>> 0;
  };
  const chunk = (type, data) => {
    const len = Buffer.alloc(4);
    len.writeUInt32BE(data.length);
    const td = Buffer.concat([Buffer.from(type, 'latin1'), data]);
    const crc = Buffer.alloc(4);
    crc.writeUInt32BE(crc32(td));
    return Buffer.concat([len, td, crc]);
  };
  const ihdr = Buffer.alloc(13);
  ihdr.writeUInt32BE(width, 0);
  ihdr.writeUInt32BE(height, 4);
  ihdr[8] = bits;  // colour type 0 (grey), deflate, filter 0, no interlace
  const bpp = bits / 8, stride = 1 + width * bpp;
  const raw = Buffer.alloc(stride * height);
  for (let y = 0; y < height; y++)
    for (let x = 0; x < width; x++) {
      const v = value(x, y);
      if (!v) continue;
      if (bits === 16) raw.writeUInt16BE(v, y * stride + 1 + 2 * x);
      else raw[y * stride + 1 + x] = v;
    }
  const sig = Buffer.from([0x89, 0x50, 0x4e, 0x47, 0x0d, 0x0a, 0x1a, 0x0a]);
  return Buffer.concat([sig, chunk('IHDR', ihdr), chunk('IDAT', zlib.deflateSync(raw)), chunk('IEND', Buffer.alloc(0))]);
}
