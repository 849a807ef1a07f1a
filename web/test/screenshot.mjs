// A screenshot of a `spacearm view` page at time t (the README's figures), in Debian's Chromium
// driven by playwright-core, offline:
//   node screenshot.mjs NODE_MODULES PAGE.html OUT.png [t]
import { createRequire } from 'node:module';
import path from 'node:path';

const [modules, page, out, t] = process.argv.slice(2);
const { chromium } = createRequire(path.join(path.resolve(modules), 'x.js'))('playwright-core');
const browser = await chromium.launch({
  executablePath: process.env.SPACEARM_CHROMIUM || '/usr/bin/chromium',
  args: ['--no-sandbox', '--use-angle=swiftshader', '--enable-unsafe-swiftshader',
         '--disable-background-networking', '--disable-component-update', '--no-first-run'],
});
try {
  const tab = await browser.newPage({ viewport: { width: 1280, height: 800 } });
  await tab.route('**/*', (r) => (r.request().url().startsWith('file:') ? r.continue() : r.abort()));
  await tab.goto('file://' + path.resolve(page));
  await tab.waitForFunction(() => window.spacearmView && window.spacearmView.ready, null, { timeout: 20000 });
  if (t !== undefined) await tab.evaluate((time) => window.spacearmView.setTime(time), +t);
  await tab.screenshot({ path: out });
} finally {
  await browser.close();
}
