#include "stokes.h"

#include <complex.h>

#include <math.h>

stokes_t stokes_make(double s0, double s1, double s2, double s3)
{
    return (stokes_t){{s0, s1, s2, s3}};
}

stokes_t stokes_unpolarised(double i)
{
    return stokes_make(i, 0.0, 0.0, 0.0);
}

stokes_t stokes_linear(double i, double theta)
{
    return stokes_make(i, i * cos(2.0 * theta), i * sin(2.0 * theta), 0.0);
}

double stokes_dop(stokes_t s)
{
    if (!(s.s[0] > 0.0))
        return 0.0;
    return sqrt(s.s[1] * s.s[1] + s.s[2] * s.s[2] + s.s[3] * s.s[3]) / s.s[0];
}

double stokes_aop(stokes_t s)
{
    return 0.5 * atan2(s.s[2], s.s[1]);
}

mueller_t mueller_identity(void)
{
    mueller_t m = {{{0.0}}};
    for (int i = 0; i < 4; i++)
        m.m[i][i] = 1.0;
    return m;
}

stokes_t mueller_apply(const mueller_t *m, stokes_t s)
{
    stokes_t r;
    for (int i = 0; i < 4; i++) {
        double v = 0.0;
        for (int k = 0; k < 4; k++)
            v += m->m[i][k] * s.s[k];
        r.s[i] = v;
    }
    return r;
}

mueller_t mueller_mul(const mueller_t *a, const mueller_t *b)
{
    mueller_t r;
    for (int i = 0; i < 4; i++)
        for (int j = 0; j < 4; j++) {
            double v = 0.0;
            for (int k = 0; k < 4; k++)
                v += a->m[i][k] * b->m[k][j];
            r.m[i][j] = v;
        }
    return r;
}

mueller_t mueller_scale(const mueller_t *m, double k)
{
    mueller_t r;
    for (int i = 0; i < 4; i++)
        for (int j = 0; j < 4; j++)
            r.m[i][j] = m->m[i][j] * k;
    return r;
}

mueller_t mueller_rotator(double phi)
{
    const double c = cos(2.0 * phi), s = sin(2.0 * phi);
    mueller_t m = mueller_identity();
    m.m[1][1] = c;
    m.m[1][2] = s;
    m.m[2][1] = -s;
    m.m[2][2] = c;
    return m;
}

mueller_t mueller_polariser(double theta)
{
    const double c = cos(2.0 * theta), s = sin(2.0 * theta);
    return (mueller_t){{{0.5, 0.5 * c, 0.5 * s, 0.0},
                        {0.5 * c, 0.5 * c * c, 0.5 * c * s, 0.0},
                        {0.5 * s, 0.5 * c * s, 0.5 * s * s, 0.0},
                        {0.0, 0.0, 0.0, 0.0}}};
}

mueller_t mueller_retarder(double theta, double delta)
{
    mueller_t m0 = mueller_identity();
    m0.m[2][2] = cos(delta);
    m0.m[2][3] = -sin(delta);
    m0.m[3][2] = sin(delta);
    m0.m[3][3] = cos(delta);
    const mueller_t to = mueller_rotator(theta), back = mueller_rotator(-theta);
    const mueller_t t = mueller_mul(&m0, &to);
    return mueller_mul(&back, &t);
}

mueller_t mueller_jones_diagonal(double a_re, double a_im, double b_re, double b_im)
{
    const double aa = a_re * a_re + a_im * a_im, bb = b_re * b_re + b_im * b_im;
    /* a b* = (a_re + i a_im)(b_re - i b_im) */
    const double re = a_re * b_re + a_im * b_im, im = a_im * b_re - a_re * b_im;
    return (mueller_t){{{0.5 * (aa + bb), 0.5 * (aa - bb), 0.0, 0.0},
                        {0.5 * (aa - bb), 0.5 * (aa + bb), 0.0, 0.0},
                        {0.0, 0.0, re, -im},
                        {0.0, 0.0, im, re}}};
}

mueller_t mueller_jones(const double j[2][2][2])
{
    double complex J[2][2];
    for (int r = 0; r < 2; r++)
        for (int c = 0; c < 2; c++)
            J[r][c] = j[r][c][0] + I * j[r][c][1];
    mueller_t m;
    for (int col = 0; col < 4; col++) {
        const double e[4] = {col == 0, col == 1, col == 2, col == 3};
        const double complex C[2][2] = {{0.5 * (e[0] + e[1]), 0.5 * (e[2] + I * e[3])},
                                        {0.5 * (e[2] - I * e[3]), 0.5 * (e[0] - e[1])}};
        /* C' = J C J^dagger */
        double complex JC[2][2], Cp[2][2];
        for (int r = 0; r < 2; r++)
            for (int c = 0; c < 2; c++)
                JC[r][c] = J[r][0] * C[0][c] + J[r][1] * C[1][c];
        for (int r = 0; r < 2; r++)
            for (int c = 0; c < 2; c++)
                Cp[r][c] = JC[r][0] * conj(J[c][0]) + JC[r][1] * conj(J[c][1]);
        m.m[0][col] = creal(Cp[0][0] + Cp[1][1]);
        m.m[1][col] = creal(Cp[0][0] - Cp[1][1]);
        m.m[2][col] = 2.0 * creal(Cp[0][1]);
        m.m[3][col] = 2.0 * cimag(Cp[0][1]);
    }
    return m;
}
