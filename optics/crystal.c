#include "crystal.h"

#include <stddef.h>
#include <stdio.h>
#include <strings.h> /* strcasecmp: names match ignoring case */

/* n^2 = 1 + a0 + sum_i b_i L^2 / (L^2 - c_i), L in um, c in um^2 (dispersion.h). */
#define SELLMEIER2(A0, B1, C1, B2, C2)                                                             \
    {                                                                                              \
        .kind = IOR_SELLMEIER, .sellmeier = {                                                      \
            .a0 = A0,                                                                              \
            .terms = 2,                                                                            \
            .b = {B1, B2},                                                                         \
            .c_um2 = {C1, C2}                                                                      \
        }                                                                                          \
    }
#define SELLMEIER3(B1, B2, B3, C1, C2, C3)                                                         \
    {                                                                                              \
        .kind = IOR_SELLMEIER, .sellmeier = {                                                      \
            .a0 = 0.0,                                                                             \
            .terms = 3,                                                                            \
            .b = {B1, B2, B3},                                                                     \
            .c_um2 = {C1, C2, C3}                                                                  \
        }                                                                                          \
    }
/* DeVore's form n^2 = A + B / (L^2 - C) as the Sellmeier term b L^2 / (L^2 - C) with
 * b = B / C and the constant a0 = A - 1 - B / C: the same function, exactly. */
#define DEVORE(A, B, C)                                                                            \
    {                                                                                              \
        .kind = IOR_SELLMEIER, .sellmeier = {                                                      \
            .a0 = (A)-1.0 - (B) / (C),                                                             \
            .terms = 1,                                                                            \
            .b = {(B) / (C)},                                                                      \
            .c_um2 = {C}                                                                           \
        }                                                                                          \
    }
#define CAUCHY(A, B)                                                                               \
    {                                                                                              \
        .kind = IOR_CAUCHY, .cauchy = {.a = A, .b_um2 = B }                                        \
    }

/* Indices from the refractiveindex.info database (polyanskiy/refractiveindex.info-database,
 * CC0), database/data-nk/main/..., each file naming the paper; the digits are the database's
 * (its formula 1 gives C in um, squared here as written; formula 2 gives C in um^2). */
