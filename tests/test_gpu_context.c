/*
 * test_gpu_context.c - the EGL context (lib/gpu/gpu_context.c): extension
 * lists matched by whole word, platform names, and opening a context on
 * each platform forced in turn.
 *
 * A forced platform either opens on that platform or fails naming only
 * that platform's attempts: what works depends on the machine (on Mesa
 * the device platform lists a software device, and the default display
 * may or may not have a platform behind it), so each outcome is checked
 * for what it must hold.  Where the automatic choice is Mesa, the
 * surfaceless platform must work.  Checks that need EGL are skipped (TAP
 * SKIP) where no context can be made at all.
 */
#include <stdio.h>
#include <string.h>

#include "gpu/gpu.h"
#include "util.h"

static const char *const names[] = {"auto", "device", "surfaceless", "default"};

static void check_extensions(void)
{
    const char *list = "EGL_KHR_a EGL_EXT_platform_device_foo  EGL_KHR_surfaceless_context "
                       "EGL_MESA_platform_surfaceless";
    check(!gv_has_extension(list, "EGL_EXT_platform_device"),
          "a longer name that starts with the extension does not match");
    check(!gv_has_extension("XEGL_EXT_platform_device", "EGL_EXT_platform_device"),
          "a longer name that ends with the extension does not match");
    check(!gv_has_extension(list, "EGL_KHR_surfaceless"),
          "a prefix of a listed extension does not match");
    check(gv_has_extension(list, "EGL_KHR_a"), "the first word matches");
    check(gv_has_extension(list, "EGL_KHR_surfaceless_context"),
          "a word after two spaces matches");
    check(gv_has_extension(list, "EGL_MESA_platform_surfaceless"),
          "the last word matches");
    check(gv_has_extension(" EGL_EXT_platform_device ", "EGL_EXT_platform_device"),
          "leading and trailing spaces are separators");
    check(!gv_has_extension(NULL, "EGL_KHR_a") && !gv_has_extension("", "EGL_KHR_a"),
          "NULL and empty lists name nothing");
    check(!gv_has_extension(list, ""), "the empty name is never listed");
}

static void check_names(void)
{
    int ok = 1;
    for (int i = 0; i < 4; i++)
        ok &= gv_gpu_platform_parse(names[i]) == i;
    check(ok && GV_GPU_PLATFORM_DEVICE == 1 && GV_GPU_PLATFORM_SURFACELESS == 2 &&
              GV_GPU_PLATFORM_DEFAULT == 3,
          "platform names parse to their enum values");
    check(gv_gpu_platform_parse("Device") < 0 && gv_gpu_platform_parse("") < 0 &&
              gv_gpu_platform_parse("wayland") < 0 &&
              gv_gpu_platform_parse("surfaceless ") < 0 &&
              gv_gpu_platform_parse(NULL) < 0,
          "other names (case, spaces, NULL) are refused");
}

/* Every attempt in an error text ("gpu: no usable EGL context: P: ...; P:
 * ...; ") names platform `want`; 1 if so and there is at least one. */
static int attempts_only(const char *text, const char *want)
{
    const char *head = "gpu: no usable EGL context: ";
    if (strncmp(text, head, strlen(head)))
        return 0;
    int n = 0;
    for (const char *p = text + strlen(head); *p; n++) {
        if (strncmp(p, want, strlen(want)) || p[strlen(want)] != ':')
            return 0;
        const char *end = strstr(p, "; ");
        if (!end)
            return 0;
        p = end + 2;
    }
    return n > 0;
}

/* Open on platform p and check what it must hold; returns whether it
 * opened, with the vendor in vendor. */
static int check_forced(int p, char *vendor, size_t size)
{
    struct gv_error err = {0};
    struct gv_gpu *g = gv_gpu_open((enum gv_gpu_platform)p, &err);
    if (!g) {
        printf("# %s: %s\n", names[p], err.text);
        check(err.code == GV_EUNAVAIL && attempts_only(err.text, names[p]),
              "%s forced: fails naming only %s attempts", names[p], names[p]);
        return 0;
    }
    const struct gv_gpu_info *in = gv_gpu_info(g);
    printf("# %s: %s, %s, %s\n", names[p], in->platform, in->api, in->renderer);
    check(!strcmp(in->platform, names[p]), "%s forced: opens on %s (got %s)",
          names[p], names[p], in->platform);
    snprintf(vendor, size, "%s", in->vendor);
    gv_gpu_close(g);
    return 1;
}

int main(void)
{
    check_extensions();
    check_names();

    /* Auto first, then each platform forced: the forced checks hold on
     * any machine, with EGL or without. */
    struct gv_error err = {0};
    struct gv_gpu *g = gv_gpu_open(GV_GPU_PLATFORM_AUTO, &err);
    char auto_platform[32] = "", auto_vendor[128] = "";
    if (g) {
        snprintf(auto_platform, sizeof auto_platform, "%s", gv_gpu_info(g)->platform);
        snprintf(auto_vendor, sizeof auto_vendor, "%s", gv_gpu_info(g)->vendor);
        gv_gpu_close(g);
    } else {
        printf("# auto: %s\n", err.text);
    }
    int auto_p = gv_gpu_platform_parse(auto_platform);
    int opened[4] = {0};
    char vendor[4][128] = {{0}};
    for (int p = GV_GPU_PLATFORM_DEVICE; p <= GV_GPU_PLATFORM_DEFAULT; p++)
        opened[p] = check_forced(p, vendor[p], sizeof vendor[p]);
    if (!g) {
        check(err.code == GV_EUNAVAIL && !opened[1] && !opened[2] && !opened[3],
              "auto fails only where every forced platform fails");
        check(1, "forcing the platform auto chose opens the same driver "
                 "# SKIP no EGL context here");
        check(1, "Mesa: the surfaceless platform works # SKIP no EGL context here");
        return tap_done();
    }
    check(auto_p > 0, "auto opens on a named platform (%s)", auto_platform);
    check(auto_p > 0 && opened[auto_p] && !strcmp(vendor[auto_p], auto_vendor),
          "forcing the platform auto chose opens the same driver (%s)", auto_vendor);
    if (strstr(auto_vendor, "Mesa"))
        check(opened[GV_GPU_PLATFORM_SURFACELESS],
              "Mesa: the surfaceless platform works");
    else
        check(1, "Mesa: the surfaceless platform works # SKIP the driver is "
                 "not Mesa (%s)", auto_vendor);
    return tap_done();
}
