// auth.mjs - the viewer's login to a restricted image (client/web/auth.js,
// IIIF Authorization Flow 2.0), in headless Chromium against a gigaviewd
// with an access policy and a trusted proxy header (tests/browser_auth.sh
// starts it).  The header stands in for the institution's single sign-on
// proxy: this script adds it to the login page's request only, as such a
// proxy does, so every other request is anonymous unless the login's
// cookie comes with it.
//
// Checks:
//   1. the public image opens with no dialog;
//   2. the restricted image shows the dialog with the policy's heading,
//      note and confirm label, and nothing of it is drawn or fetched with
//      success before the login;
//   3. cancel leaves the error "not logged in";
//   4. confirm opens the login window (which closes itself), the viewer
//      takes the token from the token service (an AuthAccessToken2) and
//      the image opens: its root and tiles answer 200, and the picture
//      read back is not blank;
//   5. a reader of another group logs in, is told the probe's "denied"
//      texts in the dialog, and the image stays closed;
//   6. no console errors but the expected 401s;
//   7. the login expires while a large restricted image is open (the
//      cookie now holds an expired token): the next tiles answer 401, the
//      viewer asks to log in again, and after the login the new view
//      completes where it was, its tiles answering 200;
//   8. the same with the viewer drawing the server's regions
//      (?renderer=region, as without WebGL2).
//
//   node auth.mjs --base URL --public ID --restricted ID --large ID --group G
//                 --other-group G2 --header NAME --expired-token TOKEN
//                 --chromium PATH --out DIR

import { mkdtempSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join } from 'node:path';
import { launchChromium, PATIENCE_MS } from './chromium.mjs';
import { check, failed, note, parseArgs } from './report.mjs';

const opt = parseArgs({ base: '', public: '', restricted: '', group: '', 'other-group': '',
    header: '', heading: '', 'expired-token': '', large: '', chromium: '/usr/bin/chromium', out: '' },
'usage: node auth.mjs --base URL --public ID --restricted ID --large ID --group G --other-group G2 --header NAME --expired-token TOKEN [--heading TEXT] [--chromium PATH] [--out DIR]',
'auth.mjs', ['base', 'public', 'restricted', 'large', 'group', 'other-group', 'header', 'expired-token']);

const base = opt.base.replace(/\/$/, '') + '/';

/** A fresh browser context whose login requests carry `group` in the
 * trusted header (null: none), with its log of responses. */
async function browser(group) {
    const ctx = await launchChromium(mkdtempSync(join(tmpdir(), 'gv-auth-')), opt.chromium, 900, 640);
    const log = [];
    ctx.on('response', (r) => log.push({ url: r.url(), status: r.status() }));
    await ctx.route('**/iiif/auth/login*', (route) => {
        const headers = { ...route.request().headers() };
        if (group)
            headers[opt.header.toLowerCase()] = group;
        route.continue({ headers });
    });
    const page = await ctx.newPage();
    const consoleErrors = [];
    page.on('console', (m) => {
        if (m.type() === 'error' && !/401/.test(m.text()))
            consoleErrors.push(m.text());
    });
    page.on('pageerror', (e) => consoleErrors.push(String(e)));
    return { ctx, page, log, consoleErrors };
}

const dialogShown = (page) => page.waitForSelector('#auth:not([hidden])', { timeout: PATIENCE_MS })
    .then(() => true, () => false);

async function opened(page, id) {
    return page.waitForFunction((want) => {
        const g = window.gigaview;
        return g && g.viewer.image && g.viewer.image.id === want;
    }, id, { timeout: PATIENCE_MS }).then(() => true, () => false);
}

