#include "hair.h"

#include "bsdf_model.h"
#include "fresnel.h"
#include "lobe.h"

#include <math.h>

/* The lobes modelled one by one (R, TT, TRT); every higher order is summed into one more. */
#define P_MAX 3

static double safe_sqrt(double x)
{
    return x > 0.0 ? sqrt(x) : 0.0;
}

static double safe_asin(double x)
{
    return asin(fmin(1.0, fmax(-1.0, x)));
}

/* The modified Bessel function I0 by its power series sum (x/2)^2i / (i!)^2, summed until
 * the terms no longer change the sum (pbrt-v4 stops at ten terms, 0.4 % short at x = 10). */
static double bessel_i0(double x)
{
    double sum = 1.0, term = 1.0, q = 0.25 * x * x;
    for (int i = 1; i < 200; i++) {
        term *= q / ((double)i * (double)i);
        sum += term;
        if (term < 1e-17 * sum)
            break;
    }
    return sum;
}

/* ln I0(x); above 12 its asymptotic form x - ln(2 pi x) / 2 + 1 / (16 x) (pbrt-v4 LogI0). */
static double log_bessel_i0(double x)
{
    if (x > 12.0)
        return x + 0.5 * (-log(2.0 * PF_PI) + log(1.0 / x) + 1.0 / (8.0 * x));
    return log(bessel_i0(x));
}

/* d'Eon et al. 2011 eq. 7: the longitudinal lobe of variance v,
 * M = csch(1/v) / (2 v) exp(-sin_i sin_o / v) I0(cos_i cos_o / v); for v <= 0.1 in logs with
 * csch(1/v) ~ 2 exp(-1/v), which cannot overflow. */
static double longitudinal(double cos_i, double cos_o, double sin_i, double sin_o, double v)
{
    double a = cos_i * cos_o / v, b = sin_i * sin_o / v;
    double m = v <= 0.1 ? exp(log_bessel_i0(a) - b - 1.0 / v + log(2.0) + log(1.0 / (2.0 * v)))
                        : exp(-b) * bessel_i0(a) / (sinh(1.0 / v) * 2.0 * v);
    return lobe_finite(m);
}

static double logistic(double x, double s)
{
    x = fabs(x);
    double e = exp(-x / s);
    return e / (s * (1.0 + e) * (1.0 + e));
}

static double logistic_cdf(double x, double s)
{
    return 1.0 / (1.0 + exp(-x / s));
}

/* Chiang et al. 2016: the logistic of scale s restricted to [-pi, pi] and renormalised. */
static double trimmed_logistic(double x, double s)
{
    return logistic(x, s) / (logistic_cdf(PF_PI, s) - logistic_cdf(-PF_PI, s));
}

static double sample_trimmed_logistic(double u, double s)
{
    double lo = logistic_cdf(-PF_PI, s), k = logistic_cdf(PF_PI, s) - lo;
    double x = -s * log(1.0 / (u * k + lo) - 1.0);
    return fmin(PF_PI, fmax(-PF_PI, isfinite(x) ? x : (u < 0.5 ? -PF_PI : PF_PI)));
}

/* The exit azimuth of lobe p relative to phi_o (d'Eon et al. 2011 eq. 8). */
static double lobe_phi(int p, double gamma_o, double gamma_t)
{
    return 2.0 * p * gamma_t - 2.0 * gamma_o + p * PF_PI;
}

static double azimuthal(double phi, int p, double s, double gamma_o, double gamma_t)
{
    double d = remainder(phi - lobe_phi(p, gamma_o, gamma_t), 2.0 * PF_PI);
    return trimmed_logistic(d, s);
}

/* What the lobes share for one wo: the angles, and the lobes' variances and scale. */
typedef struct frame {
    double sin_o, cos_o, phi_o;
    double gamma_o, gamma_t;
    double path; /* 2 cos(gamma_t) / cos(theta_t): the interior path length per pass */
    double fresnel;
    double sin_po[P_MAX + 1], cos_po[P_MAX + 1]; /* theta_o tilted by the scales, per lobe */
    double v[P_MAX + 1], s;
} frame_t;

static double sq(double x)
{
    return x * x;
}

