#include "glass.h"

#include <stddef.h>
#include <strings.h> /* strcasecmp: names match ignoring case */

/* A three-term Sellmeier with no constant term: the SCHOTT catalogue's form. */
#define SELLMEIER3(B1, B2, B3, C1, C2, C3)                                                         \
    {                                                                                              \
        .kind = IOR_SELLMEIER, .sellmeier = {                                                      \
            .a0 = 0.0,                                                                             \
            .terms = 3,                                                                            \
            .b = {B1, B2, B3},                                                                     \
            .c_um2 = {C1, C2, C3}                                                                  \
        }                                                                                          \
    }

/* Coefficients: C in um^2, wavelengths in um. Unless said otherwise they come from the
 * refractiveindex.info database (polyanskiy/refractiveindex.info-database,
 * database/data-nk/...), which copies the SCHOTT Zemax catalogue 2017-01-20b for the SCHOTT
 * glasses (20 C, indices relative to air) and the cited papers for the crystals and water.
 * Every entry but SF5, SF10 and SF11 was taken from data/glasses_sellmeier.csv, the table of
 * these coefficients read from that database with each row's source file (data/README.md):
 * the digits are the table's, down to the C values it squared from the database's C in um.
 * SF5, SF10 and SF11 were read from glass/schott/SF5.yml, SF10.yml, SF11.yml of the same
 * database and have since been added to the table. tests/unit/test_glass.c checks every entry against the table,
 * coefficient for coefficient, and the SCHOTT glasses' n_d / v_d (noted for each) against the
 * datasheets. */
