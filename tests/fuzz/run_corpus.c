/*
 * run_corpus.c - replays fuzz inputs without libFuzzer.
 *
 * `run_fuzz_X FILE-OR-DIR...` calls LLVMFuzzerTestOneInput once for every
 * file (directories are read one level deep, in name order) and speaks
 * TAP, one line per input.  `make check` runs it over the committed seed
 * corpus with gcc, so every seed and every past crash stays a regression
 * test; a crash or sanitizer report fails the test.  Each input is copied
 * into an allocation of exactly its size, as libFuzzer does, so that
 * AddressSanitizer builds catch overreads.
 */
#include <dirent.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "fuzz.h"

static int count;

static int run_file(const char *path)
{
    FILE *f = fopen(path, "rb");
    if (!f) {
        printf("not ok %d - %s: cannot open\n", ++count, path);
        return -1;
    }
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    uint8_t *data = malloc(n > 0 ? (size_t)n : 1);
    if (!data || n < 0 || fread(data, 1, (size_t)n, f) != (size_t)n) {
        fclose(f);
        free(data);
        printf("not ok %d - %s: cannot read\n", ++count, path);
        return -1;
    }
    fclose(f);
    uint8_t *exact = malloc(n > 0 ? (size_t)n : 1);
    if (!exact)
        abort();
    memcpy(exact, data, (size_t)n);
    free(data);
    printf("# %s (%ld bytes)\n", path, n);
    fflush(stdout);
    LLVMFuzzerTestOneInput(exact, (size_t)n);
    free(exact);
    printf("ok %d - %s\n", ++count, path);
    fflush(stdout);
    return 0;
}

static int by_name(const void *a, const void *b)
{
    return strcmp(*(char *const *)a, *(char *const *)b);
}

static int run_dir(const char *dir)
{
    DIR *d = opendir(dir);
    if (!d) {
        printf("not ok %d - %s: cannot open the directory\n", ++count, dir);
        return -1;
    }
    char **names = NULL;
    size_t n = 0, cap = 0;
    struct dirent *e;
    while ((e = readdir(d)) != NULL) {
        if (e->d_name[0] == '.')
            continue;
        if (n == cap) {
            cap = cap ? 2 * cap : 64;
            char **bigger = realloc(names, cap * sizeof *names);
            if (!bigger)
                abort();
            names = bigger;
        }
        size_t len = strlen(dir) + strlen(e->d_name) + 2;
        names[n] = malloc(len);
        if (!names[n])
            abort();
        snprintf(names[n], len, "%s/%s", dir, e->d_name);
        n++;
    }
    closedir(d);
    qsort(names, n, sizeof *names, by_name);
    int rc = 0;
    for (size_t i = 0; i < n; i++) {
        struct stat st;
        if (stat(names[i], &st) == 0 && S_ISREG(st.st_mode) && run_file(names[i]) < 0)
            rc = -1;
        free(names[i]);
    }
    free(names);
    if (n == 0) {
        printf("not ok %d - %s: empty corpus\n", ++count, dir);
        rc = -1;
    }
    return rc;
}

int main(int argc, char **argv)
{
    int rc = 0;
    if (argc < 2) {
        fprintf(stderr, "usage: %s FILE-OR-DIR...\n", argv[0]);
        return 2;
    }
    for (int i = 1; i < argc; i++) {
        struct stat st;
        if (stat(argv[i], &st) == 0 && S_ISDIR(st.st_mode))
            rc |= run_dir(argv[i]);
        else
            rc |= run_file(argv[i]);
    }
    printf("1..%d\n", count);
    return rc ? 1 : 0;
}
