// Benchmark (not a test): how long a result page takes to open and to answer a click in
// headless Chromium.  node web/test/browser/bench.mjs PAGE.html [PAGE2.html ...]
// Prints the file size; the time from navigation to the first drawn frame (the page's own clock,
// performance.now() at that frame) and, from the outside, from asking for the page to that frame
// seen by the benchmark; and the time from a click on a patch to its row drawn and listed: the
// first click, made as soon as the first frame is seen (it waits for the rows of F it shows),
// and the median of 5 (clicks on other patches, each reading rows not read before).

import { statSync } from 'node:fs';
import path from 'node:path';
import { scratch, openPage } from './support.mjs';

for (const file of process.argv.slice(2)) {
    const tmp = scratch();
    try {
        const view = await openPage(path.resolve(file), path.join(tmp.dir, 'profile'), undefined, 'commit');
        const t0 = performance.now() - view.openMs;  // when the page was asked for
        const p = view.page;
        const firstFrame = await p.evaluate(() => new Promise((resolve) => {
            const check = () => (window.formfactorPage.timings.firstFrame !== null ? resolve(window.formfactorPage.timings.firstFrame) : setTimeout(check, 1));
            check();
        }));
        const seen = performance.now() - t0;
        const n = await p.evaluate(() => window.formfactorPage.patchCount);
        const clicks = [];
        for (let k = 0; k < 6; ++k) {
            // A visible patch near the middle of the view (a different one each time).
            const target = await p.evaluate((k) => {
                const r = document.querySelector('.ff-view canvas').getBoundingClientRect();
                return { x: r.left + r.width * (0.35 + 0.05 * k), y: r.top + r.height * (0.65 + 0.03 * k) };
            }, k);
            const before = await p.evaluate(() => window.formfactorPage.state().answered);
            const t1 = performance.now();
            await p.mouse.click(target.x, target.y);
            // One round trip: the answer (at once when the rows it shows are decoded), then a frame.
            await p.evaluate((a) => new Promise((resolve) => {
                const check = () => (window.formfactorPage.state().answered > a ? requestAnimationFrame(() => resolve()) : setTimeout(check, 1));
                check();
            }), before);
            clicks.push(performance.now() - t1);
        }
        const first = clicks.shift();
        clicks.sort((a, b) => a - b);
        const mb = statSync(file).size / 1e6;
        console.log(`${path.basename(file)}: ${n} patches, ${mb.toFixed(1)} MB, first frame at ${(firstFrame / 1000).toFixed(2)} s ` +
            `(seen after ${(seen / 1000).toFixed(2)} s), a click answers in ${(clicks[2] / 1000).toFixed(3)} s ` +
            `(median of 5; the first ${(first / 1000).toFixed(3)} s)`);
        console.log('  in the page (ms):', await p.evaluate(() => window.formfactorPage.timings));
        if (view.log.consoleErrors.length || view.log.pageErrors.length) console.log('errors:', view.log);
        await view.close();
    } finally {
        tmp.remove();
    }
}
