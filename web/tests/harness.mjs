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
