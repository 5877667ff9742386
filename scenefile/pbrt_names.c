#include "pbrt_names.h"

#include "suggest.h"

#include <stdio.h>
#include <string.h>

void pbrt_names_list(const pbrt_name_t *table, size_t n, char *buf, size_t size)
{
    size_t total = 0, used = 0;
    while (total < n && table[total].name)
        total++;
    buf[0] = 0;
    for (size_t i = 0; i < total; i++) {
        const char *sep = i == 0 ? "" : i + 1 == total ? " or " : ", ";
        int w = snprintf(buf + used, size - used, "%s\"%s\"", sep, table[i].name);
        if (w < 0 || (size_t)w >= size - used)
            return; /* truncated: what fits is kept */
        used += (size_t)w;
    }
}

int pbrt_names_lookup(const pbrt_name_t *table, size_t n, const char *what, const char *s,
                      pbrt_loc_t loc, int *value, err_t *err)
{
    suggest_t sg = suggest_begin(s);
    bool listed = true;
    for (size_t i = 0; i < n; i++) {
        if (!table[i].name) {
            listed = false;
            continue;
        }
        if (!strcmp(s, table[i].name)) {
            *value = table[i].value;
            return 0;
        }
        if (listed)
            suggest_consider(&sg, table[i].name);
    }
    char names[1024];
    pbrt_names_list(table, n, names, sizeof names);
    const char *best = suggest_result(&sg);
    if (best)
        return pbrt_error(err, loc, "%s \"%s\" (did you mean \"%s\"? %s)", what, s, best, names);
    return pbrt_error(err, loc, "%s \"%s\" (%s)", what, s, names);
}
