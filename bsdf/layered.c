#include "layered.h"

#include "fresnel.h"
#include "lobe.h"
#include "lowdisc.h"
#include "microfacet.h"
#include "regularize.h"
#include "sample.h"

#include <float.h>
#include <math.h>
#include <stdint.h>
#include <string.h>

/* Lanes [lo, lo + n) walked together: they share the coating index eta. */
typedef struct group {
    const bsdf_t *b;
    int lo, n;
    double eta;
    bool albedo; /* some lane of the group has a scattering medium */
} group_t;

enum { TOP, BOTTOM };

/* One interface sample for the group: a lane-independent direction and pdf, per-lane f. */
typedef struct isample {
    vec3_t wi;
    double f[BSDF_MAX_LANES];
    double pdf;
    int flags;
} isample_t;

static group_t group_make(const bsdf_t *b, int lo, int n)
{
    group_t g = {b, lo, n, b->eta[lo], false};
    for (int i = 0; i < n; i++)
        if (b->albedo[lo + i] > 0.0)
            g.albedo = true;
    return g;
}

static double max_lane(const double *v, int n)
{
    double m = 0.0;
    for (int i = 0; i < n; i++)
        m = fmax(m, v[i]);
    return m;
}

static double next_u(rng_stream_t *rng)
{
    return fmin(rng_stream_next(rng), 1.0 - DBL_EPSILON / 2.0);
}

/* A walk's random numbers. Its first WALK_LD_EVENTS interface events (the directions in and
 * out of the coating, the first bounce at the base) take stratified numbers: for event e, a
 * 2D point and a 1D number of the Owen-scrambled (0,2)-sequence at the stream's sample index,
 * the index shuffled by an Owen scramble of its bits (Burley 2020 sec. 4, as paddedsobol),
 * both keyed by (seed, pixel, the stream's position at the walk's start, e). A caller that
 * starts the same decision at the same stream position in every sample of a pixel (render.c
 * does, per vertex and decision) gets a (0,2)-net over the pixel's samples for each of those
 * events, where pbrt-v4's walk draws independent numbers; every other draw is the stream's
 * Philox. Each number is uniform and independent of the sample's other numbers (its own
 * scramble), so the estimates stay unbiased. The walk advances the stream by one at its
 * start, so two walks of one sample never share a key. */
enum { WALK_LD_EVENTS = 3 };

typedef struct walk {
    rng_stream_t *rng;
    uint64_t key;
    uint32_t sample;
    int event;
} walk_t;

static walk_t walk_begin(rng_stream_t *rng)
{
    walk_t w = {rng, lowdisc_hash(lowdisc_hash(rng->seed, rng->index), rng->next_dim), rng->sample,
                0};
    (void)rng_stream_next(rng);
    return w;
}

static double walk_1d(walk_t *w)
{
    return next_u(w->rng);
}

static double walk_unit(uint32_t v)
{
    return fmin(lowdisc_unit(v), 1.0 - DBL_EPSILON / 2.0);
}

/* One interface event's numbers: uc (the lobe choice), u1, u2 (the direction, a 2D pair). */
static void walk_event(walk_t *w, double *uc, double *u1, double *u2)
{
    if (w->event >= WALK_LD_EVENTS) {
        *uc = walk_1d(w);
        *u1 = walk_1d(w);
        *u2 = walk_1d(w);
        return;
    }
    const uint64_t h = lowdisc_hash(w->key, (uint64_t)w->event++);
    const uint64_t h2 = lowdisc_hash(h, 2), h1 = lowdisc_hash(h, 1);
    const uint32_t i2 = lowdisc_owen(w->sample, (uint32_t)h);
    const uint32_t i1 = lowdisc_owen(w->sample, (uint32_t)(h >> 32));
    *u1 = walk_unit(lowdisc_owen_sobol(i2, 0, (uint32_t)h2));
    *u2 = walk_unit(lowdisc_owen_sobol(i2, 1, (uint32_t)(h2 >> 32)));
    *uc = walk_unit(lowdisc_owen_sobol(i1, 0, (uint32_t)h1));
}

/* The power heuristic with one sample each (Veach & Guibas 1995). */
static double power_heuristic(double f, double g)
{
    double f2 = f * f, g2 = g * g;
    if (isinf(f2))
        return 1.0;
    return f2 + g2 > 0.0 ? f2 / (f2 + g2) : 0.0;
}

/* Transmittance of a unit-extinction slab crossed over height dz along w (pbrt-v4
 * LayeredBxDF::Tr): exp(-|dz / w.z|); no height, no attenuation. */
static double layer_tr(double dz, vec3_t w)
{
    if (fabs(dz) <= DBL_MIN)
        return 1.0;
    double t = exp(-fabs(dz / w.z));
    return isfinite(t) ? t : 0.0;
}

