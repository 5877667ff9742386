#include "uniaxial.h"

#include "fresnel.h"

#include <math.h>

/* Below this |a x b| two unit vectors count as parallel: the plane they span (of incidence, or
 * the principal plane) is undefined and the s / p shares are taken as 1/2, the limit in which
 * both terms agree. */
#define PARALLEL_EPS 1e-9

double uniaxial_e_index(double no, double ne, double cos_theta)
{
    const double c2 = fmin(1.0, cos_theta * cos_theta);
    return 1.0 / sqrt(c2 / (no * no) + (1.0 - c2) / (ne * ne));
}

double uniaxial_index(uniaxial_wave_t w, vec3_t k, vec3_t axis, double no, double ne)
{
    return w == UNIAXIAL_E ? uniaxial_e_index(no, ne, vec3_dot(k, axis)) : no;
}

vec3_t uniaxial_ray_from_wave(uniaxial_wave_t w, vec3_t k, vec3_t axis, double no, double ne)
{
    if (w != UNIAXIAL_E)
        return k;
    /* The gradient of F(K) = (K.c)^2 (1/n_o^2 - 1/n_e^2) + |K|^2 / n_e^2, the normal to the
     * surface F = 1 on which the e-wave vectors lie (Born & Wolf §15.3.3). */
    const double a = 1.0 / (no * no) - 1.0 / (ne * ne);
    return vec3_normalize(vec3_fma(vec3_scale(k, 1.0 / (ne * ne)), axis, a * vec3_dot(k, axis)));
}

vec3_t uniaxial_wave_from_ray(uniaxial_wave_t w, vec3_t s, vec3_t axis, double no, double ne)
{
    if (w != UNIAXIAL_E)
        return s;
    return vec3_normalize(
        vec3_fma(vec3_scale(s, ne * ne), axis, (no * no - ne * ne) * vec3_dot(s, axis)));
}

double uniaxial_walkoff(double no, double ne, double theta)
{
    const double ts = atan2((no * no) * sin(theta), (ne * ne) * cos(theta));
    return fabs(ts - theta);
}

double uniaxial_absorption(uniaxial_wave_t w, vec3_t k, vec3_t axis, double alpha_o, double alpha_e)
{
    if (w != UNIAXIAL_E)
        return alpha_o;
    const double c = vec3_dot(k, axis), c2 = fmin(1.0, c * c);
    return alpha_o * c2 + alpha_e * (1.0 - c2);
}

vec3_t uniaxial_polarisation(uniaxial_wave_t w, vec3_t k, vec3_t axis)
{
    const vec3_t zero = vec3_make(0.0, 0.0, 0.0);
    if (w == UNIAXIAL_OUTSIDE)
        return zero;
    const vec3_t d = vec3_cross(k, axis);
    const double len = vec3_length(d);
    if (!(len > PARALLEL_EPS))
        return zero;
    const vec3_t o = vec3_scale(d, 1.0 / len);
    return w == UNIAXIAL_E ? vec3_normalize(vec3_cross(o, k)) : o;
}

/* (D . s)^2 for wave w along k: o has D along k x c, e in the principal plane (k, c),
 * perpendicular to k and to o's D. 1/2 where s or the principal plane is undefined. */
static double share_s(uniaxial_wave_t w, vec3_t k, vec3_t axis, vec3_t s)
{
    const vec3_t d = vec3_cross(k, axis);
    const double len = vec3_length(d);
    if (!(len > PARALLEL_EPS) || !(vec3_dot(s, s) > 0.0))
        return 0.5;
    const double c = vec3_dot(d, s) / len, f = fmin(1.0, c * c);
    return w == UNIAXIAL_E ? 1.0 - f : f;
}

/* The e-wave vectors K = t + beta m with tangential part t: the roots beta of
 * (K.c)^2 A + |K|^2 / n_e^2 = 1, A = 1/n_o^2 - 1/n_e^2, a quadratic whose leading coefficient
 * (m.c)^2 / n_o^2 + (1 - (m.c)^2) / n_e^2 is positive. The larger root carries energy along
 * +m (the line through the convex wave surface leaves it there), the smaller along -m.
 * Returns false when the line misses the surface (no e-wave with this t). */
