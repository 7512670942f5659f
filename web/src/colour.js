// Colour scales of the page: the inferno colour map of the PNG renders (the same polynomial as
// colormap_inferno() in src/output/render.cpp), linear and logarithmic scales with their
// ticks, and the radiosity tone map (exposure, then sRGB, as render_radiosity()). Pure
// functions: node's test runner checks them (test/colour.test.js).

// Degree-6 fit of matplotlib's inferno (van der Walt & Smith) by Matt Zucker (CC0).
const kInferno = [
    [0.0002189403691192265, 0.001651004631001012, -0.01948089843709184],
    [0.1065134194856116, 0.5639564367884091, 3.932712388889277],
    [11.60249308247187, -3.972853965665698, -15.9423941062914],
    [-41.70399613139459, 17.43639888205313, 44.35414519872813],
    [77.162935699427, -33.40235894210092, -81.80730925738993],
    [-71.31942824499214, 32.62606426397723, 73.20951985803202],
    [25.13112622477341, -12.24266895238567, -23.07032500287172],
];

const clamp01 = (x) => (x > 1 ? 1 : x > 0 ? x : 0);

/// Inferno at t ∈ [0, 1] (clamped; NaN → 0) as display sRGB [r, g, b] in [0, 1].
export function inferno(t) {
    t = Number.isFinite(t) ? clamp01(t) : 0;
    const out = [0, 0, 0];
    for (let c = 0; c < 3; ++c) {
        let v = kInferno[6][c];
        for (let k = 5; k >= 0; --k) v = kInferno[k][c] + t * v;
        out[c] = clamp01(v);
    }
    return out;
}

/// Linear light → sRGB-encoded value in [0, 1] (IEC 61966-2-1), clamped.
export function linearToSrgb(v) {
    if (!(v > 0)) return 0;
    if (v >= 1) return 1;
    return v <= 0.0031308 ? 12.92 * v : 1.055 * Math.pow(v, 1 / 2.4) - 0.055;
}

/// Linear RGB radiosity times `exposure`, sRGB-encoded: the colour of the PNG renders.
export function toneMap(rgb, exposure) {
    return [linearToSrgb(rgb[0] * exposure), linearToSrgb(rgb[1] * exposure), linearToSrgb(rgb[2] * exposure)];
}

/// Range of the finite values: [min, max] ([0, 0] when none); with `positive`, of the values > 0.
export function valueRange(values, positive = false) {
    let lo = Infinity, hi = -Infinity;
    for (const v of values) {
        if (!Number.isFinite(v) || (positive && !(v > 0))) continue;
        if (v < lo) lo = v;
        if (v > hi) hi = v;
    }
    return lo <= hi ? [lo, hi] : [0, 0];
}

/// The smallest value a log scale shows below its maximum: 6 decades.
export const kLogDecades = 6;

/// A scale from values to t ∈ [0, 1]: linear on [min, max], or logarithmic on
/// [max(min, max·10⁻⁶), max] for positive values (0 and below map to t = 0, NaN to NaN).
export function makeScale(min, max, log = false) {
    if (log) {
        const hi = max > 0 ? max : 1;
        const lo = min > 0 && min < hi ? Math.max(min, hi * Math.pow(10, -kLogDecades)) : hi * Math.pow(10, -kLogDecades);
        const a = Math.log10(lo), b = Math.log10(hi);
        return {
            min: lo, max: hi, log: true,
            map: (v) => (Number.isNaN(v) ? NaN : v > 0 ? clamp01((Math.log10(v) - a) / (b - a)) : 0),
            value: (t) => Math.pow(10, a + t * (b - a)),
        };
    }
    const span = max > min ? max - min : 1;
    return {
        min, max, log: false,
        map: (v) => (Number.isNaN(v) ? NaN : clamp01((v - min) / span)),
        value: (t) => min + t * span,
    };
}

/// Tick values for a colour bar of `scale`: for a linear scale, "nice" steps (1, 2, 5 × 10^k)
/// giving about `count` ticks inside [min, max]; for a log scale, the powers of ten inside (and
/// their 2× and 5× when fewer than three powers are).
export function ticks(scale, count = 5) {
    const out = [];
    if (scale.log) {
        // Powers of ten; with fewer than three inside, their 2× and 5× too.
        const lo = Math.floor(Math.log10(scale.min)), hi = Math.ceil(Math.log10(scale.max));
        const inside = (v) => v >= scale.min * (1 - 1e-9) && v <= scale.max * (1 + 1e-9);
        for (let e = lo; e <= hi; ++e) if (inside(Math.pow(10, e))) out.push(Math.pow(10, e));
        if (out.length >= 3) return out;
        out.length = 0;
        for (let e = lo; e <= hi; ++e)
            for (const m of [1, 2, 5]) {
                const v = Number((m * Math.pow(10, e)).toPrecision(12));
                if (inside(v)) out.push(v);
            }
        return out;
    }
    const span = scale.max - scale.min;
    if (!(span > 0)) return [scale.min];
    const raw = span / Math.max(1, count - 1);
    const mag = Math.pow(10, Math.floor(Math.log10(raw)));
    const step = [1, 2, 5, 10].map((m) => m * mag).find((s) => s >= raw * 0.999);
    for (let v = Math.ceil(scale.min / step - 1e-9) * step; v <= scale.max + step * 1e-9; v += step)
        out.push(Math.abs(v) < step * 1e-9 ? 0 : v);
    return out;
}

/// A number for people: 4 significant digits, exponent form outside [1e-3, 1e5).
export function formatNumber(v, digits = 4) {
    if (!Number.isFinite(v)) return String(v);
    if (v === 0) return '0';
    const a = Math.abs(v);
    if (a >= 1e-3 && a < 1e5) return String(Number(v.toPrecision(digits)));
    return v.toExponential(digits - 1);
}

/// A categorical colour for index k (surfaces): golden-angle hues, display sRGB in [0, 1].
export function categorical(k) {
    const h = ((k * 137.508) % 360) / 60;
    const s = 0.55, l = 0.6;
    const c = (1 - Math.abs(2 * l - 1)) * s;
    const x = c * (1 - Math.abs((h % 2) - 1));
    const m = l - c / 2;
    const [r, g, b] = h < 1 ? [c, x, 0] : h < 2 ? [x, c, 0] : h < 3 ? [0, c, x] : h < 4 ? [0, x, c] : h < 5 ? [x, 0, c] : [c, 0, x];
    return [r + m, g + m, b + m];
}