/* Henyey & Greenstein 1941 with pbrt-v4's convention: both directions point away from the
 * scattering point, so forward scattering (g > 0) is wi = -wo, cos = wo.wi = -1. */
static double hg_p(vec3_t wo, vec3_t wi, double g)
{
    double denom = 1.0 + g * g + 2.0 * g * vec3_dot(wo, wi);
    if (!(denom > 0.0))
        return 0.0;
    return lobe_finite((1.0 - g * g) / (4.0 * PF_PI * denom * sqrt(denom)));
}

/* Inversion of HG's cumulative distribution in cos (pbrt-v4 SampleHenyeyGreenstein), then a
 * uniform azimuth about wo. */
static vec3_t hg_sample(vec3_t wo, double g, double u1, double u2, double *pdf)
{
    double c;
    if (fabs(g) < 1e-3) {
        c = 1.0 - 2.0 * u1;
    } else {
        double s = (1.0 - g * g) / (1.0 + g - 2.0 * g * u1);
        c = -(1.0 + g * g - s * s) / (2.0 * g);
    }
    c = fmin(1.0, fmax(-1.0, c));
    double sn = sqrt(fmax(0.0, 1.0 - c * c)), phi = 2.0 * PF_PI * u2;
    vec3_t t, bt;
    vec3_basis(wo, &t, &bt);
    vec3_t wi = vec3_add(vec3_add(vec3_scale(t, sn * cos(phi)), vec3_scale(bt, sn * sin(phi))),
                         vec3_scale(wo, c));
    *pdf = hg_p(wo, wi, g);
    return wi;
}

/* ---- The two interfaces ---- */

static bool iface_specular(const group_t *g, int which)
{
    if (which == TOP)
        return lobe_dielectric_specular(&g->b->mf, g->eta);
    return g->b->kind == BSDF_COATED_CONDUCTOR && lobe_conductor_specular(&g->b->mf_base);
}

static void iface_f(const group_t *g, int which, vec3_t wo, vec3_t wi, bsdf_mode_t mode, double *f)
{
    const bsdf_t *b = g->b;
    if (which == TOP) {
        double v = lobe_dielectric_f(&b->mf, g->eta, mode, wo, wi);
        for (int i = 0; i < g->n; i++)
            f[i] = v;
        return;
    }
    if (b->kind != BSDF_COATED_CONDUCTOR) {
        for (int i = 0; i < g->n; i++)
            f[i] = lobe_diffuse_f(b->reflectance[g->lo + i], wo, wi);
        return;
    }
    /* lobe_conductor_f per lane, with the lane-independent D, G and half vector computed once
     * (the same operations in the same order: the same bits). */
    for (int i = 0; i < g->n; i++)
        f[i] = 0.0;
    const microfacet_t *mf = &b->mf_base;
    if (!(wo.z * wi.z > 0.0) || microfacet_smooth(mf))
        return;
    double co = fabs(wo.z), ci = fabs(wi.z);
    vec3_t wm = vec3_add(wo, wi);
    if (co == 0.0 || ci == 0.0 || vec3_dot(wm, wm) == 0.0)
        return;
    wm = vec3_normalize(wm);
    double cm = fabs(vec3_dot(wo, wm)), d = microfacet_d(mf, wm), gg = microfacet_g(mf, wo, wi);
    for (int i = 0; i < g->n; i++) {
        int j = g->lo + i;
        double fr = fresnel_conductor(cm, b->cond_eta[j], b->cond_k[j]);
        f[i] = lobe_finite(d * fr * gg / (4.0 * co * ci));
    }
}

static double iface_pdf(const group_t *g, int which, vec3_t wo, vec3_t wi, int allowed)
{
    const bsdf_t *b = g->b;
    if (which == TOP)
        return lobe_dielectric_pdf(&b->mf, g->eta, wo, wi, allowed);
    return b->kind == BSDF_COATED_CONDUCTOR ? lobe_conductor_pdf(&b->mf_base, wo, wi, allowed)
                                            : lobe_diffuse_pdf(wo, wi, allowed);
}

/* The base's sample for every lane of the group at once. Its direction, pdf and (for a
 * conductor) D and G depend on neither the lane's reflectance nor its conductor index, so they
 * are computed once and only the reflectance or the Fresnel term per lane: the numbers of
 * lobe_diffuse_sample / lobe_conductor_sample called lane by lane (the same operations in the
 * same order), at a quarter of their cost with four hero lanes. */