static void frame_make(const bsdf_t *b, vec3_t wo, frame_t *fr)
{
    double h = fmin(1.0, fmax(-1.0, b->hair_h)), eta = b->hair_eta;
    fr->sin_o = fmin(1.0, fmax(-1.0, wo.x));
    fr->cos_o = safe_sqrt(1.0 - sq(fr->sin_o));
    fr->phi_o = atan2(wo.z, wo.y);
    fr->gamma_o = safe_asin(h);
    /* Bravais: the refraction seen in the normal plane has the index
     * eta' = sqrt(eta^2 - sin^2 theta_o) / cos theta_o. */
    double sin_t = fr->sin_o / eta, cos_t = safe_sqrt(1.0 - sq(sin_t));
    double etap = safe_sqrt(eta * eta - sq(fr->sin_o)) / fmax(fr->cos_o, 1e-12);
    double sin_gt = h / etap;
    fr->gamma_t = safe_asin(sin_gt);
    fr->path = 2.0 * safe_sqrt(1.0 - sq(sin_gt)) / fmax(cos_t, 1e-12);
    fr->fresnel = fresnel_dielectric(fr->cos_o * safe_sqrt(1.0 - h * h), 1.0, eta);
    /* Chiang et al. 2016 eq. 7 and 4: the variance of M_p from beta_m (TT half, TRT four
     * times R's), and the logistic's scale from beta_n. */
    double bm = b->hair_beta_m, bn = b->hair_beta_n;
    fr->v[0] = sq(0.726 * bm + 0.812 * bm * bm + 3.7 * pow(bm, 20));
    fr->v[1] = 0.25 * fr->v[0];
    fr->v[2] = 4.0 * fr->v[0];
    fr->v[3] = fr->v[2];
    fr->s = sqrt(PF_PI / 8.0) * (0.265 * bn + 1.194 * bn * bn + 5.372 * pow(bn, 22));
    /* The scales tilt R by -2 alpha, TT by alpha and TRT by 4 alpha (Marschner et al. 2003):
     * sin/cos of 2^k alpha by the double-angle formulas. */
    double s2k[3], c2k[3];
    s2k[0] = sin(b->hair_alpha * (PF_PI / 180.0));
    c2k[0] = safe_sqrt(1.0 - sq(s2k[0]));
    for (int i = 1; i < 3; i++) {
        s2k[i] = 2.0 * c2k[i - 1] * s2k[i - 1];
        c2k[i] = sq(c2k[i - 1]) - sq(s2k[i - 1]);
    }
    double so = fr->sin_o, co = fr->cos_o;
    fr->sin_po[0] = so * c2k[1] - co * s2k[1];
    fr->cos_po[0] = co * c2k[1] + so * s2k[1];
    fr->sin_po[1] = so * c2k[0] + co * s2k[0];
    fr->cos_po[1] = co * c2k[0] - so * s2k[0];
    fr->sin_po[2] = so * c2k[2] + co * s2k[2];
    fr->cos_po[2] = co * c2k[2] - so * s2k[2];
    fr->sin_po[3] = so;
    fr->cos_po[3] = co;
    for (int p = 0; p <= P_MAX; p++)
        fr->cos_po[p] = fabs(fr->cos_po[p]);
}

/* A_p for one lane: Fresnel reflection f, transmittance T per interior pass;
 * A_0 = f, A_1 = (1 - f)^2 T, A_p = A_{p-1} T f, and the tail sum A_3 T f / (1 - T f). */
static void attenuation(const frame_t *fr, double sigma_a, double ap[P_MAX + 1])
{
    double f = fr->fresnel, t = exp(-fmax(sigma_a, 0.0) * fr->path);
    ap[0] = f;
    ap[1] = sq(1.0 - f) * t;
    for (int p = 2; p < P_MAX; p++)
        ap[p] = ap[p - 1] * t * f;
    ap[P_MAX] = 1.0 - t * f > 0.0 ? ap[P_MAX - 1] * f * t / (1.0 - t * f) : 0.0;
}

/* M_p N_p for every lobe (N = 1 / 2 pi for the tail), which no lane's absorption changes. */
static void lobes(const frame_t *fr, vec3_t wi, double mn[P_MAX + 1])
{
    double sin_i = fmin(1.0, fmax(-1.0, wi.x)), cos_i = safe_sqrt(1.0 - sq(sin_i));
    double phi = atan2(wi.z, wi.y) - fr->phi_o;
    for (int p = 0; p < P_MAX; p++)
        mn[p] = longitudinal(cos_i, fr->cos_po[p], sin_i, fr->sin_po[p], fr->v[p]) *
                azimuthal(phi, p, fr->s, fr->gamma_o, fr->gamma_t);
    mn[P_MAX] = longitudinal(cos_i, fr->cos_o, sin_i, fr->sin_o, fr->v[P_MAX]) / (2.0 * PF_PI);
}

void hair_eval(const bsdf_t *b, vec3_t wo, vec3_t wi, double *f)
{
    frame_t fr;
    double mn[P_MAX + 1], ap[P_MAX + 1];
    frame_make(b, wo, &fr);
    lobes(&fr, wi, mn);
    /* pbrt-v4 divides by |cos| to the normal so that the renderer's cosine cancels. */
    double c = fabs(wi.z) > 0.0 ? fabs(wi.z) : 1.0;
    for (int j = 0; j < bsdf_lanes(b); j++) {
        attenuation(&fr, b->sigma_a[j], ap);
        double sum = 0.0;
        for (int p = 0; p <= P_MAX; p++)
            sum += mn[p] * ap[p];
        f[j] = lobe_finite(sum / c);
    }
}

