// The colour scales of the page.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { inferno, linearToSrgb, toneMap, makeScale, ticks, valueRange, formatNumber } from '../src/colour.js';

const close = (a, b, tol = 1e-3) => assert.ok(Math.abs(a - b) <= tol, `${a} vs ${b}`);

test('inferno runs from near black through red to pale yellow, as matplotlib', () => {
    // matplotlib's inferno at 0, 0.5 and 1: #000004, #bc3754, #fcffa4 (the fit is within ~0.02).
    const at = (t, hex) => inferno(t).forEach((v, c) => close(v, parseInt(hex.slice(2 * c, 2 * c + 2), 16) / 255, 0.03));
    at(0, '000004');
    at(0.5, 'bc3754');
    at(1, 'fcffa4');
    assert.deepEqual(inferno(NaN), inferno(0));
    assert.deepEqual(inferno(2), inferno(1));
});

test('sRGB encoding matches IEC 61966-2-1 and the tone map applies the exposure first', () => {
    assert.equal(linearToSrgb(0), 0);
    assert.equal(linearToSrgb(1), 1);
    assert.equal(linearToSrgb(5), 1);
    close(linearToSrgb(0.0031308), 0.04045, 1e-5);
    close(linearToSrgb(0.5), 0.7354, 1e-4);
    assert.deepEqual(toneMap([0.25, 0.5, 0], 2), [linearToSrgb(0.5), 1, 0]);
});

test('a linear scale maps its ends to 0 and 1 and clamps outside', () => {
    const s = makeScale(2, 6);
    assert.equal(s.map(2), 0);
    assert.equal(s.map(4), 0.5);
    assert.equal(s.map(6), 1);
    assert.equal(s.map(10), 1);
    assert.ok(Number.isNaN(s.map(NaN)));
    assert.equal(s.value(0.25), 3);
    assert.equal(makeScale(3, 3).map(3), 0); // an empty range does not divide by zero
});

test('a log scale spans at most six decades and maps zero to its bottom', () => {
    const s = makeScale(1e-9, 0.1, true);
    close(s.min, 1e-7, 1e-20);
    assert.equal(s.map(0.1), 1);
    close(s.map(1e-4), 0.5, 1e-9);
    assert.equal(s.map(0), 0);
    assert.equal(s.map(1e-12), 0);
    const t = ticks(s);
    assert.equal(t.length, 7);
    t.forEach((v, k) => close(Math.log10(v), k - 7, 1e-12));
    close(makeScale(1e-3, 1e-2, true).map(10 ** -2.5), 0.5, 1e-9);
    // Less than a decade: the 2× and 5× steps too.
    assert.deepEqual(ticks(makeScale(6e-4, 5.3e-3, true)), [1e-3, 2e-3, 5e-3]);
});

test('linear ticks are round steps inside the range', () => {
    const t = ticks(makeScale(0, 1));
    assert.ok(t.length >= 3 && t.length <= 7);
    assert.equal(t[0], 0);
    for (let k = 1; k < t.length; ++k) close(t[k] - t[k - 1], t[1] - t[0], 1e-12);
    const u = ticks(makeScale(273.15, 351.7));
    assert.ok(u.every((v) => v >= 273.15 && v <= 351.7));
    assert.ok(u.every((v) => Math.abs(v / 10 - Math.round(v / 10)) < 1e-9 || Math.abs(v / 20 - Math.round(v / 20)) < 1e-9));
});

test('the value range skips NaN and, for log scales, values that are not positive', () => {
    assert.deepEqual(valueRange([3, NaN, -1, 7]), [-1, 7]);
    assert.deepEqual(valueRange([0, 0.5, -1, 2], true), [0.5, 2]);
    assert.deepEqual(valueRange([NaN]), [0, 0]);
});

test('numbers print with four significant digits, exponents outside [1e-3, 1e5)', () => {
    assert.equal(formatNumber(0.123456), '0.1235');
    assert.equal(formatNumber(12345.6), '12350');
    assert.equal(formatNumber(123456.7), '1.235e+5');
    assert.equal(formatNumber(1.5e-5), '1.500e-5');
    assert.equal(formatNumber(0), '0');
});