static const crystal_t CATALOGUE[] = {
    /* G. Ghosh, "Dispersion-equation coefficients for the refractive index and birefringence
     * of calcite and quartz crystals", Opt. Commun. 163, 95-102 (1999); CaCO3/Ghosh-o.yml,
     * Ghosh-e.yml (formula 2), valid 0.204-2.172 um, room temperature. n_o(589) = 1.6584,
     * n_e = 1.4864: negative, birefringence -0.172. */
    {"calcite",
     {"CaCO3", "iceland-spar"},
     "calcite (Iceland spar), negative uniaxial",
     "Ghosh 1999, Opt. Commun. 163:95",
     SELLMEIER2(0.73358749, 0.96464345, 1.94325203e-2, 1.82831454, 120.0),
     SELLMEIER2(0.35859695, 0.82427830, 1.06689543e-2, 0.14429128, 120.0),
     {0},
     {0, 0}},
    /* Ghosh 1999 as above, SiO2/Ghosh-o.yml, Ghosh-e.yml (formula 2), valid 0.198-2.053 um.
     * n_o(589) = 1.5443, n_e = 1.5534: positive, +0.009. Right-handed quartz's optical
     * activity along the axis, Drude's one-term rho = a / (lambda^2 - lambda0^2) with
     * a = 7.161 deg um^2/mm and lambda0^2 = 0.01757 um^2 (lambda0 = 132.6 nm), fitted here
     * through the rotations 21.72 deg/mm at the sodium D line (589.3 nm) and 41.55 at the
     * mercury 435.8 nm line (quartz at 20 C, T. M. Lowry, Phil. Trans. R. Soc. A 212, 261,
     * 1912, as the handbooks tabulate it); it gives 48.98, 25.52 and 16.56 deg/mm at 404.7,
     * 546.1 and 670.8 nm against the tabulated 48.95, 25.54 and 16.54 (docs/physics.md
     * §14.1). Dextrorotatory; a laevorotatory (left) crystal is the same with a < 0. */
    {"quartz",
     {"crystalline-quartz", "alpha-quartz", "SiO2-crystal"},
     "crystalline (alpha) quartz, positive uniaxial, right-handed (dextrorotatory)",
     "Ghosh 1999, Opt. Commun. 163:95; rotation after Lowry 1912",
     SELLMEIER2(0.28604141, 1.07044083, 1.00585997e-2, 1.10202242, 100.0),
     SELLMEIER2(0.28851804, 1.09509924, 1.02101864e-2, 1.15662475, 100.0),
     {0},
     {7.161, 0.01757}},
    /* I. H. Malitson and M. J. Dodge, JOSA 62, 1405 (1972), with the formula of M. J. Dodge,
     * Handbook of Laser Science and Technology IV (CRC 1986) p. 30; Al2O3/Malitson-o.yml,
     * Malitson-e.yml (formula 1), 20 C, valid 0.2-5 um. n_o(589) = 1.7682, n_e = 1.7601. */
    {"sapphire",
     {"Al2O3", "corundum", "ruby"},
     "synthetic sapphire, negative uniaxial",
     "Malitson & Dodge 1972, JOSA 62:1405; Dodge 1986",
     SELLMEIER3(1.4313493, 0.65054713, 5.3414021, 0.0726631 * 0.0726631, 0.1193242 * 0.1193242,
                18.028251 * 18.028251),
     SELLMEIER3(1.5039759, 0.55069141, 6.5927379, 0.0740288 * 0.0740288, 0.1216529 * 0.1216529,
                20.072248 * 20.072248),
     {0},
     {0, 0}},
    /* J. R. DeVore, "Refractive indices of rutile and sphalerite", JOSA 41, 416-419 (1951);
     * TiO2/Devore-o.yml, Devore-e.yml (formula 4: n^2 = A + B / (L^2 - C)), room temperature,
     * valid 0.43-1.53 um (used down to 380 nm here, where the fit has no pole). n_o(589) =
     * 2.613, n_e = 2.909: positive, +0.30, about eight times calcite's walk-off angle. */
    {"rutile",
     {"TiO2", "TiO2-rutile"},
     "rutile (TiO2), positive uniaxial",
     "DeVore 1951, JOSA 41:416",
     DEVORE(5.913, 0.2441, 0.0803),
     DEVORE(7.197, 0.3322, 0.0843),
     {0},
     {0, 0}},
    /* M. J. Dodge, "Refractive properties of magnesium fluoride", Appl. Opt. 23, 1980-1985
     * (1984); MgF2/Dodge-o.yml, Dodge-e.yml (formula 1), 19 C, valid 0.2-7 um. n_o(589) =
     * 1.3777, n_e = 1.3895: positive, +0.012. */
    {"MgF2",
     {"magnesium-fluoride"},
     "magnesium fluoride, positive uniaxial",
     "Dodge 1984, Appl. Opt. 23:1980",
     SELLMEIER3(0.48755108, 0.39875031, 2.3120353, 0.04338408 * 0.04338408, 0.09461442 * 0.09461442,
                23.793604 * 23.793604),
     SELLMEIER3(0.41344023, 0.50497499, 2.4904862, 0.03684262 * 0.03684262, 0.09076162 * 0.09076162,
                23.771995 * 23.771995),
     {0},
     {0, 0}},
    /* Tourmaline (green elbaite) is a solid solution whose indices vary from stone to stone;
     * no dispersion fit is in the database. These are representative values inside the
     * gemmological ranges (n 1.614-1.666, birefringence 0.014-0.040, B-G dispersion 0.017):
     * n_o(589) = 1.640, n_e = 1.620, both Cauchy with B = 0.0052 um^2 (which gives the 0.017
     * between 430.8 and 686.7 nm). The absorption is illustrative, shaped after the polarised
     * spectra of green tourmaline (Fe2+ bands near 700 nm, charge transfer below 460 nm,
     * J.-M. Derochette's spectra): the ordinary ray absorbed strongly at every wavelength
     * (a 1 mm plate passes about 1 %, the tourmaline-tongs polariser), the extraordinary one
     * through a green window. Not a measurement: scenes that need one give their own. */
    {"tourmaline",
     {"elbaite"},
     "tourmaline (green elbaite), negative uniaxial, dichroic",
     "representative gemmological values; illustrative absorption",
     CAUCHY(1.6250, 0.0052),
     CAUCHY(1.6050, 0.0052),
     {.rows = 8,
      .lambda_nm = {400, 450, 500, 550, 600, 650, 700, 750},
      .o_per_mm = {5.0, 4.8, 4.5, 4.2, 4.5, 5.0, 5.5, 5.5},
      .e_per_mm = {0.9, 0.5, 0.15, 0.08, 0.15, 0.35, 0.6, 0.6}},
     {0, 0}},
};

