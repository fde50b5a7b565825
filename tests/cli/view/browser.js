// browser.js: starting Debian's chromium through puppeteer-core for the
// `dtx view` tests, and loading a page with every console error, page error,
// failed request and dialog recorded.
'use strict';
const fs = require('fs');
const path = require('path');
const os = require('os');

function requirePuppeteer() {
  const roots = [process.env.DTX_BUILD_TOOLS, path.join(process.env.DTX_SRC || '.', 'build-tools')];
  for (const r of roots) {
    if (!r) continue;
    try { return require(path.join(r, 'node_modules', 'puppeteer-core')); } catch (e) { /* next */ }
  }
  return require('puppeteer-core');
}

async function launch(scratch) {
  const puppeteer = requirePuppeteer();
  const profile = fs.mkdtempSync(path.join(scratch || os.tmpdir(), 'chromium-profile-'));
  return puppeteer.launch({
    executablePath: process.env.DTX_CHROMIUM || '/usr/bin/chromium',
    headless: 'new',
    args: ['--headless=new', '--no-sandbox', '--use-angle=swiftshader', '--enable-unsafe-swiftshader',
      '--disable-gpu-sandbox', '--no-first-run', '--disable-background-networking',
      '--disable-component-update', '--disable-sync', '--user-data-dir=' + profile],
    defaultViewport: { width: 1280, height: 720 },
  });
}

// Opens file (a path) in a new tab; returns { page, problems, dialogs, ms }
// where problems collects console errors, page errors and failed or
// non-file requests, and ms is the time from navigation to the first
// drawn frame.
async function open(browser, file) {
  const page = await browser.newPage();
  const problems = [], dialogs = [];
  page.on('console', (m) => { if (m.type() === 'error' || m.type() === 'warning') problems.push('console ' + m.type() + ': ' + m.text()); });
  page.on('pageerror', (e) => problems.push('page error: ' + e.message));
  page.on('requestfailed', (r) => problems.push('request failed: ' + r.url()));
  page.on('request', (r) => { if (!r.url().startsWith('file://')) problems.push('request: ' + r.url()); });
  page.on('dialog', async (d) => { dialogs.push(d.message()); await d.dismiss(); });
  const t0 = Date.now();
  await page.goto('file://' + path.resolve(file), { waitUntil: 'load' });
  await page.waitForFunction(() => window.dtxView && window.dtxView.firstFrameMs() !== null, { timeout: 30000 });
  const ms = await page.evaluate(() => window.dtxView.firstFrameMs());
  return { page, problems, dialogs, ms, wallMs: Date.now() - t0 };
}

module.exports = { launch, open };
