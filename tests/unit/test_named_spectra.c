/* Named spectra, spectrum files and tabulated eta (issue 14, "Spectra"): pbrt-v4's named
 * spectra against its published table numbers (mmp/pbrt-v4 spectrum.cpp @033e6d99, copied in
 * data/named_spectra/), stdillum-D65 against the CIE D65 of data/d65_5nm.csv, pbrt-v4 spectrum
 * files good and bad (each bad one names its line), IOR_TABULATED's interpolation, clamping and
 * dispersion, scenes that use them, files reached through Include, confinement and bundling.
 * Runs with the working directory tests/. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "cie.h"
#include "dispersion.h"
#include "files_testutil.h"
#include "named_spectra.h"
#include "pbrt_parser.h"
#include "scene.h"
#include "scene_load.h"
#include "spectrum.h"

static void write_text(const char *path, const char *text)
{
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fputs(text, f);
    assert_int_equal(fclose(f), 0);
}

static double named_at(const char *name, double lambda)
{
    const named_spectrum_t *e = named_spectra_find(name);
    assert_non_null(e);
    err_t err;
    spectrum_t *s = named_spectrum_new(e, &err);
    assert_non_null(s);
    double v = spectrum_eval(s, lambda);
    spectrum_destroy(&s);
    return v;
}

/* Numbers from pbrt-v4's tables (Au_eta, Cu_k, GlassBK7_eta, MgO_eta), interpolated by hand. */
static void test_table_values(void **state)
{
    (void)state;
    /* Au_eta: 495.936707 -> 0.916, 506.057861 -> 0.7545: at 500 nm */
    double t = (500.0 - 495.936707) / (506.057861 - 495.936707);
    assert_float_equal(named_at("metal-Au-eta", 500.0), 0.916 + t * (0.7545 - 0.916), 1e-12);
    assert_float_equal(named_at("metal-Au-k", 298.75705), 1.920375, 1e-12);
    assert_float_equal(named_at("metal-Cu-k", 885.601257), 5.717, 1e-12);
    assert_float_equal(named_at("glass-BK7", 586.0), 1.516865556749, 1e-12);
    /* held outside the table (pbrt-v4 would give 0 there; see docs/scene-format.md) */
    assert_float_equal(named_at("glass-BK7", 1000.0), 1.5087426727363, 1e-12);
    assert_float_equal(named_at("metal-MgO-eta", 800.0), 1.72872, 1e-12);
    /* illuminants: 0 outside the table, luminance 1 (pbrt-v4 normalises them) */
    assert_float_equal(named_at("stdillum-F1", 370.0), 0.0, 0.0);
    assert_float_equal(named_at("stdillum-F1", 790.0), 0.0, 0.0);
    err_t err;
    spectrum_t *f4 = named_spectrum_new(named_spectra_find("stdillum-F4"), &err);
    assert_float_equal(spectrum_photometric(f4) / CIE_Y_INTEGRAL, 1.0, 1e-12);
    /* F4's ratio at two tabulated wavelengths is the table's: 435 nm 30.280001, 545 nm 22.59 */
    assert_float_equal(spectrum_eval(f4, 435.0) / spectrum_eval(f4, 545.0), 30.280001 / 22.59, 1e-12);
    spectrum_destroy(&f4);
}

static void test_every_name(void **state)
{
    (void)state;
    static const char *NAMES[] = {
        "glass-BK7", "glass-BAF10", "glass-FK51A", "glass-LASF9", "glass-F5", "glass-F10",
        "glass-F11", "metal-Ag-eta", "metal-Ag-k", "metal-Al-eta", "metal-Al-k", "metal-Au-eta",
        "metal-Au-k", "metal-Cu-eta", "metal-Cu-k", "metal-MgO-eta", "metal-MgO-k",
        "metal-TiO2-eta", "metal-TiO2-k", "stdillum-A", "stdillum-D50", "stdillum-D65",
        "stdillum-F1", "stdillum-F2", "stdillum-F3", "stdillum-F4", "stdillum-F5", "stdillum-F6",
        "stdillum-F7", "stdillum-F8", "stdillum-F9", "stdillum-F10", "stdillum-F11",
        "stdillum-F12", "illum-acesD60"};
    /* and 17 cameras' r, g, b curves (test_sensor checks them) after them */
    assert_int_equal(named_spectra_count(), (int)(sizeof NAMES / sizeof NAMES[0]) + 17 * 3);
    for (int i = 0; i < named_spectra_count(); i++)
        assert_true((i < (int)(sizeof NAMES / sizeof NAMES[0])) ==
                    (named_spectra_get(i)->kind != NAMED_SPECTRUM_SENSOR));
    for (size_t i = 0; i < sizeof NAMES / sizeof NAMES[0]; i++) {
        const named_spectrum_t *e = named_spectra_find(NAMES[i]);
        assert_non_null(e);
        err_t err;
        spectrum_t *s = named_spectrum_new(e, &err);
        assert_non_null(s);
        assert_true(isfinite(spectrum_eval(s, 550.0)));
        spectrum_destroy(&s);
    }
    assert_null(named_spectra_find("glass-bk7")); /* exact, as pbrt-v4 */
    assert_null(named_spectra_find("metal-CuZn-eta")); /* not in the copied pbrt-v4 */
    char buf[2048];
    assert_non_null(strstr(named_spectra_list(buf, sizeof buf), "stdillum-F12"));
    assert_non_null(strstr(named_spectra_list(buf, 40), "..."));
}

