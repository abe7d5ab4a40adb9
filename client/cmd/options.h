/*
 * options.h - the command-line options of the gigaview subcommands,
 * declared once in a table per command.
 *
 * A table row names an option (long name, optional short letter, an
 * optional second long name), the kind of argument it takes, the range a
 * number must lie in, the field it fills (an offset into the command's
 * own argument struct) and its help.  One parser, opt_parse(), reads argv
 * against the table with getopt_long, so options and operands may come
 * in any order, long names may be abbreviated and getopt itself reports
 * unknown options; it converts and range-checks every value, and prints
 * the same message for a bad value whatever the command.  The help of
 * each command is made from the same table by opt_usage().  (As redis
 * declares its configuration in static_configs[], or libvips the
 * arguments of an operation.)
 */
#ifndef GV_OPTIONS_H
#define GV_OPTIONS_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

/* A macro's value as a string literal, for help texts: OPT_STR(GV_MAX_RATE). */
#define OPT_STR_(x) #x
#define OPT_STR(x) OPT_STR_(x)

enum opt_kind {
    OPT_FLAG,    /* no argument; int field set to 1 */
    OPT_STRING,  /* const char * field: the argument itself (points into argv) */
    OPT_INT,     /* int field: decimal (strtol over the whole argument), in min..max */
    OPT_DOUBLE,  /* double field: strtod over the whole argument, not nan, in min..max */
    OPT_COUNT,   /* uint64_t field: parse_count (digits only, at least 1) */
    OPT_CUSTOM,  /* the row's parse function fills what it wants */
};

/* Flags of a row. */
#define OPT_FINITE   1u   /* OPT_DOUBLE: refuse inf too (nan is always refused:
                             it would pass every range check) */
#define OPT_MIN_OPEN 2u   /* the range excludes min itself */
#define OPT_NO_ECHO  4u   /* the message for a bad value does not quote it */

/* Fills from the argument whatever fields of the command's struct (at
 * `fields`) it stands for.  Returns 0, or -1 for a bad value; it may then
 * point *wants at a more precise text than the row's. */
typedef int opt_parse_fn(const char *arg, void *fields, const char **wants);

struct opt_spec {
    const char *name;        /* long name, without the "--" */
    char short_name;         /* short letter, 0 for none */
    enum opt_kind kind;
    const char *arg;         /* the argument's name in the help ("N", "WxH") */
    size_t field;            /* offsetof the field in the command's struct
                                (unused by OPT_CUSTOM) */
    double min, max;         /* OPT_INT, OPT_DOUBLE: the accepted range */
    unsigned flags;          /* OPT_FINITE, OPT_MIN_OPEN, OPT_NO_ECHO */
    /* What a bad value is told: "ME: --NAME wants WANTS, not 'ARG'" (or
     * without ", not 'ARG'" under OPT_NO_ECHO); NULL: "ME: bad --NAME 'ARG'". */
    const char *wants;
    opt_parse_fn *parse;     /* OPT_CUSTOM only */
    const char *help;        /* lines separated by '\n', no final '\n' */
    const char *alias;       /* a second long name, not in the help; or NULL */
};

struct opt_command {
    const char *me;              /* "gigaview encode": prefix of messages */
    const char *synopsis;        /* help text before the options, "\n"-ended */
    const struct opt_spec *opts; /* the table, in the order the help lists it */
    size_t nopts;
};

/* opt_parse's answer when the command should go on. */
#define OPT_GO_ON (-1)

/* Parse argv[1..argc) against cmd's table, filling the struct at `fields`
 * (set its defaults first); -h and --help are implied.  Options and
 * operands may be mixed: getopt_long moves the operands to the end of
 * argv.  Returns OPT_GO_ON with *first_operand the index of the first
 * operand in argv; or the exit status the command should end with: 0
 * after --help (the help is on stdout), 2 after a usage error (a message
 * on stderr, and for an unknown option or a missing argument also the
 * help).  Not thread-safe (getopt's state is global). */
int opt_parse(const struct opt_command *cmd, int argc, char **argv, void *fields,
              int *first_operand);

/* Print cmd's help on out: the synopsis, then for each option a line
 * "  -s, --name ARG     help", continuation lines aligned under the
 * help, and last -h, --help. */
void opt_usage(const struct opt_command *cmd, FILE *out);

/* Parse a positive decimal count: digits only (no sign, no spaces), no
 * overflow, at least 1.  Returns 0 and sets *out, or -1.  (strtoull alone
 * would take "-5" as a huge number and skip leading spaces.) */
int parse_count(const char *s, unsigned long long *out);

#endif
