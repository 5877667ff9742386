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