/* pbrt-v4's D65 table equals the CIE D65 of data/d65_5nm.csv (to its float printing), and so
 * does prismfarm's spectrum_new_cie_d65, which stdillum-D65 resolves to. */
static void test_d65(void **state)
{
    (void)state;
    FILE *f = fopen(testutil_source_path("data/d65_5nm.csv"), "r");
    assert_non_null(f);
    const named_spectrum_t *e = named_spectra_find("stdillum-D65");
    err_t err;
    spectrum_t *cie = spectrum_new_cie_d65(&err);
    char line[256];
    int rows = 0;
    while (fgets(line, sizeof line, f)) {
        double l, v;
        if (sscanf(line, "%lf,%lf", &l, &v) != 2)
            continue;
        size_t i = (size_t)((l - 300.0) / 5.0 + 0.5);
        assert_float_equal(e->lambda[i], l, 0.0);
        assert_float_equal(e->value[i], v, 1e-7 * v + 1e-9);
        assert_float_equal(spectrum_eval(cie, l), v, 1e-9 * v);
        rows++;
    }
    fclose(f);
    assert_int_equal(rows, 107);
    spectrum_destroy(&cie);
}

static void test_ior_tabulated(void **state)
{
    (void)state;
    static const double L[] = {400, 500, 700}, N[] = {1.53, 1.52, 1.51};
    ior_model_t m;
    err_t err;
    assert_int_equal(ior_tabulated(&m, L, N, 3, &err), 0);
    assert_int_equal(m.kind, IOR_TABULATED);
    assert_string_equal(ior_kind_name(m.kind), "tabulated");
    assert_float_equal(ior_eval(&m, 450), 1.525, 1e-12);
    assert_float_equal(ior_eval(&m, 600), 1.515, 1e-12);
    assert_float_equal(ior_eval(&m, 350), 1.53, 0.0); /* clamped */
    assert_float_equal(ior_eval(&m, 900), 1.51, 0.0);
    assert_true(ior_is_dispersive(&m, 380, 720));
    assert_false(ior_is_dispersive(&m, 710, 830)); /* flat beyond the table */
    assert_int_equal(ior_validate(&m, "t", 380, 720, &err), 0);
    /* a bump between the 65 samples is still seen: the knots are checked */
    static const double L2[] = {500, 500.001, 500.002}, N2[] = {1.5, 1.6, 1.5};
    assert_int_equal(ior_tabulated(&m, L2, N2, 3, &err), 0);
    assert_true(ior_is_dispersive(&m, 380, 720));
    static const double N3[] = {1.5, -0.1, 1.5};
    assert_int_equal(ior_tabulated(&m, L2, N3, 3, &err), 0);
    assert_int_equal(ior_validate(&m, "neg", 380, 720, &err), -1);
    assert_non_null(strstr(err.msg, "tabulated n = -0.1"));
    static const double Lbad[] = {400, 400};
    assert_int_equal(ior_tabulated(&m, Lbad, N, 2, &err), -1);
    assert_non_null(strstr(err.msg, "pair 2"));
    static const double one[] = {500}, n1[] = {1.4};
    assert_int_equal(ior_tabulated(&m, one, n1, 1, &err), 0);
    assert_false(ior_is_dispersive(&m, 380, 720));
}

/* Loads scene text written as DIR/main.pbrt. */
static scene_t *load_text(const char *dir, const char *text, bool confined, err_t *err)
{
    const char *main = testutil_path_in(dir, "main.pbrt");
    write_text(main, text);
    return confined ? scene_load_file_confined(main, dir, NULL, err) : scene_load_file(main, NULL, err);
}

