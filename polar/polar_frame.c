#include "polar_frame.h"

#include <math.h>

vec3_t polar_frame_perp(vec3_t x, vec3_t k)
{
    vec3_t p = vec3_fma(x, k, -vec3_dot(x, k));
    double l = vec3_length(p);
    if (l > 1e-9)
        return vec3_scale(p, 1.0 / l);
    vec3_t t, b;
    vec3_basis(k, &t, &b);
    return t;
}

mueller_t polar_frame_change(vec3_t x_from, vec3_t x_to, vec3_t k)
{
    /* The angle phi from x_from toward y_from = k x x_from that brings x_from onto x_to: the
     * new frame is the old rotated by phi, so S' = mueller_rotator(phi) S. */
    const vec3_t y_from = vec3_cross(k, x_from);
    return mueller_rotator(atan2(vec3_dot(x_to, y_from), vec3_dot(x_to, x_from)));
}

polar_event_t polar_event_interface(vec3_t k_in, vec3_t k_out, vec3_t n, vec3_t hint)
{
    vec3_t s = vec3_cross(k_in, n);
    double l = vec3_length(s);
    s = l > 1e-9 ? vec3_scale(s, 1.0 / l) : polar_frame_perp(hint, k_in);
    /* s is perpendicular to k_in and n, so to the plane of incidence and to k_out (in it). */
    return (polar_event_t){
        .k_in = k_in, .x_in = s, .k_out = k_out, .x_out = polar_frame_perp(s, k_out)};
}

mueller_t polar_event_rebase(const mueller_t *m, const polar_event_t *from, const polar_event_t *to)
{
    const mueller_t a = polar_frame_change(from->x_out, to->x_out, to->k_out);
    const mueller_t b = polar_frame_change(to->x_in, from->x_in, to->k_in);
    const mueller_t mb = mueller_mul(m, &b);
    return mueller_mul(&a, &mb);
}

polar_event_t polar_event_sheet(vec3_t k, vec3_t axis)
{
    const vec3_t x = polar_frame_perp(axis, k);
    return (polar_event_t){.k_in = k, .x_in = x, .k_out = k, .x_out = x};
}

void polar_carrier_apply(mueller_t *t, int n, vec3_t *x, const polar_event_t *ev,
                         const mueller_t *m, int m_stride)
{
    const mueller_t r = polar_frame_change(ev->x_out, *x, ev->k_out);
    mueller_t rm = mueller_mul(&r, m);
    for (int j = 0; j < n; j++) {
        if (m_stride && j > 0)
            rm = mueller_mul(&r, &m[j]);
        t[j] = mueller_mul(&t[j], &rm);
    }
    *x = ev->x_in;
}

void polar_carrier_depolarise(mueller_t *t, int n, vec3_t *x, vec3_t k_in)
{
    for (int j = 0; j < n; j++)
        for (int r = 0; r < 4; r++)
            t[j].m[r][1] = t[j].m[r][2] = t[j].m[r][3] = 0.0;
    *x = polar_frame_perp(*x, k_in);
}

mueller_t mueller_normalised(const mueller_t *m)
{
    const double d = m->m[0][0];
    return d > 0.0 && isfinite(d) ? mueller_scale(m, 1.0 / d) : mueller_identity();
}
