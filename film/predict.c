#include "predict.h"

#include "passes.h"

#include <math.h>

predict_t predict_target(const pass_record_t *history, int n, double target)
{
    predict_t p = {0};
    if (!(target > 0.0 && target < 1.0) || !history || n <= 0)
        return p;
    /* The latest estimate: the most samples, the least noise in the estimate itself. */
    int last = -1;
    for (int i = n - 1; i >= 0 && last < 0; i--)
        if (history[i].valid && history[i].rel_error > 0.0 && isfinite(history[i].rel_error) &&
            history[i].spp > 0)
            last = i;
    if (last < 0)
        return p;
    const pass_record_t *r = &history[last];
    p.from_spp = r->spp;
    p.from_error = r->rel_error;
    const double ratio = r->rel_error / target;
    p.spp = r->spp * ratio * ratio;
    /* Time: a line through the first record and the last (what came before the first sample,
     * a photon pass or a load, is the line's offset); one record gives the rate alone. */
    const pass_record_t *f = &history[0];
    if (last > 0 && r->spp > f->spp && r->elapsed > f->elapsed) {
        p.per_spp = (r->elapsed - f->elapsed) / (double)(r->spp - f->spp);
        p.fixed = f->elapsed - p.per_spp * f->spp;
        if (p.fixed < 0.0)
            p.fixed = 0.0;
    } else {
        p.per_spp = r->elapsed / r->spp;
        p.fixed = 0.0;
    }
    p.seconds = p.fixed + p.per_spp * p.spp;
    p.valid = isfinite(p.seconds) && isfinite(p.spp);
    return p;
}

int predict_pass_spp(const predict_t *p, int max_spp)
{
    if (!p->valid || max_spp < 1)
        return max_spp;
    uint32_t bounds[PASSES_MAX_BOUNDS];
    int n = passes_bounds(max_spp, bounds);
    for (int i = 1; i <= n; i++)
        if ((double)bounds[i] >= p->spp)
            return (int)bounds[i];
    return max_spp;
}

double predict_pass_seconds(const predict_t *p, int max_spp)
{
    return p->fixed + p->per_spp * predict_pass_spp(p, max_spp);
}
