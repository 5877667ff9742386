/* fuzz_run_seeds: runs a libFuzzer harness (linked beside it) over the files given or the files
 * of the folders given, as the fuzzer's own reproducer mode does, in an ordinary build without
 * clang: ctest's fuzz_http_seeds runs fuzz_http over its committed seeds, so a seed that makes
 * the harness abort fails the test suite, not only deploy/fuzz.sh. */
#define _XOPEN_SOURCE 700

#include "fuzz_fixture.h"

#include <dirent.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

int LLVMFuzzerInitialize(int *argc, char ***argv);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static int run_file(const char *path)
{
    size_t n;
    uint8_t *data = fuzz_fixture_read(path, &n);
    if (!data)
        return -1;
    LLVMFuzzerTestOneInput(data, n);
    free(data);
    return 0;
}

int main(int argc, char **argv)
{
    LLVMFuzzerInitialize(&argc, &argv);
    int runs = 0;
    for (int i = 1; i < argc; i++) {
        struct stat st;
        if (stat(argv[i], &st) != 0) {
            fprintf(stderr, "fuzz_run_seeds: %s: no such file\n", argv[i]);
            return 1;
        }
        if (!S_ISDIR(st.st_mode)) {
            if (run_file(argv[i]) < 0)
                return 1;
            runs++;
            continue;
        }
        DIR *d = opendir(argv[i]);
        for (struct dirent *e; d && (e = readdir(d));) {
            if (e->d_name[0] == '.')
                continue;
            char path[4096];
            snprintf(path, sizeof path, "%s/%s", argv[i], e->d_name);
            if (run_file(path) < 0) {
                closedir(d);
                return 1;
            }
            runs++;
        }
        if (d)
            closedir(d);
    }
    printf("fuzz_run_seeds: %d inputs ran without a failure\n", runs);
    return runs > 0 ? 0 : 1;
}
