// window.js - the display window (black point, white point, gamma per
// channel): its text, its lookup tables and the histogram that sets it
// automatically.  The twin of lib/render/window.c: parseWindow accepts
// exactly what gv_window_parse accepts, formatWindow writes its canonical
// text, and buildTable gives the same bytes as gv_window_table (256 for
// 8-bit samples, 65536 for a sample store's codes), by the same double
// operations in the same order (tests/window.sh compares the two over many
// windows).  A sample store's colours resolve here as in
// lib/render/samples_region.c.  The text: "B,W[,G]" for every channel or
// one per channel joined by ';' (docs/API.md, `window`).

export const MAX_CHANNELS = 8;
export const MAX_TEXT = 512;
const GAMMA_MIN = 100, GAMMA_MAX = 10000;     // thousandths

/** Parse text s for samples 0 .. max into [{black, white, gammaMilli}],
 * or null when it is not a window. */
export function parseWindow(s, max = 255) {
    if (typeof s !== 'string' || s.length > MAX_TEXT)
        return null;
    const parts = s.split(';');
    if (parts.length > MAX_CHANNELS)
        return null;
    const out = [];
    for (const p of parts) {
        const m = /^([0-9]+),([0-9]+)(?:,([0-9]+)(?:\.([0-9]{1,3}))?)?$/.exec(p);
        if (!m)
            return null;
        const black = Number(m[1]), white = Number(m[2]);
        let gammaMilli = 1000;
        if (m[3] !== undefined) {
            if (Number(m[3]) > GAMMA_MAX / 1000)
                return null;
            gammaMilli = Number(m[3]) * 1000 + Number((m[4] || '').padEnd(3, '0'));
        }
        if (black > max || white > max || black >= white || gammaMilli < GAMMA_MIN || gammaMilli > GAMMA_MAX)
            return null;
        out.push({ black, white, gammaMilli });
    }
    return out;
}

/** The canonical text of window w (gv_window_format). */
export function formatWindow(w) {
    return w.map((c) => `${c.black},${c.white},${Math.floor(c.gammaMilli / 1000)}.` +
        String(c.gammaMilli % 1000).padStart(3, '0')).join(';');
}

/** The table of channel window c for samples 0 .. max (gv_window_table):
 * max + 1 bytes, 256 by default (gv_window_table8). */
export function buildTable(c, max = 255) {
    const t = new Uint8Array(max + 1);
    const range = c.white - c.black, e = 1000 / c.gammaMilli;
    for (let v = 0; v <= max; v++) {
        if (v <= c.black) {
            t[v] = 0;
            continue;
        }
        if (v >= c.white) {
            t[v] = 255;
            continue;
        }
        const tt = (v - c.black) / range;
        const p = c.gammaMilli === 1000 ? tt : Math.pow(tt, e);
        const y = Math.floor(255 * p + 0.500000001);
        t[v] = y >= 255 ? 255 : y <= 0 ? 0 : y;
    }
    return t;
}

/** The default colours of a sample store's channels, in order
 * (lib/render/samples_region.c). */
export const PALETTE = ['ff0000', '00ff00', '0000ff', 'ff00ff', '00ffff', 'ffff00', 'ff8000', 'ffffff'];

/** The colours a sample store of `channels` channels is drawn in:
 * ["rrggbb", ...] one per channel: text (a `colours` value) when it gives
 * one per channel, else the store's (metadata display.colours, `meta`
 * the image document's metadata), else the palette.  One channel is gray
 * and takes none (gv_colours_check). */
export function sampleColours(text, meta, channels) {
    const ok = (t) => typeof t === 'string' && channels > 1 &&
        /^[0-9a-fA-F]{6}(;[0-9a-fA-F]{6}){0,7}$/.test(t) && t.split(';').length === channels;
    const store = meta && meta['display.colours'];
    const t = ok(text) ? text : ok(store) ? store : null;
    return t ? t.toLowerCase().split(';') : PALETTE.slice(0, channels);
}

/** A sample store's window when it keeps none (gv_samples_default_window):
 * black and white at the smallest and largest code, gamma 1.  s: the image
 * document's `samples`. */
export function defaultSampleWindow(s) {
    let lo = s.code_min, hi = s.code_max;
    if (hi <= lo) {
        if (lo === 65535) lo--;
        hi = lo + 1;
    }
    return [{ black: lo, white: hi, gammaMilli: 1000 }];
}

/** The window of channel k of w: its own, or the one for all. */
export function channelWindow(w, k) {
    return w[w.length === 1 ? 0 : k];
}

/** The display texture's bytes: 256 RGBA texels, texel v holding the
 * tables of channels 0, 1, 2 at v (a gray store's one table in all three),
 * alpha 255.  w null: the identity. */
export function lutBytes(w, channels) {
    const px = new Uint8Array(256 * 4);
    const tabs = [0, 1, 2].map((k) => (w ? buildTable(channelWindow(w, channels === 1 ? 0 : k)) : null));
    for (let v = 0; v < 256; v++)
        for (let k = 0; k < 4; k++)
            px[v * 4 + k] = k === 3 ? 255 : tabs[k] ? tabs[k][v] : v;
    return px;
}

/** Per channel, the 0.5 % and 99.5 % points of the samples px (interleaved,
 * `channels` a pixel; a store's gray root may come as three equal
 * channels, then give channels 1 and stride 3): [[lo, hi], ...], hi > lo. */
export function autoPoints(px, channels, stride = channels, lowFrac = 0.005, highFrac = 0.995, max = 255) {
    const out = [];
    for (let k = 0; k < channels; k++) {
        const h = new Uint32Array(max + 1);
        let n = 0;
        for (let i = k; i < px.length; i += stride, n++)
            h[px[i]]++;
        const lowN = n * lowFrac, highN = n * highFrac;
        let lo = 0, hi = max, acc = 0;
        for (let v = 0; v <= max; v++) {
            acc += h[v];
            if (acc > lowN) { lo = v; break; }
        }
        acc = 0;
        for (let v = 0; v <= max; v++) {
            acc += h[v];
            if (acc >= highN) { hi = v; break; }
        }
        if (hi <= lo) {
            if (lo >= max) lo = max - 1;
            hi = lo + 1;
        }
        out.push([lo, hi]);
    }
    return out;
}
