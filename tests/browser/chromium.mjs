// chromium.mjs - how the headless-Chromium test scripts start the browser:
// Debian's chromium (never a downloaded one), WebGL2 on SwiftShader, a
// fixed viewport at device scale 1 and the sRGB colour profile, so that
// pixels read back are the ones drawn; nothing in the background talks
// to the network.
//
// Every wait has one bound, PATIENCE_MS: GV_TEST_PATIENCE seconds from
// the environment (tests/lib.sh), after which what must happen (the
// browser starting, an element, a popup, a frame) is called a hang.  It
// is the context's default timeout, so that playwright calls without a
// timeout of their own wait as long; a script passes it where it gives
// one.  No outcome may depend on how fast the machine is: on a busy one,
// in the sanitizer build, a login dialog that appears in 1 s idle has
// taken over 15 s.

import { chromium } from 'playwright-core';

/** How long (ms) a test waits for what must happen before calling it a hang. */
export const PATIENCE_MS = (Number(process.env.GV_TEST_PATIENCE) || 240) * 1000;

/**
 * A persistent browser context in directory `profile`, running the
 * chromium binary at `executablePath` with a `width` x `height` viewport;
 * `extraArgs` are added to the command line.  Resolves to playwright's
 * BrowserContext (the caller closes it).
 */
export async function launchChromium(profile, executablePath, width, height, extraArgs = []) {
    const ctx = await chromium.launchPersistentContext(profile, {
        executablePath,
        headless: true,
        viewport: { width, height },
        deviceScaleFactor: 1,
        timeout: PATIENCE_MS,
        args: ['--headless=new', '--no-sandbox', '--use-angle=swiftshader', '--enable-unsafe-swiftshader',
            '--disable-background-networking', '--disable-component-update', '--disable-sync',
            '--no-first-run', '--force-color-profile=srgb', ...extraArgs],
    });
    ctx.setDefaultTimeout(PATIENCE_MS);
    return ctx;
}
