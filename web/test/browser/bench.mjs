// Benchmark (not a test): how long a result page takes to open and to answer a click in
// headless Chromium.  node web/test/browser/bench.mjs PAGE.html [PAGE2.html ...]
// Prints the file size, the time from navigation to the first drawn frame, and the time from a
// click on a patch to its row drawn and listed: the first click, made as soon as the page is
// drawn (it may wait for F's rows to be decoded), and the median of 5.

import { statSync } from 'node:fs';
import path from 'node:path';
import { scratch, openPage } from './support.mjs';

for (const file of process.argv.slice(2)) {
    const tmp = scratch();
    try {
        const view = await openPage(path.resolve(file), path.join(tmp.dir, 'profile'));
        const p = view.page;
        const n = await p.evaluate(() => window.formfactorPage.patchCount);
        const clicks = [];
        for (let k = 0; k < 5; ++k) {
            // A visible patch near the middle of the view.
            const target = await p.evaluate(() => {
                const r = document.querySelector('.ff-view canvas').getBoundingClientRect();
                return { x: r.left + r.width * (0.4 + 0.05 * Math.random()), y: r.top + r.height * (0.7 + 0.05 * Math.random()) };
            });
            const before = await p.evaluate(() => window.formfactorPage.state().answered);
            const t0 = performance.now();
            await p.mouse.click(target.x, target.y);
            // One round trip: the answer (at once when F's rows are decoded), then a frame.
            await p.evaluate((a) => new Promise((resolve) => {
                const check = () => (window.formfactorPage.state().answered > a ? requestAnimationFrame(() => resolve()) : setTimeout(check, 1));
                check();
            }), before);
            clicks.push(performance.now() - t0);
        }
        const first = clicks[0];
        clicks.sort((a, b) => a - b);
        const mb = statSync(file).size / 1e6;
        console.log(`${path.basename(file)}: ${n} patches, ${mb.toFixed(1)} MB, opens in ${(view.openMs / 1000).toFixed(2)} s, ` +
            `a click answers in ${(clicks[2] / 1000).toFixed(3)} s (median of 5; the first ${(first / 1000).toFixed(3)} s)`);
        console.log('  in the page (ms):', await p.evaluate(() => window.formfactorPage.timings));
        if (view.log.consoleErrors.length || view.log.pageErrors.length) console.log('errors:', view.log);
        await view.close();
    } finally {
        tmp.remove();
    }
}
