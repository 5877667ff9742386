/* Tests for pbrt_upgrade (pbrt-v4's `pbrt --upgrade` rules, parser.cpp): a pbrt-v3 file
 * (tests/data/scenes/v3/old.pbrt) upgraded parses and loads, each construct becomes what
 * pbrt-v4's upgrade writes (uber with Ks becomes coateddiffuse with its index as eta, plastic
 * with a black Ks diffuse, mirror a smooth silver conductor, mix's pair reversed into
 * "materials", Film scale 1.5 iso 150, a gaussian's alpha 2 sigma 1/sqrt(2 alpha) = 0.5, ...),
 * each rewrite is listed with its file:line, a pbrt-v4 file comes out byte for byte, and what
 * pbrt-v4 refuses to upgrade is refused with its line. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "files.h"
#include "pbrt_parser.h"
#include "pbrt_upgrade.h"
#include "warnings.h"

static char *upgrade_file(const char *path, warnings_t *w, size_t *len)
{
    err_t err = {{0}};
    uint8_t *data;
    size_t size;
    if (files_read(path, 1 << 24, &data, &size, &err))
        fail_msg("%s", err.msg);
    char *out = pbrt_upgrade_text(path, (const char *)data, size, w, len, &err);
    if (!out)
        fail_msg("upgrade: %s", err.msg);
    free(data);
    return out;
}

static bool has_warning(const warnings_t *w, const char *text)
{
    for (size_t i = 0; i < warnings_count(w); i++)
        if (!strcmp(warnings_at(w, i), text))
            return true;
    return false;
}

static const scene_material_t *named(const scene_desc_t *d, const char *name)
{
    for (size_t i = 0; i < d->nmaterials; i++)
        if (d->materials[i].name && !strcmp(d->materials[i].name, name))
            return &d->materials[i];
    fail_msg("no material \"%s\"", name);
    return NULL;
}

static void test_v3_file(void **state)
{
    (void)state;
    err_t err = {{0}};
    warnings_t *w = warnings_new(&err);
    assert_non_null(w);
    size_t len;
    char *text = upgrade_file("data/scenes/v3/old.pbrt", w, &len);
    assert_true(has_warning(w,
                            "data/scenes/v3/old.pbrt:18:1: upgraded: pbrt-v3's material \"uber\" "
                            "is pbrt-v4's \"coateddiffuse\""));
    assert_true(
        has_warning(w, "data/scenes/v3/old.pbrt:47:1: upgraded: pbrt-v3's WorldEnd dropped"));
    assert_true(has_warning(w, "data/scenes/v3/old.pbrt:38:3: upgraded: pbrt-v3's material "
                               "\"plastic\" is pbrt-v4's \"diffuse\""));
    /* What pbrt-v4's upgrade writes, statement by statement. */
    const char *want[] = {
        "Film \"rgb\"\n",
        "    \"float iso\" [ 150 ]\n",
        "Sampler \"paddedsobol\"\n",
        "    \"float xradius\" [ 2 ]\n",
        "    \"float sigma\" [ 0.5 ]\n",
        "Integrator \"path\"\n    \"integer maxdepth\" [ 1 ]\n",
        "AreaLightSource \"diffuse\"\n    \"blackbody L\" [ 5500 ]\n    \"float scale\" [ 8 ]\n",
        "Texture \"checks\" \"spectrum\" \"checkerboard\"\n",
        "Texture \"half\" \"spectrum\" \"scale\"\n    \"texture tex\" [ \"checks\" ]\n    \"float "
        "scale\" [ 0.5 ]\n",
        "    \"string type\" [ \"coateddiffuse\" ]\n    \"color reflectance\" [ 0.4 0.2 0.1 ]\n",
        "    \"float eta\" [ 1.6 ]\n",
        "Material \"conductor\"\n    \"float roughness\" [ 0 ]\n    \"spectrum eta\" [ "
        "\"metal-Ag-eta\" ]\n",
        "Material \"dielectric\"\n    \"float eta\" [ 1.5 ]\n",
        "    \"string materials\" [ \"dull\" \"shiny\" ]\n",
        "    \"point2 uv\" [ 0 0 1 0 1 1 0 1 ]\n",
        "  Translate 0 4 0\n", /* the statement after a rewritten one keeps its indentation */
        "AttributeBegin\n  Translate -1 0.5 0\n",
        "# WorldEnd (pbrt-v3)\n",
    };
    for (size_t i = 0; i < sizeof want / sizeof want[0]; i++)
        if (!strstr(text, want[i]))
            fail_msg("missing from the upgraded text:\n%s\n--\n%s", want[i], text);
    assert_null(strstr(text, "Ks"));
    assert_null(strstr(text, "WorldEnd\n"));
    /* The result is a pbrt-v4 file prismfarm reads. */
    scene_desc_t *d = pbrt_parse_string(text, len, "new.pbrt", &err);
    if (!d)
        fail_msg("parse: %s\n--\n%s", err.msg, text);
    const scene_material_t *shiny = named(d, "shiny"), *dull = named(d, "dull");
    assert_string_equal(shiny->type, "coateddiffuse");
    assert_string_equal(dull->type, "diffuse");
    scene_desc_destroy(&d);
    free(text);
    warnings_destroy(&w);
}