static bool base_sample(const group_t *g, vec3_t wo, double u1, double u2, int allowed,
                        isample_t *s)
{
    const bsdf_t *b = g->b;
    if (!(allowed & LOBE_R) || wo.z == 0.0)
        return false;
    if (b->kind != BSDF_COATED_CONDUCTOR) {
        vec3_t wi = sample_cosine_hemisphere(u1, u2);
        if (wo.z < 0.0)
            wi.z = -wi.z;
        s->pdf = lobe_diffuse_pdf(wo, wi, LOBE_R);
        if (!(s->pdf > 0.0))
            return false;
        for (int i = 0; i < g->n; i++)
            s->f[i] = lobe_diffuse_f(b->reflectance[g->lo + i], wo, wi);
        s->wi = wi;
        s->flags = BSDF_REFLECTION;
        return true;
    }
    const microfacet_t *mf = &b->mf_base;
    if (microfacet_smooth(mf)) {
        vec3_t wi = vec3_make(-wo.x, -wo.y, wo.z);
        double c = fabs(wi.z);
        for (int i = 0; i < g->n; i++) {
            int j = g->lo + i;
            s->f[i] = lobe_finite(fresnel_conductor(c, b->cond_eta[j], b->cond_k[j]) / c);
        }
        s->wi = wi;
        s->pdf = 1.0;
        s->flags = BSDF_REFLECTION | BSDF_SPECULAR;
        return true;
    }
    vec3_t wm = microfacet_sample_wm(mf, wo, u1, u2);
    vec3_t wi = fresnel_reflect(vec3_neg(wo), wm);
    if (!(wo.z * wi.z > 0.0))
        return false;
    double d = fabs(vec3_dot(wo, wm));
    double co = fabs(wo.z), ci = fabs(wi.z);
    if (d == 0.0 || ci == 0.0)
        return false;
    s->pdf = lobe_finite(microfacet_pdf(mf, wo, wm) / (4.0 * d));
    if (!(s->pdf > 0.0))
        return false;
    double dd = microfacet_d(mf, wm), gg = microfacet_g(mf, wo, wi);
    for (int i = 0; i < g->n; i++) {
        int j = g->lo + i;
        double fr = fresnel_conductor(d, b->cond_eta[j], b->cond_k[j]);
        s->f[i] = lobe_finite(dd * fr * gg / (4.0 * co * ci));
    }
    s->wi = wi;
    s->flags = BSDF_REFLECTION;
    return true;
}

/* pbrt-v4's test after every interface sample: a sample, some f, pdf > 0, wi off the plane. */
static bool iface_sample(const group_t *g, int which, vec3_t wo, double uc, double u1, double u2,
                         bsdf_mode_t mode, int allowed, isample_t *s)
{
    const bsdf_t *b = g->b;
    if (g->n < 1)
        return false;
    if (which == TOP) {
        lobe_sample_t ls = {0};
        if (!lobe_dielectric_sample(&b->mf, g->eta, mode, wo, uc, u1, u2, allowed, &ls))
            return false;
        for (int i = 0; i < g->n; i++)
            s->f[i] = ls.f;
        s->wi = ls.wi;
        s->pdf = ls.pdf;
        s->flags = ls.flags;
    } else if (!base_sample(g, wo, u1, u2, allowed, s)) {
        return false;
    }
    return max_lane(s->f, g->n) > 0.0 && s->pdf > 0.0 && s->wi.z != 0.0;
}

static bsdf_mode_t adjoint(bsdf_mode_t m)
{
    return m == BSDF_RADIANCE ? BSDF_IMPORTANCE : BSDF_RADIANCE;
}

static double thickness_of(const bsdf_t *b)
{
    return fmax(b->thickness, DBL_MIN);
}

static int nsamples_of(const bsdf_t *b)
{
    return b->nsamples > 0 ? b->nsamples : 1;
}

/* The probability that a sample of the coated model takes the coating's reflection rather
 * than entering the layer. pbrt-v4 reflects with the Fresnel share R / (R + T) of the sampled
 * microfacet, about 4 % on glass, although everything under the coating comes back at most
 * with the base's albedo a: where a glossy coat mirrors a small bright source (the sun, a
 * lamp) that light sampling cannot find inside its narrow lobe, 1 sample in 25 carries the
 * whole highlight (material-testball's sun glint and the floor's fireflies, docs/rendering.md
 * "Coated surfaces"). Mitsuba's roughplastic reallocates the choice by the components'
 * expected weights (Jakob, Mitsuba 0.6 src/bsdfs/roughplastic.cpp, "Reallocate samples"):
 *   q = R / (R + (1 - R) a),
 * with R the Fresnel reflectance at the macro normal, a the lanes' mean base albedo (a
 * diffuse base's reflectance, a conductor's normal-incidence reflectance, or the medium's
 * albedo where larger). q is kept between R (pbrt-v4's share: a white base) and 1/2, so that a
 * transmitted sample's weight grows at most to 2 (1 - R) times pbrt-v4's. A sample's weight
 * and the MIS pdf both use q, so the estimate stays unbiased; only which paths it spends its
 * samples on changes. */