static const glass_t CATALOGUE[] = {
    /* SCHOTT N-BK7, glass/schott/N-BK7.yml; datasheet n_d 1.51680, v_d 64.17. pbrt-v4's
     * "glass-BK7"; the lead-containing predecessor BK7 had the same catalogue n_d and v_d. */
    {"N-BK7",
     {"BK7", "glass-BK7"},
     "SCHOTT borosilicate crown",
     "SCHOTT 2017",
     SELLMEIER3(1.03961212, 0.231792344, 1.01046945, 0.00600069867, 0.0200179144, 103.560653)},
    /* SCHOTT N-SF11, glass/schott/N-SF11.yml; n_d 1.78472, v_d 25.68. */
    {"N-SF11",
     {NULL},
     "SCHOTT dense flint",
     "SCHOTT 2017",
     SELLMEIER3(1.73759695, 0.313747346, 1.89878101, 0.013188707, 0.0623068142, 155.23629)},
    /* SCHOTT N-LASF9, glass/schott/N-LASF9.yml; n_d 1.85025, v_d 32.17; pbrt-v4 "glass-LASF9". */
    {"N-LASF9",
     {"glass-LASF9"},
     "SCHOTT lanthanum dense flint",
     "SCHOTT 2017",
     SELLMEIER3(2.00029547, 0.298926886, 1.80691843, 0.0121426017, 0.0538736236, 156.530829)},
    /* SCHOTT F2, glass/schott/F2.yml; n_d 1.62004, v_d 36.37. */
    {"F2",
     {NULL},
     "SCHOTT flint",
     "SCHOTT 2017",
     SELLMEIER3(1.34533359, 0.209073176, 0.937357162, 0.00997743871, 0.0470450767, 111.886764)},
    /* SCHOTT N-SF6, glass/schott/N-SF6.yml; n_d 1.80518, v_d 25.36. */
    {"N-SF6",
     {NULL},
     "SCHOTT dense flint",
     "SCHOTT 2017",
     SELLMEIER3(1.77931763, 0.338149866, 2.08734474, 0.0133714182, 0.0617533621, 174.01759)},
    /* SCHOTT N-BAF10, glass/schott/N-BAF10.yml; n_d 1.67003, v_d 47.11; pbrt-v4 "glass-BAF10". */
    {"N-BAF10",
     {"glass-BAF10"},
     "SCHOTT barium light flint",
     "SCHOTT 2017",
     SELLMEIER3(1.5851495, 0.143559385, 1.08521269, 0.00926681282, 0.0424489805, 105.613573)},
    /* SCHOTT N-FK51A, glass/schott/N-FK51A.yml; n_d 1.48656, v_d 84.47; pbrt-v4 "glass-FK51A". */
    {"N-FK51A",
     {"glass-FK51A"},
     "SCHOTT fluor crown",
     "SCHOTT 2017",
     SELLMEIER3(0.971247817, 0.216901417, 0.904651666, 0.00472301995, 0.0153575612, 168.68133)},
    /* SCHOTT LASF35, glass/schott/LASF35.yml; n_d 2.02204, v_d 29.06. The thesis's "LaSF 35";
     * SCHOTT makes no N-LASF35. */
    {"LASF35",
     {"LaSF35", "LaSF 35"},
     "SCHOTT lanthanum dense flint",
     "SCHOTT 2017",
     SELLMEIER3(2.45505861, 0.453006077, 2.3851308, 0.0135670404, 0.054580302, 167.904715)},
    /* SCHOTT SF5, glass/schott/SF5.yml (SCHOTT Zemax catalogue 2017-01-20b); n_d 1.67270,
     * v_d 32.21. pbrt-v4's "glass-F5" is tabulated from this glass. */
    {"SF5",
     {"glass-F5"},
     "SCHOTT dense flint",
     "SCHOTT 2017",
     SELLMEIER3(1.46141885, 0.247713019, 0.949995832, 0.0111826126, 0.0508594669, 112.041888)},
    /* SCHOTT SF10, glass/schott/SF10.yml (SCHOTT Zemax catalogue 2017-01-20b); n_d 1.72825,
     * v_d 28.41. pbrt-v4's "glass-F10". */
    {"SF10",
     {"glass-F10"},
     "SCHOTT dense flint",
     "SCHOTT 2017",
     SELLMEIER3(1.61625977, 0.259229334, 1.07762317, 0.0127534559, 0.0581983954, 116.60768)},
    /* SCHOTT SF11, glass/schott/SF11.yml (SCHOTT Zemax catalogue 2017-01-20b); n_d 1.78472,
     * v_d 25.76. pbrt-v4's "glass-F11". */
    {"SF11",
     {"glass-F11"},
     "SCHOTT dense flint",
     "SCHOTT 2017",
     SELLMEIER3(1.73848403, 0.311168974, 1.17490871, 0.0136068604, 0.0615960463, 121.922711)},
    /* Fused silica: I. H. Malitson, "Interspecimen comparison of the refractive index of fused
     * silica", JOSA 55, 1205 (1965), 20 C; main/SiO2/Malitson.yml (C given there in um, squared
     * here). Valid 0.21-6.7 um. */
    {"fused-silica",
     {"fused silica", "FusedSilica", "SiO2"},
     "amorphous SiO2",
     "Malitson 1965",
     SELLMEIER3(0.6961663, 0.4079426, 0.8974794, 0.004679148258, 0.01351206307, 97.93400254)},
    /* Water at 20 C: M. Daimon and A. Masumura, "Measurement of the refractive index of
     * distilled water from the near-infrared region to the ultraviolet region", Appl. Opt. 46,
     * 3811 (2007), 4-term fit; main/H2O/Daimon-20.0C.yml. An absolute index (vacuum
     * wavelengths), unlike SCHOTT's air-relative ones: the 3e-4 difference is invisible. */
    {"water",
     {"H2O"},
     "liquid water, 20 C",
     "Daimon-Masumura 2007",
     {.kind = IOR_SELLMEIER,
      .sellmeier = {.a0 = 0.0,
                    .terms = 4,
                    .b = {0.5684027565, 0.1726177391, 0.02086189578, 0.1130748688},
                    .c_um2 = {0.005101829712, 0.01821153936, 0.02620722293, 10.69792721}}}},
    /* Diamond: H. Peter, "Ueber Brechungsindizes und Absorptionskonstanten des Diamanten
     * zwischen 644 und 226 mu", Z. Phys. 15, 358 (1923), 2-term fit; main/C/Peter.yml.
     * Fitted over 0.226-0.76 um: above 760 nm it is an extrapolation (smooth, no pole). */
    {"diamond",
     {NULL},
     "diamond (C)",
     "Peter 1923",
     {.kind = IOR_SELLMEIER,
      .sellmeier = {.a0 = 0.0, .terms = 2, .b = {0.3306, 4.3356}, .c_um2 = {0.030625, 0.011236}}}},
    /* Sapphire, ordinary ray: I. H. Malitson, "Refraction and dispersion of synthetic
     * sapphire", JOSA 52, 1377 (1962), 24 C; main/Al2O3/Malitson.yml. */
    {"sapphire",
     {"sapphire-o", "Al2O3"},
     "sapphire (Al2O3), ordinary ray",
     "Malitson 1962",
     SELLMEIER3(1.023798, 1.058264, 5.280792, 0.003775882512, 0.01225442358, 321.3615534)},
    /* Calcium fluoride: H. H. Li, "Refractive index of alkaline earth halides and its
     * wavelength and temperature derivatives", J. Phys. Chem. Ref. Data 9, 161 (1980), 20 C;
     * main/CaF2/Li.yml. Chosen over Malitson 1963 (24 C) for its 20 C reference temperature,
     * matching the SCHOTT data; it has a constant term A0 = 0.33973. */
    {"CaF2",
     {"calcium fluoride", "fluorite"},
     "calcium fluoride crystal",
     "Li 1980",
     {.kind = IOR_SELLMEIER,
      .sellmeier = {.a0 = 0.33973,
                    .terms = 3,
                    .b = {0.69913, 0.11994, 4.35181},
                    .c_um2 = {0.0087871876, 448.5924, 1479.1716}}}},
};

#define CATALOGUE_SIZE ((int)(sizeof CATALOGUE / sizeof CATALOGUE[0]))

int glass_count(void)
{
    return CATALOGUE_SIZE;
}

const glass_t *glass_get(int i)
{
    return i >= 0 && i < CATALOGUE_SIZE ? &CATALOGUE[i] : NULL;
}

const glass_t *glass_find(const char *name)
{
    if (!name)
        return NULL;
    for (int i = 0; i < CATALOGUE_SIZE; i++) {
        const glass_t *g = &CATALOGUE[i];
        if (!strcasecmp(name, g->name))
            return g;
        for (int k = 0; k < GLASS_MAX_ALIASES && g->aliases[k]; k++)
            if (!strcasecmp(name, g->aliases[k]))
                return g;
    }
    return NULL;
}

const glass_t *glass_lookup(const char *name, err_t *err)
{
    const glass_t *g = glass_find(name);
    if (!g)
        err_set(err, "unknown glass '%s'", name ? name : "(null)");
    return g;
}
