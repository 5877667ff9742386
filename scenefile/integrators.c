#include "integrators.h"

#include <stdio.h>
#include <string.h>

/* "auto" runs the path tracer unless the effect plan (scene/plan.h) chooses otherwise. */
static const integrator_name_t TABLE[] = {
    {"simplepath", INTEGRATOR_SIMPLEPATH, false, true},
    {"path", INTEGRATOR_PATH, false, true},
    {"whitted", INTEGRATOR_WHITTED, false, true},
    {"photon", INTEGRATOR_PATH, true, false},
    {"auto", INTEGRATOR_PATH, false, false},
};

#define COUNT (sizeof TABLE / sizeof TABLE[0])

const integrator_name_t *integrators_find(const char *name)
{
    for (size_t i = 0; name && i < COUNT; i++)
        if (!strcmp(TABLE[i].name, name))
            return &TABLE[i];
    return NULL;
}

const char *integrators_kind_name(integrator_kind_t kind)
{
    for (size_t i = 0; i < COUNT; i++)
        if (!TABLE[i].photon && TABLE[i].overridable && TABLE[i].kind == kind)
            return TABLE[i].name;
    return "?";
}

const char *integrators_used_name(integrator_kind_t kind, bool photon)
{
    if (!photon)
        return integrators_kind_name(kind);
    return kind == INTEGRATOR_WHITTED ? "photon+whitted" : "photon+path";
}

void integrators_list(bool overridable_only, char *buf, size_t size)
{
    const char *q = overridable_only ? "" : "\"";
    size_t n = 0, k = 0, total = 0;
    for (size_t i = 0; i < COUNT; i++)
        total += !overridable_only || TABLE[i].overridable;
    if (size > 0)
        buf[0] = 0;
    for (size_t i = 0; i < COUNT; i++) {
        if (overridable_only && !TABLE[i].overridable)
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
