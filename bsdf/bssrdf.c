#include "bssrdf.h"

#include "bsdf_model.h"
#include "catmull_rom.h"
#include "diffuse.h"
#include "fresnel.h"
#include "sample.h"

#include <math.h>
#include <stdlib.h>

struct bssrdf_table {
    double g, eta;
    double rho[BSSRDF_RHO_SAMPLES];
    double radius[BSSRDF_RADIUS_SAMPLES]; /* optical radii (sigma_t = 1) */
    /* Row i (albedo rho[i]): 2 pi r times the profile at each radius (the radial marginal,
     * which is what is sampled), its running integral, and the total, rho_eff. */
    double profile[BSSRDF_RHO_SAMPLES * BSSRDF_RADIUS_SAMPLES];
    double cdf[BSSRDF_RHO_SAMPLES * BSSRDF_RADIUS_SAMPLES];
    double rho_eff[BSSRDF_RHO_SAMPLES];
};

double bssrdf_fresnel_moment1(double eta)
{
    const double e2 = eta * eta, e3 = e2 * eta, e4 = e3 * eta, e5 = e4 * eta;
    if (eta < 1.0)
        return 0.45966 - 1.73965 * eta + 3.37668 * e2 - 3.904945 * e3 + 2.49277 * e4 - 0.68441 * e5;
    return -4.61686 + 11.1136 * eta - 10.4646 * e2 + 5.11455 * e3 - 1.27198 * e4 + 0.12746 * e5;
}

double bssrdf_fresnel_moment2(double eta)
{
    const double e2 = eta * eta, e3 = e2 * eta, e4 = e3 * eta, e5 = e4 * eta;
    if (eta < 1.0)
        return 0.27614 - 0.87350 * eta + 1.12077 * e2 - 0.65095 * e3 + 0.07883 * e4 + 0.04860 * e5;
    const double r = 1.0 / eta, r2 = r * r, r3 = r2 * r;
    return -547.033 + 45.3087 * r3 - 218.725 * r2 + 458.843 * r + 404.557 * eta - 189.519 * e2 +
           54.9327 * e3 - 9.00603 * e4 + 0.63942 * e5;
}

/* Midpoint quadrature over depth in PBD's integrals: both use 100 points placed by inverting
 * the beam's exponential attenuation, as pbrt-v4 does (so that the table is its table). */
#define PBD_SAMPLES 100

/* The quadrature's unit-rate exponential depths -ln(1 - (i + 1/2) / PBD_SAMPLES). */
static void pbd_depths(double q[PBD_SAMPLES])
{
    for (int i = 0; i < PBD_SAMPLES; i++)
        q[i] = -log(1.0 - (i + 0.5) / PBD_SAMPLES);
}

/* Multiple scattering (Habel et al. 2013, eqs. 7-11; pbrt-v4 BeamDiffusionMS): the dipole of
 * Grosjean's diffusion coefficient D_G = (2 sigma_a + sigma_s') / (3 sigma_t'^2) for a source at
 * depth z_r along the refracted beam, mirrored about the extrapolated boundary
 * z_e = -2 D_G (1 + 3 M2) / (1 - 2 M1) (Fresnel moments M1, M2 of the inside), its exitance
 * c_phi phi + c_E E.n with c_phi = (1 - 2 M1) / 4 and c_E = (1 - 3 M2) / 2, each depth weighted
 * by rho'^2 and the correction kappa = 1 - exp(-2 sigma_t' (d_r + z_r)). */
static double beam_ms(const double *q, double sigma_s, double sigma_a, double g, double eta,
                      double r)
{
    const double sps = sigma_s * (1.0 - g), spt = sigma_a + sps;
    if (!(spt > 0.0))
        return 0.0;
    const double rhop = sps / spt;
    const double dg = (2.0 * sigma_a + sps) / (3.0 * spt * spt);
    const double ratio = sigma_a / dg, str = ratio > 0.0 ? sqrt(ratio) : 0.0;
    const double m1 = bssrdf_fresnel_moment1(eta), m2 = bssrdf_fresnel_moment2(eta);
    const double ze = -2.0 * dg * (1.0 + 3.0 * m2) / (1.0 - 2.0 * m1);
    const double c_phi = 0.25 * (1.0 - 2.0 * m1), c_e = 0.5 * (1.0 - 3.0 * m2);
    const double inv4pi = 1.0 / (4.0 * PF_PI);
    double sum = 0.0;
    for (int i = 0; i < PBD_SAMPLES; i++) {
        const double zr = q[i] / spt;
        const double zv = -zr + 2.0 * ze;
        const double dr = sqrt(r * r + zr * zr), dv = sqrt(r * r + zv * zv);
        const double er = exp(-str * dr), ev = exp(-str * dv);
        const double phi = inv4pi / dg * (er / dr - ev / dv);
        const double edn = inv4pi * (zr * (1.0 + str * dr) * er / (dr * dr * dr) -
                                     zv * (1.0 + str * dv) * ev / (dv * dv * dv));
        const double kappa = 1.0 - exp(-2.0 * spt * (dr + zr));
        sum += kappa * rhop * rhop * (phi * c_phi + edn * c_e);
    }
    return sum / PBD_SAMPLES;
}

