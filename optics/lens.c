#include "lens.h"

#include "glass.h"

#include <ctype.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Rays are traced in pbrt-v4's lens space: the film at z = 0, the elements at negative z, the
 * scene beyond them (camera space with z mirrored). Element i's vertex is at -(the thicknesses
 * from i to the last). */

struct lens_system {
    int n;
    lens_element_t e[LENS_MAX_ELEMENTS];
    int defaulted, clamped;
    double diagonal;
    int xres, yres;
    double extent_x, extent_y; /* the film's physical size, m */
    double pupil[LENS_PUPIL_INTERVALS][4];
};

double lens_element_eta(const lens_element_t *e, double lambda_nm)
{
    if (!e->glass)
        return 1.0;
    double n = ior_eval(&e->ior, lambda_nm) + e->ior_shift;
    return n > 1.0 && isfinite(n) ? n : 1.0;
}

double lens_system_rear_z(const lens_system_t *s)
{
    return s->e[s->n - 1].thickness;
}

double lens_system_front_z(const lens_system_t *s)
{
    double z = 0;
    for (int i = 0; i < s->n; i++)
        z += s->e[i].thickness;
    return z;
}

double lens_system_rear_radius(const lens_system_t *s)
{
    return s->e[s->n - 1].aperture_radius;
}
int lens_system_count(const lens_system_t *s)
{
    return s->n;
}
const lens_element_t *lens_system_element(const lens_system_t *s, int i)
{
    return i >= 0 && i < s->n ? &s->e[i] : NULL;
}
int lens_system_defaulted(const lens_system_t *s)
{
    return s->defaulted;
}
int lens_system_clamped(const lens_system_t *s)
{
    return s->clamped;
}

