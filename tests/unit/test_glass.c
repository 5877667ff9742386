/* glass: the catalogue against published datasheet indices and Abbe numbers and against the
 * coefficient table it was taken from (data/glasses_sellmeier.csv), its lookup rules (aliases,
 * pbrt-v4 names, case), and that every entry is physical over 360-830 nm. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h> /* after the four headers above, which it needs */

#include <ctype.h>
#include <math.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "dispersion.h"
#include "files_testutil.h"
#include "glass.h"
#include "numeric_testutil.h"

/* SCHOTT datasheet values (n_d to 5 decimals, v_d to 2), typed in from the SCHOTT optical
 * glass data sheets / Zemax catalogue 2017-01-20b as given in the SPECS "nd" and "Vd" fields
 * of refractiveindex.info-database data-nk/glass/schott/<glass>.yml (and the nd_cat, vd_cat
 * columns of data/glasses_sellmeier.csv). SF5, SF10, SF11 from SF5.yml, SF10.yml,
 * SF11.yml of the same database. */
typedef struct datasheet {
    const char *name;
    double nd, vd;
} datasheet_t;

static const datasheet_t SCHOTT[] = {
    {"N-BK7", 1.51680, 64.17},   {"N-SF11", 1.78472, 25.68}, {"N-LASF9", 1.85025, 32.17},
    {"F2", 1.62004, 36.37},      {"N-SF6", 1.80518, 25.36},  {"N-BAF10", 1.67003, 47.11},
    {"N-FK51A", 1.48656, 84.47}, {"LASF35", 2.02204, 29.06}, {"SF5", 1.67270, 32.21},
    {"SF10", 1.72825, 28.41},    {"SF11", 1.78472, 25.76},
};

/* Tolerances: the datasheet rounds n_d to 5 decimals (+-5e-6) and SCHOTT's Sellmeier fits
 * reproduce their own n_d to about 1e-6, so 1e-5 holds with margin. v_d is rounded to 2
 * decimals (+-0.005); a 1e-6 fit error in n_F - n_C (about 0.01-0.03) moves v_d by under 0.01
 * for these glasses, so 0.05 holds. */
#define ND_TOL 1e-5
#define VD_TOL 0.05

static void test_schott_datasheet(void **state)
{
    (void)state;
    for (size_t i = 0; i < sizeof SCHOTT / sizeof SCHOTT[0]; i++) {
        const glass_t *g = glass_find(SCHOTT[i].name);
        assert_non_null(g);
        assert_string_equal(g->name, SCHOTT[i].name);
        double nd = ior_eval(&g->ior, IOR_LAMBDA_D_NM);
        double vd;
        assert_true(ior_abbe_number(&g->ior, &vd));
        if (fabs(nd - SCHOTT[i].nd) > ND_TOL || fabs(vd - SCHOTT[i].vd) > VD_TOL)
            fail_msg("%s: n_d %.6f (datasheet %.5f), v_d %.3f (datasheet %.2f)", g->name, nd,
                     SCHOTT[i].nd, vd, SCHOTT[i].vd);
    }
}

/* SCHOTT N-BK7 datasheet: n_e (546.074 nm, mercury e line) = 1.51872. */
static void test_nbk7_e_line(void **state)
{
    (void)state;
    const glass_t *g = glass_find("N-BK7");
    assert_non_null(g);
    testutil_assert_near(ior_eval(&g->ior, IOR_LAMBDA_E_NM), 1.51872, ND_TOL);
}

/* Non-SCHOTT entries against handbook values (coarser, as those are quoted):
 * - water, 20 C, sodium D (589.29 nm): n = 1.33299 relative to air (CRC Handbook of Chemistry
 *   and Physics, "Index of refraction of water"); times n_air = 1.00027 (Ciddor 1996, 589 nm,
 *   20 C) gives the absolute 1.33335 that Daimon-Masumura fit. Tolerance 1e-4 covers the
 *   air-index correction and the fits' stated accuracy.
 * - diamond n_d = 2.4175 (handbook value, quoted 2.417-2.418): tolerance 5e-4.
 * - fused silica n_d = 1.45846 (Heraeus Suprasil / Corning 7980 datasheets 1.4585): 5e-5.
 * - CaF2 n_d = 1.43385 (Korth Kristalle / Hellma datasheets, 1.43384-1.43385): 5e-5.
 * - sapphire ordinary n_d = 1.7682 (Malitson 1962's table; datasheets n_o 1.768): 2e-4. */
