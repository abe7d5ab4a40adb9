/*
 * cmd_merge.c - `gigaview merge -o STORE SHARD...`: the shard files of
 * `gigaview encode --shard I/N` to a store (lib/encode/shard_merge.h).
 *
 * The shards may be listed in any order; all N of them are needed.  The
 * store is written atomically, like encode's, and is byte for byte the
 * store an unsharded encode of the same input with the same options
 * writes.
 */
#include <stddef.h>
#include <stdio.h>

#include "commands.h"
#include "encode/shard_merge.h"
#include "options.h"
#include "store/store_read.h"
#include "summary.h"

#define ME "gigaview merge"

struct merge_args {
    const char *output;
    int quiet;
};

#define F(field) offsetof(struct merge_args, field)
static const struct opt_spec merge_opts[] = {
    {.name = "output", .short_name = 'o', .kind = OPT_STRING, .arg = "STORE",
     .field = F(output), .help = "store file to write (replaced atomically)"},
    {.name = "quiet", .kind = OPT_FLAG, .field = F(quiet), .help = "no summary"},
};
#undef F

static const struct opt_command merge_command = {
    .me = ME,
    .synopsis =
        "usage: gigaview merge [OPTIONS] -o STORE SHARD...\n"
        "\n"
        "Assemble the N shard files written by 'gigaview encode --shard I/N'\n"
        "(in any order) into STORE.  Fails, writing nothing, unless every\n"
        "shard is there and all come from the same input and options.\n",
    .opts = merge_opts,
    .nopts = sizeof merge_opts / sizeof merge_opts[0],
};

/* Print the summary of the store just merged to `output`, with the
 * per-tile target the shards were encoded with (from its header).
 * Returns the exit status. */
static int print_summary(const char *output, const struct gv_encode_result *r)
{
    struct gv_error err = {0};
    struct gv_store *s = gv_store_open(output, &err);
    if (!s) {
        fprintf(stderr, ME ": %s\n", err.text);
        return 1;
    }
    double target = gv_store_info(s)->header.target_mpsnr / 1000.0;
    gv_store_close(s);
    print_store_summary(output, r, target);
    return 0;
}

int cmd_merge(int argc, char **argv)
{
    struct merge_args a = {0};
    int first, rc = opt_parse(&merge_command, argc, argv, &a, &first);
    if (rc != OPT_GO_ON)
        return rc;
    if (!a.output || first >= argc) {
        opt_usage(&merge_command, stderr);
        return 2;
    }
    struct gv_encode_result r;
    struct gv_error err = {0};
    gv_error_clear(&err);
    if (gv_shard_merge((const char *const *)argv + first, argc - first, a.output,
                       &r, &err) < 0) {
        fprintf(stderr, ME ": %s\n", err.text);
        return 1;
    }
    return a.quiet ? 0 : print_summary(a.output, &r);
}