/* Single scattering (Habel et al. 2013, eq. 12; pbrt-v4 BeamDiffusionSS): light scattered
 * once at depth t along the beam toward the exit point at distance d = sqrt(r^2 + t^2), only
 * from below the critical depth t_crit = r sqrt(eta^2 - 1), with the HG phase function and the
 * exit's Fresnel transmission. */
static double beam_ss(const double *q, double sigma_s, double sigma_a, double g, double eta,
                      double r)
{
    const double st = sigma_a + sigma_s;
    if (!(st > 0.0))
        return 0.0;
    const double rho = sigma_s / st;
    const double e = eta * eta - 1.0, tcrit = r * (e > 0.0 ? sqrt(e) : 0.0);
    double sum = 0.0;
    for (int i = 0; i < PBD_SAMPLES; i++) {
        const double ti = tcrit + q[i] / st;
        const double d = sqrt(r * r + ti * ti), cos_o = ti / d;
        const double den = 1.0 + g * g + 2.0 * g * cos_o;
        const double hg = (1.0 - g * g) / (4.0 * PF_PI * den * sqrt(den));
        /* The exit seen from inside: fresnel_dielectric with the cosine's sign for "inside". */
        const double tr = 1.0 - fresnel_dielectric(-cos_o, 1.0, eta);
        sum += rho * exp(-st * (d + tcrit)) / (d * d) * hg * tr * fabs(cos_o);
    }
    return sum / PBD_SAMPLES;
}

double bssrdf_beam_diffusion_ms(double sigma_s, double sigma_a, double g, double eta, double r)
{
    double q[PBD_SAMPLES];
    pbd_depths(q);
    return beam_ms(q, sigma_s, sigma_a, g, eta, r);
}

double bssrdf_beam_diffusion_ss(double sigma_s, double sigma_a, double g, double eta, double r)
{
    double q[PBD_SAMPLES];
    pbd_depths(q);
    return beam_ss(q, sigma_s, sigma_a, g, eta, r);
}

bssrdf_table_t *bssrdf_table_new(double g, double eta)
{
    bssrdf_table_t *t = calloc(1, sizeof *t);
    if (!t)
        return NULL;
    t->g = g;
    t->eta = eta;
    /* pbrt-v4's grid: radii 0, 2.5e-3, then x1.2 (to about 2.3e2 optical lengths); albedos
     * dense toward 1, (1 - exp(-8 i / 99)) / (1 - exp(-8)). */
    t->radius[0] = 0.0;
    t->radius[1] = 2.5e-3;
    for (int i = 2; i < BSSRDF_RADIUS_SAMPLES; i++)
        t->radius[i] = t->radius[i - 1] * 1.2;
    for (int i = 0; i < BSSRDF_RHO_SAMPLES; i++)
        t->rho[i] = (1.0 - exp(-8.0 * i / (BSSRDF_RHO_SAMPLES - 1.0))) / (1.0 - exp(-8.0));
    double q[PBD_SAMPLES];
    pbd_depths(q);
    for (int i = 0; i < BSSRDF_RHO_SAMPLES; i++) {
        double *row = t->profile + (size_t)i * BSSRDF_RADIUS_SAMPLES;
        const double rho = t->rho[i];
        for (int j = 0; j < BSSRDF_RADIUS_SAMPLES; j++) {
            const double r = t->radius[j];
            row[j] =
                2.0 * PF_PI * r *
                (beam_ss(q, rho, 1.0 - rho, g, eta, r) + beam_ms(q, rho, 1.0 - rho, g, eta, r));
        }
        t->rho_eff[i] = catmull_rom_integrate(t->radius, row, BSSRDF_RADIUS_SAMPLES,
                                              t->cdf + (size_t)i * BSSRDF_RADIUS_SAMPLES);
    }
    return t;
}