static void test_other_materials(void **state)
{
    (void)state;
    const glass_t *w = glass_find("water");
    assert_non_null(w);
    assert_int_equal(w->ior.sellmeier.terms, 4);
    testutil_assert_near(ior_eval(&w->ior, 589.29), 1.33335, 1e-4);

    const glass_t *d = glass_find("diamond");
    assert_non_null(d);
    assert_int_equal(d->ior.sellmeier.terms, 2);
    testutil_assert_near(ior_eval(&d->ior, IOR_LAMBDA_D_NM), 2.4175, 5e-4);

    const glass_t *s = glass_find("fused silica");
    assert_non_null(s);
    testutil_assert_near(ior_eval(&s->ior, IOR_LAMBDA_D_NM), 1.45846, 5e-5);

    const glass_t *c = glass_find("CaF2");
    assert_non_null(c);
    assert_true(c->ior.sellmeier.a0 != 0.0); /* Li 1980's constant term is in use */
    testutil_assert_near(ior_eval(&c->ior, IOR_LAMBDA_D_NM), 1.43385, 5e-5);

    const glass_t *a = glass_find("sapphire");
    assert_non_null(a);
    testutil_assert_near(ior_eval(&a->ior, IOR_LAMBDA_D_NM), 1.7682, 2e-4);
}

static void expect_alias(const char *alias, const char *name)
{
    const glass_t *g = glass_find(alias);
    if (!g || strcmp(g->name, name) != 0)
        fail_msg("'%s' should find %s, found %s", alias, name, g ? g->name : "nothing");
}

/* pbrt-v4's named spectra (src/pbrt/util/spectrum.cpp): glass-BK7, -BAF10, -FK51A, -LASF9
 * are those SCHOTT glasses; glass-F5, -F10, -F11 are SCHOTT SF5, SF10, SF11. */
static void test_aliases_and_case(void **state)
{
    (void)state;
    expect_alias("glass-BK7", "N-BK7");
    expect_alias("glass-BAF10", "N-BAF10");
    expect_alias("glass-FK51A", "N-FK51A");
    expect_alias("glass-LASF9", "N-LASF9");
    expect_alias("glass-F5", "SF5");
    expect_alias("glass-F10", "SF10");
    expect_alias("glass-F11", "SF11");
    expect_alias("LaSF35", "LASF35");
    expect_alias("LaSF 35", "LASF35");
    expect_alias("lasf 35", "LASF35");
    expect_alias("n-bk7", "N-BK7");
    expect_alias("GLASS-bk7", "N-BK7");
    expect_alias("WATER", "water");
    expect_alias("sf11", "SF11");
    expect_alias("n-sf11", "N-SF11");

    assert_null(glass_find("N-BK"));
    assert_null(glass_find("N-BK77"));
    assert_null(glass_find(""));
    assert_null(glass_find(NULL));
    err_t err;
    assert_null(glass_lookup("unobtainium", &err));
    assert_string_equal(err.msg, "unknown glass 'unobtainium'");
}

/* Every material docs/core.md lists is in the catalogue. */
static void test_required_entries(void **state)
{
    (void)state;
    const char *required[] = {"N-BK7",   "N-SF11",  "N-LASF9",  "F2",   "N-SF6", "N-BAF10",
                              "N-FK51A", "LASF35",  "SF5",      "SF10", "SF11",  "fused-silica",
                              "water",   "diamond", "sapphire", "CaF2"};
    for (size_t i = 0; i < sizeof required / sizeof required[0]; i++)
        if (!glass_find(required[i]))
            fail_msg("catalogue lacks %s", required[i]);
}

static bool same_ignoring_case(const char *a, const char *b)
{
    for (; *a && *b; a++, b++)
        if (tolower((unsigned char)*a) != tolower((unsigned char)*b))
            return false;
    return *a == *b;
}

/* No name or alias of one entry may be spelled (ignoring case) like another entry's, or
 * lookup would be ambiguous; and every entry is physical over the CIE table's 360-830 nm
 * and dispersive. */
