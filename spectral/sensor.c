#include "sensor.h"

#include "named_spectra.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Every integral here is pbrt-v4's: a sum over whole nanometres 360..830 (its DenselySampled
 * spectra and InnerProduct), so the fitted matrix is pbrt-v4's up to float rounding. */
#define NLAMBDA CIE_SAMPLE_COUNT
#define LAMBDA0 CIE_LAMBDA_MIN

struct sensor {
    int identity, is_xyz;
    double whitebalance;
    double m[3][3];          /* XYZ from the record */
    double resp[3][NLAMBDA]; /* a camera's r, g, b at 360..830 nm (unused for cie1931) */
};

/* Bradford's cone response matrix (Lam 1985, as pbrt-v4's LMSFromXYZ). */
static const double BRADFORD[3][3] = {
    {0.8951, 0.2664, -0.1614},
    {-0.7502, 1.7135, 0.0367},
    {0.0389, -0.0685, 1.0296},
};

static int mat3_inverse(const double a[3][3], double out[3][3])
{
    double c00 = a[1][1] * a[2][2] - a[1][2] * a[2][1];
    double c01 = a[1][2] * a[2][0] - a[1][0] * a[2][2];
    double c02 = a[1][0] * a[2][1] - a[1][1] * a[2][0];
    double det = a[0][0] * c00 + a[0][1] * c01 + a[0][2] * c02;
    if (!(fabs(det) > 1e-300) || !isfinite(det))
        return -1;
    double k = 1.0 / det;
    out[0][0] = c00 * k;
    out[0][1] = (a[0][2] * a[2][1] - a[0][1] * a[2][2]) * k;
    out[0][2] = (a[0][1] * a[1][2] - a[0][2] * a[1][1]) * k;
    out[1][0] = c01 * k;
    out[1][1] = (a[0][0] * a[2][2] - a[0][2] * a[2][0]) * k;
    out[1][2] = (a[0][2] * a[1][0] - a[0][0] * a[1][2]) * k;
    out[2][0] = c02 * k;
    out[2][1] = (a[0][1] * a[2][0] - a[0][0] * a[2][1]) * k;
    out[2][2] = (a[0][0] * a[1][1] - a[0][1] * a[1][0]) * k;
    return 0;
}

static void mat3_mul(const double a[3][3], const double b[3][3], double out[3][3])
{
    double t[3][3];
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            t[i][j] = a[i][0] * b[0][j] + a[i][1] * b[1][j] + a[i][2] * b[2][j];
    memcpy(out, t, sizeof t);
}

/* Piecewise linear on a uniform grid, 0 outside it. */
static double uniform_eval(const double *v, int n, double lambda0, double step, double lambda)
{
    double t = (lambda - lambda0) / step;
    if (!(t >= 0.0) || t > n - 1)
        return 0.0;
    int i = (int)t;
    if (i >= n - 1)
        return v[n - 1];
    double f = t - i;
    return v[i] + f * (v[i + 1] - v[i]);
}

