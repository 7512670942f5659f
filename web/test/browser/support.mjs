// What the headless-Chromium checks of the result page share: the CLI, a scratch folder, a
// browser that records every request, console error and page error, a PNG decoder for the
// screenshots and an NPY reader for the matrix.

import { execFileSync } from 'node:child_process';
import { existsSync, mkdtempSync, rmSync, readFileSync } from 'node:fs';
import { createRequire } from 'node:module';
import os from 'node:os';
import path from 'node:path';
import { pathToFileURL } from 'node:url';
import zlib from 'node:zlib';

export const cli = process.env.FF_CLI ?? 'build/bin/formfactor';
export const chromiumPath = process.env.FF_CHROMIUM ?? '/usr/bin/chromium';
if (!existsSync(chromiumPath)) {
    console.log(`skipped: no Chromium at ${chromiumPath} (apt-get install chromium, or set FF_CHROMIUM)`);
    process.exit(77);
}
const nodeModules = process.env.FF_WEB_NODE_MODULES ?? path.resolve('build/web/node_modules');
const require = createRequire(path.join(nodeModules, 'noop.js'));
const { chromium } = require('playwright-core');

/// A scratch folder removed by the returned function.
export function scratch() {
    const dir = mkdtempSync(path.join(os.tmpdir(), 'ff-page-'));
    return { dir, remove: () => rmSync(dir, { recursive: true, force: true }) };
}

/// Runs the CLI with `args` in `cwd`; throws with its output when it fails.
export function runCli(args, cwd) {
    return execFileSync(cli, args, { cwd, encoding: 'utf8', stdio: ['ignore', 'pipe', 'pipe'] });
}

/// Headless Chromium (Debian's) with the throw-away profile `profileDir`, and a page on `file` whose requests,
/// console errors and page errors are recorded. Returns {browser, page, log, close}.
/// waitUntil: when navigation counts as done before waiting for the page's ready flag ('load':
/// the whole file read; 'commit': as soon as the browser starts reading it).
export async function openPage(file, profileDir, viewport = { width: 1100, height: 700 }, waitUntil = 'load') {
    // A persistent context: Chromium's --user-data-dir is the throw-away profile.
    const browser = await chromium.launchPersistentContext(profileDir, {
        executablePath: chromiumPath,
        headless: true,
        viewport,
        args: ['--no-sandbox', '--disable-gpu', '--disable-background-networking',
            '--disable-component-update', '--disable-sync', '--no-first-run',
            '--use-angle=swiftshader', '--enable-unsafe-swiftshader'],
    });
    const page = browser.pages()[0] ?? (await browser.newPage());
    const log = { requests: [], consoleErrors: [], pageErrors: [] };
    const url = pathToFileURL(file).href;
    page.on('request', (r) => {
        if (r.url() !== url) log.requests.push(r.url());
    });
    page.on('console', (m) => {
        if (m.type() === 'error') log.consoleErrors.push(m.text());
    });
    page.on('pageerror', (e) => log.pageErrors.push(String(e)));
    const t0 = performance.now();
    await page.goto(url, { waitUntil });
    await waitReady(page);
    const openMs = performance.now() - t0;
    return { browser, page, log, openMs, close: () => browser.close() };
}

/// The data block of a page file, parsed (the \u003c escapes are JSON), with F's entries (the
/// block after the script) in its matrix.
export function pageData(file) {
    const html = readFileSync(file, 'utf8');
    const block = (id) => html.match(new RegExp(`<script type="application/json" id="${id}">([^]*?)</script>`));
    const m = block('ff-data');
    if (!m) throw new Error('no data block');
    const data = JSON.parse(m[1]);
    if (data.matrix?.entries_block) {
        const e = block(data.matrix.entries_block);
        if (!e) throw new Error('no block of the entries of F');
        Object.assign(data.matrix, JSON.parse(e[1]));
    }
    return data;
}

/// A little-endian float64 NPY file (C order, 2-D) as {rows, cols, data: Float64Array}.
export function readNpy(file) {
    const buf = readFileSync(file);
    const headerLen = buf.readUInt16LE(8);
    const header = buf.toString('latin1', 10, 10 + headerLen);
    if (!header.includes("'<f8'") || header.includes("'fortran_order': True")) throw new Error('not a C-order <f8 array');
    const [rows, cols] = header.match(/\((\d+), (\d+)\)/).slice(1).map(Number);
    const body = buf.subarray(10 + headerLen);
    const data = new Float64Array(body.buffer.slice(body.byteOffset, body.byteOffset + rows * cols * 8));
    return { rows, cols, data };
}

