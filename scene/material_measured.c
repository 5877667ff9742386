/* pbrt-v4's MeasuredMaterial: RGL's measured BSDF data (bsdf/measured.h) from a .bsdf file. */
#include "material_measured.h"
#include "material_class.h"

#include "material_params.h"

#include "files.h"
#include "pbrt_parser.h"

#include <stdlib.h>

/* pbrt-v4's MeasuredMaterial: "string filename", an RGL .bsdf file, confined and listed like
 * every file a scene names when the scene was parsed (so a bundle carries it), read here once
 * however many materials name it (as pbrt-v4 does), its bytes bounded as any file a scene
 * reads is. */
static int load(material_params_t *mp, material_t *m)
{
    (void)m;
    material_measured_t *rec = mp->data;
    const char *filename;
    if (params_get_string(mp->ps, "filename", NULL, &filename, mp->err) != 0)
        return -1;
    const param_t *fp = params_find(mp->ps, "filename");
    const char *path = material_params_file(mp, fp);
    if (!filename || !*filename || !path)
        return pbrt_error(mp->err, mp->dm->loc,
                          "Material \"measured\" needs \"string filename\" (an RGL .bsdf file)");
    if ((rec->bsdf = scene_find_measured(mp->L->sc, path)))
        return 0;
    const pbrt_loc_t at = fp->loc;
    err_t *err = mp->err;
    uint8_t *bytes;
    size_t len;
    measured_t *md = NULL;
    if (files_read(path, PBRT_FILE_BYTES_MAX, &bytes, &len, err) == 0) {
        md = measured_new(bytes, len, path, err);
        free(bytes);
    }
    if (!md)
        return err_prefix(err, "%s:%d:%d: Material \"measured\": ", at.file, at.line, at.col);
    rec->bsdf = md;
    return scene_own_measured(mp->L->sc, md, path, err);
}

static void bsdf(const material_t *m, const surface_t *sf, const double *lambda, int n, bsdf_t *b)
{
    (void)sf;
    b->kind = BSDF_MEASURED;
    const material_measured_t *rec = material_measured_of(m);
    b->measured = rec ? rec->bsdf : NULL;
    for (int j = 0; j < n; j++)
        b->lambda[j] = lambda[j];
}

const material_class_t material_measured = {
    .name = "measured", .data_size = sizeof(material_measured_t), .load = load, .bsdf = bsdf};
