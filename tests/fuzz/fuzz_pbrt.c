/* fuzz_pbrt: libFuzzer harness for the pbrt-v4 scene parser and the scene loader. Each input is
 * a scene file; it is written into a fixture folder (fuzz_fixture.h: an include, a subfolder
 * include, an ascii and a binary PLY, a PNG) and parsed with pbrt_parse_file_confined, so
 * Include, Import, plymesh and imagemap run but no input can read a file outside that folder
 * (not /dev/zero, not a FIFO, not the host's files). A scene that parses goes through
 * scene_load (textures, spectra, instances, Embree geometry). Any failure must come back as a
 * message, never a crash, a leak, a hang or an empty message. */
#include "fuzz_fixture.h"
#include "pbrt_parser.h"
#include "scene_load.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static char g_dir[4096];
static char g_scene[4200];

static void cleanup(void)
{
    if (g_dir[0])
        fuzz_fixture_remove(g_dir);
}

int LLVMFuzzerInitialize(int *argc, char ***argv);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerInitialize(int *argc, char ***argv)
{
    (void)argc;
    (void)argv;
    if (fuzz_fixture_make("fuzz-pbrt", 1, g_dir, sizeof g_dir) != 0)
        abort();
    snprintf(g_scene, sizeof g_scene, "%s/scene.pbrt", g_dir);
    atexit(cleanup);
    return 0;
}

static void expect_message(const err_t *err, const char *what)
{
    if (!memchr(err->msg, 0, sizeof err->msg) || !err->msg[0]) {
        fprintf(stderr, "fuzz_pbrt: %s failed without a message\n", what);
        abort();
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (fuzz_fixture_write(g_scene, data, size) != 0)
        abort();
    err_t err = {{0}};
    /* The master's default budget: its refusals are paths the fuzzer must reach too. */
    const scene_budget_t budget = scene_budget_default();
    scene_desc_t *desc = pbrt_parse_file_confined(g_scene, g_dir, &budget, &err);
    if (!desc) {
        expect_message(&err, "pbrt_parse_file_confined");
        return 0;
    }
    memset(&err, 0, sizeof err);
    scene_t *scene = scene_load(desc, NULL, &err);
    if (!scene)
        expect_message(&err, "scene_load");
    scene_destroy(&scene);
    scene_desc_destroy(&desc);
    return 0;
}