static void test_catalogue_consistent(void **state)
{
    (void)state;
    const char *names[256];
    int owner[256];
    int count = 0;
    for (int i = 0; i < glass_count(); i++) {
        const glass_t *g = glass_get(i);
        assert_non_null(g);
        assert_non_null(g->source);
        assert_non_null(g->description);
        assert_true(count + 1 + GLASS_MAX_ALIASES <= 256);
        owner[count] = i;
        names[count++] = g->name;
        for (int k = 0; k < GLASS_MAX_ALIASES && g->aliases[k]; k++) {
            owner[count] = i;
            names[count++] = g->aliases[k];
        }
        err_t err;
        if (ior_validate(&g->ior, g->name, 360.0, 830.0, &err) != 0)
            fail_msg("%s", err.msg);
        assert_true(ior_is_dispersive(&g->ior, 380.0, 720.0));
        /* Normal dispersion: n falls with wavelength across the visible for all of them. */
        assert_true(ior_eval(&g->ior, 400.0) > ior_eval(&g->ior, 700.0));
    }
    assert_null(glass_get(-1));
    assert_null(glass_get(glass_count()));
    for (int i = 0; i < count; i++)
        for (int j = i + 1; j < count; j++)
            if (owner[i] != owner[j] && same_ignoring_case(names[i], names[j]))
                fail_msg("'%s' and '%s' name different entries", names[i], names[j]);
}

/* data/glasses_sellmeier.csv (data/README.md) against the compiled catalogue: each row's
 * coefficients are the catalogue entry's, exactly (the same decimal strings, so the same
 * doubles), and its n_d, n_F, n_C recomputed from them (printed to 6 decimals) are what
 * ior_eval gives; every catalogue entry has its row. Two rows are other fits of materials
 * the catalogue takes from elsewhere (data/README.md) and are only checked to be physical. */
static const struct {
    const char *row, *entry; /* entry NULL: a fit the catalogue does not use */
} DATA_ROWS[] = {
    {"N-BK7", "N-BK7"},
    {"N-SF11", "N-SF11"},
    {"N-LASF9", "N-LASF9"},
    {"F2", "F2"},
    {"N-SF6", "N-SF6"},
    {"N-BAF10", "N-BAF10"},
    {"LASF35", "LASF35"},
    {"N-FK51A", "N-FK51A"},
    {"FusedSilica_Malitson1965", "fused-silica"},
    {"Water_Daimon2007_20C", "water"},
    {"Diamond_Peter1923", "diamond"},
    {"Sapphire_o_Malitson1962", "sapphire"},
    {"Sapphire_o_MalitsonDodge1972", NULL},
    {"CaF2_Malitson1963", NULL},
    {"CaF2_Li1980", "CaF2"},
    {"SF5", "SF5"},
    {"SF10", "SF10"},
    {"SF11", "SF11"},
};
#define DATA_ROW_COUNT (sizeof DATA_ROWS / sizeof DATA_ROWS[0])

/* Columns of the file: material, A0, B1, B2, B3, C1_um2, C2_um2, C3_um2, B4, C4_um2, nd_cat,
 * vd_cat, nd_calc, nF_calc, nC_calc, vd_calc, source_file, notes. */
enum {
    COL_NAME,
    COL_A0,
    COL_B1,
    COL_C1 = 5,
    COL_B4 = 8,
    COL_C4,
    COL_ND_CALC = 12,
    COL_NF_CALC,
    COL_NC_CALC,
    COL_COUNT = 18
};

/* Splits one CSV line in place at commas outside double quotes (quotes removed). */
static int split_csv(char *line, char **field, int max)
{
    int n = 0;
    char *out = line, *start = line;
    bool quoted = false;
    for (char *p = line;; p++) {
        if (*p == '"') {
            quoted = !quoted;
            continue;
        }
        if ((*p == ',' && !quoted) || *p == '\0' || *p == '\n' || *p == '\r') {
            char end = *p;
            *out++ = '\0';
            if (n < max)
                field[n] = start;
            n++;
            if (end != ',')
                return n;
            start = out;
            continue;
        }
        *out++ = *p;
    }
}

static double number(const char *s, const char *row, const char *column)
{
    char *end;
    double v = strtod(s, &end);
    if (end == s || *end != '\0')
        fail_msg("%s: column %s: '%s' is not a number", row, column, s);
    return v;
}

