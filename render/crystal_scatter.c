#include "crystal_scatter.h"

#include "specular.h"
#include "uniaxial.h"

#include <math.h>

/* A photon's branch chosen by its Stokes vector (crystal_polar_t.s_in). Photons reach a
 * crystal one lane at a time (photon.c splits them first), so lane 0 is the photon; every lane
 * keeps its weight (importance mode: each branch's factor is 1). */
static int choose_polarised(const uniaxial_event_t *e, vec3_t nrm, vec3_t dir, double u,
                            double *weight, int n, vec3_t *out, int *wave, crystal_polar_t *pol)
{
    polar_event_t ev[UNIAXIAL_MAX_BRANCHES];
    mueller_t mm[UNIAXIAL_MAX_BRANCHES];
    double p[UNIAXIAL_MAX_BRANCHES], sum = 0.0;
    stokes_t s = *pol->s_in;
    for (int b = 0; b < e->nbranch; b++) {
        ev[b] = polar_event_interface(dir, e->branch[b].dir, nrm, pol->x);
        if (b == 0) {
            /* Every branch's entry frame is s = k_in x n: the vector is rebased once. */
            const mueller_t r = polar_frame_change(pol->x, ev[0].x_in, dir);
            s = mueller_apply(&r, s);
        }
        mm[b] = uniaxial_branch_mueller_frames(e, b, &ev[b]);
        const double pb = mueller_apply(&mm[b], s).s[0];
        p[b] = pb > 0.0 && isfinite(pb) ? pb : 0.0;
        sum += p[b];
    }
    if (!(sum > 0.0))
        return 1;
    double acc = 0.0;
    int b = -1;
    for (int k = 0; k < e->nbranch; k++) {
        if (!(p[k] > 0.0))
            continue;
        b = k;
        acc += p[k];
        if (u * sum < acc)
            break;
    }
    const uniaxial_branch_t *br = &e->branch[b];
    for (int j = 0; j < n; j++)
        weight[j] *= br->factor;
    *out = br->dir;
    pol->ev = ev[b];
    pol->m = mueller_scale(&mm[b], 1.0 / p[b]);
    if (br->after != UNIAXIAL_OUTSIDE)
        *wave = br->after;
    return 0;
}

vec3_t crystal_axis(const scene_t *scene, const hit_t *h, const material_t *m)
{
    const vec3_t axis = material_uniaxial_of(m)->optic_axis;
    if (h->instance == GEOMETRY_NO_INSTANCE || h->instance >= scene->ninstances)
        return axis;
    const vec3_t a = transform_vector(&scene->instances[h->instance].to_world, axis);
    const double l = vec3_length(a);
    return l > 0.0 && isfinite(l) ? vec3_scale(a, 1.0 / l) : axis;
}

int crystal_scatter(const material_t *m, const surface_t *sf, vec3_t axis, vec3_t org, vec3_t dir,
                    int *wave, int n, const double *lambda, double *weight, bsdf_mode_t mode,
                    double u, vec3_t *out, int *end_secondaries, crystal_polar_t *pol)
{
    const material_uniaxial_t *cr = material_uniaxial_of(m);
    if (n < 1)
        return 1;
    if (n > BSDF_MAX_LANES)
        n = BSDF_MAX_LANES;
    /* Which side the ray is on comes from the geometric surface alone, as at glass. */
    const bool entering = vec3_dot(dir, sf->ng) < 0.0;
    const uniaxial_wave_t inside = *wave == UNIAXIAL_E ? UNIAXIAL_E : UNIAXIAL_O;
    double no[BSDF_MAX_LANES], ne[BSDF_MAX_LANES];
    for (int j = 0; j < n; j++) {
        no[j] = ior_eval(&cr->crystal.no, lambda[j]);
        ne[j] = ior_eval(&cr->crystal.ne, lambda[j]);
    }
    /* A coherent crystal on a camera path (crystal_coherent.h): inside, both waves as one ray. */
    const int coherent = cr->coherent && pol && pol->coh && mode == BSDF_RADIANCE;
    if (coherent && *wave == UNIAXIAL_COHERENT) {
        vec3_t mo = specular_normal(sf, dir, no[0], NULL);
        if (vec3_dot(mo, dir) < 0.0)
            mo = vec3_neg(mo);
        *end_secondaries = 0;
        pol->pending = !crystal_coherent_inside(pol->coh, m, axis, org, sf->p, mo, lambda, no, ne,
                                                u, out, &pol->ev);
        if (!pol->pending) {
            pol->lanes = pol->coh->mm;
            *wave = UNIAXIAL_O;
        }
        return 0;
    }
    if (!entering && cr->crystal.absorption.rows > 0) {
        /* Beer-Lambert along the segment inside, at the wave's own coefficient (uniaxial.h). */
        const double d_mm = vec3_length(vec3_sub(sf->p, org)) * cr->mm_per_unit;
        for (int j = 0; j < n; j++) {
            double ao, ae;
            crystal_absorption_eval(&cr->crystal.absorption, lambda[j], &ao, &ae);
            const vec3_t k = uniaxial_wave_from_ray(inside, dir, axis, no[j], ne[j]);
            weight[j] *= exp(-uniaxial_absorption(inside, k, axis, ao, ae) * d_mm);
        }
    }
    /* The shading normal where it is safe (render/specular.h), judged with the o index. */
    const vec3_t nrm = specular_normal(sf, dir, entering ? 1.0 / no[0] : no[0], NULL);
    uniaxial_event_t e;
    uniaxial_event_make(dir, nrm, entering, inside, axis, no, ne, n, mode, &e);
    if (pol && pol->s_in && mode == BSDF_IMPORTANCE) {
        *end_secondaries = 0;
        return choose_polarised(&e, nrm, dir, u, weight, n, out, wave, pol);
    }
    const int b = uniaxial_choose(&e, u);
    const uniaxial_branch_t *br = &e.branch[b];
    *end_secondaries = 0;
    if (coherent && entering && !br->reflects) {
        crystal_coherent_enter(pol->coh, axis, dir, e.m, n, no, ne,
                               e.branch[1].prob + e.branch[2].prob, pol->x, out);
        *wave = UNIAXIAL_COHERENT;
        pol->pending = 1;
        return 0;
    }
    double any = 0.0;
    if (!br->reflects && !e.grey && n > 1) {
        weight[0] *= uniaxial_lane_weight(&e, b, 0) * n;
        *end_secondaries = 1;
        any = weight[0];
    } else {
        for (int j = 0; j < n; j++) {
            weight[j] *= uniaxial_lane_weight(&e, b, j);
            any += weight[j];
        }
    }
    *out = br->dir;
    if (pol) {
        /* The light travels the path backward in radiance mode (a camera path). */
        pol->ev = mode == BSDF_RADIANCE
                      ? polar_event_interface(vec3_neg(br->dir), vec3_neg(dir), nrm, pol->x)
                      : polar_event_interface(dir, br->dir, nrm, pol->x);
        /* Divided by the branch's probability, which the scalar weights already carry (not by
         * its own [0][0]: light leaving a mode is polarised in it, and passes T_m, not T_m/2). */
        const mueller_t mm = uniaxial_branch_mueller_frames(&e, b, &pol->ev);
        pol->m = br->prob > 0.0 ? mueller_scale(&mm, 1.0 / br->prob) : mueller_identity();
    }
    if (br->after != UNIAXIAL_OUTSIDE)
        *wave = br->after;
    return any > 0.0 ? 0 : 1;
}
