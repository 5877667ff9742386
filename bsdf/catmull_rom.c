#include "catmull_rom.h"

#include <math.h>

/* The largest i in [0, n - 2] with x[i] <= v (binary search; x increasing). */
static size_t interval(const double *x, size_t n, double v)
{
    size_t lo = 0, hi = n - 1; /* x[lo] <= v unless v < x[0]; the answer is below hi */
    while (hi - lo > 1) {
        size_t mid = lo + (hi - lo) / 2;
        if (x[mid] <= v)
            lo = mid;
        else
            hi = mid;
    }
    return lo;
}

/* The Hermite segment on [x[i], x[i+1]] of values f: its end values and end derivatives
 * scaled by the segment's width (so that t in [0, 1] parametrises it). */
typedef struct segment {
    double f0, f1, d0, d1, x0, width;
} segment_t;

static segment_t segment_at(const double *x, const double *f, size_t n, size_t i)
{
    segment_t s;
    s.x0 = x[i];
    s.width = x[i + 1] - x[i];
    s.f0 = f[i];
    s.f1 = f[i + 1];
    s.d0 = i > 0 ? s.width * (s.f1 - f[i - 1]) / (x[i + 1] - x[i - 1]) : s.f1 - s.f0;
    s.d1 = i + 2 < n ? s.width * (f[i + 2] - s.f0) / (x[i + 2] - x[i]) : s.f1 - s.f0;
    return s;
}

bool catmull_rom_weights(const double *x, size_t n, double at, int *offset, double w[4])
{
    if (n < 2 || !(at >= x[0] && at <= x[n - 1]))
        return false;
    const size_t i = interval(x, n, at);
    *offset = (int)i - 1;
    const double x0 = x[i], x1 = x[i + 1];
    const double t = (at - x0) / (x1 - x0), t2 = t * t, t3 = t2 * t;
    /* Hermite basis: h00 f0 + h01 f1 + h10 d0 + h11 d1, with d0 and d1 written out as the
     * differences of segment_at, each spread over the nodes it reads. */
    const double h10 = t3 - 2.0 * t2 + t, h11 = t3 - t2;
    w[0] = 0.0;
    w[1] = 2.0 * t3 - 3.0 * t2 + 1.0;
    w[2] = -2.0 * t3 + 3.0 * t2;
    w[3] = 0.0;
    if (i > 0) {
        const double a = h10 * (x1 - x0) / (x1 - x[i - 1]);
        w[0] = -a;
        w[2] += a;
    } else {
        w[1] -= h10;
        w[2] += h10;
    }
    if (i + 2 < n) {
        const double b = h11 * (x1 - x0) / (x[i + 2] - x0);
        w[1] -= b;
        w[3] = b;
    } else {
        w[1] -= h11;
        w[2] += h11;
    }
    return true;
}

double catmull_rom_integrate(const double *x, const double *f, size_t n, double *cdf)
{
    double sum = 0.0;
    cdf[0] = 0.0;
    for (size_t i = 0; i + 1 < n; i++) {
        const segment_t s = segment_at(x, f, n, i);
        /* The integral of the Hermite segment: width ((f0 + f1) / 2 + (d0 - d1) / 12). */
        sum += s.width * ((s.f0 + s.f1) * 0.5 + (s.d0 - s.d1) / 12.0);
        cdf[i + 1] = sum;
    }
    return sum;
}

/* Solves F(t) = v on [0, 1] for a segment's increasing F by Newton's method with a bisection
 * bracket (pbrt's safeguarded iteration); eval returns F and its derivative. */
typedef void (*segment_eval_t)(const segment_t *s, double t, double *F, double *dF);

static double solve(const segment_t *s, double v, double t, segment_eval_t eval)
{
    double a = 0.0, b = 1.0;
    for (int it = 0; it < 100; it++) {
        if (!(t >= a && t <= b))
            t = 0.5 * (a + b);
        double F, dF;
        eval(s, t, &F, &dF);
        if (fabs(F - v) < 1e-9 || b - a < 1e-9)
            break;
        if (F - v < 0.0)
            a = t;
        else
            b = t;
        t -= (F - v) / dF;
    }
    return t < 0.0 ? 0.0 : t > 1.0 ? 1.0 : t;
}

