/*
 * worker_main.c - gigaview-filter-worker, the sandboxed process that runs
 * filter graphs, and reads and simplifies uploaded meshes, for gigaviewd
 * (worker.h, docs/FILTERS.md section 9).
 *
 *   gigaview-filter-worker --fd N [--parent PID] [--memory-limit BYTES]
 *                          [--max-pixels N] [--gpu-platform PLATFORM]
 *
 * gigaviewd starts it with posix_spawn (server/filter_jobs.c) and talks
 * to it over the connected socket N.  Before it touches EGL or reads a
 * byte of input the process locks itself down:
 *
 *   - it dies with its parent (PR_SET_PDEATHSIG), and exits at once if
 *     the parent is already gone;
 *   - no new privileges, no core dumps;
 *   - RLIMIT_DATA = --memory-limit: heap and private mappings, which is
 *     what a runaway job grows.  RLIMIT_AS would be the obvious limit but
 *     GPU drivers reserve large address ranges they never touch, so a
 *     bound on address space breaks them while bounding nothing real;
 *   - every inherited descriptor but 0, 1, 2 and N is closed, and the
 *     signal mask and dispositions are reset.
 *
 * Then it opens its own EGL context (lib/gpu/gpu.h) on PLATFORM (auto,
 * device, surfaceless or default: gigaviewd passes its gpu_platform),
 * installs its seccomp filter (worker_seccomp.h: from here on a new
 * socket, a program or a process kills it), says hello (the platform, API
 * and renderer, or why there is no context) and answers jobs until the
 * socket closes.
 * Time limits are the server's business: it SIGKILLs a worker that
 * overruns one.
 */
#include <errno.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <unistd.h>

#include "gpu/gpu.h"
#include "worker.h"
#include "worker_seccomp.h"

#ifdef __SANITIZE_ADDRESS__
/* LeakSanitizer's check at exit stops the threads with a clone of its own
 * and ptrace, which the seccomp filter kills: no leak check here (the
 * job protocol is leak-checked under fuzz_worker's corpus replay). */
int __lsan_is_turned_off(void);
int __lsan_is_turned_off(void)
{
    return 1;
}
#endif

static void usage(void)
{
    fprintf(stderr, "usage: gigaview-filter-worker --fd N [--parent PID] "
                    "[--memory-limit BYTES] [--max-pixels N]\n"
                    "       [--gpu-platform auto|device|surfaceless|default]\n"
                    "(started by gigaviewd; see docs/FILTERS.md section 9)\n");
}

/* Strict decimal: digits only, no overflow. */
static int parse_u64(const char *s, uint64_t *out)
{
    if (!s || !*s)
        return -1;
    uint64_t v = 0;
    for (; *s; s++) {
        if (*s < '0' || *s > '9' || v > (UINT64_MAX - 9) / 10)
            return -1;
        v = v * 10 + (uint64_t)(*s - '0');
    }
    *out = v;
    return 0;
}

static void say(const char *what, const char *detail)
{
    fprintf(stderr, "gigaview-filter-worker[%ld]: %s%s%s\n", (long)getpid(),
            what, detail ? ": " : "", detail ? detail : "");
}

/* Close every descriptor above 2 except keep. */
static void close_others(int keep)
{
    if (keep > 3)
        close_range(3, (unsigned)keep - 1, 0);
    close_range((unsigned)keep + 1, ~0u, 0);
}

/* Does the context draw in software (no kernel GPU driver, no ioctl)? */
static int software_renderer(const struct gv_gpu *gpu)
{
    const char *r = gpu ? gv_gpu_info(gpu)->renderer : "";
    return !gpu || strstr(r, "llvmpipe") || strstr(r, "softpipe") ||
           strstr(r, "SwiftShader");
}

static void reset_signals(void)
{
    sigset_t none;
    sigemptyset(&none);
    sigprocmask(SIG_SETMASK, &none, NULL);
    /* Dispositions set to "ignore" survive exec; put back the defaults. */
    for (int s = 1; s < NSIG; s++)
        if (s != SIGKILL && s != SIGSTOP)
            signal(s, SIG_DFL);
    /* Writes to a closed socket are errors (MSG_NOSIGNAL), not deaths. */
    signal(SIGPIPE, SIG_IGN);
}

int main(int argc, char **argv)
{
    uint64_t fd = UINT64_MAX, parent = 0, mem = 0, max_pixels = 4u << 20;
    int platform = GV_GPU_PLATFORM_AUTO;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--gpu-platform")) {
            if (i + 1 >= argc || (platform = gv_gpu_platform_parse(argv[++i])) < 0) {
                usage();
                return 2;
            }
            continue;
        }
        uint64_t *dst = !strcmp(argv[i], "--fd")             ? &fd
                        : !strcmp(argv[i], "--parent")       ? &parent
                        : !strcmp(argv[i], "--memory-limit") ? &mem
                        : !strcmp(argv[i], "--max-pixels")   ? &max_pixels
                                                             : NULL;
        if (!dst || i + 1 >= argc || parse_u64(argv[i + 1], dst) < 0) {
            usage();
            return 2;
        }
        i++;
    }
    if (fd < 3 || fd > 1024 || max_pixels == 0) {
        usage();
        return 2;
    }
    if (prctl(PR_SET_PDEATHSIG, SIGKILL) < 0 ||
        (parent && (uint64_t)getppid() != parent)) {
        say("parent gone or PR_SET_PDEATHSIG refused", NULL);
        return 1;
    }
    if (prctl(PR_SET_NO_NEW_PRIVS, 1, 0, 0, 0) < 0)
        say("PR_SET_NO_NEW_PRIVS refused", strerror(errno));
    struct rlimit zero = {0, 0};
    setrlimit(RLIMIT_CORE, &zero);
#ifdef __SANITIZE_ADDRESS__
    /* AddressSanitizer's shadow is terabytes of private mappings, which
     * RLIMIT_DATA counts: no limit can be applied in such a build. */
    if (mem) {
        say("memory limit not applied", "built with AddressSanitizer");
        mem = 0;
    }
#endif
    if (mem) {
        struct rlimit lim = {(rlim_t)mem, (rlim_t)mem};
        if (setrlimit(RLIMIT_DATA, &lim) < 0) {
            say("cannot set RLIMIT_DATA", strerror(errno));
            return 1;
        }
    }
    close_others((int)fd);
    reset_signals();

    struct gv_error err = {0};
    gv_error_clear(&err);
    struct gv_gpu *gpu = gv_gpu_open((enum gv_gpu_platform)platform, &err);
    char hello[GV_WORKER_MSG_MAX + 1];
    if (gpu) {
        const struct gv_gpu_info *in = gv_gpu_info(gpu);
        snprintf(hello, sizeof hello, "%s, %s: %s", in->platform, in->api,
                 in->renderer);
    } else {
        snprintf(hello, sizeof hello, "%s", err.text[0] ? err.text
                                                        : "gpu: no EGL context");
    }
    if (gv_worker_seccomp(!software_renderer(gpu), &err) < 0) {
        say("stopping", err.text);
        gv_gpu_close(gpu);
        return 1;
    }
    int rc = gv_worker_serve((int)fd, gpu, hello, max_pixels, &err);
    if (rc < 0)
        say("stopping", err.text);
    gv_gpu_close(gpu);
    close((int)fd);
    return rc < 0 ? 1 : 0;
}
