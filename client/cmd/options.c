/*
 * options.c - the table-driven command-line parser of the gigaview
 * subcommands (options.h).
 *
 * opt_parse() builds getopt_long's option array and short-option string
 * from the table, lets getopt find each option and its argument, then
 * converts the argument by the row's kind.  A long-only option gets a
 * getopt value above every character (256 + its row), so a row's value
 * leads back to it; a row's alias gets the same value, which also keeps
 * getopt from calling an abbreviation of both names ambiguous.
 */
#include <assert.h>
#include <getopt.h>
#include <limits.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "options.h"

/* Rows a table may have; each takes at most two getopt entries (name and
 * alias), plus --help and the terminator. */
#define MAX_ROWS 32
#define HELP_COLUMN 25   /* where the help text of an option starts */

int parse_count(const char *s, unsigned long long *out)
{
    unsigned long long v = 0;
    if (!*s)
        return -1;
    for (; *s; s++) {
        if (*s < '0' || *s > '9')
            return -1;
        unsigned d = (unsigned)(*s - '0');
        if (v > (ULLONG_MAX - d) / 10)
            return -1;
        v = v * 10 + d;
    }
    if (v == 0)
        return -1;
    *out = v;
    return 0;
}

/* getopt_long's value for row i. */
static int row_value(const struct opt_spec *o, size_t i)
{
    return o->short_name ? (unsigned char)o->short_name : 256 + (int)i;
}

/* Fill getopt_long's arrays from the table: `longopts` (2 * MAX_ROWS + 2
 * entries) and `shortopts` (3 * MAX_ROWS + 2 bytes). */
static void getopt_tables(const struct opt_command *cmd, struct option *longopts,
                          char *shortopts)
{
    size_t nl = 0, ns = 0;
    assert(cmd->nopts <= MAX_ROWS);
    for (size_t i = 0; i < cmd->nopts; i++) {
        const struct opt_spec *o = &cmd->opts[i];
        int has_arg = o->kind == OPT_FLAG ? no_argument : required_argument;
        longopts[nl++] = (struct option){o->name, has_arg, NULL, row_value(o, i)};
        if (o->alias)
            longopts[nl++] = (struct option){o->alias, has_arg, NULL, row_value(o, i)};
        if (o->short_name) {
            shortopts[ns++] = o->short_name;
            if (has_arg)
                shortopts[ns++] = ':';
        }
    }
    longopts[nl++] = (struct option){"help", no_argument, NULL, 'h'};
    longopts[nl] = (struct option){NULL, 0, NULL, 0};
    shortopts[ns++] = 'h';
    shortopts[ns] = '\0';
}

static int in_range(const struct opt_spec *o, double v)
{
    if (o->flags & OPT_MIN_OPEN ? v <= o->min : v < o->min)
        return 0;
    return !(v > o->max);
}

/* Convert `arg` by the row's kind into its field of `fields`.  Returns 0,
 * or -1 with *wants possibly replaced by a custom parser. */
static int convert(const struct opt_spec *o, const char *arg, void *fields,
                   const char **wants)
{
    void *field = (char *)fields + o->field;
    char *end;
    switch (o->kind) {
    case OPT_FLAG:
        *(int *)field = 1;
        return 0;
    case OPT_STRING:
        *(const char **)field = arg;
        return 0;
    case OPT_INT: {
        long v = strtol(arg, &end, 10);
        if (end == arg || *end || !in_range(o, (double)v))
            return -1;
        *(int *)field = (int)v;
        return 0;
    }
    case OPT_DOUBLE: {
        double v = strtod(arg, &end);
        if (end == arg || *end || isnan(v) || ((o->flags & OPT_FINITE) && !isfinite(v)) ||
            !in_range(o, v))
            return -1;
        *(double *)field = v;
        return 0;
    }
    case OPT_COUNT: {
        unsigned long long v;
        if (parse_count(arg, &v) < 0)
            return -1;
        *(uint64_t *)field = v;
        return 0;
    }
    case OPT_CUSTOM:
        return o->parse(arg, fields, wants);
    }
    return -1;
}

static void complain(const struct opt_command *cmd, const struct opt_spec *o,
                     const char *wants, const char *arg)
{
    if (!wants)
        fprintf(stderr, "%s: bad --%s '%s'\n", cmd->me, o->name, arg);
    else if (o->flags & OPT_NO_ECHO)
        fprintf(stderr, "%s: --%s wants %s\n", cmd->me, o->name, wants);
    else
        fprintf(stderr, "%s: --%s wants %s, not '%s'\n", cmd->me, o->name, wants, arg);
}

static const struct opt_spec *row_of(const struct opt_command *cmd, int value)
{
    for (size_t i = 0; i < cmd->nopts; i++)
        if (row_value(&cmd->opts[i], i) == value)
            return &cmd->opts[i];
    return NULL;
}

int opt_parse(const struct opt_command *cmd, int argc, char **argv, void *fields,
              int *first_operand)
{
    struct option longopts[2 * MAX_ROWS + 2];
    char shortopts[3 * MAX_ROWS + 2];
    getopt_tables(cmd, longopts, shortopts);
    int c;
    optind = 1;
    while ((c = getopt_long(argc, argv, shortopts, longopts, NULL)) != -1) {
        if (c == 'h') {
            opt_usage(cmd, stdout);
            return 0;
        }
        const struct opt_spec *o = row_of(cmd, c);
        if (!o) {               /* '?': getopt has said what is wrong */
            opt_usage(cmd, stderr);
            return 2;
        }
        const char *arg = o->kind == OPT_FLAG ? NULL : optarg;
        const char *wants = o->wants;
        if (convert(o, arg, fields, &wants) < 0) {
            complain(cmd, o, wants, arg);
            return 2;
        }
    }
    *first_operand = optind;
    return OPT_GO_ON;
}

/* One option's help: "  -s, --name ARG" padded to HELP_COLUMN, then the
 * help's lines, every one after the first indented to HELP_COLUMN. */
static void usage_row(FILE *out, char short_name, const char *name, const char *arg,
                      const char *help)
{
    char head[64];
    snprintf(head, sizeof head, "--%s%s%s", name, arg ? " " : "", arg ? arg : "");
    const int width = HELP_COLUMN - 7;   /* "  -s, " before, one space after */
    /* A head wider than its column gets a line of its own. */
    const int own_line = (int)strlen(head) > width;
    if (short_name)
        fprintf(out, "  -%c, %-*s", short_name, width, head);
    else
        fprintf(out, "      %-*s", width, head);
    fputs(own_line ? "\n" : " ", out);
    for (const char *line = help; line;) {
        const char *nl = strchr(line, '\n');
        int len = nl ? (int)(nl - line) : (int)strlen(line);
        if (line != help || own_line)
            fprintf(out, "%*s", HELP_COLUMN, "");
        fprintf(out, "%.*s\n", len, line);
        line = nl ? nl + 1 : NULL;
    }
}

void opt_usage(const struct opt_command *cmd, FILE *out)
{
    fputs(cmd->synopsis, out);
    fputc('\n', out);
    for (size_t i = 0; i < cmd->nopts; i++) {
        const struct opt_spec *o = &cmd->opts[i];
        usage_row(out, o->short_name, o->name, o->kind == OPT_FLAG ? NULL : o->arg,
                  o->help);
    }
    usage_row(out, 'h', "help", NULL, "print this help and exit");
}
