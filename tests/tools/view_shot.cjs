// Opens a `cubeforge view` page in headless Chromium (WebGL2 on SwiftShader) once per query,
// waits for that query's frame (window.cubeforgeReady), and writes the canvas as a PNG:
//   node view_shot.cjs PAGE OUTDIR QUERY...      (OUTDIR/0.png, 1.png, ... in query order)
// Prints one JSON line per query: {"ready": true, "ms": ...} (ms from navigation to the
// frame) or {"error": "...", "shown": "..."} (the page's own message, for broken data). Needs
// puppeteer-core (target/tools) and chromium (CHROMIUM names another). SHOT_PAGE=1 takes the
// whole page (picture and panel) at 900 x 620 instead of the canvas.
'use strict';
const path = require('path');
const fs = require('fs');
// $CUBEFORGE_TOOLS, as the other readers, else target/tools.
const tools = path.join(process.env.CUBEFORGE_TOOLS || path.join(__dirname, '..', '..', 'target', 'tools'), 'node_modules');
const puppeteer = require(path.join(tools, 'puppeteer-core'));

(async () => {
  const [page, outdir, ...queries] = process.argv.slice(2);
  const exe = process.env.CHROMIUM || '/usr/bin/chromium';
  const browser = await puppeteer.launch({
    executablePath: exe,
    headless: true,
    args: ['--no-sandbox', '--use-angle=swiftshader', '--enable-unsafe-swiftshader',
           '--force-color-profile=srgb'],
  });
  try {
    const tab = await browser.newPage();
    await tab.setViewport({ width: 1400, height: 1200, deviceScaleFactor: 1 });
    for (const [i, query] of queries.entries()) {
      const start = Date.now();
      const url = 'file://' + path.resolve(page) + (query ? '?' + query : '');
      await tab.goto(url);
      await tab.waitForFunction('window.cubeforgeReady === true || window.cubeforgeError !== undefined',
                                { timeout: 120000 });
      const ms = Date.now() - start;
      const error = await tab.evaluate(() => window.cubeforgeError);
      if (error !== undefined) {
        const shown = await tab.evaluate(() => document.getElementById('status').textContent);
        console.log(JSON.stringify({ error, shown }));
        continue;
      }
      if (process.env.SHOT_PAGE) {
        // The whole page (picture and panel), for the documentation.
        await tab.setViewport({ width: 900, height: 620, deviceScaleFactor: 1 });
        await tab.waitForFunction('window.cubeforgeReady === true');
        await tab.screenshot({ path: path.join(outdir, i + '.png') });
      } else {
        const png = await tab.evaluate(() => document.getElementById('view').toDataURL('image/png'));
        fs.writeFileSync(path.join(outdir, i + '.png'), Buffer.from(png.split(',')[1], 'base64'));
      }
      console.log(JSON.stringify({ ready: true, ms, title: await tab.title() }));
    }
  } finally {
    await browser.close();
  }
})().catch((e) => { console.log(JSON.stringify({ error: String(e) })); process.exit(1); });