static void test_catalogue_matches_data(void **state)
{
    (void)state;
    const char *path = testutil_source_path("data/glasses_sellmeier.csv");
    FILE *f = fopen(path, "r");
    if (!f)
        fail_msg("cannot open %s", path);
    bool seen_row[DATA_ROW_COUNT] = {false};
    bool seen_entry[256] = {false};
    assert_true(glass_count() <= 256);
    char line[2048];
    while (fgets(line, sizeof line, f)) {
        if (line[0] == '#' || line[0] == '\n' || !strncmp(line, "material,", 9))
            continue;
        char *col[COL_COUNT];
        int n = split_csv(line, col, COL_COUNT);
        if (n != COL_COUNT)
            fail_msg("%s: a row of %d columns, expected %d", path, n, COL_COUNT);
        size_t r = 0;
        while (r < DATA_ROW_COUNT && strcmp(DATA_ROWS[r].row, col[COL_NAME]) != 0)
            r++;
        if (r == DATA_ROW_COUNT)
            fail_msg("%s: row '%s' is not known to this test", path, col[COL_NAME]);
        assert_false(seen_row[r]);
        seen_row[r] = true;

        /* The row as a model: B1..B3 with C1..C3, then B4 with C4; empty cells end the terms. */
        double b[4], c[4];
        int terms = 0;
        for (int k = 0; k < 4; k++) {
            const char *bs = col[k < 3 ? COL_B1 + k : COL_B4];
            const char *cs = col[k < 3 ? COL_C1 + k : COL_C4];
            if (!*bs && !*cs)
                break;
            b[k] = number(bs, col[COL_NAME], "B");
            c[k] = number(cs, col[COL_NAME], "C");
            terms++;
        }
        double a0 = number(col[COL_A0], col[COL_NAME], "A0");
        ior_model_t model;
        err_t err;
        assert_int_equal(ior_sellmeier(&model, a0, b, c, terms, &err), 0);
        if (ior_validate(&model, col[COL_NAME], 360.0, 830.0, &err) != 0)
            fail_msg("%s", err.msg);
        const double lines_nm[3] = {IOR_LAMBDA_D_NM, IOR_LAMBDA_F_NM, IOR_LAMBDA_C_NM};
        for (int k = 0; k < 3; k++) {
            double calc = number(col[COL_ND_CALC + k], col[COL_NAME], "n_calc");
            if (!(fabs(ior_eval(&model, lines_nm[k]) - calc) <= 5.1e-7))
                fail_msg("%s: n(%.4f nm) = %.7f, the file's recomputed %.6f", col[COL_NAME],
                         lines_nm[k], ior_eval(&model, lines_nm[k]), calc);
        }
        if (!DATA_ROWS[r].entry)
            continue;

        const glass_t *g = glass_find(DATA_ROWS[r].entry);
        assert_non_null(g);
        assert_string_equal(g->name, DATA_ROWS[r].entry);
        for (int i = 0; i < glass_count(); i++)
            if (glass_get(i) == g) {
                assert_false(seen_entry[i]);
                seen_entry[i] = true;
            }
        const ior_sellmeier_coefs_t *s = &g->ior.sellmeier;
        assert_int_equal(g->ior.kind, IOR_SELLMEIER);
        if (s->terms != terms || s->a0 != a0)
            fail_msg("%s: %d terms, A0 %.17g; %s has %d terms, A0 %.17g", g->name, s->terms, s->a0,
                     col[COL_NAME], terms, a0);
        for (int k = 0; k < terms; k++)
            if (s->b[k] != b[k] || s->c_um2[k] != c[k])
                fail_msg("%s term %d: B %.17g C %.17g; %s has B %.17g C %.17g", g->name, k + 1,
                         s->b[k], s->c_um2[k], col[COL_NAME], b[k], c[k]);
    }
    fclose(f);
    for (size_t r = 0; r < DATA_ROW_COUNT; r++)
        if (!seen_row[r])
            fail_msg("%s has no row '%s'", path, DATA_ROWS[r].row);
    for (int i = 0; i < glass_count(); i++)
        if (!seen_entry[i])
            fail_msg("catalogue entry %s has no row in %s", glass_get(i)->name, path);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_schott_datasheet),       cmocka_unit_test(test_nbk7_e_line),
        cmocka_unit_test(test_other_materials),        cmocka_unit_test(test_aliases_and_case),
        cmocka_unit_test(test_required_entries),       cmocka_unit_test(test_catalogue_consistent),
        cmocka_unit_test(test_catalogue_matches_data),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