static const material_t *last_material(const scene_t *sc)
{
    assert_true(sc->nmaterials > 0);
    return &sc->materials[sc->nmaterials - 1];
}

static void test_scene_eta(void **state)
{
    (void)state;
    const char *dir = testutil_scratch_dir();
    err_t err;
    scene_t *sc = load_text(dir, "WorldBegin\nMaterial \"dielectric\" \"spectrum eta\" \"glass-BK7\"\nShape \"sphere\"\n", false, &err);
    assert_non_null(sc);
    const material_t *m = last_material(sc);
    assert_int_equal(m->ior.kind, IOR_TABULATED);
    assert_true(m->dispersive);
    assert_float_equal(ior_eval(&m->ior, 586.0), 1.516865556749, 1e-12);
    scene_destroy(&sc);

    sc = load_text(dir, "WorldBegin\nMaterial \"dielectric\" \"spectrum eta\" [400 1.53 700 1.51]\nShape \"sphere\"\n", false, &err);
    assert_non_null(sc);
    m = last_material(sc);
    assert_int_equal(m->ior.kind, IOR_TABULATED);
    assert_true(m->dispersive);
    assert_float_equal(ior_eval(&m->ior, 550.0), 1.52, 1e-12);
    scene_destroy(&sc);

    /* prismfarm's catalogue names still work */
    sc = load_text(dir, "WorldBegin\nMaterial \"dielectric\" \"spectrum eta\" \"N-SF11\"\nShape \"sphere\"\n", false, &err);
    assert_non_null(sc);
    assert_int_equal(last_material(sc)->ior.kind, IOR_SELLMEIER);
    scene_destroy(&sc);

    sc = load_text(dir, "WorldBegin\nMaterial \"dielectric\" \"spectrum eta\" \"stdillum-F1\"\nShape \"sphere\"\n", false, &err);
    assert_null(sc);
    assert_non_null(strstr(err.msg, "main.pbrt:2:23: material"));
    assert_non_null(strstr(err.msg, "is an illuminant"));

    sc = load_text(dir, "WorldBegin\nMaterial \"dielectric\" \"spectrum eta\" \"glass-XYZ\"\nShape \"sphere\"\n", false, &err);
    assert_null(sc);
    assert_non_null(strstr(err.msg, "\"glass-XYZ\" is neither a named spectrum, a glass of the catalogue"));
    assert_non_null(strstr(err.msg, "glass-BK7"));
}

static void test_scene_conductor(void **state)
{
    (void)state;
    const char *dir = testutil_scratch_dir();
    err_t err;
    scene_t *sc = load_text(dir, "WorldBegin\nMaterial \"conductor\" \"spectrum eta\" \"metal-Au-eta\" \"spectrum k\" \"metal-Au-k\"\nShape \"sphere\"\n", false, &err);
    if (!sc)
        fail_msg("%s", err.msg);
    const material_t *m = last_material(sc);
    assert_float_equal(spectrum_eval(m->eta, 298.75705), 1.795, 1e-12);
    assert_float_equal(spectrum_eval(m->k, 885.601257), 5.88, 1e-12);
    scene_destroy(&sc);
    /* the bare conductor: pbrt-v4's defaults metal-Cu-eta and metal-Cu-k */
    sc = load_text(dir, "WorldBegin\nMaterial \"conductor\"\nShape \"sphere\"\n", false, &err);
    if (!sc)
        fail_msg("%s", err.msg);
    assert_float_equal(spectrum_eval(last_material(sc)->k, 298.75705), 1.662125, 1e-12);
    scene_destroy(&sc);
    sc = load_text(dir, "WorldBegin\nMaterial \"conductor\" \"spectrum eta\" \"nosuch\" \"spectrum k\" \"metal-Au-k\"\nShape \"sphere\"\n", false, &err);
    assert_null(sc);
    assert_non_null(strstr(err.msg, "main.pbrt:2:22: \"nosuch\" is neither a named spectrum nor a spectrum file (looked for"));
}

