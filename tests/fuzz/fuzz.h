/*
 * fuzz.h - what the fuzz targets share with their drivers.
 *
 * Each target (fuzz_*.c) defines LLVMFuzzerTestOneInput.
 * Built with --enable-fuzzing it links against libFuzzer; otherwise
 * run_corpus.c supplies main() and replays a corpus, so `make check` runs
 * every committed case (and every past crash) as a regression test.
 */
#ifndef GV_FUZZ_H
#define GV_FUZZ_H

#include <stddef.h>
#include <stdint.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

#endif