static double top_reflect_prob(const group_t *g, vec3_t wo)
{
    const bsdf_t *b = g->b;
    const double r = fresnel_dielectric(fabs(wo.z), 1.0, g->eta);
    if (!(r > 0.0))
        return 0.0;
    double a = 0.0;
    for (int i = 0; i < g->n; i++) {
        int j = g->lo + i;
        double base = b->kind == BSDF_COATED_CONDUCTOR
                          ? fresnel_conductor(1.0, b->cond_eta[j], b->cond_k[j])
                          : b->reflectance[j];
        a += fmax(base, b->albedo[j]) / g->n;
    }
    double q = r / (r + (1.0 - r) * fmin(1.0, fmax(a, 0.0)));
    return fmax(r, fmin(q, 0.5));
}

/* A sample of the exponential free-flight distance along w in a unit-extinction medium,
 * projected on z: -ln(1 - u) |w.z|. */
static double free_flight_dz(double u, vec3_t w)
{
    return -log1p(-u) * fabs(w.z);
}

/* ---- f: pbrt-v4 LayeredBxDF::f, the estimator of Guo et al. 2018 sec. 5 with NEE through
 * the exit interface and MIS against the phase function or the other interface ---- */

static void group_eval(const group_t *g, vec3_t wo, vec3_t wi, walk_t *wk, double *f)
{
    const bsdf_t *b = g->b;
    const int n = g->n, ns = nsamples_of(b);
    const double th = thickness_of(b);
    if (wo.z < 0.0) { /* two-sided: seen from below, it is the same coating */
        wo = vec3_neg(wo);
        wi = vec3_neg(wi);
    }
    bool same = wo.z * wi.z > 0.0;
    int exit_if = same ? TOP : BOTTOM, nonexit_if = same ? BOTTOM : TOP;
    double exit_z = same ? th : 0.0;
    bool exit_spec = iface_specular(g, exit_if), nonexit_spec = iface_specular(g, nonexit_if);
    double tmp[BSDF_MAX_LANES], beta[BSDF_MAX_LANES];

    for (int i = 0; i < n; i++)
        f[i] = 0.0;
    if (same) {
        iface_f(g, TOP, wo, wi, b->mode, tmp);
        for (int i = 0; i < n; i++)
            f[i] = ns * tmp[i];
    }
    for (int s = 0; s < ns; s++) {
        isample_t wos, wis, bs;
        double uc, u1, u2;
        walk_event(wk, &uc, &u1, &u2);
        if (!iface_sample(g, TOP, wo, uc, u1, u2, b->mode, LOBE_T, &wos))
            continue;
        /* The adjoint walk from wi: a "virtual light" through the exit interface. */
        walk_event(wk, &uc, &u1, &u2);
        if (!iface_sample(g, exit_if, wi, uc, u1, u2, adjoint(b->mode), LOBE_T, &wis))
            continue;
        for (int i = 0; i < n; i++)
            beta[i] = wos.f[i] * fabs(wos.wi.z) / wos.pdf;
        double z = th;
        vec3_t w = wos.wi;
        for (int depth = 0; depth < b->maxdepth; depth++) {
            double bmax = max_lane(beta, n);
            if (depth > 3 && bmax < 0.25) { /* Russian roulette */
                double q = fmax(0.0, 1.0 - bmax);
                if (walk_1d(wk) < q)
                    break;
                for (int i = 0; i < n; i++)
                    beta[i] /= 1.0 - q;
            }
            if (!g->albedo) {
                z = z == th ? 0.0 : th;
                double tr = layer_tr(th, w);
                for (int i = 0; i < n; i++)
                    beta[i] *= tr;
            } else {
                double dz = free_flight_dz(walk_1d(wk), w);
                double zp = w.z > 0.0 ? z + dz : z - dz;
                if (zp == z)
                    continue;
                if (0.0 < zp && zp < th) {
                    /* Scattering in the medium: NEE through the exit along wis, MIS-weighted
                     * against the phase function's own sampling of that direction. */
                    double ph = hg_p(vec3_neg(w), vec3_neg(wis.wi), b->g);
                    double wt = exit_spec ? 1.0 : power_heuristic(wis.pdf, ph);
                    double tr = layer_tr(zp - exit_z, wis.wi);
                    for (int i = 0; i < n; i++)
                        f[i] += beta[i] * b->albedo[g->lo + i] * ph * wt * tr * wis.f[i] / wis.pdf;
                    double ppdf;
                    u1 = walk_1d(wk), u2 = walk_1d(wk);
                    vec3_t pwi = hg_sample(vec3_neg(w), b->g, u1, u2, &ppdf);
                    if (!(ppdf > 0.0) || pwi.z == 0.0)
                        continue;
                    /* p / pdf = 1 for the exactly sampled phase function. */
                    for (int i = 0; i < n; i++)
                        beta[i] *= b->albedo[g->lo + i];
                    w = pwi;
                    z = zp;
                    if (((z < exit_z && w.z > 0.0) || (z > exit_z && w.z < 0.0)) && !exit_spec) {
                        iface_f(g, exit_if, vec3_neg(w), wi, b->mode, tmp);
                        if (max_lane(tmp, n) > 0.0) {
                            /* The technique this is weighed against is the exit's sampling
                             * from wi (wis), whose density at -w is PDF(wi, -w). pbrt-v4 uses
                             * PDF(-w, wi) here, which differs for a rough dielectric (the
                             * refraction Jacobian is not symmetric): its weights do not sum to
                             * 1 and its f is 9-27 % too bright at eta 1.5 against a path-
                             * sampled ground truth (test_bsdf_layered; docs/physics.md 10.4). */
                            double epdf = iface_pdf(g, exit_if, wi, vec3_neg(w), LOBE_T);
                            double wt2 = power_heuristic(ppdf, epdf);
                            double tr2 = layer_tr(zp - exit_z, pwi);
                            for (int i = 0; i < n; i++)
                                f[i] += beta[i] * tr2 * tmp[i] * wt2;
                        }
                    }
                    continue;
                }
                z = fmin(fmax(zp, 0.0), th);
            }
            if (z == exit_z) {
                walk_event(wk, &uc, &u1, &u2);
                if (!iface_sample(g, exit_if, vec3_neg(w), uc, u1, u2, b->mode, LOBE_R, &bs))
                    break;
                for (int i = 0; i < n; i++)
                    beta[i] *= bs.f[i] * fabs(bs.wi.z) / bs.pdf;
                w = bs.wi;
            } else {
                if (!nonexit_spec) {
                    /* NEE at the far interface along the presampled wis. */
                    double wt = 1.0;
                    if (!exit_spec)
                        wt = power_heuristic(wis.pdf, iface_pdf(g, nonexit_if, vec3_neg(w),
                                                                vec3_neg(wis.wi), LOBE_ALL));
                    iface_f(g, nonexit_if, vec3_neg(w), vec3_neg(wis.wi), b->mode, tmp);
                    double c = fabs(wis.wi.z) * wt * layer_tr(th, wis.wi) / wis.pdf;
                    for (int i = 0; i < n; i++)
                        f[i] += beta[i] * tmp[i] * c * wis.f[i];
                }
                walk_event(wk, &uc, &u1, &u2);
                if (!iface_sample(g, nonexit_if, vec3_neg(w), uc, u1, u2, b->mode, LOBE_R, &bs))
                    break;
                for (int i = 0; i < n; i++)
                    beta[i] *= bs.f[i] * fabs(bs.wi.z) / bs.pdf;
                w = bs.wi;
                if (!exit_spec) {
                    iface_f(g, exit_if, vec3_neg(w), wi, b->mode, tmp);
                    if (max_lane(tmp, n) > 0.0) {
                        double wt = 1.0;
                        if (!nonexit_spec) /* PDF(wi, -w), as above */
                            wt = power_heuristic(bs.pdf,
                                                 iface_pdf(g, exit_if, wi, vec3_neg(w), LOBE_T));
                        double tr = layer_tr(th, bs.wi);
                        for (int i = 0; i < n; i++)
                            f[i] += beta[i] * tr * tmp[i] * wt;
                    }
                }
            }
        }
    }
    for (int i = 0; i < n; i++)
        f[i] = lobe_finite(f[i] / ns);
}

