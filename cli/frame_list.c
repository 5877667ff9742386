#include "frame_list.h"

#include "frame_pattern.h"
#include "proto.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

void frame_list_free(frame_list_t *fl)
{
    for (size_t k = 0; fl->paths && k < fl->n; k++)
        free(fl->paths[k]);
    free(fl->paths);
    free(fl->numbers);
    *fl = (frame_list_t){0};
}

static bool path_exists(const char *path)
{
    return access(path, F_OK) == 0;
}

/* A scene operand that names no file: a shell glob that matched nothing arrives as it is, and
 * a pattern needs --frames; both get a message saying so. Returns 2, or 0 when the file is
 * there or nothing tells why it is not. */
static int check_operand(const char *path, const char *cmd)
{
    if (path_exists(path))
        return 0;
    if (strpbrk(path, "*?[")) {
        fprintf(stderr, "prismfarm %s: '%s' matched no file (an empty glob?)\n", cmd, path);
        return 2;
    }
    if (frame_pattern_has(path)) {
        fprintf(stderr,
                "prismfarm %s: '%s' looks like a frame pattern: give --frames "
                "FIRST-LAST\n",
                cmd, path);
        return 2;
    }
    return 0;
}

static int alloc_list(frame_list_t *fl, size_t n, const char *cmd)
{
    fl->paths = calloc(n, sizeof *fl->paths);
    fl->numbers = calloc(n, sizeof *fl->numbers);
    if (!fl->paths || !fl->numbers) {
        fprintf(stderr, "prismfarm %s: out of memory\n", cmd);
        return 1;
    }
    return 0;
}

int frame_list_parse(frame_list_t *fl, char **ops, size_t nops, const char *range, const char *cmd)
{
    err_t err;
    *fl = (frame_list_t){0};
    if (range) {
        uint32_t a, b;
        if (nops != 1) {
            fprintf(stderr,
                    "prismfarm %s: --frames takes one scene pattern (such as "
                    "frame%%04d.pbrt), not %zu files\n",
                    cmd, nops);
            return 2;
        }
        if (frame_pattern_check(ops[0], &err) < 0 ||
            frame_pattern_parse_range(range, PROTO_MAX_FRAMES, &a, &b, &err) < 0) {
            fprintf(stderr, "prismfarm %s: %s\n", cmd, err.msg);
            return 2;
        }
        size_t n = (size_t)b - a + 1;
        if (alloc_list(fl, n, cmd))
            return 1;
        fl->sequence = true;
        for (size_t k = 0; k < n; k++) {
            char path[4096];
            if (frame_pattern_format(ops[0], a + (uint32_t)k, path, sizeof path, &err) < 0) {
                fprintf(stderr, "prismfarm %s: %s\n", cmd, err.msg);
                return 2;
            }
            if (!(fl->paths[k] = strdup(path))) {
                fprintf(stderr, "prismfarm %s: out of memory\n", cmd);
                return 1;
            }
            fl->numbers[k] = a + (uint32_t)k;
            fl->n = k + 1;
            if (!path_exists(path)) {
                fprintf(stderr, "prismfarm %s: frame %u: %s does not exist\n", cmd, fl->numbers[k],
                        path);
                return 2;
            }
        }
        return 0;
    }
    if (nops > PROTO_MAX_FRAMES) {
        fprintf(stderr, "prismfarm %s: %zu scene files, at most %d frames in one job\n", cmd, nops,
                PROTO_MAX_FRAMES);
        return 2;
    }
    if (alloc_list(fl, nops, cmd))
        return 1;
    fl->sequence = nops > 1;
    bool named = true;
    for (size_t k = 0; k < nops; k++) {
        int bad = check_operand(ops[k], cmd);
        if (bad)
            return bad;
        /* One scene missing is the loader's error (exit 1, as any scene it cannot read); a
         * sequence is refused before its first frame is sent or rendered. */
        if (nops > 1 && !path_exists(ops[k])) {
            fprintf(stderr, "prismfarm %s: %s (scene file %zu of %zu) does not exist\n", cmd,
                    ops[k], k + 1, nops);
            return 2;
        }
        if (!(fl->paths[k] = strdup(ops[k]))) {
            fprintf(stderr, "prismfarm %s: out of memory\n", cmd);
            return 1;
        }
        fl->n = k + 1;
        named = named && frame_pattern_number_of(ops[k], &fl->numbers[k]);
        for (size_t i = 0; named && i < k; i++)
            named = fl->numbers[i] != fl->numbers[k];
    }
    for (size_t k = 0; !named && k < nops; k++)
        fl->numbers[k] = (uint32_t)k + 1;
    return 0;
}

void frame_list_name(const frame_list_t *fl, char *out, size_t size)
{
    char stems[2][200];
    for (int e = 0; e < 2; e++) {
        const char *path = fl->paths[e ? fl->n - 1 : 0];
        const char *base = strrchr(path, '/');
        base = base ? base + 1 : path;
        size_t n = strlen(base);
        if (n > 5 && !strcmp(base + n - 5, ".pbrt"))
            n -= 5;
        snprintf(stems[e], sizeof stems[e], "%.*s", (int)n, base);
    }
    /* A sequence is named after its first and last frames: frame0001..frame0120. */
    if (fl->sequence)
        snprintf(out, size, "%s..%s", stems[0], stems[1]);
    else
        snprintf(out, size, "%s", stems[0]);
}
