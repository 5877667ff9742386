#include "bsdf.h"

#include "bsdf_model.h"
#include "polar_frame.h"
#include "polar_fresnel.h"
#include "thinfilm.h"

#include <math.h>
#include <stddef.h>

#define BSDF_MODEL_ROW(kind, row) [kind] = &row,
static const bsdf_model_t *const MODELS[] = {BSDF_MODEL_LIST(BSDF_MODEL_ROW)};
#undef BSDF_MODEL_ROW

const bsdf_model_t *bsdf_model_of(const bsdf_t *b)
{
    return (size_t)b->kind < sizeof MODELS / sizeof MODELS[0] ? MODELS[b->kind] : NULL;
}

bool bsdf_eta_varies(const bsdf_t *b, int n)
{
    for (int j = 1; j < n; j++)
        if (!bsdf_eta_same(b->eta[j], b->eta[0]))
            return true;
    return false;
}

mueller_t bsdf_interface_mueller(const bsdf_t *b, int j, double cos_i, double complex n_i,
                                 double complex n_t, bool reflect)
{
    cos_i = fmin(1.0, cos_i);
    mueller_t m;
    if (b->film_nm > 0.0) {
        const thinfilm_t f = thinfilm_eval(cos_i, n_i, b->film_n[j], b->film_nm, n_t, b->lambda[j]);
        m = reflect ? thinfilm_reflection(&f) : thinfilm_transmission(&f);
    } else {
        const polar_fresnel_t f = polar_fresnel_eval(cos_i, n_i, n_t);
        m = reflect ? polar_fresnel_reflection(&f) : polar_fresnel_transmission(&f);
    }
    return mueller_normalised(&m);
}

double bsdf_guide(const bsdf_t *b, vec3_t wo, vec3_t wi)
{
    const int n = bsdf_lanes(b);
    const bsdf_model_t *m = bsdf_model_of(b);
    return m && m->guide && n > 0 ? m->guide(b, n, wo, wi) : 1.0;
}

void bsdf_eval(const bsdf_t *b, vec3_t wo, vec3_t wi, rng_stream_t *rng, double *f)
{
    const int n = bsdf_lanes(b);
    const bsdf_model_t *m = bsdf_model_of(b);
    if (n == 0)
        return;
    if (m && m->eval) {
        m->eval(b, n, wo, wi, rng, f);
        return;
    }
    for (int j = 0; j < n; j++)
        f[j] = 0.0;
}

void bsdf_pdf(const bsdf_t *b, vec3_t wo, vec3_t wi, rng_stream_t *rng, double *pdf)
{
    const int n = bsdf_lanes(b);
    const bsdf_model_t *m = bsdf_model_of(b);
    if (n == 0)
        return;
    if (m && m->pdf) {
        m->pdf(b, n, wo, wi, rng, pdf);
        return;
    }
    for (int j = 0; j < n; j++)
        pdf[j] = 0.0;
}

bool bsdf_sample(const bsdf_t *b, vec3_t wo, int hero, double uc, double u1, double u2,
                 rng_stream_t *rng, bsdf_sample_t *out)
{
    const int n = bsdf_lanes(b);
    const bsdf_model_t *m = bsdf_model_of(b);
    if (!m || n == 0 || !(wo.z != 0.0) || !isfinite(wo.x + wo.y + wo.z))
        return false;
    if (hero < 0 || hero >= n)
        hero = 0;
    out->flags = 0;
    out->eta = 1.0;
    out->pdf_is_estimate = (m->flags & BSDF_MODEL_PDF_ESTIMATE) != 0;
    switch (m->sample(b, n, wo, hero, uc, u1, u2, rng, out)) {
    case BSDF_SAMPLED_NONE:
        return false;
    case BSDF_SAMPLED_ALL:
        return true;
    case BSDF_SAMPLED_HERO:
        break;
    }
    /* A non-delta lobe: every other lane's own f and pdf at the hero's direction. */
    double f[BSDF_MAX_LANES], pdf[BSDF_MAX_LANES];
    m->eval(b, n, wo, out->wi, rng, f);
    m->pdf(b, n, wo, out->wi, rng, pdf);
    for (int j = 0; j < n; j++) {
        if (j == hero)
            continue;
        out->f[j] = f[j];
        out->pdf[j] = pdf[j];
    }
    return true;
}

bool bsdf_is_specular(const bsdf_t *b)
{
    const bsdf_model_t *m = bsdf_model_of(b);
    if (!m)
        return false;
    if (!m->eval)
        return true;
    return m->is_specular && m->is_specular(b, bsdf_lanes(b));
}

bool bsdf_lanes_disperse(const bsdf_t *b)
{
    const bsdf_model_t *m = bsdf_model_of(b);
    return m && (m->flags & BSDF_MODEL_DISPERSIVE) && bsdf_eta_varies(b, bsdf_lanes(b));
}

bool bsdf_pdf_is_estimate(const bsdf_t *b)
{
    const bsdf_model_t *m = bsdf_model_of(b);
    return m && (m->flags & BSDF_MODEL_PDF_ESTIMATE);
}

bool bsdf_mueller(const bsdf_t *b, int j, vec3_t wo, vec3_t wi, mueller_t *m, vec3_t *wm)
{
    const bsdf_model_t *model = bsdf_model_of(b);
    if (!model || !model->mueller || j < 0 || j >= bsdf_lanes(b) || wo.z == 0.0 || wi.z == 0.0)
        return false;
    return model->mueller(b, j, wo, wi, m, wm);
}
