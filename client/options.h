/*
 * options.h - strict parsing of command-line numbers shared by the
 * gigaview subcommands.
 */
#ifndef GV_OPTIONS_H
#define GV_OPTIONS_H

/* Parse a positive decimal count: digits only (no sign, no spaces), no
 * overflow, at least 1.  Returns 0 and sets *out, or -1. */
int parse_count(const char *s, unsigned long long *out);

#endif
