#include "crystal_coherent.h"

#include "material_uniaxial.h"
#include "uniaxial.h"

#include <math.h>

static vec3_t re3(const double complex K[3])
{
    return vec3_make(creal(K[0]), creal(K[1]), creal(K[2]));
}

static vec3_t unit_or(vec3_t v, vec3_t fallback)
{
    const double l = vec3_length(v);
    return l > 0.0 && isfinite(l) ? vec3_scale(v, 1.0 / l) : fallback;
}

/* The direction a camera path follows back along the light arriving at a face from inside in
 * f's o and e waves: against the mean of their ray (energy) directions. */
static vec3_t mean_ray_back(const uniaxial_fresnel_t *f, vec3_t axis, double no, double ne)
{
    vec3_t r = vec3_make(0.0, 0.0, 0.0);
    const vec3_t ko = unit_or(re3(f->in[UF_O].K), vec3_make(0.0, 0.0, 1.0));
    if (f->in[UF_O].propagating)
        r = vec3_add(r, uniaxial_ray_from_wave(UNIAXIAL_O, ko, axis, no, ne));
    if (f->in[UF_E].propagating)
        r = vec3_add(
            r, uniaxial_ray_from_wave(UNIAXIAL_E, unit_or(re3(f->in[UF_E].K), ko), axis, no, ne));
    return vec3_neg(unit_or(r, ko));
}

/* The wave whose index surface lies inside the other's: e in a negative crystal (n_e < n_o),
 * o in a positive one. Any tangential wave vector within its surface's shadow is within the
 * other's, so a segment's next face, solved with this wave's tangential wave vector, has both
 * waves propagating (with the other wave's, a negative crystal's e wave could come out
 * evanescent there, and the light it carried would be lost). */
static int inner_wave(double no, double ne)
{
    return ne < no ? UF_E : UF_O;
}

void crystal_coherent_enter(crystal_coherent_t *c, vec3_t axis, vec3_t dir, vec3_t m, int n,
                            const double *no, const double *ne, double prob, vec3_t x, vec3_t *out)
{
    c->n = n < 1 ? 1 : n > BSDF_MAX_LANES ? BSDF_MAX_LANES : n;
    c->prob = prob;
    c->k_exit = vec3_neg(dir);
    c->x_exit = polar_frame_perp(x, c->k_exit);
    c->hint = c->x_exit;
    /* The light leaves along k_exit: its tangential wave vector (outside index 1). */
    const vec3_t t = vec3_fma(c->k_exit, m, -vec3_dot(c->k_exit, m));
    for (int j = 0; j < c->n; j++) {
        if (j > 0 && no[j] == no[0] && ne[j] == ne[0]) {
            c->j[j] = c->j[0];
            continue;
        }
        uniaxial_fresnel_t f;
        uniaxial_fresnel_solve(t, m, axis, no[j], ne[j], 1.0, c->hint, &f);
        c->j[j] = jones_uniaxial_exit(&f, c->k_exit, c->x_exit);
        if (j == 0) {
            *out = mean_ray_back(&f, axis, no[0], ne[0]);
            c->k_seg = re3(f.in[inner_wave(no[0], ne[0])].K);
        }
    }
}

/* The segment from the face (where f was solved) to the previous vertex, along dr (scene
 * units, the light's way), in the basis of f's waves going in: each wave's phase
 * 2 pi K . dr / lambda (K in units of the vacuum wavenumber; for parallel faces the difference
 * is 2 pi (N_o - N_e) t / lambda, Veiras et al. 2010's plate), the optical rotation
 * -rho L cos^2 theta (theta between the wave normal and the axis: the rotation along the axis,
 * the perpendicular gyration neglected; negative: a dextrorotatory crystal turns clockwise seen
 * facing the light) and each wave's Beer-Lambert amplitude exp(-alpha L / 2). */
