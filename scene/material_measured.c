/* pbrt-v4's MeasuredMaterial: RGL's measured BSDF data (bsdf/measured.h) from a .bsdf file. */
#include "material_class.h"

#include "loader.h"

#include "files.h"
#include "pbrt_parser.h"

#include <stdlib.h>

/* pbrt-v4's MeasuredMaterial: the .bsdf file, read once however many materials name it (as
 * pbrt-v4 does), its bytes bounded as any file a scene reads is. */
static int load(loader_t *L, const scene_material_t *dm, material_t *m, err_t *err)
{
    if ((m->measured = scene_find_measured(L->sc, dm->filename)))
        return 0;
    const pbrt_loc_t at = dm->filename_loc;
    uint8_t *bytes;
    size_t len;
    measured_t *md = NULL;
    if (files_read(dm->filename, PBRT_FILE_BYTES_MAX, &bytes, &len, err) == 0) {
        md = measured_new(bytes, len, dm->filename, err);
        free(bytes);
    }
    if (!md)
        return err_prefix(err, "%s:%d:%d: Material \"measured\": ", at.file, at.line, at.col);
    m->measured = md;
    return scene_own_measured(L->sc, md, dm->filename, err);
}

static void bsdf(const material_t *m, const surface_t *sf, const double *lambda, int n, bsdf_t *b)
{
    (void)sf;
    b->kind = BSDF_MEASURED;
    b->measured = m->measured;
    for (int j = 0; j < n; j++)
        b->lambda[j] = lambda[j];
}

const material_class_t material_measured = {.load = load, .bsdf = bsdf};