double sensor_daylight_eval(double kelvin, double lambda_nm)
{
    double cct = kelvin * 1.4388 / 1.4380;
    if (cct < 4000.0) {
        /* Planck's law relative to its value at Wien's peak (pbrt-v4 BlackbodySpectrum). */
        const double c = 299792458.0, h = 6.62606957e-34, kb = 1.3806488e-23;
        double l = lambda_nm * 1e-9, lp = 2.8977721e-3 / cct;
        double b = 1.0 / (pow(l, 5) * (exp(h * c / (l * kb * cct)) - 1.0));
        double bp = 1.0 / (pow(lp, 5) * (exp(h * c / (lp * kb * cct)) - 1.0));
        return b / bp;
    }
    /* The daylight locus x(T) (two cubic fits in 1/T) and y(x), then the basis weights M1, M2
     * (CIE 015:2004 §3.1; pbrt-v4 Spectra::D). */
    double x =
        cct <= 7000.0
            ? -4.607e9 / (cct * cct * cct) + 2.9678e6 / (cct * cct) + 0.09911e3 / cct + 0.244063
            : -2.0064e9 / (cct * cct * cct) + 1.9018e6 / (cct * cct) + 0.24748e3 / cct + 0.23704;
    double y = -3.0 * x * x + 2.870 * x - 0.275;
    double m = 0.0241 + 0.2562 * x - 0.7341 * y;
    double m1 = (-1.3515 - 1.7703 * x + 5.9114 * y) / m;
    double m2 = (0.0300 - 31.4424 * x + 30.0717 * y) / m;
    double s0 = uniform_eval(sensor_daylight_s0_table, SENSOR_DAYLIGHT_SAMPLES,
                             SENSOR_DAYLIGHT_LAMBDA_MIN, SENSOR_DAYLIGHT_STEP, lambda_nm);
    double s1 = uniform_eval(sensor_daylight_s1_table, SENSOR_DAYLIGHT_SAMPLES,
                             SENSOR_DAYLIGHT_LAMBDA_MIN, SENSOR_DAYLIGHT_STEP, lambda_nm);
    double s2 = uniform_eval(sensor_daylight_s2_table, SENSOR_DAYLIGHT_SAMPLES,
                             SENSOR_DAYLIGHT_LAMBDA_MIN, SENSOR_DAYLIGHT_STEP, lambda_nm);
    return (s0 + s1 * m1 + s2 * m2) * 0.01;
}

static double swatch_eval(int i, double lambda)
{
    return uniform_eval(sensor_swatch_table[i], SENSOR_SWATCH_SAMPLES, SENSOR_SWATCH_LAMBDA_MIN,
                        SENSOR_SWATCH_STEP, lambda);
}

/* Chromaticity of an illuminant sampled at 360..830 nm (pbrt-v4 SpectrumToXYZ(s).xy()). */
static void illuminant_xy(const double *illum, double *x, double *y)
{
    double X = 0, Y = 0, Z = 0;
    for (int k = 0; k < NLAMBDA; k++) {
        X += cie_x_table[k] * illum[k];
        Y += cie_y_table[k] * illum[k];
        Z += cie_z_table[k] * illum[k];
    }
    *x = X / (X + Y + Z);
    *y = Y / (X + Y + Z);
}

/* pbrt-v4 WhiteBalance: XYZ -> LMS (Bradford), scale each cone by target/source white, back. */
static int white_balance(double sx, double sy, double tx, double ty, double out[3][3])
{
    double src[3] = {sx / sy, 1.0, (1.0 - sx - sy) / sy},
           dst[3] = {tx / ty, 1.0, (1.0 - tx - ty) / ty};
    double ls[3], ld[3], inv[3][3], diag[3][3] = {{0}};
    for (int i = 0; i < 3; i++) {
        ls[i] = BRADFORD[i][0] * src[0] + BRADFORD[i][1] * src[1] + BRADFORD[i][2] * src[2];
        ld[i] = BRADFORD[i][0] * dst[0] + BRADFORD[i][1] * dst[1] + BRADFORD[i][2] * dst[2];
        diag[i][i] = ld[i] / ls[i];
    }
    if (mat3_inverse(BRADFORD, inv))
        return -1;
    mat3_mul(diag, BRADFORD, out);
    mat3_mul(inv, out, out);
    return 0;
}

/* pbrt-v4 ProjectReflectance: the three responses to a swatch under illum, over the second
 * response to the illuminant alone. */
static void project(int swatch, const double *illum, const double *b[3], double out[3])
{
    double g = 0, r[3] = {0, 0, 0};
    for (int k = 0; k < NLAMBDA; k++) {
        double s = swatch_eval(swatch, LAMBDA0 + k) * illum[k];
        g += b[1][k] * illum[k];
        for (int c = 0; c < 3; c++)
            r[c] += b[c][k] * s;
    }
    for (int c = 0; c < 3; c++)
        out[c] = r[c] / g;
}

