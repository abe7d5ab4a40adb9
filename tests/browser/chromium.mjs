// chromium.mjs - how the headless-Chromium test scripts start the browser:
// Debian's chromium (never a downloaded one), WebGL2 on SwiftShader, a
// fixed viewport at device scale 1 and the sRGB colour profile, so that
// pixels read back are the ones drawn; nothing in the background talks
// to the network.

import { chromium } from 'playwright-core';

/**
 * A persistent browser context in directory `profile`, running the
 * chromium binary at `executablePath` with a `width` x `height` viewport;
 * `extraArgs` are added to the command line.  Resolves to playwright's
 * BrowserContext (the caller closes it).
 */
export function launchChromium(profile, executablePath, width, height, extraArgs = []) {
    return chromium.launchPersistentContext(profile, {
        executablePath,
        headless: true,
        viewport: { width, height },
        deviceScaleFactor: 1,
        timeout: 30000,
        args: ['--headless=new', '--no-sandbox', '--use-angle=swiftshader', '--enable-unsafe-swiftshader',
            '--disable-background-networking', '--disable-component-update', '--disable-sync',
            '--no-first-run', '--force-color-profile=srgb', ...extraArgs],
    });
}
