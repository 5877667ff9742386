#include "jobinfo.h"

#include <stdarg.h>
#include <stdio.h>

/* Appends to out at *n, keeping *n the uncut length and out NUL-terminated within size. */
__attribute__((format(printf, 4, 5))) static void add(char *out, size_t size, size_t *n,
                                                      const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    int k = vsnprintf(out + (*n < size ? *n : size), *n < size ? size - *n : 0, fmt, ap);
    va_end(ap);
    if (k > 0)
        *n += (size_t)k;
}

size_t jobinfo_format(const jobinfo_t *j, char *out, size_t size)
{
    size_t n = 0;
    if (size > 0)
        out[0] = 0;
    if (j->job > 0)
        add(out, size, &n, "job=%llu;name=%s;", (unsigned long long)j->job, j->name ? j->name : "");
    add(out, size, &n, "scene=%s;spp=%d;xres=%d;yres=%d;seed=%llu;integrator=%s;dispersion=%s;"
        "samples=%llu;", j->scene ? j->scene : "", j->spp, j->xres, j->yres,
        (unsigned long long)j->seed, j->integrator ? j->integrator : "?",
        j->dispersion ? j->dispersion : "?", (unsigned long long)j->samples);
    if (j->rays >= 0)
        add(out, size, &n, "rays=%llu;", (unsigned long long)j->rays);
    const pass_record_t *last = j->nhistory > 0 ? &j->history[j->nhistory - 1] : NULL;
    char rel[32] = "none";
    if (last && last->valid)
        snprintf(rel, sizeof rel, "%.6g", last->rel_error);
    add(out, size, &n, "nonfinite=%llu;photons=%llu;seconds=%.3f;spp_done=%d;rel_rmse=%s;stop=%s;"
        "target_error=%g;time_limit=%g;history=", (unsigned long long)j->nonfinite,
        (unsigned long long)j->photons, j->seconds, j->spp_done, rel, stopping_name(j->stop),
        j->rule.target_error, j->rule.time_limit);
    for (int i = 0; i < j->nhistory; i++) {
        const pass_record_t *r = &j->history[i];
        char e[32] = "-";
        if (r->valid)
            snprintf(e, sizeof e, "%.6g", r->rel_error);
        add(out, size, &n, "%s%d:%d:%.3f:%s", i ? "," : "", r->pass, r->spp, r->elapsed, e);
    }
    return n;
}
