/* cie: the CIE 1931 2-degree colour matching functions (360-830 nm, 1 nm) and the CIE D65
 * illuminant (300-830 nm, 5 nm) as const tables, with piecewise-linear evaluation at any
 * wavelength (0 outside the table) and exact integrals of that interpolant. Pure functions. */
#ifndef PRISMFARM_CIE_H
#define PRISMFARM_CIE_H

/* CIE XYZ tristimulus values (or the three matching functions at one wavelength). */
typedef struct xyz {
    double x, y, z;
} xyz_t;

#define CIE_LAMBDA_MIN 360.0
#define CIE_LAMBDA_MAX 830.0
#define CIE_SAMPLE_COUNT 471 /* 360..830 nm inclusive, 1 nm apart */

#define CIE_D65_LAMBDA_MIN 300.0
#define CIE_D65_LAMBDA_MAX 830.0
#define CIE_D65_STEP 5.0
#define CIE_D65_SAMPLE_COUNT 107

/* Sum of the y-bar table at 1 nm spacing, in nm: the integral that normalises XYZ so that a
 * constant spectrum of value 1 has Y = 1 (pbrt-v4's CIE_Y_integral, 106.856895, is the same
 * sum over a float32 copy of the table; they differ by 2e-7 relative). Equal to
 * cie_y_integral_value in the generated tables. */
#define CIE_Y_INTEGRAL 106.856917101

/* Generated from data/cie1931_2deg_1nm.csv and data/d65_5nm.csv by tools/gen_cie_tables.py
 * (spectral/cie_tables.c; sources in data/README.md). */
extern const double cie_x_table[CIE_SAMPLE_COUNT];
extern const double cie_y_table[CIE_SAMPLE_COUNT];
extern const double cie_z_table[CIE_SAMPLE_COUNT];
extern const double cie_d65_table[CIE_D65_SAMPLE_COUNT];
extern const double cie_y_integral_value;

/* The matching functions at lambda_nm, linearly interpolated; 0 outside [360, 830] and for a
 * non-finite lambda. */
double cie_x_bar(double lambda_nm);
double cie_y_bar(double lambda_nm);
double cie_z_bar(double lambda_nm);
xyz_t cie_cmf_eval(double lambda_nm);

/* The exact integral over [a_nm, b_nm] of the piecewise-linear matching functions (0 outside
 * the table), in nm; a > b gives the negative of the integral over [b, a]. */
xyz_t cie_cmf_integrate(double a_nm, double b_nm);

/* D65 relative spectral power (S(560) = 100), linearly interpolated between the 5 nm samples;
 * 0 outside [300, 830] and for a non-finite lambda. */
double cie_d65_eval(double lambda_nm);

#endif
