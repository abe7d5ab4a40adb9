// auth.js - the viewer's side of IIIF Authorization Flow 2.0
// (https://iiif.io/api/auth/2.0/; docs/API.md "What a client does").
//
// A restricted image answers 401.  Its info.json's 401 carries the
// services: an AuthProbeService2 holding an AuthAccessService2 (profile
// active: a login page opened in a window) that holds an
// AuthAccessTokenService2 (a page loaded in an iframe that posts an
// AuthAccessToken2 to this origin) and an AuthLogoutService2.  The login
// page sets gigaviewd's access cookie, which every later same-origin
// request of this page (fetches, workers' fetches) carries by itself; the
// token is what the probe is asked with, and tells how long the login
// lasts.  The dialog shows the service's heading, note and confirm label
// (the policy's texts), and the probe's heading and note when the login
// does not give access.

const TOKEN_TIMEOUT_MS = 10000;

/** The English (or first) string of a IIIF language map. */
function text(map) {
    if (!map)
        return '';
    const v = map.en || Object.values(map)[0];
    return Array.isArray(v) ? v.join(' ') : String(v || '');
}

/** The services of an info.json's `service` list: {probe, access, token,
 * logout}, or null when there is no probe service with a login. */
export function authServices(list) {
    const probe = (list || []).find((s) => s && s.type === 'AuthProbeService2');
    const access = probe && (probe.service || []).find((s) => s.type === 'AuthAccessService2');
    if (!access)
        return null;
    const sub = access.service || [];
    return {
        probe, access,
        token: sub.find((s) => s.type === 'AuthAccessTokenService2'),
        logout: sub.find((s) => s.type === 'AuthLogoutService2'),
    };
}

/** The services of image `id`, from its info.json (200 or 401): null for
 * an image with none (public, or absent). */
export async function servicesOf(id) {
    const r = await fetch(new URL(`iiif/3/${encodeURIComponent(id)}/info.json`, document.baseURI));
    let body = null;
    try { body = await r.json(); } catch (e) { return null; }
    return authServices(body && body.service);
}

let messageSeq = 0;

/** Load the token service in a hidden iframe and resolve to the message it
 * posts (an AuthAccessToken2 or an AuthAccessTokenError2), or to null when
 * none comes within TOKEN_TIMEOUT_MS. */
export function requestToken(tokenService) {
    const messageId = `gv${Date.now().toString(36)}-${++messageSeq}`;
    const url = new URL(tokenService.id, document.baseURI);
    url.searchParams.set('messageId', messageId);
    url.searchParams.set('origin', location.origin);
    return new Promise((resolve) => {
        const frame = document.createElement('iframe');
        frame.hidden = true;
        frame.title = 'access token';
        let timer = 0;
        const done = (v) => {
            clearTimeout(timer);
            window.removeEventListener('message', onMessage);
            frame.remove();
            resolve(v);
        };
        const onMessage = (e) => {
            if (e.origin !== url.origin || !e.data || e.data.messageId !== messageId)
                return;
            done(e.data);
        };
        window.addEventListener('message', onMessage);
        timer = setTimeout(() => done(null), TOKEN_TIMEOUT_MS);
        frame.src = url.href;
        document.body.append(frame);
    });
}

/** Ask the probe service with `token` (may be null: the cookie alone);
 * resolves to the AuthProbeResult2 (status 200 means go ahead). */
export async function probe(services, token) {
    const headers = token ? { Authorization: `Bearer ${token}` } : {};
    const r = await fetch(services.probe.id, { headers, credentials: 'same-origin' });
    return r.json();
}

/**
 * The login dialog: elements {box, heading, note, confirm, cancel}.  ask()
 * shows the texts and resolves true on confirm, false on cancel.
 */
export class AuthDialog {
    constructor(els) {
        this.els = els;
    }

    ask(heading, note, confirmLabel) {
        const { box, confirm, cancel } = this.els;
        this.els.heading.textContent = heading;
        this.els.note.textContent = note;
        confirm.textContent = confirmLabel || 'Log in';
        box.hidden = false;
        return new Promise((resolve) => {
            const end = (v) => {
                confirm.removeEventListener('click', yes);
                cancel.removeEventListener('click', no);
                box.hidden = true;
                resolve(v);
            };
            const yes = () => end(true);
            const no = () => end(false);
            confirm.addEventListener('click', yes);
            cancel.addEventListener('click', no);
        });
    }
}

/** Open the login page in a window and resolve once that window is closed
 * (the page closes itself after setting the cookie). */
function loginWindow(access) {
    const url = new URL(access.id, document.baseURI);
    url.searchParams.set('origin', location.origin);
    const w = window.open(url.href, 'gigaview-login', 'popup,width=480,height=560');
    if (!w)
        return Promise.resolve(false);
    return new Promise((resolve) => {
        const poll = setInterval(() => {
            if (w.closed) {
                clearInterval(poll);
                resolve(true);
            }
        }, 200);
    });
}

/**
 * Get access to image `id` whose routes answered 401: try the login this
 * browser may already hold, else show the dialog, open the login window,
 * fetch the token and ask the probe.  Resolves to
 * {ok, token, expiresIn, message}: ok when the probe says 200; message
 * says why not otherwise (cancelled, denied, no services).
 */
export async function obtainAccess(id, dialog) {
    const services = await servicesOf(id);
    if (!services || !services.token)
        return { ok: false, message: `image '${id}' is restricted and offers no login` };
    const attempt = async () => {
        const t = await requestToken(services.token);
        const token = t && t.type === 'AuthAccessToken2' ? t.accessToken : null;
        const result = await probe(services, token);
        return { result, token, expiresIn: token ? t.expiresIn : 0, tokenMessage: t };
    };
    let got = await attempt();
    if (got.result.status === 200)
        return { ok: true, token: got.token, expiresIn: got.expiresIn };
    const a = services.access;
    let heading = text(a.heading || a.label), note = text(a.note);
    for (;;) {
        if (!await dialog.ask(heading, note, text(a.confirmLabel) || 'Log in'))
            return { ok: false, message: `image '${id}' is restricted: not logged in` };
        if (!await loginWindow(a))
            return { ok: false, message: 'the login window could not be opened (allow pop-ups for this site)' };
        got = await attempt();
        if (got.result.status === 200)
            return { ok: true, token: got.token, expiresIn: got.expiresIn };
        // Logged in but not allowed, or the login failed: say so, offer again.
        heading = text(got.result.heading) || text(got.tokenMessage && got.tokenMessage.heading) || heading;
        note = text(got.result.note) || text(got.tokenMessage && got.tokenMessage.note) || note;
    }
}
