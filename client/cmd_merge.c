/*
 * cmd_merge.c - `gigaview merge -o STORE SHARD...`: the shard files of
 * `gigaview encode --shard I/N` to a store (lib/encode/shard_merge.h).
 *
 * The shards may be listed in any order; all N of them are needed.  The
 * store is written atomically, like encode's, and is byte for byte the
 * store an unsharded encode of the same input with the same options
 * writes.
 */
#include <getopt.h>
#include <stdio.h>

#include "commands.h"
#include "encode/shard_merge.h"
#include "store/store_read.h"
#include "summary.h"

static void usage(FILE *out)
{
    fprintf(out,
        "usage: gigaview merge [OPTIONS] -o STORE SHARD...\n"
        "\n"
        "Assemble the N shard files written by 'gigaview encode --shard I/N'\n"
        "(in any order) into STORE.  Fails, writing nothing, unless every\n"
        "shard is there and all come from the same input and options.\n"
        "\n"
        "  -o, --output STORE     store file to write (replaced atomically)\n"
        "      --quiet            no summary\n");
}

int cmd_merge(int argc, char **argv)
{
    enum { OPT_QUIET = 256 };
    static const struct option longopts[] = {
        {"output", required_argument, NULL, 'o'},
        {"quiet", no_argument, NULL, OPT_QUIET},
        {"help", no_argument, NULL, 'h'},
        {NULL, 0, NULL, 0},
    };
    const char *output = NULL;
    int quiet = 0, c;
    optind = 1;
    while ((c = getopt_long(argc, argv, "o:h", longopts, NULL)) != -1) {
        switch (c) {
        case 'o':
            output = optarg;
            break;
        case OPT_QUIET:
            quiet = 1;
            break;
        case 'h':
            usage(stdout);
            return 0;
        default:
            usage(stderr);
            return 2;
        }
    }
    if (!output || optind >= argc) {
        usage(stderr);
        return 2;
    }
    struct gv_encode_result r;
    struct gv_error err;
    gv_error_clear(&err);
    if (gv_shard_merge((const char *const *)argv + optind, argc - optind, output,
                       &r, &err) < 0) {
        fprintf(stderr, "gigaview merge: %s\n", err.text);
        return 1;
    }
    if (quiet)
        return 0;
    /* The per-tile target the shards were encoded with, from the header. */
    struct gv_store *s = gv_store_open(output, &err);
    if (!s) {
        fprintf(stderr, "gigaview merge: %s\n", err.text);
        return 1;
    }
    double target = gv_store_info(s)->header.target_mpsnr / 1000.0;
    gv_store_close(s);
    print_store_summary(output, &r, target);
    return 0;
}