async function main() {
    // 1. public
    let b = await browser(opt.group);
    await b.page.goto(`${base}#image=${encodeURIComponent(opt.public)}`);
    await b.page.evaluate(() => window.gigaview.ready);
    check(await opened(b.page, opt.public), 'the public image opens');
    check(await b.page.$eval('#auth', (e) => e.hidden), 'no login dialog for the public image');

    // 2., 3. restricted: the dialog, then cancel
    await b.page.evaluate((id) => { location.hash = `image=${encodeURIComponent(id)}`; }, opt.restricted);
    check(await dialogShown(b.page), 'the restricted image asks to log in');
    const texts = await b.page.evaluate(() => ({
        heading: document.getElementById('auth-heading').textContent,
        note: document.getElementById('auth-note').textContent,
        confirm: document.getElementById('auth-confirm').textContent,
    }));
    if (opt.heading)
        check(texts.heading === opt.heading, 'the dialog shows the policy\'s heading', JSON.stringify(texts));
    check(texts.note.length > 0 && texts.confirm.length > 0, 'the dialog has a note and a confirm label',
        JSON.stringify(texts));
    const okBefore = b.log.filter((r) => r.url.includes(`/v1/images/${opt.restricted}`) && r.status === 200);
    check(okBefore.length === 0, 'nothing of the restricted image is served before the login',
        JSON.stringify(okBefore.slice(0, 3)));
    await b.page.click('#auth-cancel');
    const err = await b.page.waitForFunction(() => document.getElementById('error').textContent, null,
        { timeout: PATIENCE_MS }).then((h) => h.jsonValue(), () => '');
    check(/not logged in/.test(err), 'cancel says the image is restricted and not logged in', err);

    // 4. log in (the group of the image)
    await b.page.evaluate(() => { location.hash = ''; });
    await b.page.evaluate((id) => { location.hash = `image=${encodeURIComponent(id)}`; }, opt.restricted);
    check(await dialogShown(b.page), 'asked again after cancelling');
    const popup = b.page.waitForEvent('popup', { timeout: PATIENCE_MS }).catch(() => null);
    await b.page.click('#auth-confirm');
    const w = await popup;
    check(w !== null, 'confirm opens the login window');
    check(await opened(b.page, opt.restricted), 'after the login the restricted image opens');
    if (w)
        check(w.isClosed(), 'the login window closed itself');
    const auth = await b.page.evaluate(() => window.gigaview.auth());
    check(auth && auth.ok && typeof auth.token === 'string' && auth.token.length > 20 && auth.expiresIn > 0,
        'the viewer holds the AuthAccessToken2 of the token service', JSON.stringify(auth));
    await b.page.evaluate(() => window.gigaview.viewer.settled && window.gigaview.viewer.settled());
    const served = b.log.filter((r) => r.url.includes(`/v1/images/${opt.restricted}`));
    const first = served.findIndex((r) => r.status === 200);
    const after = first < 0 ? [] : served.slice(first);
    check(after.length >= 2 && after.every((r) => r.status === 200),
        'after the login every request of the image answers 200', JSON.stringify(served.slice(-6)));
    // What is on the screen (a WebGL canvas keeps no buffer to read back).
    const shot = (await b.page.locator('#view').screenshot()).toString('base64');
    const lit = await b.page.evaluate(async (png) => {
        const bin = atob(png), u8 = new Uint8Array(bin.length);
        for (let i = 0; i < bin.length; i++) u8[i] = bin.charCodeAt(i);
        const bm = await createImageBitmap(new Blob([u8], { type: 'image/png' }));
        const c = new OffscreenCanvas(bm.width, bm.height), g = c.getContext('2d');
        g.drawImage(bm, 0, 0);
        const d = g.getImageData(0, 0, bm.width, bm.height).data;
        let lo = 255, hi = 0;
        for (let i = 0; i < d.length; i += 4 * 97) { lo = Math.min(lo, d[i + 1]); hi = Math.max(hi, d[i + 1]); }
        return hi - lo;
    }, shot);
    check(lit > 20, 'the restricted image is drawn', `green spread ${lit}`);
    check(b.consoleErrors.length === 0, 'no console errors (but 401s)', ...b.consoleErrors.slice(0, 5));
    if (opt.out)
        await b.page.screenshot({ path: join(opt.out, 'auth-after-login.png') }).catch(() => {});

    // 7. the login expires mid-view, on a large image of the same group
    await b.page.evaluate((id) => { location.hash = `image=${encodeURIComponent(id)}`; }, opt.large);
    check(await opened(b.page, opt.large), 'logged in, the large restricted image opens without asking');
    await b.page.evaluate(() => window.gigaview.viewer.settled());
    await b.ctx.addCookies([{ name: 'gigaview_access', value: opt['expired-token'], url: base,
        httpOnly: true }]);
    const mark = b.log.length;
    // Closer in, at once: tiles of a finer level are needed.
    await b.page.evaluate(() => {
        const v = window.gigaview.viewer;
        v.setView({ ...v.view, zoom: Math.max(0, v.view.zoom - 2.5), cx: v.view.cx * 0.6, cy: v.view.cy * 0.6 });
    });
    const asked = await dialogShown(b.page);
    const diag = await b.page.evaluate(() => {
        const c = window.gigaview.viewer.backend.cache;
        return JSON.stringify({ stats: c.stats, retryAt: c.retryAt, inflight: c.inflightCount,
            view: window.gigaview.viewer.view, errors: window.gigaview.errors });
    });
    check(asked, 'an expired login: the next tiles ask to log in again', diag);
    const refused = b.log.slice(mark).filter((r) => r.url.includes(`/v1/images/${opt.large}/`) &&
        r.status === 401);
    check(refused.length >= 1, 'an expired login: a tile request answered 401',
        JSON.stringify(b.log.slice(mark, mark + 4)));
    const popup3 = b.page.waitForEvent('popup', { timeout: PATIENCE_MS }).catch(() => null);
    const viewAsked = await b.page.evaluate(() => window.gigaview.viewer.hash());
    await b.page.click('#auth-confirm');
    check((await popup3) !== null, 'confirm opens the login window again');
    const done = await b.page.waitForFunction(() => document.getElementById('auth').hidden, null,
        { timeout: PATIENCE_MS }).then(() => true, () => false);
    check(done, 'after the new login the dialog closes');
    const complete = await b.page.evaluate((ms) => Promise.race([
        window.gigaview.viewer.settled().then(() => true),
        new Promise((r) => setTimeout(() => r(false), ms))]), PATIENCE_MS);
    check(complete, 'after the new login the view completes');
    const mark2 = b.log.findIndex((r, i) => i >= mark && r.url.includes('/iiif/auth/token') && r.status === 200);
    const later = mark2 < 0 ? [] : b.log.slice(mark2).filter((r) => r.url.includes(`/v1/images/${opt.large}/`));
    check(later.length >= 1 && later.every((r) => r.status === 200),
        'after the new login the tiles of the view answer 200', JSON.stringify(later.slice(-4)));
    const viewAfter = await b.page.evaluate(() => window.gigaview.viewer.hash());
    check(viewAfter === viewAsked, 'the view stays where it was', `${viewAsked} -> ${viewAfter}`);
    const err7 = await b.page.$eval('#error', (e) => e.hidden ? '' : e.textContent);
    check(err7 === '', 'no error shown after the new login', err7);

    // 8. the same where the viewer draws the server's regions (no WebGL2)
    await b.page.goto(`${base}?renderer=region#image=${encodeURIComponent(opt.large)}`);
    await b.page.evaluate(() => window.gigaview.ready);
    check(await opened(b.page, opt.large), 'regions: the large image opens, logged in');
    await b.page.evaluate(() => window.gigaview.viewer.settled());
    await b.ctx.addCookies([{ name: 'gigaview_access', value: opt['expired-token'], url: base,
        httpOnly: true }]);
    await b.page.evaluate(() => {
        const v = window.gigaview.viewer;
        v.setView({ ...v.view, zoom: Math.max(0, v.view.zoom - 2), cx: v.view.cx * 1.3, cy: v.view.cy * 0.7 });
    });
    check(await dialogShown(b.page), 'regions: an expired login asks again');
    const popup4 = b.page.waitForEvent('popup', { timeout: PATIENCE_MS }).catch(() => null);
    await b.page.click('#auth-confirm');
    await popup4;
    const complete8 = await b.page.evaluate((ms) => Promise.race([
        window.gigaview.viewer.settled().then(() => true),
        new Promise((r) => setTimeout(() => r(false), ms))]), PATIENCE_MS);
    const last = b.log.filter((r) => r.url.includes(`/v1/images/${opt.large}/region`)).pop();
    check(complete8 && last && last.status === 200,
        'regions: after the new login the view completes from a region answered 200',
        JSON.stringify(last));
    await b.ctx.close();

    // 5. a reader of another group
    b = await browser(opt['other-group']);
    await b.page.goto(`${base}#image=${encodeURIComponent(opt.restricted)}`);
    check(await dialogShown(b.page), 'another group\'s reader is asked to log in');
    const headingBefore = await b.page.$eval('#auth-heading', (e) => e.textContent);
    const popup2 = b.page.waitForEvent('popup', { timeout: PATIENCE_MS }).catch(() => null);
    await b.page.click('#auth-confirm');
    await popup2;
    const changed = await b.page.waitForFunction((h) => {
        const box = document.getElementById('auth');
        return !box.hidden && document.getElementById('auth-heading').textContent !== h;
    }, headingBefore, { timeout: PATIENCE_MS }).then(() => true, () => false);
    check(changed, 'after a login that gives no access the dialog says so (the probe\'s texts)',
        await b.page.$eval('#auth-heading', (e) => e.textContent));
    check(!(await b.page.evaluate(() => !!window.gigaview.viewer.image)), 'the image stays closed');
    await b.ctx.close();
}

main().then(() => process.exit(failed ? 1 : 0), (e) => {
    note(String(e && e.stack || e));
    console.log('FAIL auth.mjs ran');
    process.exit(1);
});
