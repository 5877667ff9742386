#include "uniaxial_fresnel.h"

#include <math.h>
#include <string.h>

typedef double complex cplx;

/* Below this |K x c| / |K| a wave normal counts as along the optic axis: o and e are then one
 * degenerate pair, and any two perpendicular fields serve as their modes. */
#define AXIAL_EPS 1e-9

static void cv_real(vec3_t a, cplx out[3])
{
    out[0] = a.x;
    out[1] = a.y;
    out[2] = a.z;
}

/* The bilinear (not Hermitian) products: the wave equation's algebra holds for complex K. */
static cplx cv_dot(const cplx a[3], const cplx b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

static cplx cv_dot_real(const cplx a[3], vec3_t b)
{
    return a[0] * b.x + a[1] * b.y + a[2] * b.z;
}

static void cv_cross(const cplx a[3], const cplx b[3], cplx out[3])
{
    const cplx x = a[1] * b[2] - a[2] * b[1], y = a[2] * b[0] - a[0] * b[2],
               z = a[0] * b[1] - a[1] * b[0];
    out[0] = x;
    out[1] = y;
    out[2] = z;
}

static double cv_norm2(const cplx a[3])
{
    return creal(a[0] * conj(a[0]) + a[1] * conj(a[1]) + a[2] * conj(a[2]));
}

static void cv_unit(cplx a[3])
{
    const double l = sqrt(cv_norm2(a));
    if (l > 0.0 && isfinite(l))
        for (int i = 0; i < 3; i++)
            a[i] /= l;
}

/* K = t + beta m. */
static void wave_vector(vec3_t t, vec3_t m, cplx beta, cplx K[3])
{
    K[0] = t.x + beta * m.x;
    K[1] = t.y + beta * m.y;
    K[2] = t.z + beta * m.z;
}

/* The field of a wave of kind UF_S..UF_E with wave vector K; its flux along m. */
static void wave_make(uniaxial_fresnel_wave_t *w, int kind, const cplx K[3], bool propagating,
                      vec3_t s, vec3_t axis, double no, vec3_t m)
{
    memcpy(w->K, K, sizeof w->K);
    w->propagating = propagating;
    if (propagating) {
        /* A real wave vector: the same fields in real arithmetic (the common case, and the
         * cheaper one). */
        const vec3_t k = vec3_make(creal(K[0]), creal(K[1]), creal(K[2]));
        const vec3_t kxc = vec3_cross(k, axis);
        const bool ax = !(vec3_dot(kxc, kxc) > AXIAL_EPS * AXIAL_EPS * vec3_dot(k, k));
        vec3_t e;
        if (kind == UF_S || (kind == UF_O && ax))
            e = s;
        else if (kind == UF_P || (kind == UF_E && ax))
            e = vec3_cross(k, s);
        else if (kind == UF_O)
            e = kxc;
        else
            e = vec3_fma(vec3_scale(axis, no * no), k, -vec3_dot(k, axis));
        const double l = vec3_length(e);
        if (l > 0.0 && isfinite(l))
            e = vec3_scale(e, 1.0 / l);
        cv_real(e, w->E);
        const vec3_t h = vec3_cross(k, e);
        w->flux = vec3_dot(vec3_cross(e, h), m);
        return;
    }
    cplx S[3], C[3], E[3];
    cv_real(s, S);
    cv_real(axis, C);
    cplx KxC[3];
    cv_cross(K, C, KxC);
    const bool axial = !(cv_norm2(KxC) > AXIAL_EPS * AXIAL_EPS * cv_norm2(K));
    if (kind == UF_S) {
        memcpy(E, S, sizeof E);
    } else if (kind == UF_P || (kind == UF_E && axial)) {
        /* p = k x s (polar_fresnel's frame); along the axis the e mode takes the same place. */
        cv_cross(K, S, E);
    } else if (kind == UF_O) {
        if (axial)
            memcpy(E, S, sizeof E);
        else
            memcpy(E, KxC, sizeof E);
    } else {
        /* E_e ~ n_o^2 c - (K.c) K: in the span of K and c, from the wave equation's c and K
         * components (physics.md §15.1). */
        const cplx kc = cv_dot(K, C);
        for (int i = 0; i < 3; i++)
            E[i] = no * no * C[i] - kc * K[i];
    }
    cv_unit(E);
    memcpy(w->E, E, sizeof w->E);
    cplx H[3], P[3], Hc[3];
    cv_cross(K, E, H);
    for (int i = 0; i < 3; i++)
        Hc[i] = conj(H[i]);
    cv_cross(E, Hc, P);
    w->flux = propagating ? creal(cv_dot_real(P, m)) : 0.0;
}

/* The tangential field (E.u1, E.u2, H.u1, H.u2) of a wave. */
static void tangential(const uniaxial_fresnel_wave_t *w, vec3_t u1, vec3_t u2, cplx f[4])
{
    cplx H[3];
    cv_cross(w->K, w->E, H);
    f[0] = cv_dot_real(w->E, u1);
    f[1] = cv_dot_real(w->E, u2);
    f[2] = cv_dot_real(H, u1);
    f[3] = cv_dot_real(H, u2);
}

/* |re| + |im|: a magnitude for pivoting, without cabs's hypot. */
static double cmag(cplx z)
{
    return fabs(creal(z)) + fabs(cimag(z));
}

/* 1 / z by its conjugate over |z|^2: no C99 Annex G division (__divdc3) in the inner loop; the
 * pivot is never tiny (solve4 refuses those). */
static cplx crecip(cplx z)
{
    const double re = creal(z), im = cimag(z), d = re * re + im * im;
    return CMPLX(re / d, -im / d);
}

/* Gauss-Jordan elimination with partial pivoting of a (4 x 4) x = b for the right-hand sides
 * in the bit mask cols (b[row][rhs], overwritten by x; each column's arithmetic is its own, so
 * a column's solution does not depend on which others are solved). False for a (numerically)
 * singular a. */
static bool solve4(cplx a[4][4], cplx b[4][4], unsigned cols)
{
    double scale = 0.0;
    for (int r = 0; r < 4; r++)
        for (int c = 0; c < 4; c++)
            scale = fmax(scale, cmag(a[r][c]));
    if (!(scale > 0.0) || !isfinite(scale))
        return false;
    for (int c = 0; c < 4; c++) {
        int piv = c;
        for (int r = c + 1; r < 4; r++)
            if (cmag(a[r][c]) > cmag(a[piv][c]))
                piv = r;
        if (!(cmag(a[piv][c]) > 1e-12 * scale))
            return false;
        for (int k = 0; k < 4; k++) {
            cplx t = a[c][k];
            a[c][k] = a[piv][k];
            a[piv][k] = t;
            t = b[c][k];
            b[c][k] = b[piv][k];
            b[piv][k] = t;
        }
        const cplx inv = crecip(a[c][c]);
        for (int r = 0; r < 4; r++) {
            if (r == c)
                continue;
            const cplx f = a[r][c] * inv;
            if (f == 0.0)
                continue;
            for (int k = 0; k < 4; k++)
                a[r][k] -= f * a[c][k];
            for (int k = 0; k < 4; k++)
                if (cols >> k & 1u)
                    b[r][k] -= f * b[c][k];
        }
    }
    for (int r = 0; r < 4; r++) {
        const cplx inv = crecip(a[r][r]);
        for (int k = 0; k < 4; k++)
            if (cols >> k & 1u)
                b[r][k] *= inv;
    }
    return true;
}

/* The tangential field of a propagating wave, whose K and E are real. */
static void tangential_real(const uniaxial_fresnel_wave_t *w, vec3_t u1, vec3_t u2, double f[4])
{
    const vec3_t k = vec3_make(creal(w->K[0]), creal(w->K[1]), creal(w->K[2]));
    const vec3_t e = vec3_make(creal(w->E[0]), creal(w->E[1]), creal(w->E[2]));
    const vec3_t h = vec3_cross(k, e);
    f[0] = vec3_dot(e, u1);
    f[1] = vec3_dot(e, u2);
    f[2] = vec3_dot(h, u1);
    f[3] = vec3_dot(h, u2);
}

/* solve4 on real numbers, for a boundary where every wave propagates (real K, real E: the
 * system and its solution are real). It performs solve4's operations on the real parts --
 * the same pivots, the pivot's reciprocal as crecip forms it (re / re^2), the same order --
 * and a complex product with zero imaginary parts rounds as the real one, so the two agree
 * bit for bit (test_uniaxial.c's test_real_solve) at about a quarter of the arithmetic. */
static bool solve4_real(double a[4][4], double b[4][4], unsigned cols)
{
    double scale = 0.0;
    for (int r = 0; r < 4; r++)
        for (int c = 0; c < 4; c++)
            scale = fmax(scale, fabs(a[r][c]));
    if (!(scale > 0.0) || !isfinite(scale))
        return false;
    for (int c = 0; c < 4; c++) {
        int piv = c;
        for (int r = c + 1; r < 4; r++)
            if (fabs(a[r][c]) > fabs(a[piv][c]))
                piv = r;
        if (!(fabs(a[piv][c]) > 1e-12 * scale))
            return false;
        for (int k = 0; k < 4; k++) {
            double t = a[c][k];
            a[c][k] = a[piv][k];
            a[piv][k] = t;
            t = b[c][k];
            b[c][k] = b[piv][k];
            b[piv][k] = t;
        }
        const double inv = a[c][c] / (a[c][c] * a[c][c]);
        for (int r = 0; r < 4; r++) {
            if (r == c)
                continue;
            const double f = a[r][c] * inv;
            if (f == 0.0)
                continue;
            for (int k = 0; k < 4; k++)
                a[r][k] -= f * a[c][k];
            for (int k = 0; k < 4; k++)
                if (cols >> k & 1u)
                    b[r][k] -= f * b[c][k];
        }
    }
    for (int r = 0; r < 4; r++) {
        const double inv = a[r][r] / (a[r][r] * a[r][r]);
        for (int k = 0; k < 4; k++)
            if (cols >> k & 1u)
                b[r][k] *= inv;
    }
    return true;
}

/* The power fraction from incident wave i into outgoing wave o for amplitude magnitude^2 c2. */
static double power_of(const uniaxial_fresnel_t *f, int i, int o, double c2)
{
    const double fi = fabs(f->in[i].flux), fo = fabs(f->out[o].flux);
    const double p = f->in[i].propagating && f->out[o].propagating && fi > 0.0 ? c2 * fo / fi : 0.0;
    return isfinite(p) ? p : 0.0;
}

static void solve_waves(vec3_t t, vec3_t m, vec3_t axis, double no, double ne, double n1,
                        vec3_t s_hint, unsigned incident, bool real_path, uniaxial_fresnel_t *f)
{
    memset(f, 0, sizeof *f);
    t = vec3_fma(t, m, -vec3_dot(t, m));
    const double tt = vec3_dot(t, t);
    vec3_t s = vec3_cross(t, m);
    if (vec3_length(s) > 1e-12 * (1.0 + sqrt(tt))) {
        s = vec3_normalize(s);
    } else {
        s = vec3_fma(s_hint, m, -vec3_dot(s_hint, m));
        const double l = vec3_length(s);
        if (l > 1e-9) {
            s = vec3_scale(s, 1.0 / l);
        } else {
            vec3_t b;
            vec3_basis(m, &s, &b);
        }
    }
    cplx K[3];
    /* The outside: along -m toward the crystal (incident), along +m away (outgoing, decaying
     * as exp(-kappa z) beyond the critical angle). */
    const double b1 = n1 * n1 - tt, r1 = sqrt(fabs(b1));
    wave_vector(t, m, -r1, K);
    if (incident >> UF_S & 1u)
        wave_make(&f->in[UF_S], UF_S, K, b1 > 0.0, s, axis, no, m);
    if (incident >> UF_P & 1u)
        wave_make(&f->in[UF_P], UF_P, K, b1 > 0.0, s, axis, no, m);
    wave_vector(t, m, b1 > 0.0 ? (cplx)r1 : I * r1, K);
    wave_make(&f->out[UF_S], UF_S, K, b1 > 0.0, s, axis, no, m);
    wave_make(&f->out[UF_P], UF_P, K, b1 > 0.0, s, axis, no, m);
    /* The o wave: |K| = n_o; incident along +m, outgoing along -m (decaying into the crystal,
     * z < 0, as exp(kappa z)). */
    const double bo = no * no - tt, ro = sqrt(fabs(bo));
    wave_vector(t, m, ro, K);
    if (incident >> UF_O & 1u)
        wave_make(&f->in[UF_O], UF_O, K, bo > 0.0, s, axis, no, m);
    wave_vector(t, m, bo > 0.0 ? (cplx)-ro : -I * ro, K);
    wave_make(&f->out[UF_O], UF_O, K, bo > 0.0, s, axis, no, m);
    /* The e wave: K = t + beta m on the index surface, a quadratic in beta with a positive
     * leading coefficient; the larger root carries energy along +m (the line leaves the convex
     * surface there), the smaller along -m. */
    const double A = 1.0 / (no * no) - 1.0 / (ne * ne), ine2 = 1.0 / (ne * ne);
    const double a = vec3_dot(t, axis), b = vec3_dot(m, axis);
    const double qa = A * b * b + ine2, qb = A * a * b, qc = A * a * a + tt * ine2 - 1.0;
    const double disc = qb * qb - qa * qc, rd = sqrt(fabs(disc));
    wave_vector(t, m, (-qb + rd) / qa, K);
    if (incident >> UF_E & 1u)
        wave_make(&f->in[UF_E], UF_E, K, disc > 0.0, s, axis, no, m);
    wave_vector(t, m, disc > 0.0 ? (cplx)((-qb - rd) / qa) : (-qb - I * rd) / qa, K);
    wave_make(&f->out[UF_E], UF_E, K, disc > 0.0, s, axis, no, m);

    /* Continuity of tangential E and H: outside (incident + outgoing) = inside (incident +
     * outgoing), the unknowns the four outgoing amplitudes. */
    const vec3_t u1 = s, u2 = vec3_cross(m, s);
    if (real_path && b1 > 0.0 && bo > 0.0 && disc > 0.0) {
        /* Every wave propagates (the common case): a real system. */
        double A4r[4][4], B4r[4][4];
        for (int w = 0; w < UF_WAVES; w++) {
            double fo[4], fi[4] = {0, 0, 0, 0};
            tangential_real(&f->out[w], u1, u2, fo);
            if (incident >> w & 1u)
                tangential_real(&f->in[w], u1, u2, fi);
            const double sign = w < UF_O ? 1.0 : -1.0;
            for (int r = 0; r < 4; r++) {
                A4r[r][w] = sign * fo[r];
                B4r[r][w] = -sign * fi[r];
            }
        }
        if (!(f->ok = solve4_real(A4r, B4r, incident)))
            return;
        for (int i = 0; i < UF_WAVES; i++)
            for (int o = 0; o < UF_WAVES && (incident >> i & 1u); o++) {
                const double x = B4r[o][i];
                f->amp[i][o] = isfinite(x) ? x : 0.0;
                f->power[i][o] = power_of(f, i, o, x * x);
            }
        return;
    }
    cplx A4[4][4], B4[4][4];
    for (int w = 0; w < UF_WAVES; w++) {
        cplx fo[4], fi[4] = {0, 0, 0, 0};
        tangential(&f->out[w], u1, u2, fo);
        if (incident >> w & 1u)
            tangential(&f->in[w], u1, u2, fi);
        const double sign = w < UF_O ? 1.0 : -1.0;
        for (int r = 0; r < 4; r++) {
            A4[r][w] = sign * fo[r];
            B4[r][w] = -sign * fi[r];
        }
    }
    if (!(f->ok = solve4(A4, B4, incident)))
        return;
    for (int i = 0; i < UF_WAVES; i++) {
        for (int o = 0; o < UF_WAVES && (incident >> i & 1u); o++) {
            f->amp[i][o] = B4[o][i];
            f->power[i][o] = power_of(f, i, o, creal(B4[o][i] * conj(B4[o][i])));
            if (!isfinite(creal(f->amp[i][o])) || !isfinite(cimag(f->amp[i][o])))
                f->amp[i][o] = 0.0;
        }
    }
}

void uniaxial_fresnel_solve(vec3_t t, vec3_t m, vec3_t axis, double no, double ne, double n1,
                            vec3_t s_hint, uniaxial_fresnel_t *f)
{
    solve_waves(t, m, axis, no, ne, n1, s_hint, UF_ALL, true, f);
}

void uniaxial_fresnel_solve_incident(vec3_t t, vec3_t m, vec3_t axis, double no, double ne,
                                     double n1, vec3_t s_hint, unsigned incident,
                                     uniaxial_fresnel_t *f)
{
    solve_waves(t, m, axis, no, ne, n1, s_hint, incident & UF_ALL, true, f);
}

void uniaxial_fresnel_solve_complex(vec3_t t, vec3_t m, vec3_t axis, double no, double ne,
                                    double n1, vec3_t s_hint, uniaxial_fresnel_t *f)
{
    solve_waves(t, m, axis, no, ne, n1, s_hint, UF_ALL, false, f);
}

void uniaxial_fresnel_jones(const uniaxial_fresnel_t *f, bool in_outside, int in_mode,
                            bool out_outside, int out_mode, vec3_t k_in, vec3_t x_in, vec3_t k_out,
                            vec3_t x_out, double j[2][2][2])
{
    memset(j, 0, sizeof(double[2][2][2]));
    if (!f->ok)
        return;
    const int ins[2] = {in_outside ? UF_S : in_mode, UF_P};
    const int outs[2] = {out_outside ? UF_S : out_mode, UF_P};
    const int nin = in_outside ? 2 : 1, nout = out_outside ? 2 : 1;
    const vec3_t y_in = vec3_cross(k_in, x_in), y_out = vec3_cross(k_out, x_out);
    for (int c = 0; c < 2; c++) {
        const vec3_t e3 = c ? y_in : x_in;
        cplx F[3] = {0, 0, 0};
        for (int a = 0; a < nin; a++) {
            const uniaxial_fresnel_wave_t *wi = &f->in[ins[a]];
            const double fi = fabs(wi->flux);
            if (!wi->propagating || !(fi > 0.0))
                continue;
            /* The arriving field's component along this wave (real unit E when propagating). */
            cplx Ec[3];
            for (int k = 0; k < 3; k++)
                Ec[k] = conj(wi->E[k]);
            const cplx coeff = cv_dot_real(Ec, e3);
            for (int b = 0; b < nout; b++) {
                const uniaxial_fresnel_wave_t *wo = &f->out[outs[b]];
                if (!wo->propagating)
                    continue;
                const cplx g = coeff * f->amp[ins[a]][outs[b]] * sqrt(fabs(wo->flux) / fi);
                for (int k = 0; k < 3; k++)
                    F[k] += g * wo->E[k];
            }
        }
        const cplx jx = cv_dot_real(F, x_out), jy = cv_dot_real(F, y_out);
        j[0][c][0] = creal(jx);
        j[0][c][1] = cimag(jx);
        j[1][c][0] = creal(jy);
        j[1][c][1] = cimag(jy);
    }
}
