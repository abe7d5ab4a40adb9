/*
 * gigaview.c - entry point of the `gigaview` tool: dispatches to the
 * subcommand named by the first argument (table below).  Each command
 * parses the rest of argv against its own option table (options.h).
 */
#include <stdio.h>
#include <string.h>

#include "commands.h"
#include "config.h"

struct command {
    const char *name;
    int (*run)(int argc, char **argv);
    const char *summary;
};

static const struct command commands[] = {
    {"encode", cmd_encode, "encode images into a store file"},
    {"merge", cmd_merge, "assemble the shard files of 'encode --shard' into a store"},
    {"info", cmd_info, "describe a store: size, levels, tiles, bits per pixel"},
    {"export", cmd_export, "decode a region of a store to PNG, TIFF or JPEG"},
    {"mesh", cmd_mesh, "the TIN of a region of a height field: GLB, quantized-mesh, PLY, OBJ"},
    {"simplify", cmd_simplify, "vertex clustering of a PLY/OBJ/GLB mesh to a face count"},
    {"token", cmd_token, "mint an access token for gigaviewd's protected images"},
#ifdef GV_HAVE_GPU
    {"render", cmd_render, "fetch tiles from gigaviewd, decode them on the GPU, write an image"},
#else
    {"render", cmd_render, "needs GPU support, which this build lacks (--without-gpu)"},
#endif
#if defined(GV_HAVE_GPU) && defined(GV_HAVE_SDL2)
    {"view", cmd_view, "a window on gigaviewd's images: pan, zoom, rotate (GPU, SDL2)"},
#else
    {"view", cmd_view, "needs GPU and SDL2 support, which this build lacks"},
#endif
};

static void usage(FILE *out)
{
    fprintf(out, "usage: gigaview COMMAND [ARGS]\n\ncommands:\n");
    for (size_t i = 0; i < sizeof commands / sizeof commands[0]; i++)
        fprintf(out, "  %-8s %s\n", commands[i].name, commands[i].summary);
    fprintf(out, "\noptions:\n"
                 "  -h, --help     print this help and exit\n"
                 "      --version  print the version and exit\n"
                 "\n'gigaview COMMAND --help' describes a command.\n");
}

int main(int argc, char **argv)
{
    if (argc < 2) {
        usage(stderr);
        return 2;
    }
    if (!strcmp(argv[1], "--help") || !strcmp(argv[1], "-h")) {
        usage(stdout);
        return 0;
    }
    if (!strcmp(argv[1], "--version")) {
        printf("gigaview %s\n", PACKAGE_VERSION);
        return 0;
    }
    for (size_t i = 0; i < sizeof commands / sizeof commands[0]; i++)
        if (!strcmp(argv[1], commands[i].name)) {
            /* getopt prefixes its messages with argv[0]: "gigaview CMD". */
            char name[64];
            snprintf(name, sizeof name, "gigaview %s", commands[i].name);
            argv[1] = name;
            return commands[i].run(argc - 1, argv + 1);
        }
    fprintf(stderr, "gigaview: unknown command '%s'\n", argv[1]);
    usage(stderr);
    return 2;
}
