// view.js - the view state and its geometry, and the URL hash that holds
// it, so that a copied link reopens the same view.
//
// A view is {cx, cy, zoom, rot}: the centre in level-0 pixels, the zoom
// as a level of detail (one CSS pixel is 2^zoom level-0 pixels, so 0 is
// 1:1 on a standard-density screen and negative magnifies), and the
// rotation in degrees, the image turned clockwise about the centre.  This
// is `gigaview render --center --zoom --rotate` (docs/API.md), so the
// native client renders any view of the viewer for comparison.  Screen
// coordinates have their origin at the top left, y down; a screen point s
// of a W x H viewport shows the image point
//
//     p = c + 2^zoom * R(-rot) * (s - (W/2, H/2))
//
// and a pixel's sample is taken at its centre (i + 0.5, j + 0.5).
//
// The hash: #image=ID&x=CX&y=CY&z=ZOOM&r=DEG[&roi=X,Y,W,H][&filter=FID][&terrain=hillshade|ID]
// [&p=MODULE.PARAM:VALUE,...][&window=B,W,G[;B,W,G...]] (the display
// window, window.js; docs/API.md `window`)[&colours=RRGGBB;...] (a sample
// store's channel colours, docs/API.md).  The ROI is in CSS pixels relative to the
// viewport centre (so it stays put when the window is resized).

export const deg = Math.PI / 180;

/** Image point (level 0) under screen point (sx, sy) of a w x h viewport. */
export function screenToImage(v, w, h, sx, sy) {
    const s = 2 ** v.zoom, th = v.rot * deg;
    const cs = Math.cos(th), sn = -Math.sin(th);
    const dx = (sx - w / 2) * s, dy = (sy - h / 2) * s;
    return [v.cx + dx * cs - dy * sn, v.cy + dx * sn + dy * cs];
}

/** Screen point of image point (px, py): the inverse of screenToImage. */
export function imageToScreen(v, w, h, px, py) {
    const s = 2 ** -v.zoom, th = v.rot * deg;
    const cs = Math.cos(th), sn = Math.sin(th);
    const dx = px - v.cx, dy = py - v.cy;
    return [w / 2 + (dx * cs - dy * sn) * s, h / 2 + (dx * sn + dy * cs) * s];
}

/** The view whose centre keeps image point p under screen point s. */
export function anchored(v, w, h, p, s) {
    const q = screenToImage({ ...v, cx: 0, cy: 0 }, w, h, s[0], s[1]);
    return { ...v, cx: p[0] - q[0], cy: p[1] - q[1] };
}

/** The whole image, unrotated, centred in a w x h viewport. */
export function homeView(imgW, imgH, w, h) {
    const z = Math.log2(Math.max(imgW / Math.max(1, w), imgH / Math.max(1, h)));
    return { cx: imgW / 2, cy: imgH / 2, zoom: z, rot: 0 };
}

/** Rotation in (-180, 180]. */
export function normRot(r) {
    r = ((r % 360) + 360) % 360;
    return r > 180 ? r - 360 : r;
}

/** Keep the view sensible: zoom between 1/64 (6 levels past 1:1) and four
 * times the whole image, the centre inside the image. */
export function clampView(v, imgW, imgH, w, h) {
    const home = homeView(imgW, imgH, w, h).zoom;
    return {
        cx: Math.min(Math.max(v.cx, 0), imgW), cy: Math.min(Math.max(v.cy, 0), imgH),
        zoom: Math.min(Math.max(v.zoom, -6), Math.max(home + 2, 0)),
        rot: normRot(v.rot),
    };
}

const fmt = (v, d) => String(+(+v).toFixed(d));

/** The hash for a state {image, view, roi, filter, params}. */
export function formatHash(st) {
    const q = new URLSearchParams();
    q.set('image', st.image);
    if (st.view) {
        q.set('x', fmt(st.view.cx, 2));
        q.set('y', fmt(st.view.cy, 2));
        q.set('z', fmt(st.view.zoom, 4));
        q.set('r', fmt(st.view.rot, 2));
    }
    if (st.roi)
        q.set('roi', st.roi.map((x) => fmt(x, 1)).join(','));
    if (st.filter)
        q.set('filter', st.filter);
    if (st.terrain)
        q.set('terrain', st.terrain);
    if (st.window)
        q.set('window', st.window);
    if (st.colours)
        q.set('colours', st.colours);
    if (st.params && Object.keys(st.params).length)
        q.set('p', Object.entries(st.params).map(([k, v]) => `${k}:${fmt(v, 6)}`).join(','));
    return '#' + q.toString();
}

/** Parse a hash into {image, view (or null), roi, filter, params}; fields
 * that are missing or malformed are null (params {}). */
export function parseHash(hash) {
    const q = new URLSearchParams(hash.replace(/^#/, ''));
    const num = (k) => {
        const s = q.get(k);
        if (s === null || s.trim() === '')
            return null;
        const v = Number(s);
        return Number.isFinite(v) ? v : null;
    };
    const st = { image: q.get('image') || null, view: null, roi: null, filter: q.get('filter') || null, params: {},
        terrain: q.get('terrain') || null, window: q.get('window') || null,
        colours: q.get('colours') || null };
    const x = num('x'), y = num('y'), z = num('z'), r = num('r');
    if (x !== null && y !== null && z !== null)
        st.view = { cx: x, cy: y, zoom: z, rot: r === null ? 0 : r };
    const roi = (q.get('roi') || '').split(',').map(Number);
    if (roi.length === 4 && roi.every(Number.isFinite) && roi[2] > 0 && roi[3] > 0)
        st.roi = roi;
    for (const kv of (q.get('p') || '').split(',')) {
        const i = kv.lastIndexOf(':');
        if (i > 0 && Number.isFinite(Number(kv.slice(i + 1))) && kv.slice(i + 1) !== '')
            st.params[kv.slice(0, i)] = Number(kv.slice(i + 1));
    }
    return st;
}
