#include "photon_polar.h"

#include "delta.h"
#include "lights.h"
#include "polar_fresnel.h"
#include "sheet.h"
#include "thinfilm.h"

#include <complex.h>
#include <math.h>

void photon_polar_emit(photon_polar_t *pp, const light_t *l, vec3_t dir, int n)
{
    vec3_t t, b;
    vec3_basis(dir, &t, &b);
    pp->x = t;
    double s[4];
    lights_stokes(l, dir, pp->x, s);
    for (int j = 0; j < n; j++)
        pp->s[j] = stokes_make(s[0], s[1], s[2], s[3]);
}

void photon_polar_depolarise(photon_polar_t *pp, vec3_t dir, int n)
{
    pp->x = polar_frame_perp(pp->x, dir);
    for (int j = 0; j < n; j++)
        pp->s[j] = stokes_unpolarised(1.0);
}

/* s in the frame x_to (about k) from the frame x_from. */
static stokes_t rebase(stokes_t s, vec3_t x_from, vec3_t x_to, vec3_t k)
{
    const mueller_t r = polar_frame_change(x_from, x_to, k);
    return mueller_apply(&r, s);
}

/* s / s0 into *s, and s0; a lane with no power (s0 not positive, or not finite) keeps its old
 * vector and returns 0. */
static double normalise(stokes_t in, stokes_t *s)
{
    const double s0 = in.s[0];
    if (!(s0 > 0.0) || !isfinite(s0))
        return 0.0;
    for (int i = 0; i < 4; i++)
        s->s[i] = in.s[i] / s0;
    s->s[0] = 1.0;
    return s0;
}

void photon_polar_apply(photon_polar_t *pp, const polar_event_t *ev, const mueller_t *m,
                        int m_stride, int n, double *w)
{
    const mueller_t r = polar_frame_change(pp->x, ev->x_in, ev->k_in);
    for (int j = 0; j < n; j++) {
        const mueller_t *mj = m_stride ? &m[j] : m;
        const stokes_t in = mueller_apply(&r, pp->s[j]);
        w[j] *= normalise(mueller_apply(mj, in), &pp->s[j]);
    }
    pp->x = ev->x_out;
}

void photon_polar_sheet(photon_polar_t *pp, const surface_t *sf, const material_t *m, vec3_t dir,
                        int n, const double *lambda, double *w)
{
    const vec3_t axis = sheet_axis(sf, m);
    const polar_event_t ev = polar_event_sheet(dir, axis);
    mueller_t mm[PHOTON_POLAR_MAX_LANES];
    const int per_lane = sheet_mueller(sf, m, axis, dir, n, lambda, mm);
    photon_polar_apply(pp, &ev, mm, per_lane, n, w);
}

void photon_polar_conductor(photon_polar_t *pp, vec3_t dir, vec3_t reflect, vec3_t nrm,
                            const double *eta, const double *k, const double *lambda,
                            double thickness_nm, const ior_model_t *film_ior, int n, double *w)
{
    const double cos_i = fmin(1.0, fabs(vec3_dot(dir, nrm)));
    const polar_event_t ev = polar_event_interface(dir, reflect, nrm, pp->x);
    mueller_t mm[PHOTON_POLAR_MAX_LANES];
    for (int j = 0; j < n; j++) {
        if (thickness_nm > 0.0) {
            const thinfilm_t f = thinfilm_eval(cos_i, 1.0, ior_eval(film_ior, lambda[j]),
                                               thickness_nm, eta[j] + I * k[j], lambda[j]);
            mm[j] = thinfilm_reflection(&f);
        } else {
            const polar_fresnel_t f = polar_fresnel_conductor(cos_i, eta[j], k[j]);
            mm[j] = polar_fresnel_reflection(&f);
        }
    }
    photon_polar_apply(pp, &ev, mm, 1, n, w);
}

void photon_polar_dielectric(photon_polar_t *pp, vec3_t dir, vec3_t nrm, bool entering,
                             double n_glass, double thickness_nm, const ior_model_t *film_ior,
                             const double *lambda, int n, double u, double *w, vec3_t *out)
{
    delta_dielectric_t e;
    delta_dielectric_make(dir, nrm, entering, &n_glass, 1, BSDF_IMPORTANCE, &e);
    const double n_i = entering ? 1.0 : n_glass, n_t = entering ? n_glass : 1.0;
    const double cos_i = fmin(1.0, fabs(vec3_dot(dir, nrm)));
    /* Both branches share the entry frame (s = k_in x n), so each lane's vector is rebased
     * once and both branches' fractions come from it. */
    const polar_event_t er = polar_event_interface(dir, e.reflect, nrm, pp->x);
    const polar_event_t et = e.refracts ? polar_event_interface(dir, e.refract, nrm, pp->x) : er;
    stokes_t sr[PHOTON_POLAR_MAX_LANES], st[PHOTON_POLAR_MAX_LANES];
    polar_fresnel_t bare = {0};
    if (!(thickness_nm > 0.0))
        bare = polar_fresnel_eval(cos_i, n_i, n_t);
    double p_reflect = 0.0;
    for (int j = 0; j < n; j++) {
        mueller_t mr, mt;
        if (thickness_nm > 0.0) {
            const thinfilm_t f = thinfilm_eval(cos_i, n_i, ior_eval(film_ior, lambda[j]),
                                               thickness_nm, n_t, lambda[j]);
            mr = thinfilm_reflection(&f);
            mt = thinfilm_transmission(&f);
        } else {
            mr = polar_fresnel_reflection(&bare);
            mt = polar_fresnel_transmission(&bare);
        }
        const stokes_t in = rebase(pp->s[j], pp->x, er.x_in, dir);
        sr[j] = mueller_apply(&mr, in);
        st[j] = mueller_apply(&mt, in);
        p_reflect += sr[j].s[0];
    }
    /* The lanes' mean reflectance; 1 where lane 0's direction cannot refract (the matrices
     * agree: total reflection transmits nothing). */
    p_reflect = e.refracts ? fmin(1.0, fmax(0.0, p_reflect / n)) : 1.0;
    const bool reflect = u < p_reflect;
    const double prob = reflect ? p_reflect : 1.0 - p_reflect;
    for (int j = 0; j < n; j++) {
        const double s0 = normalise(reflect ? sr[j] : st[j], &pp->s[j]);
        w[j] = prob > 0.0 ? w[j] * (s0 / prob) : 0.0;
    }
    pp->x = reflect ? er.x_out : et.x_out;
    *out = reflect ? e.reflect : e.refract;
}
