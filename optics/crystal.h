/* crystal: uniaxial birefringent crystals as plain values -- an ordinary and an extraordinary
 * index model n_o(lambda), n_e(lambda) and optional dichroic absorption (pleochroism) of each
 * mode -- and the built-in catalogue (calcite, crystalline quartz, sapphire, rutile, MgF2,
 * tourmaline), beside the glass catalogue (glass.h). Every catalogue entry names the source of
 * its numbers; lookup is case-insensitive by name or alias. The physics that uses them is
 * bsdf/uniaxial.h. */
#ifndef PRISMFARM_CRYSTAL_H
#define PRISMFARM_CRYSTAL_H

#include "dispersion.h"
#include "err.h"

#define CRYSTAL_MAX_ALIASES 4
#define CRYSTAL_MAX_ABSORPTION 12

/* Absorption coefficients per mode in 1/mm, piecewise linear in wavelength between rows,
 * held at the end values; rows 0 means no absorption. */
typedef struct crystal_absorption {
    int rows;
    double lambda_nm[CRYSTAL_MAX_ABSORPTION]; /* strictly increasing */
    double o_per_mm[CRYSTAL_MAX_ABSORPTION];
    double e_per_mm[CRYSTAL_MAX_ABSORPTION];
} crystal_absorption_t;

/* Optical activity (natural optical rotation) for light along the optic axis, by Drude's
 * one-term rotary dispersion rho(lambda) = a / (lambda^2 - lambda0^2) in degrees per mm, lambda
 * in micrometres (P. Drude, Lehrbuch der Optik, 1900; Born & Wolf, Principles of Optics, 7th
 * ed., §15.7). a > 0: dextrorotatory (the plane of polarisation turns clockwise as seen facing
 * the light), a < 0 laevorotatory, a = 0: not optically active. */
typedef struct crystal_rotation {
    double a_deg_um2_per_mm;
    double lambda0_um2;
} crystal_rotation_t;

typedef struct crystal {
    const char *name;                         /* canonical, e.g. "calcite" */
    const char *aliases[CRYSTAL_MAX_ALIASES]; /* unused slots are NULL */
    const char *description;
    const char *source; /* short citation of the indices (and of the absorption, if any) */
    ior_model_t no, ne; /* ordinary and extraordinary (principal) indices */
    crystal_absorption_t absorption;
    crystal_rotation_t rotation; /* quartz's optical activity; zero for the others */
} crystal_t;

/* Number of entries, and entry i (NULL when out of range), in catalogue order. */
int crystal_count(void);
const crystal_t *crystal_get(int i);

/* The entry whose name or an alias equals name, ignoring ASCII case; NULL if none. */
const crystal_t *crystal_find(const char *name);

/* As crystal_find, but a miss fills err with "unknown crystal 'X'" and the known names. */
const crystal_t *crystal_lookup(const char *name, err_t *err);

/* The absorption coefficients (1/mm, >= 0) of the ordinary and extraordinary principal modes
 * at lambda_nm: 0 for a crystal without absorption. */
void crystal_absorption_eval(const crystal_absorption_t *a, double lambda_nm, double *o_per_mm,
                             double *e_per_mm);

/* The rotary power rho(lambda_nm) in degrees per mm (signed as crystal_rotation_t's a); 0 for
 * a crystal that is not optically active. */
double crystal_rotary_power(const crystal_rotation_t *r, double lambda_nm);

#endif
