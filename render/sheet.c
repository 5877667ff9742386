#include "sheet.h"

#include "material_sheet.h"
#include "waveplate.h"

#include <math.h>

/* A sheet built in code without a record: axis along dp/du, no retardance. */
static const material_sheet_t NO_SHEET = {0};

static const material_sheet_t *sheet_of(const material_t *m)
{
    const material_sheet_t *s = material_sheet_of(m);
    return s ? s : &NO_SHEET;
}

vec3_t sheet_axis(const surface_t *sf, const material_t *m)
{
    const double angle = sheet_of(m)->angle;
    vec3_t t = sf->dpdu, b;
    if (!(vec3_length(t) > 0.0))
        vec3_basis(sf->ng, &t, &b);
    t = vec3_normalize(polar_frame_perp(t, sf->ng));
    b = vec3_cross(sf->ng, t);
    return vec3_add(vec3_scale(t, cos(angle)), vec3_scale(b, sin(angle)));
}

int sheet_mueller(const surface_t *sf, const material_t *m, vec3_t axis, vec3_t k, int n,
                  const double *lambda, mueller_t *mm)
{
    if (m->kind == MATERIAL_POLARISER) {
        mm[0] = mueller_polariser(0.0);
        return 0;
    }
    const material_sheet_t *s = sheet_of(m);
    if (s->retarder_mode == RETARDER_CONSTANT) {
        mm[0] = mueller_retarder(0.0, s->retardance);
        return 0;
    }
    /* A retardance per lane (§14.1): 2 pi Gamma / lambda, or the crystal plate's; a plate cut
     * across its axis turns the light by the crystal's optical activity (quartz's), clockwise
     * seen facing the light for a dextrorotatory crystal: -rho t in the frame (x, k x x). */
    const vec3_t x = polar_frame_perp(axis, k);
    for (int j = 0; j < n; j++) {
        const double l = lambda[j];
        if (s->retarder_mode == RETARDER_PLATE && s->plate_axial) {
            const double psi = -crystal_rotary_power(&s->crystal.rotation, l) * (PF_PI / 180.0) *
                               (s->plate_thickness_nm * 1e-6);
            mm[j] =
                waveplate_axial_mueller(ior_eval(&s->crystal.no, l), ior_eval(&s->crystal.ne, l),
                                        psi, s->plate_thickness_nm, l, k, sf->ng, x);
            continue;
        }
        const double delta =
            s->retarder_mode == RETARDER_RETARDATION
                ? 2.0 * PF_PI * s->retardation_nm / l
                : waveplate_retardance(ior_eval(&s->crystal.no, l), ior_eval(&s->crystal.ne, l),
                                       s->plate_thickness_nm, l, k, sf->ng, axis);
        mm[j] = mueller_retarder(0.0, delta);
    }
    return 1;
}
