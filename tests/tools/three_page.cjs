// What the three.js page tools share (three_uhdr.cjs, three_background.cjs, three_sun.cjs):
// headless Chromium driven by puppeteer-core, a page served from memory (request interception,
// so ES modules load without a server), three.js's own files from npm `three` (target/tools or
// $CUBEFORGE_TOOLS) under an import map that names them as an application imports them.
'use strict';
const path = require('path');
const fs = require('fs');
const tools = path.join(process.env.CUBEFORGE_TOOLS || path.join(__dirname, '..', '..', 'target', 'tools'), 'node_modules');
const puppeteer = require(path.join(tools, 'puppeteer-core'));

const ORIGIN = 'http://cubeforge.test/';
// The import map a page puts before its module script.
const IMPORTS = `<script type="importmap">
{"imports": {"three": "${ORIGIN}three/build/three.module.js",
             "three/addons/": "${ORIGIN}three/examples/jsm/"}}</script>`;

// Opens `page` (HTML) at ORIGIN + 'index.html', answers any other request under ORIGIN but
// three's own files with `serve(rel)` (a file's path, or {contentType, body}; nothing: 404),
// waits for the page's `window.pageReady`, runs `work(tab)` and closes the browser.
async function withPage(page, serve, work) {
  const browser = await puppeteer.launch({
    executablePath: process.env.CHROMIUM || '/usr/bin/chromium',
    headless: true,
    args: ['--no-sandbox', '--force-color-profile=srgb'],
  });
  try {
    const tab = await browser.newPage();
    tab.on('pageerror', (e) => console.error('page:', e.message));
    await tab.setRequestInterception(true);
    tab.on('request', (req) => {
      const url = req.url();
      if (!url.startsWith(ORIGIN)) return req.abort();
      const rel = decodeURIComponent(url.slice(ORIGIN.length));
      if (rel === 'index.html') return req.respond({ contentType: 'text/html', body: page });
      const got = rel.startsWith('three/') ? path.join(tools, rel) : serve(rel);
      if (got && typeof got === 'object') return req.respond(got);
      if (!got || !fs.existsSync(got)) return req.respond({ status: 404, body: '' });
      const type = got.endsWith('.js') ? 'text/javascript' : 'application/octet-stream';
      req.respond({ contentType: type, body: fs.readFileSync(got) });
    });
    await tab.goto(ORIGIN + 'index.html');
    await tab.waitForFunction('window.pageReady === true', { timeout: 60000 });
    return await work(tab);
  } finally {
    await browser.close();
  }
}

module.exports = { ORIGIN, IMPORTS, withPage };
