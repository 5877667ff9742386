/* material_class: what each kind of material is in the loaded scene, one class per kind, after
 * pbrt-v4's Material classes (materials.h: each keeps its Create and its GetBxDF together):
 * its scene-file names, its loading from the scene description into a material_t and its
 * BSDF at a hit. Each class lives in its own file pair, scene/material_<name>.c and .h (the
 * header only for a class that keeps a record; the two sheets share one pair), and is
 * registered by one line of MATERIAL_CLASS_LIST (material_kind.h), which is where its kind and
 * the name table come from. Its load reads its own parameters, which the description keeps
 * unread (scene_desc.h, scene_material_t), into the shared material_t and into its own record:
 * a struct its header declares, with a typed accessor (material_<name>_of) that checks
 * material_t.data_kind, the only way render/ and the plan read a class's own numbers. The
 * classes are constant data: no state, safe from any thread. docs/architecture.md, "Adding a
 * material", lists the files a new one touches: its file pair, its registry line, its test. */
#ifndef PRISMFARM_MATERIAL_CLASS_H
#define PRISMFARM_MATERIAL_CLASS_H

#include "bsdf.h"
#include "err.h"
#include "material_kind.h"
#include "pbrt_lexer.h"
#include "scene.h"

struct material_params; /* material_params.h, the loader's own: render/ sees only the BSDFs */

typedef struct material_class {
    /* The type a scene file writes for it ("diffuse"), which messages list; and NULL or a
     * NULL-terminated list of other spellings it accepts without listing them (pbrt-v4's ""
     * and "none" for an interface, the British "polariser"). */
    const char *name;
    const char *const *aliases;
    /* The size of the class's own record (its struct in scene/material_<name>.h; 0: none),
     * which the loader allocates zeroed for load (material_params_t.data) and the scene keeps
     * a copy of behind material_t.data, read through the header's typed accessor. */
    size_t data_size;
    /* Reads the material's parameters (mp, material_params.h: pbrt-v4's Material::Create) and
     * fills m and its own record (mp->data). The caller has set m's name and kind (the
     * description's) and remaproughness (1), and completes m afterwards with what every material
     * but mix and interface shares (its bump or normal map), then refuses the parameters nothing
     * read. Returns 0, or -1 with mp->err naming the parameter's place in the scene file. NULL: no
     * parameters. */
    int (*load)(struct material_params *mp, material_t *m);
    /* Fills b's kind and the kind's own fields at sf for the n lanes' wavelengths; the caller
     * (render/shading.c, shading_bsdf) has set b's mode, lanes, microfacets and thin film.
     * NULL: the kind has no BSDF of its own (a mix is resolved before, an interface or a sheet
     * is crossed) and gets the diffuse class's, as a surface without material would. */
    void (*bsdf)(const material_t *m, const surface_t *sf, const double *lambda, int n, bsdf_t *b);
} material_class_t;

#define MATERIAL_CLASS_DECLARE(kind, name) extern const material_class_t name;
MATERIAL_CLASS_LIST(MATERIAL_CLASS_DECLARE)
#undef MATERIAL_CLASS_DECLARE

/* The kind a scene file's type names (a class's name or alias), into *kind and 0; else -1
 * with err naming loc: "unsupported material \"x\" (did you mean ...? \"diffuse\", ... or
 * \"subsurface\")", the list written from the classes (scenefile/pbrt_names.h). */
int material_class_lookup(const char *type, pbrt_loc_t loc, material_kind_t *kind, err_t *err);

/* The class of kind; NULL for a value outside the enum. */
const material_class_t *material_class_of(material_kind_t kind);

/* The class's BSDF for m at sf (its kind's, or the diffuse class's when it has none): what
 * shading_bsdf calls once it has set the parts every kind shares. */
void material_class_bsdf(const material_t *m, const surface_t *sf, const double *lambda, int n,
                         bsdf_t *b);

#endif