/* ---- pdf: pbrt-v4 LayeredBxDF::PDF, the TRT / TT approximations mixed with a uniform
 * sphere: 0.1 / (4 pi) + 0.9 estimate ----
 *
 * Two departures. The top's reflection counts at the density group_sample really gives it, the
 * coating's reflection lobe times the probability q that the first event reflects
 * (top_reflect_prob), where pbrt-v4 counts the reflection lobe's whole density (its
 * reflection-only PDF), 1 / R times too high (25x at normal incidence on glass). The estimate
 * serves only as the MIS weight's density; with pbrt-v4's, MIS gave the glossy reflection of a
 * small bright light (the sun in an environment map) to BSDF sampling even where sampling the
 * light finds it far more often: on material-testball's sun glint (docs/rendering.md, "Image
 * lights") the weight from the true density had 1.3x less variance. And the paths through the
 * layer count with their probability 1 - q (pbrt-v4: 1). Either weight is unbiased (both
 * strategies' weights use the same estimate). */

static double group_pdf(const group_t *g, vec3_t wo, vec3_t wi, walk_t *wk)
{
    const bsdf_t *b = g->b;
    const int ns = nsamples_of(b);
    if (wo.z < 0.0) {
        wo = vec3_neg(wo);
        wi = vec3_neg(wi);
    }
    bool same = wo.z * wi.z > 0.0;
    const double q = top_reflect_prob(g, wo);
    double sum = 0.0;
    for (int s = 0; s < ns; s++) {
        isample_t wos, wis, rs;
        double a[9];
        for (int k = 0; k < 9; k += 3)
            walk_event(wk, &a[k], &a[k + 1], &a[k + 2]);
        if (same) {
            bool ok_o = iface_sample(g, TOP, wo, a[0], a[1], a[2], b->mode, LOBE_T, &wos);
            bool ok_i = iface_sample(g, TOP, wi, a[3], a[4], a[5], adjoint(b->mode), LOBE_T, &wis);
            if (!ok_o || !ok_i)
                continue;
            if (iface_specular(g, TOP)) {
                sum += iface_pdf(g, BOTTOM, vec3_neg(wos.wi), vec3_neg(wis.wi), LOBE_ALL);
            } else if (iface_sample(g, BOTTOM, vec3_neg(wos.wi), a[6], a[7], a[8], b->mode,
                                    LOBE_ALL, &rs)) {
                if (iface_specular(g, BOTTOM)) {
                    sum += iface_pdf(g, TOP, vec3_neg(rs.wi), wi, LOBE_ALL);
                } else {
                    /* MIS of the two ways to estimate the product of the three pdfs. */
                    double rpdf =
                        iface_pdf(g, BOTTOM, vec3_neg(wos.wi), vec3_neg(wis.wi), LOBE_ALL);
                    sum += power_heuristic(wis.pdf, rpdf) * rpdf;
                    double tpdf = iface_pdf(g, TOP, vec3_neg(rs.wi), wi, LOBE_ALL);
                    sum += power_heuristic(rs.pdf, tpdf) * tpdf;
                }
            }
        } else {
            if (!iface_sample(g, TOP, wo, a[0], a[1], a[2], b->mode, LOBE_ALL, &wos) ||
                (wos.flags & BSDF_REFLECTION))
                continue;
            if (!iface_sample(g, BOTTOM, wi, a[3], a[4], a[5], adjoint(b->mode), LOBE_ALL, &wis) ||
                (wis.flags & BSDF_REFLECTION))
                continue;
            if (iface_specular(g, TOP))
                sum += iface_pdf(g, BOTTOM, vec3_neg(wos.wi), wi, LOBE_ALL);
            else if (iface_specular(g, BOTTOM))
                sum += iface_pdf(g, TOP, wo, vec3_neg(wis.wi), LOBE_ALL);
            else
                sum += 0.5 * (iface_pdf(g, TOP, wo, vec3_neg(wis.wi), LOBE_ALL) +
                              iface_pdf(g, BOTTOM, vec3_neg(wos.wi), wi, LOBE_ALL));
        }
    }
    /* The mixture group_sample draws from: the coating's reflection with probability q, the
     * paths through the layer with 1 - q. */
    double top = same ? q * iface_pdf(g, TOP, wo, wi, LOBE_R) : 0.0;
    return lobe_finite(0.1 / (4.0 * PF_PI) + 0.9 * (top + (1.0 - q) * sum / ns));
}