static bool e_roots(vec3_t t, vec3_t m, vec3_t axis, double no, double ne, double *lo, double *hi)
{
    const double A = 1.0 / (no * no) - 1.0 / (ne * ne), ine2 = 1.0 / (ne * ne);
    const double a = vec3_dot(t, axis), b = vec3_dot(m, axis);
    const double qa = A * b * b + ine2, qb = A * a * b,
                 qc = A * a * a + vec3_dot(t, t) * ine2 - 1.0;
    const double disc = qb * qb - qa * qc;
    if (!(disc >= 0.0))
        return false;
    const double r = sqrt(disc);
    *hi = (-qb + r) / qa;
    *lo = (-qb - r) / qa;
    return true;
}

/* The transmitted share T = 1 - f_s R_s - (1 - f_s) R_p at an interface from index n1 to n2,
 * with the incidence cosine cos_i > 0 on n1's side; writes the terms used. */
static double transmit(double cos_i, double n1, double n2, double fs, double *rs2, double *rp2)
{
    const fresnel_terms_t f = fresnel_dielectric_terms(cos_i, n1, n2);
    *rs2 = f.tir ? 1.0 : f.rs * f.rs;
    *rp2 = f.tir ? 1.0 : f.rp * f.rp;
    const double t = 1.0 - fs * *rs2 - (1.0 - fs) * *rp2;
    return fmin(1.0, fmax(0.0, t));
}

static double sq(double x)
{
    return x * x;
}

/* The event for one pair of indices: lane 0's in full; for other lanes only the
 * reflection probability is read. */
static void one_event(vec3_t dir, vec3_t nrm, bool entering, uniaxial_wave_t inside, vec3_t axis,
                      double no, double ne, bsdf_mode_t mode, uniaxial_event_t *e)
{
    /* m: the unit normal along the way the ray travels (toward the transmission side). */
    const vec3_t m = vec3_dot(dir, nrm) > 0.0 ? nrm : vec3_neg(nrm);
    const uniaxial_wave_t w_in = entering ? UNIAXIAL_OUTSIDE : inside;
    const vec3_t k_in = entering ? dir : uniaxial_wave_from_ray(w_in, dir, axis, no, ne);
    const double n_in = entering ? 1.0 : uniaxial_index(w_in, k_in, axis, no, ne);
    const vec3_t K = vec3_scale(k_in, n_in);
    const double kn = vec3_dot(K, m);
    const vec3_t t = vec3_fma(K, m, -kn);
    const double tt = vec3_dot(t, t);
    const double cos_i = vec3_dot(k_in, m);
    const vec3_t sx = vec3_cross(k_in, m);
    const double sl = vec3_length(sx);
    e->s_dir = sl > PARALLEL_EPS ? vec3_scale(sx, 1.0 / sl) : vec3_make(0.0, 0.0, 0.0);
    e->d_in = uniaxial_polarisation(w_in, k_in, axis);
    const bool radiance = mode == BSDF_RADIANCE;
    uniaxial_branch_t *r = &e->branch[0];
    *r = (uniaxial_branch_t){.reflects = true, .factor = 1.0};

    if (entering) {
        e->nbranch = 3;
        r->dir = r->wave = fresnel_reflect(dir, m);
        r->after = UNIAXIAL_OUTSIDE;
        r->n_after = 1.0;
        r->nmodes = 2;
        double p_t = 0.0;
        for (int w = UNIAXIAL_O; w <= UNIAXIAL_E; w++) {
            uniaxial_branch_t *b = &e->branch[1 + w];
            *b = (uniaxial_branch_t){.after = (uniaxial_wave_t)w, .nmodes = 1};
            vec3_t Kt;
            if (w == UNIAXIAL_O) {
                const double q = no * no - tt;
                if (!(q > 0.0))
                    continue;
                Kt = vec3_fma(t, m, sqrt(q));
            } else {
                double lo, hi;
                if (!e_roots(t, m, axis, no, ne, &lo, &hi) || !(hi > 0.0))
                    continue;
                Kt = vec3_fma(t, m, hi);
            }
            const double n_t = vec3_length(Kt);
            b->wave = vec3_scale(Kt, 1.0 / n_t);
            b->dir = uniaxial_ray_from_wave((uniaxial_wave_t)w, b->wave, axis, no, ne);
            b->n_after = n_t;
            b->d_after = uniaxial_polarisation((uniaxial_wave_t)w, b->wave, axis);
            const double fs = share_s((uniaxial_wave_t)w, b->wave, axis, e->s_dir);
            double rs2, rp2;
            /* Snell holds at the wave's own index: n_t sin(theta_t) = |t| by construction. */
            const double T = transmit(cos_i, 1.0, n_t, fs, &rs2, &rp2);
            b->prob = 0.5 * T;
            b->factor = radiance ? 1.0 / (n_t * n_t) : 1.0;
            b->term_s[0] = 1.0 - rs2;
            b->term_p[0] = 1.0 - rp2;
            b->frac_s[0] = fs;
            r->term_s[w] = rs2;
            r->term_p[w] = rp2;
            r->frac_s[w] = fs;
            p_t += b->prob;
        }
        r->prob = fmax(0.0, 1.0 - p_t);
        return;
    }

    e->nbranch = 2;
    uniaxial_branch_t *x = &e->branch[1];
    *x = (uniaxial_branch_t){.after = UNIAXIAL_OUTSIDE, .nmodes = 1, .n_after = 1.0};
    /* The reflected wave, in the same mode: o mirrors k; e takes the other root of its wave
     * surface for the same tangential wave vector (the incident one is K.m). */
    r->after = inside;
    r->nmodes = 1;
    if (inside == UNIAXIAL_E) {
        double lo, hi;
        const double sum = e_roots(t, m, axis, no, ne, &lo, &hi) ? lo + hi : kn;
        const vec3_t Kr = vec3_fma(t, m, sum - kn);
        const double n_r = vec3_length(Kr);
        r->wave = n_r > 0.0 ? vec3_scale(Kr, 1.0 / n_r) : fresnel_reflect(k_in, m);
        r->n_after = n_r > 0.0 ? n_r : n_in;
        r->dir = uniaxial_ray_from_wave(UNIAXIAL_E, r->wave, axis, no, ne);
        r->factor = radiance ? sq(n_in / r->n_after) : 1.0;
    } else {
        r->wave = r->dir = fresnel_reflect(k_in, m);
        r->n_after = n_in;
    }
    const double fs = share_s(inside, k_in, axis, e->s_dir);
    r->frac_s[0] = x->frac_s[0] = fs;
    r->d_after = uniaxial_polarisation(inside, r->wave, axis);
    if (!(tt < 1.0) || !(cos_i > 0.0)) {
        /* Total internal reflection (or a wave normal that, walked off, points away from the
         * surface its ray reaches: nothing can leave). */
        r->prob = 1.0;
        r->term_s[0] = r->term_p[0] = 1.0;
        return;
    }
    x->dir = x->wave = vec3_fma(t, m, sqrt(1.0 - tt));
    double rs2, rp2;
    const double T = transmit(cos_i, n_in, 1.0, fs, &rs2, &rp2);
    x->prob = T;
    x->factor = radiance ? n_in * n_in : 1.0;
    x->term_s[0] = 1.0 - rs2;
    x->term_p[0] = 1.0 - rp2;
    r->term_s[0] = rs2;
    r->term_p[0] = rp2;
    r->prob = 1.0 - T;
}

