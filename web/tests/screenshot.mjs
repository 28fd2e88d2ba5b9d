// Takes the README's screenshot (docs/studio.png): the island preset in the 3D view with the
// panel open. Usage: node web/tests/screenshot.mjs [OUT.png]   (RELIEF_BINARY names the binary)
import { startStudio, launchBrowser, waitIdle } from './harness.mjs';

const out = process.argv[2] || 'docs/studio.png';
const server = await startStudio();
const browser = await launchBrowser({ width: 1440, height: 900 });
try {
  const { page } = browser;
  page.on('console', (m) => m.type() === 'error' && console.error('console:', m.text()));
  await page.goto(server.url);
  await waitIdle(page);
  if (process.env.SHOT_VIEW) await page.click(`#views button[data-view="${process.env.SHOT_VIEW}"]`);
  await page.hover('[data-param="stages[0].octaves"] .lil-name');  // the help box explains it
  await page.mouse.move(500, 300);
  await page.hover('[data-param="stages[0].octaves"] .lil-name');
  await page.waitForTimeout(600);
  await page.screenshot({ path: out });
  console.log(`wrote ${out}`);
} finally {
  await browser.close();
  await server.stop();
}
