#include "jobinfo.h"

#include "adaptive.h"
#include "strbuf.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

size_t jobinfo_format(const jobinfo_t *j, char *out, size_t size)
{
    size_t n = 0;
    if (size > 0)
        out[0] = 0;
    if (j->job > 0)
        strbuf_appendf(out, size, &n, "job=%llu;name=%s;", (unsigned long long)j->job,
                       j->name ? j->name : "");
    strbuf_appendf(out, size, &n,
                   "scene=%s;spp=%d;xres=%d;yres=%d;seed=%llu;integrator=%s;dispersion=%s;"
                   "samples=%llu;",
                   j->scene ? j->scene : "", j->spp, j->xres, j->yres, (unsigned long long)j->seed,
                   j->integrator ? j->integrator : "?", j->dispersion ? j->dispersion : "?",
                   (unsigned long long)j->samples);
    if (j->rays >= 0)
        strbuf_appendf(out, size, &n, "rays=%llu;", (unsigned long long)j->rays);
    const pass_record_t *last = j->nhistory > 0 ? &j->history[j->nhistory - 1] : NULL;
    char rel[32] = "none";
    if (last && last->valid)
        snprintf(rel, sizeof rel, "%.6g", last->rel_error);
    strbuf_appendf(out, size, &n,
                   "nonfinite=%llu;photons=%llu;seconds=%.3f;spp_done=%d;rel_rmse=%s;stop=%s;"
                   "target_error=%g;time_limit=%g;",
                   (unsigned long long)j->nonfinite, (unsigned long long)j->photons, j->seconds,
                   j->spp_done, rel, stopping_name(j->stop), j->rule.target_error,
                   j->rule.time_limit);
    if (j->tile_spp) {
        adaptive_summary_t s = adaptive_summarize(&j->grid, j->tile_spp);
        strbuf_appendf(out, size, &n,
                       "adaptive=on;tile=%d;tiles=%dx%d;spp_mean=%.4g;tile_spp=", j->grid.tile,
                       j->grid.tiles_x, j->grid.tiles_y, s.mean_spp);
        n += adaptive_format_tile_spp(j->tile_spp, tilegrid_count(&j->grid),
                                      out + (n < size ? n : size), n < size ? size - n : 0);
        strbuf_appendf(out, size, &n, ";");
    }
    strbuf_appendf(out, size, &n, "history=");
    for (int i = 0; i < j->nhistory; i++) {
        const pass_record_t *r = &j->history[i];
        char e[32] = "-";
        if (r->valid)
            snprintf(e, sizeof e, "%.6g", r->rel_error);
        strbuf_appendf(out, size, &n, "%s%d:%d:%.3f:%s", i ? "," : "", r->pass, r->spp, r->elapsed,
                       e);
    }
    return n;
}

/* The value after "key=" where key starts the text or follows a ';'; NULL when absent. */
static const char *value_of(const char *info, const char *key)
{
    size_t n = strlen(key);
    for (const char *p = info; p && *p; p = strchr(p, ';') ? strchr(p, ';') + 1 : NULL)
        if (!strncmp(p, key, n) && p[n] == '=')
            return p + n + 1;
    return NULL;
}

int jobinfo_tile_spp(const char *info, tilegrid_t *grid, int **tile_spp, err_t *err)
{
    *tile_spp = NULL;
    const char *a = value_of(info, "adaptive"), *list = value_of(info, "tile_spp");
    if (!a || strncmp(a, "on;", 3) || !list)
        return 0;
    const char *xs = value_of(info, "xres"), *ys = value_of(info, "yres");
    const char *ts = value_of(info, "tile"), *tn = value_of(info, "tiles");
    int xres, yres, tile, tx, ty;
    if (!xs || !ys || !ts || !tn || sscanf(xs, "%d", &xres) != 1 || sscanf(ys, "%d", &yres) != 1 ||
        sscanf(ts, "%d", &tile) != 1 || sscanf(tn, "%dx%d", &tx, &ty) != 2 || xres < 1 ||
        yres < 1 || tile < 1)
        return err_set(err, "the adaptive keys name no grid of tiles");
    *grid = tilegrid_make(xres, yres, tile);
    if (grid->tiles_x != tx || grid->tiles_y != ty)
        return err_set(err, "tiles=%dx%d is not the grid of %dx%d pixels in tiles of %d", tx, ty,
                       xres, yres, tile);
    int n = tilegrid_count(grid), k = 0;
    int *spp = malloc((size_t)n * sizeof *spp);
    if (!spp)
        return err_set(err, "out of memory");
    const char *p = list;
    while (k < n && *p && *p != ';') {
        char *end;
        long v = strtol(p, &end, 10), run = 1;
        if (end == p || v < 0 || v > 1L << 30)
            break;
        p = end;
        if (*p == '*') {
            run = strtol(p + 1, &end, 10);
            if (end == p + 1 || run < 1 || run > n - k)
                break;
            p = end;
        }
        for (long i = 0; i < run; i++)
            spp[k++] = (int)v;
        if (*p == ',')
            p++;
    }
    if (k != n || (*p && *p != ';')) {
        free(spp);
        return err_set(err, "tile_spp does not hold the %d tiles of the grid", n);
    }
    *tile_spp = spp;
    return 1;
}