/* A spectrum file: read, resolved against the file that names it, and listed for bundling. */
static void test_spd_files(void **state)
{
    (void)state;
    const char *dir = testutil_scratch_dir();
    char sub[512], spds[512];
    snprintf(sub, sizeof sub, "%s/sub", dir);
    snprintf(spds, sizeof spds, "%s/sub/spds", dir);
    mkdir(sub, 0755);
    mkdir(spds, 0755);
    write_text(testutil_path_in(spds, "Au.eta.spd"), "# gold\n400 0.5, 500 0.6\n\n600 0.7e0 # end\n");
    write_text(testutil_path_in(sub, "mat.pbrt"),
               "Material \"conductor\" \"spectrum eta\" \"spds/Au.eta.spd\" \"spectrum k\" \"metal-Au-k\"\n");
    err_t err;
    const char *main = testutil_path_in(dir, "main.pbrt");
    write_text(main, "WorldBegin\nInclude \"sub/mat.pbrt\"\nShape \"sphere\"\n");
    scene_desc_t *d = pbrt_parse_file(main, &err);
    if (!d)
        fail_msg("%s", err.msg);
    /* cli/scene_bundle.c bundles every file of desc->files but the main one */
    bool listed = false;
    for (size_t i = 0; i < d->nfiles; i++)
        if (d->files[i].kind == SCENE_FILE_SPECTRUM) {
            assert_string_equal(d->files[i].relative, "sub/spds/Au.eta.spd");
            listed = true;
        }
    assert_true(listed);
    scene_desc_destroy(&d);
    scene_t *sc = scene_load_file_confined(main, dir, NULL, &err);
    if (!sc)
        fail_msg("%s", err.msg);
    assert_float_equal(spectrum_eval(last_material(sc)->eta, 550.0), 0.65, 1e-12);
    scene_destroy(&sc);

}

static void expect_spd_error(const char *spd, const char *want)
{
    const char *dir = testutil_scratch_dir();
    write_text(testutil_path_in(dir, "bad.spd"), spd);
    err_t err;
    scene_t *sc = load_text(dir, "WorldBegin\nLightSource \"point\" \"spectrum I\" \"bad.spd\"\n", false, &err);
    assert_null(sc);
    if (!strstr(err.msg, want))
        fail_msg("got: %s\nwant: %s", err.msg, want);
}

static void test_spd_errors(void **state)
{
    (void)state;
    expect_spd_error("400 1\n500 2\n600\n", "main.pbrt:2:21: spectrum file");
    expect_spd_error("400 1\n500 2\n600\n", "holds 5 numbers, an odd count: it needs (wavelength, value) pairs (the last number is on line 3)");
    expect_spd_error("400 1\n# c\n390 2\n", "line 3: wavelength 390 nm does not follow 400 nm (line 1): wavelengths must increase");
    expect_spd_error("400 1\n500 abc\n", "line 2: unexpected text \"abc\"");
    expect_spd_error("400 1\n500 1.2.3\n", "line 2: \"1.2.3\" is not a finite number");
    expect_spd_error("# only a comment\n", "holds no numbers");
    const char *dir = testutil_scratch_dir();
    err_t err;
    scene_t *sc = load_text(dir, "WorldBegin\nLightSource \"point\" \"spectrum I\" \"spds/none.spd\"\n", false, &err);
    assert_null(sc);
    assert_non_null(strstr(err.msg, "main.pbrt:2:21: \"spds/none.spd\" is not a named spectrum, and no spectrum file is there (looked for"));
}

/* On the farm a spectrum file outside the scene's folder is refused like any other file. */
static void test_spd_confined(void **state)
{
    (void)state;
    const char *dir = testutil_scratch_dir();
    err_t err;
    scene_t *sc = load_text(dir, "WorldBegin\nLightSource \"point\" \"spectrum I\" \"../../etc/passwd\"\n", true, &err);
    assert_null(sc);
    assert_non_null(strstr(err.msg, "main.pbrt:2:21: \"../../etc/passwd\" is outside the scene's folder"));
    sc = load_text(dir, "WorldBegin\nLightSource \"point\" \"spectrum I\" \"/etc/hostname\"\n", true, &err);
    assert_null(sc);
    assert_non_null(strstr(err.msg, "is outside the scene's folder"));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_table_values),  cmocka_unit_test(test_every_name),
        cmocka_unit_test(test_d65),           cmocka_unit_test(test_ior_tabulated),
        cmocka_unit_test(test_scene_eta),     cmocka_unit_test(test_scene_conductor),
        cmocka_unit_test(test_spd_files),     cmocka_unit_test(test_spd_errors),
        cmocka_unit_test(test_spd_confined),
    };
    return cmocka_run_group_tests(tests, testutil_scratch_setup, testutil_scratch_teardown);
}
