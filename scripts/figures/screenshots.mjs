// Takes the screenshots of scripts/render-figures: for each job of the JSON file given, opens a
// self-contained viewer page (gaussmesh view --html) with its query in headless Chromium and
// saves the canvas as a PNG.
//   node scripts/figures/screenshots.mjs JOBS.json --modules DIR [--chromium PATH]
// A job: { "page": "x.html", "query": "panel=0&view=30,20", "out": "docs/images/x.png",
//          "width": 480, "height": 360 }.
import fs from 'node:fs';
import { createRequire } from 'node:module';
import path from 'node:path';

const args = process.argv.slice(2);
const value = (name, fallback) => (args.includes(name) ? args[args.indexOf(name) + 1] : fallback);
const jobs = JSON.parse(fs.readFileSync(args[0], 'utf8'));
const require = createRequire(path.join(path.resolve(value('--modules', 'build/web/node_modules')), 'index.js'));
const { chromium } = require('playwright-core');

const browser = await chromium.launch({
  executablePath: value('--chromium', '/usr/bin/chromium'),
  args: ['--use-angle=swiftshader', '--enable-unsafe-swiftshader', '--ignore-gpu-blocklist'],
});
let failed = 0;
for (const job of jobs) {
  const page = await browser.newPage({ viewport: { width: job.width ?? 480, height: job.height ?? 360 } });
  await page.goto(`file://${path.resolve(job.page)}?${job.query ?? ''}`);
  await page.waitForFunction(() => ['ready', 'error'].includes(window.gaussmeshViewer?.status), null, { timeout: 60000 });
  const state = await page.evaluate(() => ({ ...window.gaussmeshViewer }));
  if (state.status !== 'ready') {
    console.error(`screenshots: ${job.page}: ${state.error}`);
    failed += 1;
  } else {
    await page.locator('#view').screenshot({ path: job.out });
    console.log(`${job.out}  ${state.faces} faces`);
  }
  await page.close();
}
await browser.close();
process.exit(failed > 0 ? 1 : 0);