void bssrdf_table_destroy(bssrdf_table_t **self_p)
{
    if (!self_p || !*self_p)
        return;
    free(*self_p);
    *self_p = NULL;
}

double bssrdf_table_eta(const bssrdf_table_t *t)
{
    return t->eta;
}

double bssrdf_table_g(const bssrdf_table_t *t)
{
    return t->g;
}

static double clamp01(double v)
{
    return v > 0.0 ? (v < 1.0 ? v : 1.0) : 0.0;
}

double bssrdf_rho_eff(const bssrdf_table_t *t, double rho)
{
    int off;
    double w[4];
    if (!catmull_rom_weights(t->rho, BSSRDF_RHO_SAMPLES, clamp01(rho), &off, w))
        return 0.0;
    double v = 0.0;
    for (int k = 0; k < 4; k++)
        if (w[k] != 0.0)
            v += w[k] * t->rho_eff[off + k];
    return v > 0.0 ? v : 0.0;
}

double bssrdf_rho_from_eff(const bssrdf_table_t *t, double rho_eff)
{
    return clamp01(catmull_rom_invert(t->rho, t->rho_eff, BSSRDF_RHO_SAMPLES, rho_eff));
}

/* The tensor-spline interpolation of the radial marginal 2 pi r_opt S at (rho, r_opt), with
 * the interpolated rho_eff when wanted; false outside the table. */
static bool interpolate(const bssrdf_table_t *t, double rho, double r_opt, double *marginal,
                        double *rho_eff)
{
    int ro, xo;
    double rw[4], xw[4];
    if (!catmull_rom_weights(t->rho, BSSRDF_RHO_SAMPLES, rho, &ro, rw) ||
        !catmull_rom_weights(t->radius, BSSRDF_RADIUS_SAMPLES, r_opt, &xo, xw))
        return false;
    double m = 0.0, e = 0.0;
    for (int a = 0; a < 4; a++) {
        if (rw[a] == 0.0)
            continue;
        e += rw[a] * t->rho_eff[ro + a];
        for (int b = 0; b < 4; b++)
            if (xw[b] != 0.0)
                m += rw[a] * xw[b] * t->profile[(size_t)(ro + a) * BSSRDF_RADIUS_SAMPLES + xo + b];
    }
    *marginal = m;
    if (rho_eff)
        *rho_eff = e;
    return true;
}

/* S_r in world units from the optical marginal: divide out 2 pi r_opt, scale by sigma_t^2
 * (the profile is per unit optical area). At r = 0 the marginal is 0 and so is this, as in
 * pbrt-v4. */
static double per_area(double marginal, double r_opt, double sigma_t)
{
    if (r_opt != 0.0)
        marginal /= 2.0 * PF_PI * r_opt;
    const double v = marginal * sigma_t * sigma_t;
    return v > 0.0 && isfinite(v) ? v : 0.0;
}

double bssrdf_sr(const bssrdf_table_t *t, double sigma_t, double rho, double r)
{
    double m;
    const double r_opt = r * sigma_t;
    if (!(sigma_t > 0.0) || !interpolate(t, clamp01(rho), r_opt, &m, NULL))
        return 0.0;
    return per_area(m, r_opt, sigma_t);
}

double bssrdf_pdf_sr(const bssrdf_table_t *t, double sigma_t, double rho, double r)
{
    double m, e;
    const double r_opt = r * sigma_t;
    if (!(sigma_t > 0.0) || !interpolate(t, clamp01(rho), r_opt, &m, &e) || !(e > 0.0))
        return 0.0;
    return per_area(m, r_opt, sigma_t) / e;
}

double bssrdf_sample_sr(const bssrdf_table_t *t, double sigma_t, double rho, double u)
{
    if (!(sigma_t > 0.0))
        return -1.0;
    const double x =
        catmull_rom_sample_2d(t->rho, BSSRDF_RHO_SAMPLES, t->radius, BSSRDF_RADIUS_SAMPLES,
                              t->profile, t->cdf, clamp01(rho), u, NULL, NULL);
    return x >= 0.0 ? x / sigma_t : -1.0;
}

/* The probe's three axes about ns: the two tangents of vec3_basis, then ns, and their
 * probabilities. */
static const double AXIS_PROB[3] = {0.25, 0.25, 0.5};

static void axes(vec3_t ns, vec3_t ax[3])
{
    vec3_basis(ns, &ax[0], &ax[1]);
    ax[2] = ns;
}