/* ---- Sample_f: pbrt-v4 LayeredBxDF::Sample_f, a random walk until the path leaves ---- */

static bool group_sample(const group_t *g, vec3_t wo, double uc, double u1, double u2, walk_t *wk,
                         double *f, double *pdf_out, vec3_t *wi_out, int *flags_out)
{
    const bsdf_t *b = g->b;
    const int n = g->n;
    const double th = thickness_of(b);
    bool flip = wo.z < 0.0;
    if (flip)
        wo = vec3_neg(wo);
    isample_t bs;
    /* The first event: reflection with probability q (top_reflect_prob), its uniform
     * rescaled to [0, 1) for the interface's own use of it. */
    const double q = top_reflect_prob(g, wo);
    const bool refl = uc < q;
    const double ur = refl ? uc / q : (uc - q) / (1.0 - q);
    if (!iface_sample(g, TOP, wo, fmin(ur, 1.0 - DBL_EPSILON / 2.0), u1, u2, b->mode,
                      refl ? LOBE_R : LOBE_T, &bs))
        return false;
    bs.pdf *= refl ? q : 1.0 - q;
    if (bs.flags & BSDF_REFLECTION) {
        memcpy(f, bs.f, sizeof(double) * (size_t)n);
        *pdf_out = bs.pdf;
        *wi_out = flip ? vec3_neg(bs.wi) : bs.wi;
        *flags_out = bs.flags;
        return true;
    }
    vec3_t w = bs.wi;
    bool specular_path = bs.flags & BSDF_SPECULAR;
    for (int i = 0; i < n; i++)
        f[i] = bs.f[i] * fabs(bs.wi.z);
    double pdf = bs.pdf, z = th;
    for (int depth = 0; depth < b->maxdepth; depth++) {
        double rr = max_lane(f, n) / pdf;
        if (depth > 3 && rr < 0.25) {
            double q = fmax(0.0, 1.0 - rr);
            if (walk_1d(wk) < q)
                return false;
            pdf *= 1.0 - q;
        }
        if (w.z == 0.0)
            return false;
        if (g->albedo) {
            double dz = free_flight_dz(walk_1d(wk), w);
            double zp = w.z > 0.0 ? z + dz : z - dz;
            if (zp == z)
                return false;
            if (0.0 < zp && zp < th) {
                double ppdf, a1 = walk_1d(wk), a2 = walk_1d(wk);
                vec3_t pwi = hg_sample(vec3_neg(w), b->g, a1, a2, &ppdf);
                if (!(ppdf > 0.0) || pwi.z == 0.0)
                    return false;
                for (int i = 0; i < n; i++)
                    f[i] *= b->albedo[g->lo + i] * ppdf;
                pdf *= ppdf;
                specular_path = false;
                w = pwi;
                z = zp;
                continue;
            }
            z = fmin(fmax(zp, 0.0), th);
        } else {
            z = z == th ? 0.0 : th;
            double tr = layer_tr(th, w);
            for (int i = 0; i < n; i++)
                f[i] *= tr;
        }
        int which = z == 0.0 ? BOTTOM : TOP;
        double c, a1, a2;
        walk_event(wk, &c, &a1, &a2);
        if (!iface_sample(g, which, vec3_neg(w), c, a1, a2, b->mode, LOBE_ALL, &bs))
            return false;
        for (int i = 0; i < n; i++)
            f[i] *= bs.f[i];
        pdf *= bs.pdf;
        specular_path = specular_path && (bs.flags & BSDF_SPECULAR);
        w = bs.wi;
        if (bs.flags & BSDF_TRANSMISSION) {
            int flags = wo.z * w.z > 0.0 ? BSDF_REFLECTION : BSDF_TRANSMISSION;
            if (specular_path)
                flags |= BSDF_SPECULAR;
            *wi_out = flip ? vec3_neg(w) : w;
            *pdf_out = pdf;
            *flags_out = flags;
            for (int i = 0; i < n; i++)
                f[i] = lobe_finite(f[i]);
            return lobe_finite(pdf) > 0.0;
        }
        for (int i = 0; i < n; i++)
            f[i] *= fabs(bs.wi.z);
    }
    return false;
}