/* pbrt-v4's PixelSensor(r, g, b, ...) constructor: the least-squares fit (normal equations,
 * as pbrt-v4's LinearLeastSquares) of XYZ = M rgb over the swatches, the camera seeing them
 * under the white-balance daylight and XYZ being their look under the output space's D65,
 * scaled so that the daylight's white keeps its luminance. */
static int fit_camera(sensor_t *s, const double *illum, err_t *err)
{
    double d65[NLAMBDA];
    for (int k = 0; k < NLAMBDA; k++)
        d65[k] = cie_d65_eval(LAMBDA0 + k);
    const double *cam[3] = {s->resp[0], s->resp[1], s->resp[2]};
    const double *cmf[3] = {cie_x_table, cie_y_table, cie_z_table};
    double white_g = 0, white_y = 0;
    for (int k = 0; k < NLAMBDA; k++) {
        white_g += illum[k] * s->resp[1][k];
        white_y += illum[k] * cie_y_table[k];
    }
    double ata[3][3] = {{0}}, atb[3][3] = {{0}};
    for (int i = 0; i < SENSOR_SWATCH_COUNT; i++) {
        double a[3], b[3];
        project(i, illum, cam, a);
        project(i, d65, cmf, b);
        for (int c = 0; c < 3; c++)
            b[c] *= white_y / white_g;
        for (int p = 0; p < 3; p++)
            for (int q = 0; q < 3; q++) {
                ata[p][q] += a[p] * a[q];
                atb[p][q] += a[p] * b[q];
            }
    }
    double inv[3][3], sol[3][3];
    if (mat3_inverse(ata, inv))
        return err_set(err, "the sensor's XYZ-from-sensor-RGB matrix could not be solved");
    mat3_mul(inv, atb, sol);
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            s->m[i][j] = sol[j][i];
    return 0;
}

const char *sensor_list(char *buf, size_t size)
{
    if (size == 0)
        return buf;
    snprintf(buf, size, "cie1931");
    size_t len = strlen(buf);
    for (int i = 0; i < named_spectra_count(); i++) {
        const named_spectrum_t *e = named_spectra_get(i);
        size_t n = strlen(e->name);
        if (e->kind != NAMED_SPECTRUM_SENSOR || n < 2 || strcmp(e->name + n - 2, "_r") != 0)
            continue;
        if (len + n + 6 >= size) {
            if (len + 4 < size)
                strcat(buf, "...");
            break;
        }
        strcat(buf, ", ");
        strncat(buf, e->name, n - 2);
        len += n;
    }
    return buf;
}

static const named_spectrum_t *curve(const char *name, char channel)
{
    char full[128];
    if (snprintf(full, sizeof full, "%s_%c", name, channel) >= (int)sizeof full)
        return NULL;
    const named_spectrum_t *e = named_spectra_find(full);
    return e && e->kind == NAMED_SPECTRUM_SENSOR ? e : NULL;
}

/* Piecewise linear through a named table, 0 outside it (pbrt-v4 PiecewiseLinearSpectrum). */
static double table_eval(const named_spectrum_t *e, double lambda)
{
    if (!(lambda >= e->lambda[0]) || lambda > e->lambda[e->count - 1])
        return 0.0;
    size_t i = 0;
    while (i + 2 < e->count && e->lambda[i + 1] < lambda)
        i++;
    double f = (lambda - e->lambda[i]) / (e->lambda[i + 1] - e->lambda[i]);
    return e->value[i] + f * (e->value[i + 1] - e->value[i]);
}

