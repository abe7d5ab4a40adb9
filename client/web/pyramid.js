// pyramid.js - the image's levels (docs/FORMAT.md sections 1 and 2) and
// which tiles a view needs.
//
// Levels 0 .. R-1 are tiled (513-pixel tiles every 512 pixels); level R is
// the root and levels R+1 .. top its mips, each treated as a level of one
// "tile" (0, 0) that is the whole level.  A tile's *domain* is the part of
// the image (level-0 coordinates) that it draws: the points whose
// bilinear taps at its level fall inside it.  At level k with s = 2^k, a
// point p samples level pixels floor(p/s - 0.5) and one more, so tile tx
// draws p/s - 0.5 in [512 tx, 512 tx + 512): both taps are in the tile
// thanks to the one-pixel overlap, and neighbouring domains share their
// edges exactly, so there are no seams.  The first and last tiles reach
// the image's edges (their taps are clamped there, as in every decoder).

import { STEP } from './tilebuf.js';

/** Level table from the /v1/images/{id} metadata: [{w, h, tilesX,
 * tilesY, tiled}], index = level, up to the last root mip. */
export function levelsOf(info) {
    const out = [];
    for (const l of info.levels)
        out.push({ w: l.width, h: l.height, tilesX: l.tiles_x, tilesY: l.tiles_y, tiled: true });
    for (const m of info.root.mips)
        out[m.level] = { w: m.width, h: m.height, tilesX: 1, tilesY: 1, tiled: false };
    return out;
}

/** Level-0 rectangle [x0, y0, x1, y1] that tile (k, tx, ty) draws. */
export function tileDomain(levels, W, H, k, tx, ty) {
    const L = levels[k], s = 2 ** k;
    if (!L.tiled)
        return [0, 0, W, H];
    return [
        tx === 0 ? 0 : (STEP * tx + 0.5) * s,
        ty === 0 ? 0 : (STEP * ty + 0.5) * s,
        tx === L.tilesX - 1 ? W : (STEP * (tx + 1) + 0.5) * s,
        ty === L.tilesY - 1 ? H : (STEP * (ty + 1) + 0.5) * s,
    ];
}

/** The four corners of a w x h viewport in level-0 coordinates. */
export function viewCorners(toImage, w, h) {
    return [toImage(0, 0), toImage(w, 0), toImage(w, h), toImage(0, h)];
}

// Separating-axis test of a rectangle against a convex polygon.
function overlaps(rect, poly) {
    const [x0, y0, x1, y1] = rect;
    let ax = Infinity, bx = -Infinity, ay = Infinity, by = -Infinity;
    for (const [x, y] of poly) {
        ax = Math.min(ax, x); bx = Math.max(bx, x);
        ay = Math.min(ay, y); by = Math.max(by, y);
    }
    if (bx < x0 || ax > x1 || by < y0 || ay > y1)
        return false;
    const corners = [[x0, y0], [x1, y0], [x1, y1], [x0, y1]];
    for (let i = 0; i < poly.length; i++) {
        const [px, py] = poly[i], [qx, qy] = poly[(i + 1) % poly.length];
        const nx = qy - py, ny = px - qx;     // edge normal
        let pmin = Infinity, pmax = -Infinity, rmin = Infinity, rmax = -Infinity;
        for (const [x, y] of poly) {
            const d = nx * x + ny * y;
            pmin = Math.min(pmin, d); pmax = Math.max(pmax, d);
        }
        for (const [x, y] of corners) {
            const d = nx * x + ny * y;
            rmin = Math.min(rmin, d); rmax = Math.max(rmax, d);
        }
        if (rmax < pmin || rmin > pmax)
            return false;
    }
    return true;
}

/**
 * Tiles [k, tx, ty] of level k whose domain meets the polygon `poly`
 * (level-0 coordinates, convex), nearest to (cx, cy) first.
 */
export function tilesIn(levels, W, H, k, poly, cx, cy) {
    const L = levels[k];
    if (!L.tiled)
        return [[k, 0, 0]];
    const s = 2 ** k;
    let ax = Infinity, bx = -Infinity, ay = Infinity, by = -Infinity;
    for (const [x, y] of poly) {
        ax = Math.min(ax, x); bx = Math.max(bx, x);
        ay = Math.min(ay, y); by = Math.max(by, y);
    }
    // Level pixels of the bounding box, one more each side for the taps.
    const px0 = Math.max(0, Math.floor(ax / s - 0.5) - 1), px1 = Math.min(L.w - 1, Math.ceil(bx / s - 0.5) + 1);
    const py0 = Math.max(0, Math.floor(ay / s - 0.5) - 1), py1 = Math.min(L.h - 1, Math.ceil(by / s - 0.5) + 1);
    if (px0 > px1 || py0 > py1)
        return [];
    const tx0 = Math.min(Math.floor(px0 / STEP), L.tilesX - 1), tx1 = Math.min(Math.floor(px1 / STEP), L.tilesX - 1);
    const ty0 = Math.min(Math.floor(py0 / STEP), L.tilesY - 1), ty1 = Math.min(Math.floor(py1 / STEP), L.tilesY - 1);
    const out = [];
    for (let ty = ty0; ty <= ty1; ty++)
        for (let tx = tx0; tx <= tx1; tx++) {
            const d = tileDomain(levels, W, H, k, tx, ty);
            if (!overlaps([d[0] - s, d[1] - s, d[2] + s, d[3] + s], poly))
                continue;
            const mx = (d[0] + d[2]) / 2 - cx, my = (d[1] + d[3]) / 2 - cy;
            out.push({ t: [k, tx, ty], d2: mx * mx + my * my });
        }
    out.sort((a, b) => a.d2 - b.d2);
    return out.map((o) => o.t);
}

/** Tiles of level k whose centres lie within radius r of (cx, cy), nearest
 * first: the prefetch circle of thesis section 7.5. */
export function tilesInCircle(levels, W, H, k, cx, cy, r) {
    const L = levels[k];
    if (!L.tiled)
        return [];
    const s = 2 ** k, span = STEP * s;
    const tx0 = Math.max(0, Math.floor((cx - r) / span)), tx1 = Math.min(L.tilesX - 1, Math.floor((cx + r) / span));
    const ty0 = Math.max(0, Math.floor((cy - r) / span)), ty1 = Math.min(L.tilesY - 1, Math.floor((cy + r) / span));
    const out = [];
    for (let ty = ty0; ty <= ty1; ty++)
        for (let tx = tx0; tx <= tx1; tx++) {
            const d = tileDomain(levels, W, H, k, tx, ty);
            const mx = (d[0] + d[2]) / 2 - cx, my = (d[1] + d[3]) / 2 - cy;
            const d2 = mx * mx + my * my;
            if (d2 <= r * r)
                out.push({ t: [k, tx, ty], d2 });
        }
    out.sort((a, b) => a.d2 - b.d2);
    return out.map((o) => o.t);
}

/** The channels of an image's 8-bit pixels: a sample store of several
 * channels is shown in RGB (docs/API.md), every other store as it is. */
export function displayChannels(info) {
    return info.samples && info.channels > 1 ? 3 : info.channels;
}