/// A PNG (8-bit RGB or RGBA, not interlaced: what Chromium's screenshots are) as
/// {width, height, rgb(x, y) → [r, g, b]}.
export function decodePng(buf) {
    if (buf.readUInt32BE(0) !== 0x89504e47) throw new Error('not a PNG');
    let at = 8, width = 0, height = 0, channels = 0;
    const idat = [];
    while (at < buf.length) {
        const len = buf.readUInt32BE(at), type = buf.toString('latin1', at + 4, at + 8);
        const body = buf.subarray(at + 8, at + 8 + len);
        if (type === 'IHDR') {
            width = body.readUInt32BE(0);
            height = body.readUInt32BE(4);
            if (body[8] !== 8 || body[12] !== 0) throw new Error('only 8-bit, non-interlaced PNGs');
            channels = { 2: 3, 6: 4 }[body[9]];
            if (!channels) throw new Error('only RGB and RGBA PNGs');
        } else if (type === 'IDAT') idat.push(body);
        at += 12 + len;
    }
    const raw = zlib.inflateSync(Buffer.concat(idat));
    const stride = width * channels;
    const px = new Uint8Array(height * stride);
    for (let y = 0; y < height; ++y) {
        const filter = raw[y * (stride + 1)];
        const line = raw.subarray(y * (stride + 1) + 1, (y + 1) * (stride + 1));
        for (let x = 0; x < stride; ++x) {
            const a = x >= channels ? px[y * stride + x - channels] : 0;
            const b = y > 0 ? px[(y - 1) * stride + x] : 0;
            const c = x >= channels && y > 0 ? px[(y - 1) * stride + x - channels] : 0;
            let v = line[x];
            if (filter === 1) v += a;
            else if (filter === 2) v += b;
            else if (filter === 3) v += (a + b) >> 1;
            else if (filter === 4) {
                const p = a + b - c, pa = Math.abs(p - a), pb = Math.abs(p - b), pc = Math.abs(p - c);
                v += pa <= pb && pa <= pc ? a : pb <= pc ? b : c;
            }
            px[y * stride + x] = v & 255;
        }
    }
    return {
        width, height,
        rgb: (x, y) => Array.from(px.subarray(y * stride + x * channels, y * stride + x * channels + 3)),
    };
}

/// Mean colour of the screenshot over the box [x0, x1) × [y0, y1).
export function meanColour(png, x0, y0, x1, y1) {
    const sum = [0, 0, 0];
    let n = 0;
    for (let y = Math.round(y0); y < Math.round(y1); ++y)
        for (let x = Math.round(x0); x < Math.round(x1); ++x) {
            const c = png.rgb(x, y);
            for (let k = 0; k < 3; ++k) sum[k] += c[k];
            ++n;
        }
    return sum.map((s) => s / n);
}

/// A typed array of the page's data ({dtype, count, compression, base64}; deflated when
/// compression is 'deflate', by byte planes when byte_planes), copied out of Node's buffer pool.
export function dataArray(entry) {
    const Type = { f32: Float32Array, f64: Float64Array, u16: Uint16Array, u32: Uint32Array }[entry.dtype];
    let bytes = Buffer.from(entry.base64, 'base64');
    if (entry.compression === 'deflate') bytes = zlib.inflateSync(bytes);
    if (entry.byte_planes) {
        // Byte planes within each segment (the whole array: one segment).
        const w = Type.BYTES_PER_ELEMENT, bounds = entry.segments ?? [0, entry.count], planes = bytes;
        bytes = Buffer.alloc(planes.length);
        for (let s = 0; s + 1 < bounds.length; ++s) {
            const a = bounds[s], n = bounds[s + 1] - a;
            for (let k = 0; k < n; ++k) for (let b = 0; b < w; ++b) bytes[(a + k) * w + b] = planes[a * w + b * n + k];
        }
    }
    const a = new Type(new Uint8Array(bytes).buffer);
    if (a.length !== entry.count) throw new Error('array length');
    return a;
}

/// Clicks at (x, y) and waits until the page has answered one more selection (its row drawn
/// and listed).
export async function clickAndWait(page, x, y) {
    const before = await page.evaluate(() => window.formfactorPage.state().answered);
    await page.mouse.click(x, y);
    await waitAnswered(page, before);
}

// Polled in the page itself, by a function given whole to evaluate: playwright's
// waitForFunction evaluates a string when it polls, which the page's Content-Security-Policy
// refuses. Each resolves false after a minute.
async function waitReady(page) {
    const ok = await page.evaluate(() => new Promise((resolve) => {
        const until = performance.now() + 60000;
        const check = () => (document.body?.dataset.ready ? resolve(true) : performance.now() > until ? resolve(false) : setTimeout(check, 1));
        check();
    }));
    if (!ok) throw new Error('the page did not get ready in a minute');
}

async function waitAnswered(page, before) {
    const ok = await page.evaluate((k) => new Promise((resolve) => {
        const until = performance.now() + 60000;
        const check = () => (window.formfactorPage.state().answered > k ? resolve(true) : performance.now() > until ? resolve(false) : setTimeout(check, 1));
        check();
    }), before);
    if (!ok) throw new Error('the page did not answer the click in a minute');
}