/* ---- The lanes ---- */

/* A stream keyed by the directions' bits, for callers that pass none (pbrt-v4 hashes wo and
 * wi the same way). */
static rng_stream_t direction_stream(vec3_t a, vec3_t b)
{
    uint64_t h[2] = {0x243F6A8885A308D3ull, 0x13198A2E03707344ull};
    double v[6] = {a.x, a.y, a.z, b.x, b.y, b.z};
    for (int k = 0; k < 6; k++) {
        uint64_t bits;
        memcpy(&bits, &v[k], sizeof bits);
        h[k / 3] = (h[k / 3] ^ bits) * 0x100000001B3ull;
        h[k / 3] ^= h[k / 3] >> 29;
    }
    return rng_stream_make(h[0], h[1], 0);
}

static void eval(const bsdf_t *b, int n, vec3_t wo, vec3_t wi, rng_stream_t *rng, double *f)
{
    rng_stream_t local = direction_stream(wo, wi);
    if (!rng)
        rng = &local;
    if (!bsdf_eta_varies(b, n)) {
        group_t g = group_make(b, 0, n);
        walk_t wk = walk_begin(rng);
        group_eval(&g, wo, wi, &wk, f);
        return;
    }
    for (int j = 0; j < n; j++) {
        group_t g = group_make(b, j, 1);
        walk_t wk = walk_begin(rng);
        group_eval(&g, wo, wi, &wk, &f[j]);
    }
}

static void pdf(const bsdf_t *b, int n, vec3_t wo, vec3_t wi, rng_stream_t *rng, double *pdf)
{
    rng_stream_t local = direction_stream(wi, wo);
    if (!rng)
        rng = &local;
    if (!bsdf_eta_varies(b, n)) {
        group_t g = group_make(b, 0, n);
        walk_t wk = walk_begin(rng);
        double p = group_pdf(&g, wo, wi, &wk);
        for (int j = 0; j < n; j++)
            pdf[j] = p;
        return;
    }
    for (int j = 0; j < n; j++) {
        group_t g = group_make(b, j, 1);
        walk_t wk = walk_begin(rng);
        pdf[j] = group_pdf(&g, wo, wi, &wk);
    }
}

