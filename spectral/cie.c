#include "cie.h"

#include <math.h>

/* Linear interpolation in a table sampled every `step` nm from `lambda0`; 0 outside. */
static double table_lerp(const double *table, int count, double lambda0, double step, double lambda)
{
    if (!isfinite(lambda))
        return 0.0;
    double pos = (lambda - lambda0) / step;
    if (pos < 0.0 || pos > (double)(count - 1))
        return 0.0;
    int i = (int)pos;
    if (i >= count - 1)
        return table[count - 1];
    double f = pos - (double)i;
    return table[i] + f * (table[i + 1] - table[i]);
}

double cie_x_bar(double lambda_nm)
{
    return table_lerp(cie_x_table, CIE_SAMPLE_COUNT, CIE_LAMBDA_MIN, 1.0, lambda_nm);
}

double cie_y_bar(double lambda_nm)
{
    return table_lerp(cie_y_table, CIE_SAMPLE_COUNT, CIE_LAMBDA_MIN, 1.0, lambda_nm);
}

double cie_z_bar(double lambda_nm)
{
    return table_lerp(cie_z_table, CIE_SAMPLE_COUNT, CIE_LAMBDA_MIN, 1.0, lambda_nm);
}

xyz_t cie_cmf_eval(double lambda_nm)
{
    return (xyz_t){cie_x_bar(lambda_nm), cie_y_bar(lambda_nm), cie_z_bar(lambda_nm)};
}

double cie_d65_eval(double lambda_nm)
{
    return table_lerp(cie_d65_table, CIE_D65_SAMPLE_COUNT, CIE_D65_LAMBDA_MIN, CIE_D65_STEP,
                      lambda_nm);
}

/* Integral of one table's linear interpolant over [a, b] with CIE_LAMBDA_MIN <= a <= b <=
 * CIE_LAMBDA_MAX: whole 1 nm segments by the trapezoid rule (exact for a linear function),
 * partial end segments by the midpoint value times the length (also exact). */
static double table_integrate(const double *table, double a, double b)
{
    double sum = 0.0;
    double lo = a;
    while (lo < b) {
        int i = (int)(lo - CIE_LAMBDA_MIN);
        if (i >= CIE_SAMPLE_COUNT - 1)
            i = CIE_SAMPLE_COUNT - 2;
        double seg_end = CIE_LAMBDA_MIN + (double)(i + 1);
        double hi = seg_end < b ? seg_end : b;
        double mid = 0.5 * (lo + hi);
        double f = mid - (CIE_LAMBDA_MIN + (double)i);
        sum += (hi - lo) * (table[i] + f * (table[i + 1] - table[i]));
        lo = hi;
    }
    return sum;
}

xyz_t cie_cmf_integrate(double a_nm, double b_nm)
{
    if (!isfinite(a_nm) || !isfinite(b_nm))
        return (xyz_t){0.0, 0.0, 0.0};
    double sign = 1.0;
    if (a_nm > b_nm) {
        double t = a_nm;
        a_nm = b_nm;
        b_nm = t;
        sign = -1.0;
    }
    double a = a_nm < CIE_LAMBDA_MIN ? CIE_LAMBDA_MIN : a_nm;
    double b = b_nm > CIE_LAMBDA_MAX ? CIE_LAMBDA_MAX : b_nm;
    if (a >= b)
        return (xyz_t){0.0, 0.0, 0.0};
    return (xyz_t){sign * table_integrate(cie_x_table, a, b),
                   sign * table_integrate(cie_y_table, a, b),
                   sign * table_integrate(cie_z_table, a, b)};
}