void uniaxial_event_make(vec3_t dir, vec3_t nrm, bool entering, uniaxial_wave_t inside, vec3_t axis,
                         const double *no, const double *ne, int count, bsdf_mode_t mode,
                         uniaxial_event_t *e)
{
    if (count < 1)
        count = 1;
    if (count > BSDF_MAX_LANES)
        count = BSDF_MAX_LANES;
    if (inside != UNIAXIAL_E)
        inside = UNIAXIAL_O;
    e->mode = mode;
    e->count = count;
    e->grey = true;
    one_event(dir, nrm, entering, inside, axis, no[0], ne[0], mode, e);
    e->lane_reflect[0] = e->branch[0].prob;
    for (int j = 1; j < count; j++) {
        if (no[j] == no[0] && ne[j] == ne[0]) {
            e->lane_reflect[j] = e->lane_reflect[0];
            continue;
        }
        e->grey = false;
        uniaxial_event_t lane;
        one_event(dir, nrm, entering, inside, axis, no[j], ne[j], mode, &lane);
        e->lane_reflect[j] = lane.branch[0].prob;
    }
}

int uniaxial_choose(const uniaxial_event_t *e, double u)
{
    double acc = 0.0;
    int last = 0;
    for (int b = 0; b < e->nbranch; b++) {
        if (!(e->branch[b].prob > 0.0))
            continue;
        last = b;
        acc += e->branch[b].prob;
        if (u < acc)
            return b;
    }
    /* u beyond the rounded sum: the last branch that can happen. */
    return last;
}

