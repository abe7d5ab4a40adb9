/*
 * fuzz_worker.c - libFuzzer target for the filter job protocol
 * (filters/worker.c): both ends' decoders of the frames the other end
 * sends.  gigaviewd trusts nothing a worker sends, and a worker should
 * survive anything on its socket.
 *
 * Byte 0 picks the reader, the rest is what arrives on the socket (then
 * end of file):
 *   0  the server reading a worker's hello;
 *   1  the server reading the answer to a 3x2-ROI run job;
 *   2  the server reading the answer to a compile job;
 *   3  the worker's loop (with no GPU: every compile and run job it
 *      decodes is answered "no GPU context", a simplify job runs on the
 *      CPU, through the mesh readers), its answers left unread;
 *   4  the server reading the answer to a simplify job (limits 64
 *      triangles, 192 vertices, an answer file of at most 4 KiB).
 * Byte 0's values 5..7 are mode 4 too (0..3 as before, so the seeds
 * keep their meaning).
 * Invariants: a reader returns one of the documented codes; a result it
 * accepts has exactly the ROI's floats, or a mesh of at most max_out
 * bytes with counts within the limits, and a known error code with a
 * printable message; hello text is printable.  Inputs are capped at
 * 16 KiB so that the worker's answers fit in the socket's buffer.
 */
#include <fcntl.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <unistd.h>

#include "fuzz.h"
#include "worker.h"

static void check_text(const char *s)
{
    for (; *s; s++)
        if (*s < 0x20 || *s > 0x7e)
            abort();
}

static void check_rc(int rc)
{
    if (rc != GV_WORKER_OK && rc != GV_WORKER_BAD && rc != GV_WORKER_EOF &&
        rc != GV_WORKER_TIMEOUT)
        abort();
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size < 1 || size > 16384)
        return 0;
    int mode = data[0] & 7;
    if (mode > 4)
        mode = 4;
    int sv[2];
    if (socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, sv) < 0)
        return 0;
    /* sv[1] is the peer: it sends the input, then end of file */
    if (write(sv[1], data + 1, size - 1) != (ssize_t)(size - 1))
        abort();
    struct gv_error err = {0};
    gv_error_clear(&err);
    if (mode == 3) {
        shutdown(sv[1], SHUT_WR);
        int rc = gv_worker_serve(sv[0], NULL, "fuzz", 64, &err);
        if (rc != 0 && rc != -1)
            abort();
        close(sv[0]);
        close(sv[1]); /* the answers, unread */
        return 0;
    }
    shutdown(sv[1], SHUT_WR);
    fcntl(sv[0], F_SETFL, O_NONBLOCK);
    int64_t deadline = gv_worker_now_ms() + 1000;
    if (mode == 0) {
        int ok = -1;
        char text[GV_WORKER_MSG_MAX + 1];
        int rc = gv_worker_recv_hello(sv[0], deadline, &ok, text, sizeof text, &err);
        check_rc(rc);
        if (rc == 0) {
            if (ok != 0 && ok != 1)
                abort();
            check_text(text);
        }
    } else if (mode == 4) {
        struct gv_worker_job job;
        memset(&job, 0, sizeof job);
        job.op = GV_WORKER_SIMPLIFY;
        job.mesh = (const uint8_t *)"ply";
        job.mesh_len = 3;
        job.simplify.faces = 10;
        job.simplify.format = GV_MESH_PLY;
        job.simplify.lim.max_bytes = 16384;
        job.simplify.lim.max_tris = 64;
        job.simplify.lim.max_verts = 192;
        job.max_out = 4096;
        struct gv_worker_result res;
        int rc = gv_worker_recv_result(sv[0], &job, deadline, &res, &err);
        check_rc(rc);
        if (rc == 0 && res.failed) {
            if (res.err.code <= GV_OK || res.err.code > GV_CODE_MAX || res.mesh)
                abort();
            check_text(res.err.text);
        } else if (rc == 0) {
            if (!res.mesh || res.mesh_len > job.max_out || res.out ||
                res.sstats.in_tris > 64 || res.sstats.in_verts > 192 ||
                res.sstats.out_tris > res.sstats.in_tris)
                abort();
            volatile uint8_t sum = 0;
            for (size_t i = 0; i < res.mesh_len; i++) /* all there (ASan) */
                sum ^= res.mesh[i];
            (void)sum;
        } else if (res.mesh) {
            abort();
        }
        free(res.mesh);
    } else {
        static const uint8_t rgba[4 * 4 * 4];
        static const double params[1] = {0};
        struct gv_worker_job job;
        memset(&job, 0, sizeof job);
        job.op = mode == 1 ? GV_WORKER_RUN : GV_WORKER_COMPILE;
        gv_filter_limits_default(&job.lim);
        job.doc = "{}";
        job.doc_len = 2;
        job.nparams = 1;
        job.in.w = 4;
        job.in.h = 4;
        job.in.rgba = rgba;
        job.in.roi_x = 1;
        job.in.roi_y = 1;
        job.in.roi_w = 3;
        job.in.roi_h = 2;
        job.in.params = params;
        struct gv_worker_result res;
        int rc = gv_worker_recv_result(sv[0], &job, deadline, &res, &err);
        check_rc(rc);
        if (rc == 0 && res.failed) {
            if (res.err.code <= GV_OK || res.err.code > GV_CODE_MAX || res.out)
                abort();
            check_text(res.err.text);
        } else if (rc == 0) {
            volatile float sum = 0;
            if (job.op == GV_WORKER_RUN) {
                if (!res.out)
                    abort();
                for (int i = 0; i < 3 * 2 * 4; i++) /* all there (ASan) */
                    sum += res.out[i];
            } else if (res.out) {
                abort();
            }
            (void)sum;
        }
        free(res.out);
    }
    close(sv[0]);
    close(sv[1]);
    return 0;
}