bool bssrdf_probe(const bssrdf_table_t *t, double sigma_t, double rho, vec3_t po, vec3_t ns,
                  double u_axis, double u_r, double u_phi, vec3_t *p0, vec3_t *p1)
{
    vec3_t ax[3];
    axes(ns, ax);
    /* The probe runs along ax[k]; the disc it samples lies in the plane of the other two. */
    const int k = u_axis < AXIS_PROB[0] ? 0 : u_axis < AXIS_PROB[0] + AXIS_PROB[1] ? 1 : 2;
    const vec3_t a = ax[(k + 1) % 3], b = ax[(k + 2) % 3], z = ax[k];
    const double r = bssrdf_sample_sr(t, sigma_t, rho, u_r);
    const double r_max = bssrdf_sample_sr(t, sigma_t, rho, 0.999);
    if (!(r >= 0.0) || !(r < r_max))
        return false;
    const double phi = 2.0 * PF_PI * u_phi, l = 2.0 * sqrt(r_max * r_max - r * r);
    const vec3_t c =
        vec3_add(po, vec3_add(vec3_scale(a, r * cos(phi)), vec3_scale(b, r * sin(phi))));
    *p0 = vec3_fma(c, z, -0.5 * l);
    *p1 = vec3_fma(c, z, 0.5 * l);
    return true;
}

double bssrdf_pdf_sp(const bssrdf_table_t *t, double sigma_t, double rho, vec3_t po, vec3_t ns,
                     vec3_t pi, vec3_t ni)
{
    vec3_t ax[3];
    axes(ns, ax);
    const vec3_t d = vec3_sub(pi, po);
    double pdf = 0.0;
    for (int k = 0; k < 3; k++) {
        const double along = vec3_dot(d, ax[k]);
        const double q = vec3_dot(d, d) - along * along;
        const double r = q > 0.0 ? sqrt(q) : 0.0;
        pdf += AXIS_PROB[k] * bssrdf_pdf_sr(t, sigma_t, rho, r) * fabs(vec3_dot(ni, ax[k]));
    }
    return pdf;
}

/* ---- Where the light leaves (BSDF_SSS_EXIT) ---- */

/* pbrt-v4's NormalizedFresnelBxDF, the BSSRDF's directional factor S_w where light leaves:
 * the outside's Fresnel transmission (1 - F_r(cos wi)) normalised by its cosine-weighted
 * integral c pi, c = 1 - 2 M1(1 / eta) (the moment of the outside), so that int S_w cos = 1;
 * in radiance mode times eta^2, which undoes the 1 / eta^2 of the refraction that took the
 * light in. Reflection only, on wo's side, sampled by the cosine. */
static double exit_f(double eta, bsdf_mode_t mode, vec3_t wo, vec3_t wi)
{
    if (!(wo.z * wi.z > 0.0) || !(eta > 0.0))
        return 0.0;
    const double c = 1.0 - 2.0 * bssrdf_fresnel_moment1(1.0 / eta);
    const double f = (1.0 - fresnel_dielectric(fabs(wi.z), 1.0, eta)) / (c * PF_PI);
    return lobe_finite(mode == BSDF_RADIANCE ? f * eta * eta : f);
}

static void exit_eval(const bsdf_t *b, int n, vec3_t wo, vec3_t wi, rng_stream_t *rng, double *f)
{
    (void)rng;
    for (int j = 0; j < n; j++)
        f[j] = exit_f(b->eta[j], b->mode, wo, wi);
}

static bsdf_sampled_t exit_sample(const bsdf_t *b, int n, vec3_t wo, int hero, double uc, double u1,
                                  double u2, rng_stream_t *rng, bsdf_sample_t *out)
{
    (void)uc;
    (void)rng;
    vec3_t wi = sample_cosine_hemisphere(u1, u2);
    if (wo.z < 0.0)
        wi.z = -wi.z;
    if (wi.z == 0.0)
        return BSDF_SAMPLED_NONE;
    out->wi = wi;
    out->flags = BSDF_REFLECTION;
    for (int j = 0; j < n; j++) {
        out->f[j] = exit_f(b->eta[j], b->mode, wo, wi);
        out->pdf[j] = sample_cosine_hemisphere_pdf(fabs(wi.z));
    }
    return out->pdf[hero] > 0.0 ? BSDF_SAMPLED_ALL : BSDF_SAMPLED_NONE;
}

const bsdf_model_t bsdf_model_sss_exit = {
    .eval = exit_eval, .pdf = diffuse_pdf, .sample = exit_sample};
