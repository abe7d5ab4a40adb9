/*
 * cmd_simplify.c - `gigaview simplify IN -o OUT (--faces N | --ratio R)
 * [--cpu | --gpu] [--format F] [--interp paper]`: vertex-clustering
 * simplification with face-count control (Kanaya et al.;
 * lib/mesh/cluster.h) of a PLY, OBJ or GLB triangle mesh, written as GLB,
 * PLY or OBJ.  The selection runs on the GPU through EGL when one opens
 * (--gpu insists, --cpu never tries); both give the same file.  Prints
 * the faces asked and achieved and the time of each step.
 */
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "base/atomic_file.h"
#include "commands.h"
#include "config.h"
#include "mesh/cluster_run.h"
#include "options.h"
#ifdef GV_HAVE_GPU
#include "gpu/gpu.h"
#include "gpu/gpu_cluster.h"
#endif

#define ME "gigaview simplify"

struct simplify_args {
    const char *output, *format, *interp;
    uint64_t faces;
    double ratio;
    int cpu, gpu;
};

#define F(field) offsetof(struct simplify_args, field)
static const struct opt_spec simplify_opts[] = {
    {.name = "output", .short_name = 'o', .kind = OPT_STRING, .arg = "OUT",
     .field = F(output), .help = "the simplified mesh"},
    {.name = "faces", .short_name = 'n', .kind = OPT_COUNT, .arg = "N",
     .field = F(faces), .help = "about N triangles (nearest reachable)"},
    {.name = "ratio", .short_name = 'r', .kind = OPT_DOUBLE, .arg = "R",
     .field = F(ratio), .min = 0, .max = 1, .flags = OPT_FINITE,
     .help = "R times the input's triangles (0..1)"},
    {.name = "format", .short_name = 'f', .kind = OPT_STRING, .arg = "F",
     .field = F(format),
     .help = "glb, ply or obj (default: by the extension of OUT)"},
    {.name = "interp", .kind = OPT_STRING, .arg = "exact|paper",
     .field = F(interp),
     .help = "level choice: nearest face count (default) or Kanaya eq. 3"},
    {.name = "cpu", .kind = OPT_FLAG, .field = F(cpu),
     .help = "select on the CPU"},
    {.name = "gpu", .kind = OPT_FLAG, .field = F(gpu),
     .help = "select on the GPU (fail without one)"},
};
#undef F

static const struct opt_command simplify_command = {
    .me = ME,
    .synopsis = "usage: gigaview simplify IN -o OUT (--faces N | --ratio R)\n"
                "       [--cpu | --gpu] [--format F] [--interp exact|paper]\n"
                "IN: a triangle mesh, PLY (ascii or binary), OBJ or GLB\n",
    .opts = simplify_opts,
    .nopts = sizeof simplify_opts / sizeof simplify_opts[0],
};

static uint8_t *read_all(const char *path, size_t *len)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return NULL;
    size_t cap = 1 << 16, n = 0;
    uint8_t *b = malloc(cap);
    while (b) {
        if (n == cap) {
            uint8_t *q = cap > (SIZE_MAX >> 1) ? NULL : realloc(b, cap * 2);
            if (!q) {
                free(b);
                b = NULL;
                break;
            }
            b = q;
            cap *= 2;
        }
        size_t r = fread(b + n, 1, cap - n, f);
        n += r;
        if (r == 0)
            break;
    }
    if (b && ferror(f)) {
        free(b);
        b = NULL;
    }
    fclose(f);
    *len = n;
    return b;
}

int cmd_simplify(int argc, char **argv)
{
    struct simplify_args a = {.ratio = -1};
    int first, rc = opt_parse(&simplify_command, argc, argv, &a, &first);
    if (rc != OPT_GO_ON)
        return rc;
    if (!a.output || first != argc - 1 || (a.faces == 0) == (a.ratio < 0) ||
        (a.cpu && a.gpu)) {
        opt_usage(&simplify_command, stderr);
        return 2;
    }
    struct gv_simplify_opts o = {.faces = a.faces, .ratio = a.ratio,
                                 .mode = GV_CLUSTER_EXACT};
    if (a.interp && strcmp(a.interp, "paper") == 0)
        o.mode = GV_CLUSTER_PAPER;
    else if (a.interp && strcmp(a.interp, "exact") != 0) {
        fprintf(stderr, ME ": --interp is exact or paper, not '%s'\n",
                a.interp);
        return 2;
    }
    const char *fname = a.format;
    if (!fname) {
        const char *dot = strrchr(a.output, '.');
        fname = dot ? dot + 1 : "";
    }
    if (gv_mesh_format_parse(fname, &o.format) < 0 ||
        o.format == GV_MESH_QMESH) {
        fprintf(stderr, ME ": unknown format '%s' (glb, ply, obj)\n", fname);
        return 2;
    }
    size_t len = 0;
    uint8_t *in = read_all(argv[first], &len);
    if (!in) {
        fprintf(stderr, ME ": cannot read %s\n", argv[first]);
        return 1;
    }
    struct gv_error err = {0};
    const char *where = "cpu";
#ifdef GV_HAVE_GPU
    struct gv_gpu *gpu = NULL;
    if (!a.cpu) {
        gpu = gv_gpu_open(GV_GPU_PLATFORM_AUTO, &err);
        if (!gpu && a.gpu) {
            fprintf(stderr, ME ": %s\n", err.text);
            free(in);
            return 1;
        }
        if (gpu) {
            o.select = gv_gpu_cluster_run;
            o.select_ctx = gpu;
            where = "gpu";
        }
    }
#else
    if (a.gpu) {
        fprintf(stderr, ME ": this build has no GPU support\n");
        free(in);
        return 1;
    }
#endif
    uint8_t *out = NULL;
    size_t out_len = 0;
    struct gv_simplify_stats st;
    rc = 1;
    if (gv_simplify(in, len, &o, &out, &out_len, &st, &err) < 0 ||
        gv_atomic_file_write(a.output, out, out_len, NULL, &err) < 0) {
        fprintf(stderr, ME ": %s\n", err.text);
    } else {
        printf("simplify: %u vertices, %u triangles -> %u vertices, %u "
               "triangles (asked %llu, %+.2f%%), level %u of %u, %s; "
               "read %.3f ms, build %.3f ms, select %.3f ms, write %.3f ms\n",
               st.in_verts, st.in_tris, st.out_verts, st.out_tris,
               (unsigned long long)st.asked,
               st.asked ? 100.0 * ((double)st.out_tris - (double)st.asked) /
                              (double)st.asked : 0.0,
               st.level, st.nnodes, where, st.read_ms, st.build_ms,
               st.select_ms, st.write_ms);
        rc = 0;
    }
#ifdef GV_HAVE_GPU
    gv_gpu_close(gpu);
#endif
    free(out);
    free(in);
    return rc;
}
