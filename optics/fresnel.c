#include "fresnel.h"

#include <complex.h>
#include <math.h>

/* Snell: sin^2(theta_t) = eta^2 sin^2(theta_i), cos_i in [0, 1]. At normal incidence it is 0
 * for any eta: written as a product, an eta^2 that overflows (indices 1e300 apart) would give
 * Inf * 0 = NaN there. An overflowing product elsewhere is +Inf, read as total reflection. */
static double sin2_transmitted(double eta, double cos_i)
{
    double sin2_i = fmax(0.0, 1.0 - cos_i * cos_i);
    return sin2_i > 0.0 ? eta * eta * sin2_i : 0.0;
}

vec3_t fresnel_reflect(vec3_t d, vec3_t n)
{
    return vec3_fma(d, n, -2.0 * vec3_dot(d, n));
}

bool fresnel_refract(vec3_t d, vec3_t n, double eta_ratio, vec3_t *t)
{
    *t = vec3_make(0.0, 0.0, 0.0);
    if (!(eta_ratio > 0.0) || !isfinite(eta_ratio))
        return false;
    /* Orient n against d so that cos_i = -d.n >= 0 whichever way the caller's normal faces. */
    double cos_i = -vec3_dot(d, n);
    if (cos_i < 0.0) {
        n = vec3_neg(n);
        cos_i = -cos_i;
    }
    cos_i = fmin(cos_i, 1.0);
    double sin2_t = sin2_transmitted(eta_ratio, cos_i);
    if (sin2_t >= 1.0)
        return false;
    double cos_t = sqrt(1.0 - sin2_t);
    /* t = eta d + (eta cos_i - cos_t) n: the tangential part of d scaled by eta (Snell), the
     * normal part chosen so |t| = 1 (Heckbert & Hanrahan 1984; pbrt-v4 Refract). */
    *t = vec3_normalize(vec3_fma(vec3_scale(d, eta_ratio), n, eta_ratio * cos_i - cos_t));
    return true;
}

fresnel_terms_t fresnel_dielectric_terms(double cos_theta_i, double n_outside, double n_inside)
{
    fresnel_terms_t f = {.rs = 1.0,
                         .rp = 1.0,
                         .reflectance = 1.0,
                         .transmittance = 0.0,
                         .cos_t = 0.0,
                         .n1 = n_outside,
                         .n2 = n_inside,
                         .tir = false};
    if (!(n_outside > 0.0) || !(n_inside > 0.0) || !isfinite(n_outside) || !isfinite(n_inside))
        return f;

    /* fmin/fmax also map a NaN cosine to a finite one, so nothing below divides by NaN. */
    double cos_i = fmin(fmax(cos_theta_i, -1.0), 1.0);
    if (cos_i < 0.0) {
        f.n1 = n_inside;
        f.n2 = n_outside;
        cos_i = -cos_i;
    }
    double n1 = f.n1, n2 = f.n2;
    if (n1 == n2) {
        f.rs = f.rp = 0.0;
        f.reflectance = 0.0;
        f.transmittance = 1.0;
        f.cos_t = cos_i;
        return f;
    }

    double sin2_t = sin2_transmitted(n1 / n2, cos_i);
    if (sin2_t >= 1.0) {
        /* Beyond the critical angle asin(n2/n1): every polarisation is reflected. The cosine
         * form gives r_s = r_p = 1 at cos_t = 0, so R is continuous across the critical angle. */
        f.tir = true;
        return f;
    }
    f.cos_t = sqrt(1.0 - sin2_t);
    if (cos_i < FRESNEL_GRAZING_COS) {
        /* Grazing: both coefficients tend to -1 (the numerators' n cos_i terms vanish). */
        f.rs = f.rp = -1.0;
        return f;
    }

    /* Both denominators are sums of positive terms here (cos_i >= 1e-6, n > 0): no 0/0. At
     * the Brewster angle n2 cos_i = n1 cos_t and r_p is exactly the rounding of a difference,
     * not a ratio of infinities as in the tan form. */
    double rs = (n1 * cos_i - n2 * f.cos_t) / (n1 * cos_i + n2 * f.cos_t);
    double rp = (n2 * cos_i - n1 * f.cos_t) / (n2 * cos_i + n1 * f.cos_t);
    f.rs = rs;
    f.rp = rp;
    f.reflectance = 0.5 * (rs * rs + rp * rp);
    f.transmittance = 1.0 - f.reflectance;
    return f;
}