static jones_t propagate(const uniaxial_fresnel_t *f, const material_t *mat, vec3_t axis, vec3_t dr,
                         double lambda)
{
    const material_uniaxial_t *cr = material_uniaxial_of(mat);
    const double len_mm = vec3_length(dr) * cr->mm_per_unit;
    const double k0 = 2.0 * PF_PI / lambda * cr->mm_per_unit * 1e6; /* per scene unit */
    const vec3_t Ko = re3(f->out[UF_O].K), Ke = re3(f->out[UF_E].K);
    const vec3_t ko = unit_or(Ko, vec3_make(0.0, 0.0, 1.0));
    const vec3_t eo = re3(f->out[UF_O].E), ee = re3(f->out[UF_E].E);
    const double cth = vec3_dot(ko, axis);
    const double psi =
        -crystal_rotary_power(&cr->crystal.rotation, lambda) * (PF_PI / 180.0) * len_mm * cth * cth;
    /* The waves' basis (E_o, E_e) turned right-handed about k (jones_elliptical's): the
     * rotation's sign flips with E_e's. */
    const double sigma = vec3_dot(vec3_cross(ko, eo), ee) < 0.0 ? -1.0 : 1.0;
    jones_t r = jones_elliptical(k0 * vec3_dot(Ko, dr), k0 * vec3_dot(Ke, dr), sigma * psi);
    if (cr->crystal.absorption.rows > 0) {
        double ao, ae;
        crystal_absorption_eval(&cr->crystal.absorption, lambda, &ao, &ae);
        const double a[2] = {uniaxial_absorption(UNIAXIAL_O, ko, axis, ao, ae),
                             uniaxial_absorption(UNIAXIAL_E, unit_or(Ke, ko), axis, ao, ae)};
        for (int w = 0; w < 2; w++)
            for (int k = 0; k < 2; k++)
                r.m[w][k] *= exp(-0.5 * a[w] * len_mm);
    }
    return r;
}

int crystal_coherent_inside(crystal_coherent_t *c, const material_t *mat, vec3_t axis, vec3_t org,
                            vec3_t p, vec3_t m, const double *lambda, const double *no,
                            const double *ne, double u, vec3_t *out, polar_event_t *ev)
{
    /* The light's tangential wave vector here: lane 0's inner wave's on the segment (for
     * parallel faces every wave's and every lane's). */
    const vec3_t t = vec3_fma(c->k_seg, m, -vec3_dot(c->k_seg, m));
    const vec3_t dr = vec3_sub(org, p);
    uniaxial_fresnel_t f0;
    uniaxial_fresnel_solve(t, m, axis, no[0], ne[0], 1.0, c->hint, &f0);
    /* Leave with lane 0's transmittance for unpolarised light from outside (reciprocal to the
     * light's way); none where no outside wave propagates (total internal reflection). */
    double p_exit = 0.0;
    if (f0.ok && f0.in[UF_S].propagating)
        p_exit = 0.5 * (f0.power[UF_S][UF_O] + f0.power[UF_S][UF_E] + f0.power[UF_P][UF_O] +
                        f0.power[UF_P][UF_E]);
    p_exit = fmin(1.0, fmax(0.0, p_exit));
    const int leave = p_exit > 0.0 && u < p_exit;
    const double pb = leave ? p_exit : 1.0 - p_exit;
    const vec3_t k_in = unit_or(re3(f0.in[UF_S].K), vec3_neg(m));
    const vec3_t x_in = polar_frame_perp(c->x_exit, k_in);
    const double scale = c->prob * pb > 0.0 ? 1.0 / (c->prob * pb) : 0.0;
    for (int j = 0; j < c->n; j++) {
        uniaxial_fresnel_t fj;
        const uniaxial_fresnel_t *f = &f0;
        if (j > 0 && (no[j] != no[0] || ne[j] != ne[0])) {
            uniaxial_fresnel_solve(t, m, axis, no[j], ne[j], 1.0, c->hint, &fj);
            f = &fj;
        }
        const jones_t prop = propagate(f, mat, axis, dr, lambda[j]);
        const jones_t here =
            leave ? jones_uniaxial_enter(f, k_in, x_in) : jones_uniaxial_reflect(f);
        const jones_t a = jones_mul(&c->j[j], &prop);
        c->j[j] = jones_mul(&a, &here);
        if (leave) {
            const mueller_t mm = jones_mueller(&c->j[j]);
            c->mm[j] = mueller_scale(&mm, scale);
        }
    }
    if (leave) {
        *ev = (polar_event_t){.k_in = k_in, .x_in = x_in, .k_out = c->k_exit, .x_out = c->x_exit};
        *out = vec3_neg(k_in);
        return 1;
    }
    c->prob *= pb;
    c->k_seg = re3(f0.in[inner_wave(no[0], ne[0])].K);
    *out = mean_ray_back(&f0, axis, no[0], ne[0]);
    return 0;
}
