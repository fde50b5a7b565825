// test_hostile.js PAGE.html SHOT.png TEXT...: a page (made from a file whose
// names and labels may be hostile: markup, quotes, script) loads with no dialog,
// no console error (a script the page did not ship would be refused by its
// Content-Security-Policy, which logs one) and no failed request; no
// element other than the page's own appears (no <img>, no extra <script>),
// no injected code ran (window.dtxPwned stays unset), and every TEXT shows
// on the page exactly as written, as the text of one element.
'use strict';
const path = require('path');
const { launch, open } = require('./browser.js');

const [pageFile, shot, ...texts] = process.argv.slice(2);
let fails = 0;
function check(what, ok, detail) {
  console.log((ok ? 'ok: ' : 'FAILED: ') + what + (ok || !detail ? '' : ': ' + detail));
  if (!ok) fails++;
}

(async () => {
  const browser = await launch(path.dirname(path.resolve(shot)));
  try {
    const { page, problems, dialogs } = await open(browser, pageFile);
    await new Promise((r) => setTimeout(r, 300));
    for (const t of texts) {
      const n = await page.evaluate((s) => Array.from(document.querySelectorAll('#dtx-app *')).filter((e) => e.children.length === 0 && e.textContent.includes(s)).length, t);
      check('shows ' + JSON.stringify(t) + ' as text (' + n + ' elements)', n >= 1);
    }
    const st = await page.evaluate(() => ({
      pwned: window.dtxPwned,
      imgs: document.querySelectorAll('img, iframe, object, embed').length,
      scripts: Array.from(document.scripts).map((s) => s.type || 'classic'),
    }));
    check('no injected code ran', st.pwned === undefined);
    check('no injected elements', st.imgs === 0);
    check('only the page\'s own scripts (' + st.scripts.length + ')',
          st.scripts.filter((t) => t === 'module').length === 1 && st.scripts.every((t) => t === 'module' || t === 'application/json' || t === 'application/octet-stream'),
          st.scripts.join(','));
    check('no dialog', dialogs.length === 0, dialogs.join('; '));
    check('no console error or failed request', problems.length === 0, problems.join('; '));
    await page.screenshot({ path: shot });
  } finally {
    await browser.close();
  }
  console.log(fails ? fails + ' failed' : 'all passed');
  process.exit(fails ? 1 : 0);
})().catch((e) => { console.error('FAILED: ' + (e.stack || e)); process.exit(1); });
