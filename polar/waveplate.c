#include "waveplate.h"

#include <math.h>

double waveplate_retardance(double n_o, double n_e, double thickness_nm, double lambda_nm,
                            vec3_t dir, vec3_t normal, vec3_t axis)
{
    /* K = t + N normal in units of the vacuum wavenumber; t is continuous across the face. */
    const double dn = vec3_dot(dir, normal);
    const vec3_t t = vec3_sub(dir, vec3_scale(normal, dn));
    const double tt = vec3_dot(t, t), a = vec3_dot(t, axis);
    /* From air |t| <= 1 < n: the roots are real; fmax keeps absurd input finite. */
    const double no2 = fmax(n_o * n_o - tt, 0.0);
    const double ne2 = fmax(n_e * n_e - tt - (n_e * n_e / (n_o * n_o) - 1.0) * a * a, 0.0);
    const double phase = 2.0 * 3.14159265358979323846 * thickness_nm / lambda_nm;
    const double d = phase * (sqrt(no2) - sqrt(ne2));
    return isfinite(d) ? d : 0.0;
}

mueller_t waveplate_axial_mueller(double n_o, double n_e, double psi, double thickness_nm,
                                  double lambda_nm, vec3_t k, vec3_t normal, vec3_t x)
{
    const double kn = vec3_dot(k, normal);
    const vec3_t t = vec3_sub(k, vec3_scale(normal, kn));
    const double q2 = fmin(vec3_dot(t, t), 1.0);
    const double No = sqrt(fmax(0.0, n_o * n_o - q2)),
                 Ne = n_o * sqrt(fmax(0.0, 1.0 - q2 / (n_e * n_e)));
    const double delta = 2.0 * 3.14159265358979323846 * thickness_nm * (No - Ne) / lambda_nm;
    /* exp(N) in the frame (s, k x s) */
    const double g = sqrt(0.25 * delta * delta + psi * psi);
    const double c = cos(g), sg = g > 1e-300 ? sin(g) / g : 1.0;
    const double j[2][2][2] = {{{c, -sg * 0.5 * delta}, {-sg * psi, 0.0}},
                               {{sg * psi, 0.0}, {c, sg * 0.5 * delta}}};
    const mueller_t ms = mueller_jones(j);
    /* s's angle phi from x toward y = k x x; the element turned to phi is R(-phi) M R(phi)
     * (stokes.h). At normal incidence s is undefined and delta = 0: the rotator is the same in
     * any frame. */
    vec3_t s = vec3_cross(k, normal);
    const double ls = vec3_length(s);
    if (!(ls > 1e-12))
        return ms;
    s = vec3_scale(s, 1.0 / ls);
    const double phi = atan2(vec3_dot(s, vec3_cross(k, x)), vec3_dot(s, x));
    const mueller_t ra = mueller_rotator(-phi), rb = mueller_rotator(phi);
    const mueller_t tmp = mueller_mul(&ms, &rb);
    return mueller_mul(&ra, &tmp);
}
