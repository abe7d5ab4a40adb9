/*
 * commands.h - the subcommands of the `gigaview` tool, one file each,
 * listed in the table in gigaview.c.
 */
#ifndef GV_COMMANDS_H
#define GV_COMMANDS_H

/* Each returns the process exit status: 0 success, 1 failure, 2 usage. */
int cmd_encode(int argc, char **argv);
int cmd_info(int argc, char **argv);
int cmd_export(int argc, char **argv);
int cmd_render(int argc, char **argv);
int cmd_merge(int argc, char **argv);
int cmd_mesh(int argc, char **argv);
int cmd_view(int argc, char **argv);
int cmd_simplify(int argc, char **argv);
int cmd_token(int argc, char **argv);

#endif