/* A pbrt-v4 file is copied as it is. */
static void test_v4_unchanged(void **state)
{
    (void)state;
    const char *files[] = {"data/scenes/materials.pbrt", "data/scenes/lights.pbrt",
                           "data/scenes/shapes.pbrt", "data/scenes/procedural.pbrt",
                           "data/scenes/options.pbrt"};
    for (size_t i = 0; i < sizeof files / sizeof files[0]; i++) {
        err_t err = {{0}};
        uint8_t *data;
        size_t size, len;
        assert_int_equal(files_read(files[i], 1 << 24, &data, &size, &err), 0);
        warnings_t *w = warnings_new(&err);
        char *text = upgrade_file(files[i], w, &len);
        if (len != size || memcmp(text, data, size) != 0)
            fail_msg("%s changed by the upgrade", files[i]);
        assert_int_equal(warnings_count(w), 0);
        free(text);
        free(data);
        warnings_destroy(&w);
    }
}

static void expect_refused(const char *text, const char *msg)
{
    err_t err = {{0}};
    size_t len;
    char *out = pbrt_upgrade_text("t.pbrt", text, strlen(text), NULL, &len, &err);
    if (out)
        fail_msg("upgraded, should be refused with: %s\n--\n%s", msg, out);
    if (strcmp(err.msg, msg) != 0)
        fail_msg("got      %s\nexpected %s", err.msg, msg);
}

static void test_refused(void **state)
{
    (void)state;
    expect_refused("WorldBegin\nMaterial \"uber\" \"color opacity\" [0.5 0.5 0.5]\n",
                   "t.pbrt:2:17: a non-opaque \"opacity\" in the \"uber\" material has no pbrt-v4 "
                   "counterpart; edit the file by hand");
    expect_refused("WorldBegin\nTexture \"s\" \"color\" \"scale\" \"color tex1\" [1 0 0] "
                   "\"color tex2\" [1 1 1]\n",
                   "t.pbrt:2:29: a non-grey \"color tex1\" of a \"scale\" texture has no pbrt-v4 "
                   "counterpart; edit the file by hand");
    expect_refused("WorldBegin\nLightSource \"point\" \"color scale\" [1 2 3]\n",
                   "t.pbrt:2:21: pbrt-v4's \"scale\" of a light is a float: a coloured scale "
                   "cannot be upgraded; edit the file by hand");
    expect_refused("WorldBegin\nShape \"sphere\" \"float radius\" [1\n",
                   "t.pbrt:2:31: unterminated [ after \"float radius\"");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_v3_file),
        cmocka_unit_test(test_v4_unchanged),
        cmocka_unit_test(test_refused),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