#define NCATALOGUE ((int)(sizeof CATALOGUE / sizeof CATALOGUE[0]))

int crystal_count(void)
{
    return NCATALOGUE;
}

const crystal_t *crystal_get(int i)
{
    return i >= 0 && i < NCATALOGUE ? &CATALOGUE[i] : NULL;
}

const crystal_t *crystal_find(const char *name)
{
    if (!name)
        return NULL;
    for (int i = 0; i < NCATALOGUE; i++) {
        const crystal_t *c = &CATALOGUE[i];
        if (!strcasecmp(c->name, name))
            return c;
        for (int k = 0; k < CRYSTAL_MAX_ALIASES && c->aliases[k]; k++)
            if (!strcasecmp(c->aliases[k], name))
                return c;
    }
    return NULL;
}

const crystal_t *crystal_lookup(const char *name, err_t *err)
{
    const crystal_t *c = crystal_find(name);
    if (!c) {
        /* The known names from the catalogue itself, so the list cannot fall behind it. */
        char known[256] = "";
        size_t n = 0;
        for (int i = 0; i < NCATALOGUE && n < sizeof known; i++)
            n += (size_t)snprintf(known + n, sizeof known - n, "%s%s", i ? ", " : "",
                                  CATALOGUE[i].name);
        err_set(err, "unknown crystal '%s' (known: %s)", name ? name : "", known);
    }
    return c;
}

void crystal_absorption_eval(const crystal_absorption_t *a, double lambda_nm, double *o_per_mm,
                             double *e_per_mm)
{
    *o_per_mm = *e_per_mm = 0.0;
    if (!a || a->rows < 1)
        return;
    const int last = a->rows - 1;
    if (!(lambda_nm > a->lambda_nm[0])) {
        *o_per_mm = a->o_per_mm[0];
        *e_per_mm = a->e_per_mm[0];
        return;
    }
    if (lambda_nm >= a->lambda_nm[last]) {
        *o_per_mm = a->o_per_mm[last];
        *e_per_mm = a->e_per_mm[last];
        return;
    }
    int i = 0;
    while (i + 1 < last && lambda_nm >= a->lambda_nm[i + 1])
        i++;
    const double f = (lambda_nm - a->lambda_nm[i]) / (a->lambda_nm[i + 1] - a->lambda_nm[i]);
    *o_per_mm = a->o_per_mm[i] + f * (a->o_per_mm[i + 1] - a->o_per_mm[i]);
    *e_per_mm = a->e_per_mm[i] + f * (a->e_per_mm[i + 1] - a->e_per_mm[i]);
}

double crystal_rotary_power(const crystal_rotation_t *r, double lambda_nm)
{
    if (r->a_deg_um2_per_mm == 0.0)
        return 0.0;
    const double l = lambda_nm * 1e-3, d = l * l - r->lambda0_um2;
    return d > 0.0 ? r->a_deg_um2_per_mm / d : 0.0;
}
