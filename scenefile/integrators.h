/* integrators: the one table of integrator names prismfarm knows, and of the dispersion
 * strategies an integrator's "string dispersion" names -- what a scene file's
 * `Integrator` may say (the parser), what each means (the loader), what `--integrator` accepts
 * (the command line) and how an output names what ran (the master, `render`, `plan`). A name is
 * a camera-pass integrator, optionally after a photon pass. */
#ifndef PRISMFARM_INTEGRATORS_H
#define PRISMFARM_INTEGRATORS_H

#include <stdbool.h>
#include <stddef.h>

/* The camera pass's integrator. */
typedef enum integrator_kind {
    INTEGRATOR_SIMPLEPATH, /* the thesis's simple path tracer: no light sampling */
    INTEGRATOR_PATH,       /* next-event estimation with MIS */
    INTEGRATOR_WHITTED,    /* specular chains, shadow rays at the first diffuse hit */
} integrator_kind_t;

/* How a path carries wavelengths through a dispersive interface (docs/rendering.md). */
typedef enum dispersion_kind {
    DISPERSION_HERO,   /* 4 continuous hero wavelengths, secondaries terminated at dispersion */
    DISPERSION_FANOUT, /* the thesis: monochrome fan-out over the framebuffer buckets */
} dispersion_kind_t;

/* "hero" or "fanout". */
const char *integrators_dispersion_name(dispersion_kind_t kind);

/* The strategy named name into *kind; false if there is none of that name. */
bool integrators_dispersion_find(const char *name, dispersion_kind_t *kind);

/* What ran, as outputs name it: "off" when the scene has no dispersive material, else the
 * strategy's name. */
const char *integrators_dispersion_used(dispersion_kind_t kind, bool dispersive);

typedef struct integrator_name {
    const char *name;
    integrator_kind_t kind; /* the camera pass it runs (photon: its "gather" may change it) */
    bool photon;            /* a photon pass comes first */
    bool overridable;       /* `--integrator` may choose it for any scene */
    /* pbrt-v4's integrators that prismfarm does not have: mapped_from_pbrt says the name is
     * read as `kind` (and the photon pass), `why` is the warning that says so (NULL: none, as
     * for volpath without media), `ignored` the pbrt-v4 parameters accepted and not simulated
     * (NULL-terminated; each one given warns). */
    bool mapped_from_pbrt;
    const char *why;
    const char *const *ignored;
    /* Known to pbrt-v4 and refused, with the reason (ambientocclusion). */
    const char *refused;
    /* The camera pass simulates participating media: pbrt-v4's integrator of that name does
     * (volpath, its default "auto", bdpt, mlt). The others ignore them, as pbrt-v4's path,
     * simplepath, lightpath and randomwalk do. */
    bool media;
    /* pbrt-v4's integrators that trace paths from the lights (bdpt, mlt, lightpath): they find
     * caustics of delta and small lights through smooth glass that a camera path cannot, so
     * the photon pass is the effect plan's to decide (scene/plan.h), as for "auto". */
    bool plan_photons;
} integrator_name_t;

/* The entry named name, or NULL if prismfarm knows no integrator of that name. */
const integrator_name_t *integrators_find(const char *name);

/* The usable integrator name nearest to a misspelt one (base/suggest.h), or NULL. */
const char *integrators_suggest(const char *name);

/* "simplepath", "path" or "whitted". */
const char *integrators_kind_name(integrator_kind_t kind);

/* What ran, as outputs name it: the kind's name, "volpath" for the path tracer simulating
 * participating media, or "photon+path" / "photon+whitted" after a photon pass ("photon+volpath"
 * when the path tracer carries media). */
const char *integrators_used_name(integrator_kind_t kind, bool photon, bool media);

/* Every name for a message (refused names left out), quoted, in table order: "\"simplepath\", ..., \"photon\" or \"auto\"";
 * with overridable_only, only the names `--integrator` takes, unquoted: "simplepath, path or
 * whitted". Cut to fit buf (INTEGRATORS_LIST_MAX is always enough). */
#define INTEGRATORS_LIST_MAX 320
void integrators_list(bool overridable_only, char *buf, size_t size);

#endif
