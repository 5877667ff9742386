#include "sheet.h"

#include "waveplate.h"

#include <math.h>

vec3_t sheet_axis(const surface_t *sf, const material_t *m)
{
    vec3_t t = sf->dpdu, b;
    if (!(vec3_length(t) > 0.0))
        vec3_basis(sf->ng, &t, &b);
    t = vec3_normalize(polar_frame_perp(t, sf->ng));
    b = vec3_cross(sf->ng, t);
    return vec3_add(vec3_scale(t, cos(m->sheet_angle)), vec3_scale(b, sin(m->sheet_angle)));
}

int sheet_mueller(const surface_t *sf, const material_t *m, vec3_t axis, vec3_t dir, int n,
                  const double *lambda, mueller_t *mm)
{
    if (m->kind == MATERIAL_POLARISER) {
        mm[0] = mueller_polariser(0.0);
        return 0;
    }
    if (m->retarder_mode == RETARDER_CONSTANT) {
        mm[0] = mueller_retarder(0.0, m->retardance);
        return 0;
    }
    /* A retardance per lane (§14.1): 2 pi Gamma / lambda, or the crystal plate's. */
    for (int j = 0; j < n; j++) {
        const double l = lambda[j];
        const double delta =
            m->retarder_mode == RETARDER_RETARDATION
                ? 2.0 * PF_PI * m->retardation_nm / l
                : waveplate_retardance(ior_eval(&m->crystal.no, l), ior_eval(&m->crystal.ne, l),
                                       m->plate_thickness_nm, l, dir, sf->ng, axis);
        mm[j] = mueller_retarder(0.0, delta);
    }
    return 1;
}