static bsdf_sampled_t sample(const bsdf_t *b, int n, vec3_t wo, int hero, double uc, double u1,
                             double u2, rng_stream_t *rng, bsdf_sample_t *out)
{
    rng_stream_t local = direction_stream(wo, vec3_make(uc, u1, u2));
    if (!rng)
        rng = &local;
    if (!bsdf_eta_varies(b, n)) {
        group_t g = group_make(b, 0, n);
        double pdf;
        walk_t wk = walk_begin(rng);
        if (!group_sample(&g, wo, uc, u1, u2, &wk, out->f, &pdf, &out->wi, &out->flags))
            return BSDF_SAMPLED_NONE;
        for (int j = 0; j < n; j++)
            out->pdf[j] = pdf;
        return BSDF_SAMPLED_ALL;
    }
    group_t g = group_make(b, hero, 1);
    double fh, pdfh;
    walk_t wk = walk_begin(rng);
    if (!group_sample(&g, wo, uc, u1, u2, &wk, &fh, &pdfh, &out->wi, &out->flags))
        return BSDF_SAMPLED_NONE;
    /* The top's mirror reflection is the one delta direction every lane shares; its weight is
     * the lane's own Fresnel reflectance, its probability the lane's own choice of it. */
    bool top_mirror = (out->flags & BSDF_SPECULAR) && (out->flags & BSDF_REFLECTION) &&
                      lobe_dielectric_specular(&b->mf, b->eta[hero]) &&
                      fabs(out->wi.x + wo.x) + fabs(out->wi.y + wo.y) < 1e-12;
    for (int j = 0; j < n; j++) {
        if (j == hero) {
            out->f[j] = fh;
            out->pdf[j] = pdfh;
        } else if (out->flags & BSDF_SPECULAR) {
            group_t gj = group_make(b, j, 1);
            double r = top_mirror ? fresnel_dielectric(fabs(wo.z), 1.0, b->eta[j]) : 0.0;
            out->f[j] = lobe_finite(r / fabs(out->wi.z));
            out->pdf[j] = top_mirror ? top_reflect_prob(&gj, wo) : 0.0;
        } else {
            group_t gj = group_make(b, j, 1);
            walk_t we = walk_begin(rng);
            group_eval(&gj, wo, out->wi, &we, &out->f[j]);
            walk_t wp = walk_begin(rng);
            out->pdf[j] = group_pdf(&gj, wo, out->wi, &wp);
        }
    }
    return BSDF_SAMPLED_ALL;
}

/* The coating's own reflection lobe (exact, lane 0's index) plus what comes through it, as if
 * the layer were a Lambertian of the lanes' mean base albedo behind two Fresnel
 * transmissions: (1 - R(wo)) (1 - R(wi)) a / pi. The glossy photon gather picks photons in
 * proportion to power times this (render.c), so the coat's sharp lobe, where f is tens of
 * times the rest, gets its picks instead of one in many; a floor of 0.05 on a keeps it
 * positive wherever f can be. */
static double guide(const bsdf_t *b, int n, vec3_t wo, vec3_t wi)
{
    if (wo.z < 0.0) {
        wo = vec3_neg(wo);
        wi = vec3_neg(wi);
    }
    const double eta = b->eta[0];
    double top = wi.z > 0.0 ? lobe_dielectric_f(&b->mf, eta, b->mode, wo, wi) : 0.0;
    double a = 0.0;
    for (int j = 0; j < n; j++) {
        double base = b->kind == BSDF_COATED_CONDUCTOR
                          ? fresnel_conductor(1.0, b->cond_eta[j], b->cond_k[j])
                          : b->reflectance[j];
        a += fmax(base, b->albedo[j]) / n;
    }
    a = fmax(fmin(a, 1.0), 0.05);
    double t = (1.0 - fresnel_dielectric(fabs(wo.z), 1.0, eta)) *
               (1.0 - fresnel_dielectric(fabs(wi.z), 1.0, eta));
    return lobe_finite(top) + fmax(t, 0.0) * a / PF_PI + 1e-12;
}

/* Only the coated conductor can be: a smooth coating over a smooth conductor with no medium. */
static bool is_specular(const bsdf_t *b, int n)
{
    if (!microfacet_smooth(&b->mf) || !microfacet_smooth(&b->mf_base))
        return false;
    for (int j = 0; j < n; j++)
        if (b->albedo[j] > 0.0)
            return false;
    return true;
}

static void regularize_conductor(bsdf_t *b)
{
    b->mf = regularize_microfacet(b->mf);
    b->mf_base = regularize_microfacet(b->mf_base);
}

const bsdf_model_t bsdf_model_coated_diffuse = {.eval = eval,
                                                .pdf = pdf,
                                                .sample = sample,
                                                .guide = guide,
                                                .regularize = regularize_interface,
                                                .flags = BSDF_MODEL_DISPERSIVE |
                                                         BSDF_MODEL_PDF_ESTIMATE};

const bsdf_model_t bsdf_model_coated_conductor = {.eval = eval,
                                                  .pdf = pdf,
                                                  .sample = sample,
                                                  .guide = guide,
                                                  .is_specular = is_specular,
                                                  .regularize = regularize_conductor,
                                                  .flags = BSDF_MODEL_DISPERSIVE |
                                                           BSDF_MODEL_PDF_ESTIMATE};
