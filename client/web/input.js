// input.js - mouse, touch, keyboard and gamepad to view changes.
//
//   mouse     drag to pan, wheel to zoom about the cursor, double click to
//             zoom in there (shift: out)
//   touch     one finger pans; two fingers pinch to zoom and turn to
//             rotate, about their midpoint
//   keyboard  arrows pan (shift: further), + and - zoom, [ and ] (or q and
//             e) rotate by 15 degrees, 0 resets the view, r resets the
//             rotation
//   gamepad   (Gamepad API, standard mapping; replaces the WiiMote of
//             thesis section 7.6) left stick pans, right stick up/down
//             zooms and left/right rotates, shoulder buttons rotate, A and
//             B zoom, Start resets.  A dead zone keeps a resting stick
//             still, as the thesis needed for the WiiMote.
//
// Pointer events cover mouse, pen and touch alike.  The ROI tool
// (roi_filter.js, `modes.roi`) takes a drag while it is armed or when
// Shift is held.

const KEY_PAN = 0.2;          // of the viewport per arrow press
const KEY_ZOOM = 0.5;         // levels per + or -
const KEY_ROT = 15;           // degrees per rotation key
const DEAD = 0.15;            // gamepad stick dead zone
const PAD_PAN = 1.0;          // viewports per second at full stick
const PAD_ZOOM = 1.5;         // levels per second
const PAD_ROT = 90;           // degrees per second

export function attachInput(viewer, canvas, modes = {}) {
    const pts = new Map();    // pointerId -> [x, y] (CSS, canvas-relative)
    let pair = null;          // previous {mid, dist, angle} of two pointers
    const local = (e) => {
        const r = canvas.getBoundingClientRect();
        return [e.clientX - r.left, e.clientY - r.top];
    };
    const pairOf = () => {
        const [a, b] = [...pts.values()];
        return {
            mid: [(a[0] + b[0]) / 2, (a[1] + b[1]) / 2],
            dist: Math.max(1, Math.hypot(b[0] - a[0], b[1] - a[1])),
            angle: Math.atan2(b[1] - a[1], b[0] - a[0]) * 180 / Math.PI,
        };
    };

    canvas.addEventListener('pointerdown', (e) => {
        if (modes.roi && modes.roi.down(e, local(e)))
            return;
        canvas.setPointerCapture(e.pointerId);
        pts.set(e.pointerId, local(e));
        pair = pts.size === 2 ? pairOf() : null;
        canvas.classList.add('dragging');
    });
    canvas.addEventListener('pointermove', (e) => {
        if (modes.roi && modes.roi.dragging) {
            modes.roi.move(e, local(e));
            return;
        }
        const old = pts.get(e.pointerId);
        if (!old)
            return;
        const now = local(e);
        pts.set(e.pointerId, now);
        if (pts.size === 1) {
            viewer.panBy(now[0] - old[0], now[1] - old[1]);
        } else if (pts.size === 2) {
            const p = pairOf();
            let da = p.angle - pair.angle;
            if (da > 180) da -= 360;
            if (da < -180) da += 360;
            viewer.gesture(pair.mid, p.mid, p.dist / pair.dist, da);
            pair = p;
        }
    });
    const up = (e) => {
        if (modes.roi && modes.roi.dragging) {
            modes.roi.up(e, local(e));
            return;
        }
        pts.delete(e.pointerId);
        pair = pts.size === 2 ? pairOf() : null;
        if (!pts.size)
            canvas.classList.remove('dragging');
    };
    canvas.addEventListener('pointerup', up);
    canvas.addEventListener('pointercancel', up);

    canvas.addEventListener('wheel', (e) => {
        e.preventDefault();
        // Pixels, lines or pages to levels; a pinch on a touchpad comes as
        // a wheel with ctrlKey and small deltas.
        const unit = e.deltaMode === 1 ? 1 / 12 : e.deltaMode === 2 ? 1 : 1 / 400;
        const dz = Math.max(-1, Math.min(1, e.deltaY * unit * (e.ctrlKey ? 4 : 1)));
        const [x, y] = local(e);
        viewer.zoomAbout(dz, x, y);
    }, { passive: false });

    canvas.addEventListener('dblclick', (e) => {
        const [x, y] = local(e);
        viewer.zoomAbout(e.shiftKey ? 1 : -1, x, y);
    });

    window.addEventListener('keydown', (e) => {
        const t = e.target;
        if (t && (t.isContentEditable || /^(INPUT|TEXTAREA|SELECT)$/.test(t.tagName)))
            return;
        if (e.ctrlKey || e.metaKey || e.altKey || !viewer.image)
            return;
        const big = e.shiftKey ? 3 : 1;
        const w = viewer.cssW, h = viewer.cssH;
        switch (e.key) {
        case 'ArrowLeft': viewer.panByAnimated(-KEY_PAN * w * big, 0); break;
        case 'ArrowRight': viewer.panByAnimated(KEY_PAN * w * big, 0); break;
        case 'ArrowUp': viewer.panByAnimated(0, -KEY_PAN * h * big); break;
        case 'ArrowDown': viewer.panByAnimated(0, KEY_PAN * h * big); break;
        case '+': case '=': viewer.zoomAbout(-KEY_ZOOM); break;
        case '-': case '_': viewer.zoomAbout(KEY_ZOOM); break;
        case '[': case 'q': viewer.rotateBy(-KEY_ROT); break;
        case ']': case 'e': viewer.rotateBy(KEY_ROT); break;
        case '0': viewer.reset(); break;
        case 'r': viewer.animateTo({ ...viewer.target(), rot: 0 }); break;
        default: return;
        }
        e.preventDefault();
    });

    // Gamepads: polled once per frame while one is connected.
    let pads = 0, prevButtons = [];
    const stick = (v) => (Math.abs(v) < DEAD ? 0 : (v - Math.sign(v) * DEAD) / (1 - DEAD));
    window.addEventListener('gamepadconnected', () => { pads++; viewer.schedule(); });
    window.addEventListener('gamepaddisconnected', () => { pads = Math.max(0, pads - 1); });
    viewer.on('tick', (dt) => {
        if (!navigator.getGamepads)
            return false;
        const gp = [...navigator.getGamepads()].find((g) => g && g.connected);
        if (!gp || !viewer.image)
            return false;
        const s = dt / 1000, ax = gp.axes;
        const lx = stick(ax[0] || 0), ly = stick(ax[1] || 0), rx = stick(ax[2] || 0), ry = stick(ax[3] || 0);
        const btn = (i) => !!(gp.buttons[i] && gp.buttons[i].pressed);
        const pressed = (i) => btn(i) && !prevButtons[i];
        let moved = false;
        if (lx || ly) {
            viewer.panBy(-lx * PAD_PAN * viewer.cssW * s, -ly * PAD_PAN * viewer.cssH * s);
            moved = true;
        }
        const rot = rx * PAD_ROT + (btn(5) ? PAD_ROT : 0) - (btn(4) ? PAD_ROT : 0);
        if (ry || rot) {
            const v = viewer.view;
            viewer.setView({ ...v, zoom: v.zoom + ry * PAD_ZOOM * s, rot: v.rot + rot * s });
            moved = true;
        }
        if (pressed(0)) viewer.zoomAbout(-1);
        if (pressed(1)) viewer.zoomAbout(1);
        if (pressed(9)) viewer.reset();
        prevButtons = gp.buttons.map((b) => b.pressed);
        return moved;
    }, () => pads > 0 || !!(navigator.getGamepads && [...navigator.getGamepads()].some((g) => g && g.connected)));
}
