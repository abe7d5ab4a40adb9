#!/bin/sh
# run-test.sh - runs one C test program, under valgrind when VALGRIND is set
# (make check VALGRIND=1).  Valgrind errors and definite leaks fail the
# test with status 99.
if [ -n "$VALGRIND" ] && [ "$VALGRIND" != 0 ]; then
    exec valgrind -q --error-exitcode=99 --leak-check=full \
        --errors-for-leak-kinds=definite --show-leak-kinds=definite "$@"
fi
exec "$@"