double fresnel_dielectric(double cos_theta_i, double n_outside, double n_inside)
{
    return fresnel_dielectric_terms(cos_theta_i, n_outside, n_inside).reflectance;
}

/* The complex form (pbrt-v4 FrComplex), kept for the indices the real form below does not
 * take: libgcc's complex division and csqrt rescale, so extreme magnitudes stay finite. */
static double conductor_complex(double cos_i, double eta, double k)
{
    double complex e = eta + I * k;
    double sin2_i = fmax(0.0, 1.0 - cos_i * cos_i);
    double complex cos_t = csqrt(1.0 - sin2_i / (e * e));
    double complex r_parl = (e * cos_i - cos_t) / (e * cos_i + cos_t);
    double complex r_perp = (cos_i - e * cos_t) / (cos_i + e * cos_t);
    return 0.5 * (creal(r_parl * conj(r_parl)) + creal(r_perp * conj(r_perp)));
}

double fresnel_conductor(double cos_i, double eta, double k)
{
    cos_i = fmin(1.0, fabs(cos_i));
    if (!(cos_i >= 0.0)) /* NaN */
        cos_i = 0.0;
    if (!isfinite(eta) || !isfinite(k))
        return 1.0;
    double r;
    const double m = fmax(eta, k);
    if (eta >= 0.0 && k >= 0.0 && m > 1e-100 && m < 1e100) {
        /* The same quantities in real arithmetic (issue 24: the complex calls cost more than
         * the rest of the BSDF). With e = eta + i k and w = e cos_t = sqrt(e^2 - sin^2_i)
         * (the principal root: for e in the first quadrant its argument is half that of
         * e^2 - sin^2_i, in [0, pi/2]), r_perp = (cos_i - w) / (cos_i + w) and
         * r_parl = (e^2 cos_i - w) / (e^2 cos_i + w) (r_parl's terms times e), so only
         * moduli are needed: no complex division. The bounds on eta and k keep every square
         * below finite range and above underflow. */
        const double sin2_i = fmax(0.0, 1.0 - cos_i * cos_i);
        const double p = (eta - k) * (eta + k), q = 2.0 * eta * k; /* e^2 = p + i q */
        const double ur = p - sin2_i;                              /* w^2 = ur + i q */
        const double mod = sqrt(ur * ur + q * q);
        /* The root without cancellation: the larger part from the square root, the other
         * from q = 2 a b (q >= 0, so a, b >= 0). */
        double a, b;
        if (ur >= 0.0) {
            a = sqrt(0.5 * (mod + ur));
            b = a > 0.0 ? 0.5 * q / a : 0.0;
        } else {
            b = sqrt(0.5 * (mod - ur));
            a = 0.5 * q / b;
        }
        const double rperp =
            ((cos_i - a) * (cos_i - a) + b * b) / ((cos_i + a) * (cos_i + a) + b * b);
        const double pc = p * cos_i, qc = q * cos_i;
        const double rparl = ((pc - a) * (pc - a) + (qc - b) * (qc - b)) /
                             ((pc + a) * (pc + a) + (qc + b) * (qc + b));
        r = 0.5 * (rperp + rparl);
    } else {
        r = conductor_complex(cos_i, eta, k);
    }
    return isfinite(r) ? fmin(1.0, fmax(0.0, r)) : 1.0;
}
