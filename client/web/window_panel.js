// window_panel.js - the display window panel: black, white and gamma
// sliders, for all channels at once or one set per channel, and "auto",
// which sets black and white per channel at the 0.5 % and 99.5 % points
// of the histogram of the root (the coarsest level, which the viewer holds
// from the start).  Every change goes to Viewer.setWindow, which redraws
// from the tiles already decoded and writes the window into the link.

import { autoPoints, channelWindow, defaultSampleWindow, sampleColours } from './window.js';

const NAMES = ['red', 'green', 'blue'];
// A sample store's default colours (docs/API.md, "Sample stores").

export class WindowPanel {
    /** viewer: the Viewer; el: {box, linked, auto, reset, channels}. */
    constructor(viewer, el) {
        this.viewer = viewer;
        this.el = el;
        this.sliders = [];
        el.linked.addEventListener('change', () => this.rebuild(this.current()));
        el.auto.addEventListener('click', () => this.auto());
        // Off: in a store with a default window the link then says
        // window=none, so that the default does not come back.
        el.reset.addEventListener('click', () => this.set(null, !!(viewer.image && viewer.image.info.window)));
        viewer.on('open', () => this.rebuild(viewer.window));
    }

    channels() {
        return this.viewer.image ? this.viewer.image.info.channels : 1;
    }

    /** The largest sample a window point may name: a sample store's 16-bit
     * codes, else 8-bit samples. */
    max() {
        return this.viewer.image && this.viewer.image.info.samples ? 65535 : 255;
    }

    /** The window the sliders show (one per channel, or one): without
     * one, a sample store's codes' range, else 0 .. 255. */
    current() {
        const s = this.viewer.image && this.viewer.image.info.samples;
        return this.viewer.window || (s ? defaultSampleWindow(s) : [{ black: 0, white: 255, gammaMilli: 1000 }]);
    }

    /** A sample store's channel colours as the viewer draws them: the
     * link's, else the store's (metadata display.colours), else the
     * palette; ["rrggbb", ...] one per channel. */
    colours() {
        const info = this.viewer.image ? this.viewer.image.info : null;
        return sampleColours(this.viewer.colours, info && info.metadata, this.channels());
    }

    /** Show window w (or none) and set it on the viewer. */
    set(w, none = false) {
        this.viewer.setWindow(w, none);
        this.rebuild(w);
    }

    /** Black and white from the root's histogram, per channel; gamma kept. */
    async auto() {
        const image = this.viewer.image, root = image && image.root;
        if (!root)
            return;
        const c = this.channels();
        let pts;
        if (image.info.samples) {
            // A sample store: the root's 16-bit codes (its picture is
            // 8-bit), which the WebGL2 viewer holds already.
            let codes = root.px instanceof Uint16Array ? root.px : null;
            if (!codes) {
                const r = await fetch(`${image.url}/root?format=raw`);
                if (!r.ok || this.viewer.image !== image)
                    return;
                codes = new Uint16Array(await r.arrayBuffer());
            }
            pts = autoPoints(codes, c, c, 0.005, 0.995, 65535);
        } else {
            // The 8-bit picture: a height store's gray; a gray root may
            // come as three equal channels (viewer.js loadPicture).
            const stride = root.picture.length / (root.w * root.h);
            pts = autoPoints(root.picture, c, stride);
        }
        const cur = this.current();
        let w = pts.map(([lo, hi], k) => ({ black: lo, white: hi, gammaMilli: channelWindow(cur, k).gammaMilli }));
        if (this.el.linked.checked || c === 1)
            w = [{ black: Math.min(...w.map((x) => x.black)), white: Math.max(...w.map((x) => x.white)),
                gammaMilli: w[0].gammaMilli }];
        this.set(w);
    }

    // Sliders for window w: one set when linked, else one per channel.
    rebuild(w) {
        const c = this.channels();
        const linked = this.el.linked.checked || c === 1;
        const cur = w || this.current();
        const max = this.max();
        if (!linked && cur.length === 1 && c > 1)
            w = Array.from({ length: c }, () => ({ ...cur[0] }));
        else if (linked && cur.length > 1)
            w = [{ ...cur[0] }];
        else
            w = cur.map((x) => ({ ...x }));
        this.el.channels.replaceChildren();
        this.work = w;
        w.forEach((ch, k) => {
            const fs = document.createElement('fieldset');
            const lg = document.createElement('legend');
            const samples = this.viewer.image && this.viewer.image.info.samples;
            lg.textContent = linked ? 'all channels' : (!samples && NAMES[k]) || `channel ${k + 1}`;
            fs.append(lg);
            const add = (label, min, max, step, value, put, show) => {
                const l = document.createElement('label');
                l.className = 'slider';
                const input = document.createElement('input');
                Object.assign(input, { type: 'range', min, max, step, value });
                input.setAttribute('aria-label', `${lg.textContent} ${label}`);
                const out = document.createElement('output');
                out.textContent = show(value);
                input.addEventListener('input', () => {
                    put(Number(input.value));
                    out.textContent = show(Number(input.value));
                    this.viewer.setWindow(this.work);
                });
                l.append(label, input, out);
                fs.append(l);
            };
            // A sample store's channel: its colour (the server adds them up).
            if (samples && !linked && c > 1) {
                const l = document.createElement('label');
                l.className = 'slider';
                const input = document.createElement('input');
                Object.assign(input, { type: 'color', value: `#${this.colours()[k]}` });
                input.setAttribute('aria-label', `${lg.textContent} colour`);
                input.addEventListener('input', () => {
                    const cols = this.colours();
                    cols[k] = input.value.replace('#', '').toLowerCase();
                    this.viewer.setColours(cols.join(';'));
                });
                l.append('colour', input);
                fs.append(l);
            }
            add('black', 0, max - 1, 1, ch.black, (v) => { ch.black = Math.min(v, ch.white - 1); }, String);
            add('white', 1, max, 1, ch.white, (v) => { ch.white = Math.max(v, ch.black + 1); }, String);
            // gamma on a log scale, 0.1 .. 10, in thousandths
            add('gamma', -1000, 1000, 1, Math.round(Math.log10(ch.gammaMilli / 1000) * 1000),
                (v) => { ch.gammaMilli = Math.min(10000, Math.max(100, Math.round(1000 * 10 ** (v / 1000)))); },
                (v) => (10 ** (v / 1000)).toFixed(3));
            this.el.channels.append(fs);
        });
    }
}
