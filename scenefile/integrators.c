#include "integrators.h"

#include "suggest.h"

#include <stdio.h>
#include <string.h>

static const char *const BDPT_IGNORED[] = {"visualizestrategies", "visualizeweights", NULL};
static const char *const MLT_IGNORED[] = {"bootstrapsamples", "chains", "mutationsperpixel",
                                          "largestepprobability", "sigma", NULL};
static const char *const SPPM_IGNORED[] = {"seed", NULL};

/* "auto" runs the path tracer unless the effect plan (scene/plan.h) chooses otherwise. The rows
 * after it are pbrt-v4's integrators that prismfarm reads as one of its own: each renders the
 * same expectation (the light transport equation, with media where `media` says so), so the
 * image agrees with pbrt-v4's within noise, with different noise -- for the ones that trace
 * light paths (plan_photons) because the plan adds the photon pass where a camera path cannot
 * find a caustic. */
static const integrator_name_t TABLE[] = {
    {"simplepath", INTEGRATOR_SIMPLEPATH, false, true, false, NULL, NULL, NULL, false, false},
    {"path", INTEGRATOR_PATH, false, true, false, NULL, NULL, NULL, false, false},
    {"whitted", INTEGRATOR_WHITTED, false, true, false, NULL, NULL, NULL, false, false},
    {"photon", INTEGRATOR_PATH, true, false, false, NULL, NULL, NULL, false, false},
    {"auto", INTEGRATOR_PATH, false, false, false, NULL, NULL, NULL, true, false},
    /* The path tracer with participating media (render/volume.h); without media it is path
     * exactly. */
    {"volpath", INTEGRATOR_PATH, false, false, true, NULL, NULL, NULL, true, false},
    {"bdpt", INTEGRATOR_PATH, false, false, true,
     "bdpt is rendered by the path tracer, after a photon pass when the plan calls for one "
     "(`prismfarm plan` says why): caustics of point, spot, distant and small bright lights "
     "through smooth glass and mirrors, which only bdpt's light paths find, come from photons "
     "gathered on the diffuse and glossy surfaces that receive them; the rest is the same "
     "image with different noise",
     BDPT_IGNORED, NULL, true, true},
    {"mlt", INTEGRATOR_PATH, false, false, true,
     "mlt is rendered by the path tracer (without Metropolis sampling's bootstrap, chains and "
     "mutations), after a photon pass when the plan calls for one (`prismfarm plan` says why): "
     "caustics of point, spot, distant and small bright lights through smooth glass and "
     "mirrors come from photons gathered on the diffuse and glossy surfaces that receive them",
     MLT_IGNORED, NULL, true, true},
    {"sppm", INTEGRATOR_PATH, true, false, true,
     "sppm is rendered by the photon integrator (one photon pass, then the path tracer gathers "
     "it): \"integer photons\" = photonsperiteration x the sampler's pixelsamples (pbrt-v4's "
     "iterations), \"float radius\" = radius, held fixed rather than shrunk each iteration",
     SPPM_IGNORED, NULL, false, false},
    {"lightpath", INTEGRATOR_PATH, false, false, true,
     "lightpath is rendered by the path tracer, after a photon pass for the caustics of delta "
     "and small bright lights when the plan calls for one (same expectation, different noise)",
     NULL, NULL, false, true},
    {"randomwalk", INTEGRATOR_PATH, false, false, true,
     "randomwalk is rendered by the path tracer (same expectation, less noise: it samples lights)",
     NULL, NULL, false, false},
    {"simplevolpath", INTEGRATOR_PATH, false, false, true,
     "simplevolpath is rendered by volpath's path tracer with media (same expectation, less "
     "noise: it samples lights)",
     NULL, NULL, true, false},
    {"ambientocclusion", INTEGRATOR_PATH, false, false, true, NULL, NULL,
     "ambient occlusion renders the unoccluded fraction of the hemisphere, not radiance, and "
     "prismfarm has no integrator with that expectation", false, false},
};

#define COUNT (sizeof TABLE / sizeof TABLE[0])

const integrator_name_t *integrators_find(const char *name)
{
    for (size_t i = 0; name && i < COUNT; i++)
        if (!strcmp(TABLE[i].name, name))
            return &TABLE[i];
    return NULL;
}

const char *integrators_suggest(const char *name)
{
    suggest_t near = suggest_begin(name);
    for (size_t i = 0; i < COUNT; i++)
        if (!TABLE[i].refused)
            suggest_consider(&near, TABLE[i].name);
    return suggest_result(&near);
}

const char *integrators_kind_name(integrator_kind_t kind)
{
    for (size_t i = 0; i < COUNT; i++)
        if (!TABLE[i].photon && TABLE[i].overridable && TABLE[i].kind == kind)
            return TABLE[i].name;
    return "?";
}

const char *integrators_used_name(integrator_kind_t kind, bool photon, bool media)
{
    if (!photon && media && kind == INTEGRATOR_PATH)
        return "volpath";
    if (!photon)
        return integrators_kind_name(kind);
    if (kind == INTEGRATOR_PATH && media)
        return "photon+volpath";
    return kind == INTEGRATOR_WHITTED ? "photon+whitted" : "photon+path";
}

void integrators_list(bool overridable_only, char *buf, size_t size)
{
    const char *q = overridable_only ? "" : "\"";
    size_t n = 0, k = 0, total = 0;
    for (size_t i = 0; i < COUNT; i++)
        total += TABLE[i].overridable || (!overridable_only && !TABLE[i].refused);
    if (size > 0)
        buf[0] = 0;
    for (size_t i = 0; i < COUNT; i++) {
        if (overridable_only ? !TABLE[i].overridable : TABLE[i].refused != NULL)
            continue;
        const char *sep = k == 0 ? "" : k + 1 == total ? " or " : ", ";
        int w = snprintf(buf + n, n < size ? size - n : 0, "%s%s%s%s", sep, q, TABLE[i].name, q);
        if (w > 0)
            n += (size_t)w;
        k++;
    }
}

static const char *const DISPERSIONS[] = {[DISPERSION_HERO] = "hero", [DISPERSION_FANOUT] = "fanout"};

const char *integrators_dispersion_name(dispersion_kind_t kind)
{
    return kind == DISPERSION_FANOUT ? DISPERSIONS[DISPERSION_FANOUT] : DISPERSIONS[DISPERSION_HERO];
}

bool integrators_dispersion_find(const char *name, dispersion_kind_t *kind)
{
    for (int k = DISPERSION_HERO; name && k <= DISPERSION_FANOUT; k++)
        if (!strcmp(DISPERSIONS[k], name)) {
            *kind = (dispersion_kind_t)k;
            return true;
        }
    return false;
}

const char *integrators_dispersion_used(dispersion_kind_t kind, bool dispersive)
{
    return dispersive ? integrators_dispersion_name(kind) : "off";
}