static double dot3(const double a[3], const double b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

static int normalize3(double v[3])
{
    double l = sqrt(dot3(v, v));
    if (!(l > 0.0) || !isfinite(l))
        return -1;
    v[0] /= l;
    v[1] /= l;
    v[2] /= l;
    return 0;
}

/* The ray o + t d against the sphere of radius r centred on the axis at z_center (pbrt-v4
 * IntersectSphericalElement): the nearer root when the ray runs along +z and the surface is
 * convex that way (or -z and concave), else the farther; the normal faces the incoming ray. */
static int hit_sphere(double r, double zc, const double o[3], const double d[3], double *t,
                      double n[3])
{
    double oc[3] = {o[0], o[1], o[2] - zc};
    double a = dot3(d, d), b = 2 * dot3(d, oc), c = dot3(oc, oc) - r * r;
    double disc = b * b - 4 * a * c;
    if (!(disc >= 0.0) || !(a > 0.0))
        return 0;
    double q = b < 0 ? -0.5 * (b - sqrt(disc)) : -0.5 * (b + sqrt(disc));
    double t0 = q / a, t1 = q != 0.0 ? c / q : t0;
    if (t0 > t1) {
        double tmp = t0;
        t0 = t1;
        t1 = tmp;
    }
    int closer = (d[2] > 0) ^ (r < 0);
    *t = closer ? t0 : t1;
    if (!(*t >= 0.0) || !isfinite(*t))
        return 0;
    for (int k = 0; k < 3; k++)
        n[k] = oc[k] + *t * d[k];
    if (normalize3(n))
        return 0;
    if (dot3(n, d) > 0)
        for (int k = 0; k < 3; k++)
            n[k] = -n[k];
    return 1;
}

/* Snell's law for unit d arriving at a surface of normal n (facing d's origin), from index
 * eta_i to eta_t: 0 on total internal reflection. */
static int refract(double d[3], const double n[3], double eta_i, double eta_t)
{
    double eta = eta_i / eta_t, cos_i = -dot3(n, d);
    double sin2_t = eta * eta * fmax(0.0, 1.0 - cos_i * cos_i);
    if (sin2_t >= 1.0)
        return 0;
    double cos_t = sqrt(1.0 - sin2_t);
    for (int k = 0; k < 3; k++)
        d[k] = eta * d[k] + (eta * cos_i - cos_t) * n[k];
    return normalize3(d) == 0;
}

/* One interface: intersect, test the aperture, refract. z is the vertex. */
static int cross(const lens_element_t *e, double z, double o[3], double d[3], double eta_i,
                 double eta_t)
{
    double t, n[3];
    if (e->radius == 0.0) {
        if (d[2] == 0.0)
            return 0;
        t = (z - o[2]) / d[2];
        if (!(t >= 0.0))
            return 0;
    } else if (!hit_sphere(e->radius, z + e->radius, o, d, &t, n))
        return 0;
    double p[3] = {o[0] + t * d[0], o[1] + t * d[1], o[2] + t * d[2]};
    if (!(p[0] * p[0] + p[1] * p[1] <= e->aperture_radius * e->aperture_radius))
        return 0;
    memcpy(o, p, sizeof p);
    return e->radius == 0.0 || refract(d, n, eta_i, eta_t);
}

int lens_trace_from_film(const lens_system_t *s, const double oc[3], const double dc[3],
                         double lambda, double out_o[3], double out_d[3])
{
    double o[3] = {oc[0], oc[1], -oc[2]}, d[3] = {dc[0], dc[1], -dc[2]};
    if (normalize3(d))
        return 0;
    double z = 0;
    for (int i = s->n - 1; i >= 0; i--) {
        const lens_element_t *e = &s->e[i];
        z -= e->thickness;
        double eta_i = lens_element_eta(e, lambda),
               eta_t = i > 0 ? lens_element_eta(&s->e[i - 1], lambda) : 1.0;
        if (!cross(e, z, o, d, eta_i, eta_t))
            return 0;
    }
    if (out_o) {
        out_o[0] = o[0], out_o[1] = o[1], out_o[2] = -o[2];
        out_d[0] = d[0], out_d[1] = d[1], out_d[2] = -d[2];
    }
    return 1;
}

int lens_trace_from_scene(const lens_system_t *s, const double oc[3], const double dc[3],
                          double lambda, double out_o[3], double out_d[3])
{
    double o[3] = {oc[0], oc[1], -oc[2]}, d[3] = {dc[0], dc[1], -dc[2]};
    if (normalize3(d))
        return 0;
    double z = -lens_system_front_z(s);
    for (int i = 0; i < s->n; i++) {
        const lens_element_t *e = &s->e[i];
        double eta_i = i > 0 ? lens_element_eta(&s->e[i - 1], lambda) : 1.0,
               eta_t = lens_element_eta(e, lambda);
        if (!cross(e, z, o, d, eta_i, eta_t))
            return 0;
        z += e->thickness;
    }
    if (out_o) {
        out_o[0] = o[0], out_o[1] = o[1], out_o[2] = -o[2];
        out_d[0] = d[0], out_d[1] = d[1], out_d[2] = -d[2];
    }
    return 1;
}

/* pbrt-v4 ComputeCardinalPoints: where the outgoing ray of an axis-parallel input ray crosses
 * the axis (focal point) and meets the input ray's height (principal plane), as -z. */
static int cardinal(const double in_o[3], const double out_o[3], const double out_d[3], double *pz,
                    double *fz)
{
    if (out_d[0] == 0.0)
        return -1;
    double tf = -out_o[0] / out_d[0];
    *fz = -(out_o[2] + tf * out_d[2]);
    double tp = (in_o[0] - out_o[0]) / out_d[0];
    *pz = -(out_o[2] + tp * out_d[2]);
    return 0;
}

static int thick_lens(const lens_system_t *s, double lambda, double pz[2], double fz[2])
{
    double x = 0.001 * s->diagonal, oo[3], od[3];
    double o0[3] = {x, 0, lens_system_front_z(s) + 1}, d0[3] = {0, 0, -1};
    if (!lens_trace_from_scene(s, o0, d0, lambda, oo, od) || cardinal(o0, oo, od, &pz[0], &fz[0]))
        return -1;
    double o1[3] = {x, 0, lens_system_rear_z(s) - 1}, d1[3] = {0, 0, 1};
    if (!lens_trace_from_film(s, o1, d1, lambda, oo, od) || cardinal(o1, oo, od, &pz[1], &fz[1]))
        return -1;
    return 0;
}

int lens_system_focal_length(const lens_system_t *s, double lambda, double *efl,
                             double *film_focus_z)
{
    double pz[2], fz[2];
    if (thick_lens(s, lambda, pz, fz))
        return -1;
    *efl = fz[0] - pz[0];
    *film_focus_z = -fz[0];
    return 0;
}

static double radical_inverse(unsigned base, unsigned long i)
{
    double inv = 1.0 / base, f = inv, r = 0;
    while (i) {
        r += (double)(i % base) * f;
        i /= base;
        f *= inv;
    }
    return r;
}

/* pbrt-v4 BoundExitPupil: the bounds of the points of the rear element's plane through which
 * a ray from the film segment [x0, x1] passes, found by sampling a square 1.5 times the rear
 * element's radius, here at three wavelengths (the ends of the film's range and the d line)
 * since each glass bends each differently, then widened by twice the sample spacing. */
static void bound_pupil(const lens_system_t *s, double x0, double x1, const double lambdas[3],
                        double b[4])
{
    const int side = 128, count = side * side;
    double rr = 1.5 * lens_system_rear_radius(s), zr = lens_system_rear_z(s);
    double lo[2] = {INFINITY, INFINITY}, hi[2] = {-INFINITY, -INFINITY};
    for (int i = 0; i < count; i++) {
        double pf[3] = {x0 + (x1 - x0) * (i + 0.5) / count, 0, 0};
        double px = -rr + 2 * rr * radical_inverse(2, (unsigned long)i);
        double py = -rr + 2 * rr * radical_inverse(3, (unsigned long)i);
        if (px >= lo[0] && px <= hi[0] && py >= lo[1] && py <= hi[1])
            continue;
        double d[3] = {px - pf[0], py - pf[1], zr};
        for (int k = 0; k < 3; k++)
            if (lens_trace_from_film(s, pf, d, lambdas[k], NULL, NULL)) {
                lo[0] = fmin(lo[0], px), hi[0] = fmax(hi[0], px);
                lo[1] = fmin(lo[1], py), hi[1] = fmax(hi[1], py);
                break;
            }
    }
    if (!(lo[0] <= hi[0])) {
        b[0] = b[1] = b[2] = b[3] = 0;
        return;
    }
    double grow = 2 * sqrt(8 * rr * rr) / side;
    b[0] = lo[0] - grow, b[1] = hi[0] + grow, b[2] = lo[1] - grow, b[3] = hi[1] + grow;
}

void lens_system_pupil(const lens_system_t *s, int i, double bounds[4])
{
    if (i < 0 || i >= LENS_PUPIL_INTERVALS) {
        bounds[0] = bounds[1] = bounds[2] = bounds[3] = 0;
        return;
    }
    memcpy(bounds, s->pupil[i], sizeof s->pupil[i]);
}

double lens_system_ray(const lens_system_t *s, double fx, double fy, double u1, double u2,
                       double lambda, double org[3], double dir[3])
{
    double sx = fx / s->xres, sy = fy / s->yres;
    double pf[3] = {-(-s->extent_x / 2 + sx * s->extent_x), -s->extent_y / 2 + sy * s->extent_y, 0};
    double r = sqrt(pf[0] * pf[0] + pf[1] * pf[1]);
    int k = (int)(r / (s->diagonal / 2) * LENS_PUPIL_INTERVALS);
    if (k >= LENS_PUPIL_INTERVALS)
        k = LENS_PUPIL_INTERVALS - 1;
    if (k < 0)
        k = 0;
    const double *b = s->pupil[k];
    double area = (b[1] - b[0]) * (b[3] - b[2]);
    if (!(area > 0.0))
        return 0.0;
    double lx = b[0] + u1 * (b[1] - b[0]), ly = b[2] + u2 * (b[3] - b[2]);
    double sn = r != 0 ? pf[1] / r : 0, cs = r != 0 ? pf[0] / r : 1;
    double pr[3] = {cs * lx - sn * ly, sn * lx + cs * ly, lens_system_rear_z(s)};
    double d[3] = {pr[0] - pf[0], pr[1] - pf[1], pr[2]};
    if (normalize3(d) || !lens_trace_from_film(s, pf, d, lambda, org, dir))
        return 0.0;
    double zr = lens_system_rear_z(s), c2 = d[2] * d[2];
    double w = c2 * c2 * area / (zr * zr);
    return isfinite(w) ? w : 0.0;
}

/* ---- building ---- */

static const glass_t *nearest_glass(double nd)
{
    const glass_t *best = NULL;
    double bd = INFINITY;
    for (int i = 0; i < glass_count(); i++) {
        const glass_t *g = glass_get(i);
        if (strstr(g->name, "Water"))
            continue;
        double d = fabs(ior_eval(&g->ior, LENS_LAMBDA_D) - nd);
        if (d < bd)
            bd = d, best = g;
    }
    return best;
}

static int set_glass(lens_element_t *e, const char *name, const lens_params_t *p, int line,
                     err_t *err)
{
    const glass_t *g = glass_find(name);
    if (!g)
        return err_set(
            err, "%s:%d: unknown glass \"%s\" (the catalogue of optics/glass.h: N-BK7, SF5, ...)",
            p->file, line, name);
    e->ior = g->ior;
    e->ior_shift = e->eta_d - ior_eval(&g->ior, LENS_LAMBDA_D);
    snprintf(e->glass_name, sizeof e->glass_name, "%s", g->name);
    return 0;
}

static int is_air_name(const char *s)
{
    return !s || !*s || !strcmp(s, "-") || !strcmp(s, "air");
}

static int parse(lens_system_t *s, const char *text, size_t len, const lens_params_t *p, err_t *err)
{
    int line = 0;
    size_t i = 0;
    while (i < len) {
        size_t j = i;
        while (j < len && text[j] != '\n')
            j++;
        line++;
        char buf[512];
        size_t n = j - i < sizeof buf - 1 ? j - i : sizeof buf - 1;
        memcpy(buf, text + i, n);
        buf[n] = 0;
        i = j + 1;
        char *hash = strchr(buf, '#');
        if (hash)
            *hash = 0;
        char *tok[6];
        int nt = 0;
        char *save = NULL;
        for (char *t = strtok_r(buf, " \t\r,", &save); t && nt < 6; t = strtok_r(NULL, " \t\r,", &save))
            tok[nt++] = t;
        if (nt == 0)
            continue;
        if (nt < 4 || nt > 5)
            return err_set(
                err,
                "%s:%d: expected 4 numbers (curvature radius, thickness, index n_d, aperture "
                "diameter, in mm) and an optional glass name, got %d fields",
                p->file, line, nt);
        if (s->n == LENS_MAX_ELEMENTS)
            return err_set(err, "%s:%d: more than %d lens interfaces", p->file, line,
                           LENS_MAX_ELEMENTS);
        double v[4];
        for (int k = 0; k < 4; k++) {
            char *end;
            v[k] = strtod(tok[k], &end);
            if (*end || !isfinite(v[k]))
                return err_set(err, "%s:%d: \"%s\" is not a number (field %d)", p->file, line,
                               tok[k], k + 1);
        }
        if (v[1] < 0 || v[3] <= 0 || (v[2] != 0 && v[2] < 1) || v[2] > 4)
            return err_set(
                err,
                "%s:%d: thickness must be >= 0, aperture > 0 and the index 0 (air), 1 or in "
                "(1, 4], got %g %g %g",
                p->file, line, v[1], v[3], v[2]);
        lens_element_t *e = &s->e[s->n];
        memset(e, 0, sizeof *e);
        e->radius = v[0] / 1000, e->thickness = v[1] / 1000, e->eta_d = v[2];
        e->aperture_radius = v[3] / 2000;
        e->glass = v[2] > 1.0;
        e->ior = ior_constant(1.0);
        if (e->radius == 0.0) {
            if (e->glass)
                return err_set(err,
                               "%s:%d: the aperture stop (radius 0) must be in air (index 0 or 1)",
                               p->file, line);
            double want = p->aperture_diameter_mm / 1000;
            if (want > 2 * e->aperture_radius)
                s->clamped = 1;
            else
                e->aperture_radius = want / 2;
        }
        const char *name = nt == 5 ? tok[4] : NULL;
        if (p->glasses && s->n < p->nglasses)
            name = p->glasses[s->n];
        if (!e->glass) {
            if (!is_air_name(name))
                return err_set(err, "%s:%d: glass \"%s\" given for an air gap (index %g)", p->file,
                               line, name, v[2]);
        } else if (!is_air_name(name)) {
            if (set_glass(e, name, p, line, err))
                return -1;
        } else {
            const glass_t *g = nearest_glass(e->eta_d);
            if (!g || set_glass(e, g->name, p, line, err))
                return err_set(err, "%s:%d: no catalogue glass for n_d %g", p->file, line,
                               e->eta_d);
            s->defaulted++;
            e->defaulted = 1;
        }
        if (e->glass && ior_validate(&e->ior, e->glass_name, p->lambda_min, p->lambda_max, err))
            return err_prefix(err, "%s:%d: ", p->file, line);
        s->n++;
    }
    if (s->n == 0)
        return err_set(err, "%s: no lens interfaces", p->file);
    if (p->glasses && p->nglasses != s->n)
        return err_set(err, "%s: \"string glasses\" has %d names for %d lens interfaces", p->file,
                       p->nglasses, s->n);
    return 0;
}

lens_system_t *lens_system_new(const char *text, size_t len, const lens_params_t *p, err_t *err)
{
    if (!(p->focus_distance > 0) || !(p->film_diagonal > 0) || p->xres <= 0 || p->yres <= 0 ||
        !(p->aperture_diameter_mm > 0)) {
        err_set(err, "%s: the focus distance, film diagonal and aperture diameter must be positive",
                p->file);
        return NULL;
    }
    lens_system_t *s = calloc(1, sizeof *s);
    if (!s) {
        err_set(err, "out of memory");
        return NULL;
    }
    s->diagonal = p->film_diagonal;
    s->xres = p->xres, s->yres = p->yres;
    double aspect = (double)p->yres / p->xres;
    s->extent_x = sqrt(p->film_diagonal * p->film_diagonal / (1 + aspect * aspect));
    s->extent_y = aspect * s->extent_x;
    if (parse(s, text, len, p, err))
        goto fail;
    /* pbrt-v4 FocusThickLens: move the lens by delta so that the thick-lens image of the
     * point at focus_distance falls on the film. */
    double pz[2], fz[2];
    if (thick_lens(s, LENS_LAMBDA_D, pz, fz)) {
        err_set(err, "%s: no paraxial ray passes the lens (is the aperture stop too small?)",
                p->file);
        goto fail;
    }
    double f = fz[0] - pz[0], z = -p->focus_distance;
    double c = (pz[1] - z - pz[0]) * (pz[1] - z - 4 * f - pz[0]);
    if (!(c > 0)) {
        err_set(err, "%s: the focus distance %g m is too short for this lens (focal length %g mm)",
                p->file, p->focus_distance, f * 1000);
        goto fail;
    }
    double delta = (pz[1] - z + pz[0] - sqrt(c)) / 2;
    s->e[s->n - 1].thickness += delta;
    if (!(s->e[s->n - 1].thickness > 0)) {
        err_set(err, "%s: focusing at %g m puts the film inside the lens", p->file,
                p->focus_distance);
        goto fail;
    }
    double lambdas[3] = {p->lambda_min, LENS_LAMBDA_D, p->lambda_max};
    int any = 0;
    for (int i = 0; i < LENS_PUPIL_INTERVALS; i++) {
        double r0 = (double)i / LENS_PUPIL_INTERVALS * s->diagonal / 2;
        double r1 = (double)(i + 1) / LENS_PUPIL_INTERVALS * s->diagonal / 2;
        bound_pupil(s, r0, r1, lambdas, s->pupil[i]);
        any |= s->pupil[i][1] > s->pupil[i][0];
    }
    if (!any) {
        err_set(err, "%s: no ray from the film passes the lens", p->file);
        goto fail;
    }
    return s;
fail:
    free(s);
    return NULL;
}

void lens_system_destroy(lens_system_t **self_p)
{
    if (self_p && *self_p) {
        free(*self_p);
        *self_p = NULL;
    }
}