/* The spline's value and slope (per unit t). */
static void spline_value(const segment_t *s, double t, double *F, double *dF)
{
    const double t2 = t * t, t3 = t2 * t;
    *F = (2.0 * t3 - 3.0 * t2 + 1.0) * s->f0 + (-2.0 * t3 + 3.0 * t2) * s->f1 +
         (t3 - 2.0 * t2 + t) * s->d0 + (t3 - t2) * s->d1;
    *dF = (6.0 * t2 - 6.0 * t) * s->f0 + (-6.0 * t2 + 6.0 * t) * s->f1 +
          (3.0 * t2 - 4.0 * t + 1.0) * s->d0 + (3.0 * t2 - 2.0 * t) * s->d1;
}

double catmull_rom_invert(const double *x, const double *f, size_t n, double v)
{
    if (!(v > f[0]))
        return x[0];
    if (!(v < f[n - 1]))
        return x[n - 1];
    const size_t i = interval(f, n, v);
    const segment_t s = segment_at(x, f, n, i);
    const double t0 = s.f1 != s.f0 ? (v - s.f0) / (s.f1 - s.f0) : 0.5;
    return s.x0 + s.width * solve(&s, v, t0, spline_value);
}

/* The segment's integral from 0 to t (per unit t: times width for x) and the spline's value. */
static void spline_integral(const segment_t *s, double t, double *F, double *dF)
{
    const double f0 = s->f0, f1 = s->f1, d0 = s->d0, d1 = s->d1;
    *F = t * (f0 + t * (0.5 * d0 + t * ((-2.0 * d0 - d1) / 3.0 + f1 - f0 +
                                        t * (0.25 * (d0 + d1) + 0.5 * (f0 - f1)))));
    *dF = f0 + t * (d0 + t * (-2.0 * d0 - d1 + 3.0 * (f1 - f0) + t * (d0 + d1 + 2.0 * (f0 - f1))));
}

/* The interpolation between rows at one column. */
static double row_at(const double *a, size_t n2, int offset, const double w[4], size_t col)
{
    double v = 0.0;
    for (int k = 0; k < 4; k++)
        if (w[k] != 0.0)
            v += a[(size_t)(offset + k) * n2 + col] * w[k];
    return v;
}

double catmull_rom_sample_2d(const double *x1, size_t n1, const double *x2, size_t n2,
                             const double *values, const double *cdf, double alpha, double u,
                             double *fval, double *pdf)
{
    int off;
    double w[4];
    if (!catmull_rom_weights(x1, n1, alpha, &off, w))
        return -1.0;
    const double total = row_at(cdf, n2, off, w, n2 - 1);
    if (!(total > 0.0))
        return -1.0;
    const double target = u * total;
    /* The segment whose running integral brackets the target (binary search on the
     * interpolated CDF, which increases where the row is non-negative). */
    size_t lo = 0, hi = n2 - 1;
    while (hi - lo > 1) {
        size_t mid = lo + (hi - lo) / 2;
        if (row_at(cdf, n2, off, w, mid) <= target)
            lo = mid;
        else
            hi = mid;
    }
    segment_t s;
    s.x0 = x2[lo];
    s.width = x2[lo + 1] - x2[lo];
    s.f0 = row_at(values, n2, off, w, lo);
    s.f1 = row_at(values, n2, off, w, lo + 1);
    s.d0 = lo > 0
               ? s.width * (s.f1 - row_at(values, n2, off, w, lo - 1)) / (x2[lo + 1] - x2[lo - 1])
               : s.f1 - s.f0;
    s.d1 = lo + 2 < n2
               ? s.width * (row_at(values, n2, off, w, lo + 2) - s.f0) / (x2[lo + 2] - x2[lo])
               : s.f1 - s.f0;
    const double v = (target - row_at(cdf, n2, off, w, lo)) / s.width;
    /* A first guess from the segment's linear interpolation (its integral is quadratic). */
    double t;
    if (s.f0 != s.f1) {
        const double q = s.f0 * s.f0 + 2.0 * v * (s.f1 - s.f0);
        t = (s.f0 - sqrt(q > 0.0 ? q : 0.0)) / (s.f0 - s.f1);
    } else {
        t = s.f0 > 0.0 ? v / s.f0 : 0.5;
    }
    t = solve(&s, v, t, spline_integral);
    double F, f;
    spline_integral(&s, t, &F, &f);
    if (fval)
        *fval = f;
    if (pdf)
        *pdf = f / total;
    return s.x0 + s.width * t;
}
