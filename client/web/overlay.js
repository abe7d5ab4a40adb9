// overlay.js - what is drawn over the picture: the overview (the root
// image with the view's outline; click or drag in it to move there), the
// zoom indicator (magnification, level of detail, rotation, and a scale
// bar in image pixels) and the loading indicator (tiles on the wire or
// waiting to be decoded).

import { displayChannels } from './pyramid.js';
import { screenToImage } from './view.js';

const MINI = 180;   // overview box, CSS pixels

export class Overlay {
    constructor(viewer, els) {
        this.viewer = viewer;
        this.els = els;   // {mini, zoom, loading, loadingText}
        this.mini = els.mini.getContext('2d');
        this.rootBitmap = null;
        viewer.on('open', () => this.opened());
        viewer.on('frame', (r) => this.update(r));
        let dragging = false;
        const go = (e) => {
            const v = viewer.view;
            if (!v || !this.scale)
                return;
            const r = els.mini.getBoundingClientRect();
            const x = (e.clientX - r.left) / this.scale, y = (e.clientY - r.top) / this.scale;
            viewer.setView({ ...v, cx: x, cy: y });
        };
        els.mini.addEventListener('pointerdown', (e) => {
            dragging = true;
            els.mini.setPointerCapture(e.pointerId);
            go(e);
        });
        els.mini.addEventListener('pointermove', (e) => { if (dragging) go(e); });
        els.mini.addEventListener('pointerup', () => { dragging = false; });
    }

    opened() {
        const img = this.viewer.image, info = img.info;
        const { picture: px, w, h } = img.root, c = displayChannels(info);
        const rgba = new Uint8ClampedArray(w * h * 4);
        for (let i = 0; i < w * h; i++) {
            for (let k = 0; k < 3; k++)
                rgba[4 * i + k] = px[i * c + (c === 3 ? k : 0)];
            rgba[4 * i + 3] = 255;
        }
        this.scale = MINI / Math.max(info.width, info.height);
        const cw = Math.max(1, Math.round(info.width * this.scale)), ch = Math.max(1, Math.round(info.height * this.scale));
        const dpr = window.devicePixelRatio || 1;
        this.els.mini.style.width = `${cw}px`;
        this.els.mini.style.height = `${ch}px`;
        this.els.mini.width = Math.round(cw * dpr);
        this.els.mini.height = Math.round(ch * dpr);
        this.rootBitmap = null;
        createImageBitmap(new ImageData(rgba, w, h)).then((b) => {
            this.rootBitmap = b;
            this.drawMini();
        });
        this.els.mini.hidden = false;
    }

    drawMini() {
        const v = this.viewer.view, g = this.mini, cv = this.els.mini;
        if (!v)
            return;
        const k = cv.width / this.viewer.image.info.width;
        g.setTransform(1, 0, 0, 1, 0, 0);
        g.fillStyle = '#000';
        g.fillRect(0, 0, cv.width, cv.height);
        if (this.rootBitmap) {
            g.imageSmoothingQuality = 'high';
            g.drawImage(this.rootBitmap, 0, 0, cv.width, cv.height);
        }
        const W = this.viewer.cssW, H = this.viewer.cssH;
        const corners = [[0, 0], [W, 0], [W, H], [0, H]].map(([x, y]) => screenToImage(v, W, H, x, y));
        g.beginPath();
        corners.forEach(([x, y], i) => (i ? g.lineTo(x * k, y * k) : g.moveTo(x * k, y * k)));
        g.closePath();
        g.lineWidth = Math.max(1.5, cv.width / 120);
        g.strokeStyle = '#ffd24a';
        g.stroke();
    }

    update(r) {
        const v = this.viewer.view;
        if (!v)
            return;
        this.drawMini();
        const mag = 100 / 2 ** v.zoom;
        const pct = mag >= 10 ? mag.toFixed(0) : mag >= 1 ? mag.toFixed(1) : mag.toFixed(2);
        const lod = r ? `level ${(r.level + r.t).toFixed(2)}` : '';
        // Scale bar: a round length about 100 CSS px long, of level-0
        // pixels, or of microns for a slide that says its microns per
        // pixel (metadata slide.mpp_x).
        const meta = this.viewer.image.info.metadata, mpp = meta && meta['slide.mpp_x'] > 0 ? meta['slide.mpp_x'] : 0;
        const unit = 2 ** v.zoom * (mpp || 1);       // units per CSS px
        const per = unit * 100;
        const p10 = 10 ** Math.floor(Math.log10(per));
        const nice = [1, 2, 5, 10].map((m) => m * p10).find((n) => n >= per * 0.75) || per;
        this.els.zoom.textContent = `${pct}% · ${lod} · ${v.rot.toFixed(0)}°`;
        this.els.scale.style.width = `${(nice / unit).toFixed(1)}px`;
        const num = (x) => String(Number(x.toPrecision(6)));
        this.els.scaleText.textContent = mpp ? (nice >= 1000 ? `${num(nice / 1000)} mm` : `${num(nice)} µm`)
            : `${nice >= 1000 ? `${nice / 1000}k` : nice} px`;
        const busy = r && (r.inflight > 0 || r.pending > 0);
        this.els.loading.hidden = !busy;
        if (busy)
            this.els.loadingText.textContent = r.inflight > 0 ? `loading ${r.inflight} tile${r.inflight === 1 ? '' : 's'}` :
                `decoding ${r.pending} tile${r.pending === 1 ? '' : 's'}`;
    }
}