sensor_t *sensor_new(const char *name, double whitebalance, err_t *err)
{
    char names[1024];
    if (!name) {
        err_set(err, "no sensor name");
        return NULL;
    }
    int is_xyz = !strcmp(name, "cie1931");
    const named_spectrum_t *rgb[3] = {NULL, NULL, NULL};
    if (!is_xyz) {
        rgb[0] = curve(name, 'r');
        rgb[1] = curve(name, 'g');
        rgb[2] = curve(name, 'b');
        if (!rgb[0] || !rgb[1] || !rgb[2]) {
            err_set(err, "unknown sensor \"%s\" (there are %s)", name,
                    sensor_list(names, sizeof names));
            return NULL;
        }
    }
    if (!(whitebalance == 0.0 ||
          (whitebalance >= SENSOR_WHITEBALANCE_MIN && whitebalance <= SENSOR_WHITEBALANCE_MAX))) {
        err_set(err, "white balance %g K is outside %g..%g K (or 0: the sensor's default)",
                whitebalance, SENSOR_WHITEBALANCE_MIN, SENSOR_WHITEBALANCE_MAX);
        return NULL;
    }
    sensor_t *s = calloc(1, sizeof *s);
    if (!s) {
        err_set(err, "out of memory");
        return NULL;
    }
    s->is_xyz = is_xyz;
    /* pbrt-v4 PixelSensor::Create: a camera is balanced for 6500 K unless told otherwise. */
    s->whitebalance = !is_xyz && whitebalance == 0.0 ? 6500.0 : whitebalance;
    for (int i = 0; i < 3; i++)
        s->m[i][i] = 1.0;
    s->identity = is_xyz && s->whitebalance == 0.0;
    if (s->identity)
        return s;
    double illum[NLAMBDA];
    for (int k = 0; k < NLAMBDA; k++)
        illum[k] = sensor_daylight_eval(s->whitebalance, LAMBDA0 + k);
    if (is_xyz) {
        double sx, sy, tx, ty, d65[NLAMBDA];
        for (int k = 0; k < NLAMBDA; k++)
            d65[k] = cie_d65_eval(LAMBDA0 + k);
        illuminant_xy(illum, &sx, &sy);
        illuminant_xy(d65, &tx, &ty);
        if (white_balance(sx, sy, tx, ty, s->m) == 0)
            return s;
        err_set(err, "the white balance matrix could not be solved");
        sensor_destroy(&s);
        return NULL;
    }
    for (int c = 0; c < 3; c++)
        for (int k = 0; k < NLAMBDA; k++)
            s->resp[c][k] = table_eval(rgb[c], LAMBDA0 + k);
    if (fit_camera(s, illum, err)) {
        sensor_destroy(&s);
        return NULL;
    }
    return s;
}

void sensor_destroy(sensor_t **self_p)
{
    if (self_p && *self_p) {
        free(*self_p);
        *self_p = NULL;
    }
}

int sensor_is_identity(const sensor_t *self)
{
    return self->identity;
}

double sensor_whitebalance(const sensor_t *self)
{
    return self->whitebalance;
}

xyz_t sensor_response(const sensor_t *self, double lambda_nm)
{
    if (self->is_xyz)
        return cie_cmf_eval(lambda_nm);
    double t = lambda_nm - LAMBDA0;
    if (!(t >= 0.0) || t > NLAMBDA - 1)
        return (xyz_t){0, 0, 0};
    int i = (int)t;
    if (i >= NLAMBDA - 1)
        i = NLAMBDA - 2;
    double f = t - i;
    return (xyz_t){self->resp[0][i] + f * (self->resp[0][i + 1] - self->resp[0][i]),
                   self->resp[1][i] + f * (self->resp[1][i + 1] - self->resp[1][i]),
                   self->resp[2][i] + f * (self->resp[2][i + 1] - self->resp[2][i])};
}

xyz_t sensor_to_xyz(const sensor_t *self, xyz_t v)
{
    const double(*m)[3] = self->m;
    return (xyz_t){m[0][0] * v.x + m[0][1] * v.y + m[0][2] * v.z,
                   m[1][0] * v.x + m[1][1] * v.y + m[1][2] * v.z,
                   m[2][0] * v.x + m[2][1] * v.y + m[2][2] * v.z};
}

void sensor_matrix(const sensor_t *self, double m[3][3])
{
    memcpy(m, self->m, sizeof self->m);
}