double uniaxial_lane_weight(const uniaxial_event_t *e, int b, int j)
{
    if (b < 0 || b >= e->nbranch || j < 0 || j >= e->count)
        return 0.0;
    const uniaxial_branch_t *br = &e->branch[b];
    if (!br->reflects || e->grey || j == 0)
        return br->factor;
    return br->prob > 0.0 ? e->lane_reflect[j] / br->prob * br->factor : 0.0;
}

mueller_t uniaxial_branch_mueller(const uniaxial_event_t *e, int b)
{
    mueller_t sum = {{{0}}};
    if (b < 0 || b >= e->nbranch)
        return sum;
    const uniaxial_branch_t *br = &e->branch[b];
    /* Entering, the unpolarised light is split into the modes' polarisations (a polariser at
     * psi, cos^2 psi = f_s, from s toward p) and each part takes its Fresnel amplitudes; light
     * inside is already in its mode, so there the polariser's 1/2 is undone. */
    const bool in_mode =
        br->after == UNIAXIAL_OUTSIDE ? !br->reflects : br->reflects && br->nmodes == 1;
    for (int k = 0; k < br->nmodes; k++) {
        const double psi = acos(sqrt(fmin(1.0, fmax(0.0, br->frac_s[k]))));
        const mueller_t p = mueller_polariser(psi);
        const mueller_t d = mueller_jones_diagonal(sqrt(fmax(0.0, br->term_s[k])), 0.0,
                                                   sqrt(fmax(0.0, br->term_p[k])), 0.0);
        mueller_t m = mueller_mul(&d, &p);
        if (in_mode)
            m = mueller_scale(&m, 2.0);
        for (int i = 0; i < 4; i++)
            for (int c = 0; c < 4; c++)
                sum.m[i][c] += m.m[i][c];
    }
    return sum;
}

/* A linear polariser along the line d for light along k in the frame x (angles from x toward
 * y = k x x); half of any state where d is undefined. */
static mueller_t mode_polariser(vec3_t d, vec3_t k, vec3_t x)
{
    if (!(vec3_dot(d, d) > 0.0)) {
        const mueller_t id = mueller_identity();
        return mueller_scale(&id, 0.5);
    }
    const vec3_t y = vec3_cross(k, x);
    return mueller_polariser(atan2(vec3_dot(d, y), vec3_dot(d, x)));
}

/* Mode k's Fresnel amplitudes on branch br as a diagonal Jones matrix in the s-p frame. */
static mueller_t mode_fresnel(const uniaxial_branch_t *br, int k)
{
    return mueller_jones_diagonal(sqrt(fmax(0.0, br->term_s[k])), 0.0,
                                  sqrt(fmax(0.0, br->term_p[k])), 0.0);
}

mueller_t uniaxial_branch_mueller_frames(const uniaxial_event_t *e, int b, const polar_event_t *ev)
{
    mueller_t sum = {{{0}}};
    if (b < 0 || b >= e->nbranch)
        return sum;
    const uniaxial_branch_t *br = &e->branch[b];
    if (br->nmodes == 2) {
        /* Reflected outside: each transmitted mode's share of the light, reflected with that
         * mode's amplitudes (the event's branches 1 and 2 are o and e). */
        for (int k = 0; k < 2; k++) {
            const mueller_t p = mode_polariser(e->branch[1 + k].d_after, ev->k_in, ev->x_in);
            const mueller_t f = mode_fresnel(br, k);
            const mueller_t m = mueller_mul(&f, &p);
            for (int i = 0; i < 4; i++)
                for (int c = 0; c < 4; c++)
                    sum.m[i][c] += m.m[i][c];
        }
        return sum;
    }
    const bool backward = e->mode == BSDF_RADIANCE;
    const vec3_t d_entry = backward ? br->d_after : e->d_in;
    const vec3_t d_exit = backward ? e->d_in : br->d_after;
    const bool from_inside = backward ? br->after != UNIAXIAL_OUTSIDE : e->nbranch == 2;
    const bool to_inside = backward ? e->nbranch == 2 : br->after != UNIAXIAL_OUTSIDE;
    const mueller_t f = mode_fresnel(br, 0);
    if (from_inside) {
        const mueller_t p = mode_polariser(d_entry, ev->k_in, ev->x_in);
        return mueller_mul(&f, &p);
    }
    if (to_inside) {
        const mueller_t p = mode_polariser(d_exit, ev->k_out, ev->x_out);
        return mueller_mul(&p, &f);
    }
    return f;
}