/* The probabilities of choosing each lobe: A_p over their sum. */
static bool lobe_pdf(const frame_t *fr, double sigma_a, double pick[P_MAX + 1])
{
    double ap[P_MAX + 1], sum = 0.0;
    attenuation(fr, sigma_a, ap);
    for (int p = 0; p <= P_MAX; p++)
        sum += ap[p];
    if (!(sum > 0.0) || !isfinite(sum))
        return false;
    for (int p = 0; p <= P_MAX; p++)
        pick[p] = ap[p] / sum;
    return true;
}

void hair_pdf(const bsdf_t *b, vec3_t wo, vec3_t wi, double *pdf)
{
    frame_t fr;
    double mn[P_MAX + 1], pick[P_MAX + 1];
    frame_make(b, wo, &fr);
    lobes(&fr, wi, mn);
    for (int j = 0; j < bsdf_lanes(b); j++) {
        double sum = 0.0;
        if (lobe_pdf(&fr, b->sigma_a[j], pick))
            for (int p = 0; p <= P_MAX; p++)
                sum += mn[p] * pick[p];
        pdf[j] = lobe_finite(sum);
    }
}

bool hair_sample(const bsdf_t *b, vec3_t wo, int hero, double uc, double u1, double u2,
                 bsdf_sample_t *out)
{
    frame_t fr;
    double pick[P_MAX + 1];
    frame_make(b, wo, &fr);
    if (!lobe_pdf(&fr, b->sigma_a[hero], pick))
        return false;
    /* The lobe, and uc rescaled within its interval for the azimuth (a fresh uniform). */
    int p = 0;
    double acc = 0.0;
    uc = fmin(fmax(uc, 0.0), 1.0);
    while (p < P_MAX && uc >= acc + pick[p])
        acc += pick[p++];
    while (p > 0 && !(pick[p] > 0.0))
        acc -= pick[--p];
    uc = fmin((uc - acc) / pick[p], 0x1.fffffffffffffp-1);
    uc = fmax(uc, 0.0);
    /* d'Eon et al. 2011 (pbrt-v4 4th ed. eq. 15.14): cos theta about the tilted reflection
     * cone from u1, the cone's azimuth from u2. */
    double v = fr.v[p];
    double arg = u1 + (1.0 - u1) * exp(-2.0 / v);
    double cos_t = fmax(-1.0, fmin(1.0, 1.0 + v * log(fmax(arg, 1e-300))));
    double sin_t = safe_sqrt(1.0 - cos_t * cos_t);
    double sin_i = -cos_t * fr.sin_po[p] + sin_t * cos(2.0 * PF_PI * u2) * fr.cos_po[p];
    sin_i = fmin(1.0, fmax(-1.0, sin_i));
    double cos_i = safe_sqrt(1.0 - sin_i * sin_i);
    double dphi = p < P_MAX
                      ? lobe_phi(p, fr.gamma_o, fr.gamma_t) + sample_trimmed_logistic(uc, fr.s)
                      : 2.0 * PF_PI * uc;
    double phi_i = fr.phi_o + dphi;
    out->wi = vec3_make(sin_i, cos_i * cos(phi_i), cos_i * sin(phi_i));
    hair_eval(b, wo, out->wi, out->f);
    hair_pdf(b, wo, out->wi, out->pdf);
    out->flags = out->wi.z * wo.z > 0.0 ? BSDF_REFLECTION : BSDF_TRANSMISSION;
    out->eta = 1.0;
    out->pdf_is_estimate = false;
    return out->pdf[hero] > 0.0;
}

static void eval(const bsdf_t *b, int n, vec3_t wo, vec3_t wi, rng_stream_t *rng, double *f)
{
    (void)n;
    (void)rng;
    hair_eval(b, wo, wi, f);
}

static void pdf(const bsdf_t *b, int n, vec3_t wo, vec3_t wi, rng_stream_t *rng, double *pdf)
{
    (void)n;
    (void)rng;
    hair_pdf(b, wo, wi, pdf);
}

static bsdf_sampled_t sample(const bsdf_t *b, int n, vec3_t wo, int hero, double uc, double u1,
                             double u2, rng_stream_t *rng, bsdf_sample_t *out)
{
    (void)n;
    (void)rng;
    return hair_sample(b, wo, hero, uc, u1, u2, out) ? BSDF_SAMPLED_ALL : BSDF_SAMPLED_NONE;
}

const bsdf_model_t bsdf_model_hair = {.eval = eval, .pdf = pdf, .sample = sample};

double hair_sigma_a_from_reflectance(double c, double beta_n)
{
    c = fmin(1.0, fmax(c, 1e-300));
    double b = beta_n;
    double d = 5.969 - 0.215 * b + 2.532 * b * b - 10.73 * pow(b, 3) + 5.574 * pow(b, 4) +
               0.245 * pow(b, 5);
    return sq(log(c) / d);
}

void hair_sigma_a_from_concentration(double ce, double cp, double rgb[3])
{
    static const double EU[3] = {0.419, 0.697, 1.37}, PHEO[3] = {0.187, 0.4, 1.05};
    for (int i = 0; i < 3; i++)
        rgb[i] = fmax(ce, 0.0) * EU[i] + fmax(cp, 0.0) * PHEO[i];
}
