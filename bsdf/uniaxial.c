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

static double sq(double x)
{
    return x * x;
}

/* The solver's outgoing wave of branch kind w (outside: s; o; e) as the path's direction, wave
 * normal and index. */
static void branch_geometry(const uniaxial_fresnel_t *f, int w, vec3_t axis, double no, double ne,
                            uniaxial_branch_t *b)
{
    const vec3_t K = vec3_make(creal(f->out[w].K[0]), creal(f->out[w].K[1]), creal(f->out[w].K[2]));
    const double n = vec3_length(K);
    b->n_after = n;
    b->wave = n > 0.0 ? vec3_scale(K, 1.0 / n) : K;
    b->dir = w == UF_E ? uniaxial_ray_from_wave(UNIAXIAL_E, b->wave, axis, no, ne) : b->wave;
}

/* The event for one pair of indices: lane 0's in full; for other lanes only the branches'
 * probabilities are read. */
static void one_event(vec3_t dir, vec3_t nrm, bool entering, uniaxial_wave_t inside, vec3_t axis,
                      double no, double ne, bsdf_mode_t mode, uniaxial_event_t *e)
{
    /* m: the unit normal from the crystal toward the outside. */
    const bool along = vec3_dot(dir, nrm) > 0.0;
    const vec3_t m = along == !entering ? nrm : vec3_neg(nrm);
    const uniaxial_wave_t w_in = entering ? UNIAXIAL_OUTSIDE : inside;
    const vec3_t k_in = entering ? dir : uniaxial_wave_from_ray(w_in, dir, axis, no, ne);
    const double n_in = entering ? 1.0 : uniaxial_index(w_in, k_in, axis, no, ne);
    const vec3_t K = vec3_scale(k_in, n_in);
    const vec3_t t = vec3_fma(K, m, -vec3_dot(K, m));
    e->before = w_in;
    e->m = m;
    e->t = t;
    e->axis = axis;
    e->no = no;
    e->ne = ne;
    uniaxial_fresnel_t *f = &e->fres;
    /* Only the light arriving: from outside its s and p, from inside its own wave. */
    const unsigned incident = entering               ? 1u << UF_S | 1u << UF_P
                              : inside == UNIAXIAL_E ? 1u << UF_E
                                                     : 1u << UF_O;
    uniaxial_fresnel_solve_incident(t, m, axis, no, ne, 1.0, vec3_cross(dir, m), incident, f);
    const bool radiance = mode == BSDF_RADIANCE;
    for (int b = 0; b < UNIAXIAL_MAX_BRANCHES; b++)
        e->branch[b] = (uniaxial_branch_t){.factor = 1.0};
    e->nbranch = 3;
    double p[3];
    if (entering) {
        /* Unpolarised light: the mean of s and p incidence. */
        uniaxial_branch_t *r = &e->branch[0];
        r->reflects = true;
        r->after = UNIAXIAL_OUTSIDE;
        r->dir = r->wave = fresnel_reflect(dir, vec3_neg(m));
        r->n_after = 1.0;
        p[0] = 0.5 * (f->power[UF_S][UF_S] + f->power[UF_S][UF_P] + f->power[UF_P][UF_S] +
                      f->power[UF_P][UF_P]);
        for (int w = UNIAXIAL_O; w <= UNIAXIAL_E; w++) {
            uniaxial_branch_t *b = &e->branch[1 + w];
            b->after = (uniaxial_wave_t)w;
            const int fw = w == UNIAXIAL_O ? UF_O : UF_E;
            p[1 + w] = 0.5 * (f->power[UF_S][fw] + f->power[UF_P][fw]);
            if (!(p[1 + w] > 0.0))
                continue;
            branch_geometry(f, fw, axis, no, ne, b);
            b->factor = radiance ? 1.0 / sq(b->n_after) : 1.0;
        }
        if (!f->ok) {
            p[0] = 1.0;
            p[1] = p[2] = 0.0;
        }
    } else {
        /* Light in wave `inside` (in its polarisation): reflected into the same wave, leaving,
         * reflected into the other wave. */
        const int fin = inside == UNIAXIAL_E ? UF_E : UF_O;
        const int fother = inside == UNIAXIAL_E ? UF_O : UF_E;
        const int kind[3] = {fin, UF_S, fother};
        for (int b = 0; b < 3; b++) {
            uniaxial_branch_t *br = &e->branch[b];
            br->reflects = b != 1;
            br->after = b == 1 ? UNIAXIAL_OUTSIDE : kind[b] == UF_E ? UNIAXIAL_E : UNIAXIAL_O;
            p[b] = b == 1 ? f->power[fin][UF_S] + f->power[fin][UF_P] : f->power[fin][kind[b]];
            if (!(p[b] > 0.0) && b != 0)
                continue;
            branch_geometry(f, kind[b], axis, no, ne, br);
            if (!(br->n_after > 0.0)) {
                /* The same wave's reflection even where it carries nothing (a fallback). */
                br->dir = br->wave = fresnel_reflect(k_in, m);
                br->n_after = n_in;
            }
            br->factor = radiance ? sq(n_in / br->n_after) : 1.0;
        }
        if (!f->ok) {
            p[0] = 1.0;
            p[1] = p[2] = 0.0;
        }
    }
    /* The power fractions sum to 1 for a lossless boundary; the division keeps the event's
     * probabilities exact under rounding. */
    const double sum = p[0] + p[1] + p[2];
    for (int b = 0; b < 3; b++)
        e->branch[b].prob = sum > 0.0 ? fmin(1.0, fmax(0.0, p[b] / sum)) : b == 0;
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
    e->dir_in = dir;
    e->nrm = nrm;
    e->entering = entering;
    e->inside = inside;
    for (int j = 0; j < count; j++) {
        e->lane_no[j] = no[j];
        e->lane_ne[j] = ne[j];
        e->grey = e->grey && no[j] == no[0] && ne[j] == ne[0];
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
    if (!br->reflects || e->grey || j == 0 ||
        (e->lane_no[j] == e->lane_no[0] && e->lane_ne[j] == e->lane_ne[0]))
        return br->factor;
    if (!(br->prob > 0.0))
        return 0.0;
    uniaxial_event_t lane;
    one_event(e->dir_in, e->nrm, e->entering, e->inside, e->axis, e->lane_no[j], e->lane_ne[j],
              e->mode, &lane);
    return lane.branch[b].prob / br->prob * br->factor;
}

/* The solver's wave kind of a path's wave. */
static int fresnel_kind(uniaxial_wave_t w)
{
    return w == UNIAXIAL_E ? UF_E : UF_O;
}

mueller_t uniaxial_branch_mueller_frames(const uniaxial_event_t *e, int b, const polar_event_t *ev)
{
    mueller_t zero = {{{0}}};
    if (b < 0 || b >= e->nbranch)
        return zero;
    const uniaxial_branch_t *br = &e->branch[b];
    double j[2][2][2];
    if (e->mode == BSDF_RADIANCE) {
        /* The light runs the branch backward: it arrives in the branch's wave reversed (the
         * tangential wave vector -t) and leaves in the path's arriving wave reversed. */
        uniaxial_fresnel_t rev;
        const unsigned incident =
            br->after == UNIAXIAL_OUTSIDE ? 1u << UF_S | 1u << UF_P : 1u << fresnel_kind(br->after);
        uniaxial_fresnel_solve_incident(vec3_neg(e->t), e->m, e->axis, e->no, e->ne, 1.0, ev->x_in,
                                        incident, &rev);
        uniaxial_fresnel_jones(&rev, br->after == UNIAXIAL_OUTSIDE, fresnel_kind(br->after),
                               e->before == UNIAXIAL_OUTSIDE, fresnel_kind(e->before), ev->k_in,
                               ev->x_in, ev->k_out, ev->x_out, j);
    } else {
        uniaxial_fresnel_jones(&e->fres, e->before == UNIAXIAL_OUTSIDE, fresnel_kind(e->before),
                               br->after == UNIAXIAL_OUTSIDE, fresnel_kind(br->after), ev->k_in,
                               ev->x_in, ev->k_out, ev->x_out, j);
    }
    return mueller_jones(j);
}

mueller_t uniaxial_branch_mueller(const uniaxial_event_t *e, int b)
{
    if (b < 0 || b >= e->nbranch)
        return (mueller_t){{{0}}};
    /* The ray arriving is k_in x m's plane; its frame's x = s. */
    const vec3_t k_in =
        e->before == UNIAXIAL_OUTSIDE
            ? vec3_normalize(vec3_fma(e->t, e->m, -sqrt(fmax(0.0, 1.0 - vec3_dot(e->t, e->t)))))
            : vec3_make(creal(e->fres.in[fresnel_kind(e->before)].K[0]),
                        creal(e->fres.in[fresnel_kind(e->before)].K[1]),
                        creal(e->fres.in[fresnel_kind(e->before)].K[2]));
    const vec3_t ray =
        e->before == UNIAXIAL_E
            ? uniaxial_ray_from_wave(UNIAXIAL_E, vec3_normalize(k_in), e->axis, e->no, e->ne)
            : vec3_normalize(k_in);
    const polar_event_t ev =
        polar_event_interface(ray, e->branch[b].dir, e->m, vec3_cross(ray, e->m));
    uniaxial_event_t fwd = *e;
    fwd.mode = BSDF_IMPORTANCE;
    return uniaxial_branch_mueller_frames(&fwd, b, &ev);
}
