#include "plan.h"

#include "plan_detect.h"
#include "plan_internal.h"

#include "material_subsurface.h"
#include "material_uniaxial.h"

#include "rng.h"
#include "sample.h"

#include <math.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>

/* Photon parameters (docs/plan.md): the gather disk is PLAN_GATHER_PIXELS pixel footprints
 * in radius at the specular surfaces' distance from the camera (one: a density estimate blurs
 * a caustic's edge over its disk, and on caustic-glass at 179x256 two footprints left the 4x4
 * RMSE against pbrt-v4's bdpt 1.3 times what noise explains and one brings it to 1.2 for 13 %
 * more CPU, docs/accuracy.md "Photon gather radius"); the count gives about
 * PLAN_PHOTONS_PER_BUCKET photons per bucket in a gather disk if the caustic spreads over the
 * specular surfaces' own cross-section, with PLAN_STORED_FRACTION of the emitted photons
 * stored (45 % measured in prism_beam, docs/rendering.md). */
#define PLAN_GATHER_PIXELS 1.0
#define PLAN_PHOTONS_PER_BUCKET 16.0
#define PLAN_STORED_FRACTION 0.5
#define PLAN_PHOTONS_MIN 100000.0
#define PLAN_PHOTONS_MAX 4000000.0
#define PLAN_PHOTONS_ROUND 10000.0
/* The radius stays within these fractions of the scene's bounding radius. */
#define PLAN_RADIUS_MIN 1e-3
#define PLAN_RADIUS_MAX 0.05

static const char *const EFFECT_NAMES[PLAN_EFFECT_COUNT] = {
    "wavelength splitting", "spectral colour", "dispersion strategy", "photon pass",
    "photon parameters",    "integrator",      "polarisation",        "subsurface scattering",
};

/* ---- a growing string ---- */

typedef struct text {
    char *s;
    size_t len, cap;
    int failed;
} text_t;

__attribute__((format(printf, 2, 3))) static void text_add(text_t *t, const char *fmt, ...)
{
    if (t->failed)
        return;
    va_list ap;
    va_start(ap, fmt);
    int n = vsnprintf(NULL, 0, fmt, ap);
    va_end(ap);
    if (n < 0) {
        t->failed = 1;
        return;
    }
    if (t->len + (size_t)n + 1 > t->cap) {
        size_t cap = t->cap ? t->cap : 256;
        while (cap < t->len + (size_t)n + 1)
            cap *= 2;
        char *s = realloc(t->s, cap);
        if (!s) {
            t->failed = 1;
            return;
        }
        t->s = s;
        t->cap = cap;
    }
    va_start(ap, fmt);
    vsnprintf(t->s + t->len, t->cap - t->len, fmt, ap);
    va_end(ap);
    t->len += (size_t)n;
}

/* The string (owned by the caller), or NULL when building it failed. */
static char *text_take(text_t *t)
{
    if (t->failed || !t->s) {
        free(t->s);
        return t->failed ? NULL : strdup("");
    }
    return t->s;
}

/* ---- the plan ---- */

static void copy_word(char *dst, size_t n, const char *src)
{
    snprintf(dst, n, "%s", src ? src : "");
}

plan_request_t plan_request_make(const scene_desc_t *desc, const scene_overrides_t *ov)
{
    plan_request_t r;
    memset(&r, 0, sizeof r);
    const scene_integrator_t *in = &desc->integrator;
    r.integrator_named = in->loc.line > 0;
    r.overridden = ov && ov->integrator;
    copy_word(r.integrator, sizeof r.integrator, r.overridden ? ov->integrator : in->type);
    if (ov && ov->dispersion) {
        copy_word(r.dispersion, sizeof r.dispersion, ov->dispersion);
        r.dispersion_overridden = 1;
    } else {
        /* Looked up without params_find, which would mark the parameter used. */
        for (size_t i = 0; in->params && i < params_count(in->params); i++) {
            const param_t *p = params_at(in->params, i);
            if (!strcmp(p->name, "dispersion") && p->values == PARAM_VALUES_STRINGS &&
                p->count == 1)
                copy_word(r.dispersion, sizeof r.dispersion, p->strings[0]);
        }
    }
    return r;
}

/* "'name'" for a named material, "#i" for an unnamed one. */
static void material_label(const scene_t *s, int i, char *buf, size_t n)
{
    if (i < 0 || (size_t)i >= s->nmaterials) {
        snprintf(buf, n, "(none)");
        return;
    }
    const char *name = s->materials[i].name;
    if (!name[0] || !strcmp(name, "(unnamed)"))
        snprintf(buf, n, "#%d", i);
    else if (!s->materials[i].named) /* where the file made it: jewel.pbrt:57 */
        snprintf(buf, n, "%.60s", name);
    else
        snprintf(buf, n, "'%.60s'", name);
}

static void light_label(const scene_t *s, int i, char *buf, size_t n)
{
    const light_t *l = &s->lights[i];
    if (l->kind == LIGHT_AREA || l->kind == LIGHT_COLLIMATED)
        snprintf(buf, n, "light %d (%s, shape %d)", i, plan_light_kind_name(l->kind), l->shape);
    else
        snprintf(buf, n, "light %d (%s)", i, plan_light_kind_name(l->kind));
}

/* ---- decisions ---- */

static int set_decision(plan_t *p, plan_effect_t e, int on, text_t *choice, text_t *reason)
{
    char *c = text_take(choice), *r = text_take(reason);
    p->strings[2 * e] = c;
    p->strings[2 * e + 1] = r;
    p->decisions[e] = (plan_decision_t){
        .effect = e, .effect_name = EFFECT_NAMES[e], .on = on, .choice = c, .reason = r};
    return c && r ? 0 : -1;
}

static void plan_materials(plan_t *p, const scene_t *s)
{
    spectral_grid_t g = s->settings.grid;
    double mid = 0.5 * (g.lambda_min + g.lambda_max);
    for (size_t i = 0; i < s->nmaterials; i++) {
        const material_t *m = &s->materials[i];
        plan_material_t *pm = &p->materials[i];
        pm->index = (int)i;
        material_label(s, (int)i, pm->name, sizeof pm->name);
        pm->kind = m->kind;
        pm->dispersive = m->dispersive;
        if (m->kind == MATERIAL_DIFFUSE)
            pm->spectral = plan_detect_texture_varies(m->reflectance, g);
        else if (m->kind == MATERIAL_CONDUCTOR)
            pm->spectral = m->eta ? plan_detect_spectrum_varies(m->eta, g) ||
                                        plan_detect_spectrum_varies(m->k, g)
                                  : plan_detect_texture_varies(m->reflectance, g);
        if (material_has_ior(m->kind)) {
            pm->n_lo = ior_eval(&m->ior, g.lambda_min);
            pm->n_hi = ior_eval(&m->ior, g.lambda_max);
            pm->n_mid = ior_eval(&m->ior, mid);
            double dn = pm->n_lo - pm->n_hi;
            pm->v_film = m->dispersive && dn != 0.0 ? (pm->n_mid - 1.0) / dn : 0.0;
            pm->n_d = ior_eval(&m->ior, IOR_LAMBDA_D_NM);
            pm->has_v_d = ior_abbe_number(&m->ior, &pm->v_d);
        }
    }
}

static void describe_dielectric(text_t *t, const plan_material_t *m, spectral_grid_t g)
{
    if (!m->dispersive) {
        text_add(t, "%s (n %.4f)", m->name, m->n_mid);
        return;
    }
    text_add(t, "%s: n %.4f at %g nm to %.4f at %g nm (dn %.4f, Abbe-like v over the film %.1f",
             m->name, m->n_lo, g.lambda_min, m->n_hi, g.lambda_max, m->n_lo - m->n_hi, m->v_film);
    if (m->has_v_d)
        text_add(t, "; n_d %.5f, v_d %.2f", m->n_d, m->v_d);
    text_add(t, ")");
}

/* A realistic camera whose lens glasses disperse: each camera ray is traced through the lens at
 * its own wavelength (render.c lens_ray), which splits a path's wavelengths as a dispersive
 * interface does, before the scene is reached. Appends the reason and returns 1 when it does. */
static int describe_lens(text_t *r, const scene_t *s, spectral_grid_t g, int first)
{
    const camera_t *cam = &s->camera;
    if (cam->kind != CAMERA_REALISTIC || !cam->lens || !cam->lens_dispersive)
        return 0;
    text_add(r, "%sthe realistic camera's lens disperses: ", first ? "" : " And ");
    int k = 0;
    for (int i = 0; i < lens_system_count(cam->lens); i++) {
        const lens_element_t *e = lens_system_element(cam->lens, i);
        if (!e->glass)
            continue;
        double lo = ior_eval(&e->ior, g.lambda_min) + e->ior_shift;
        double hi = ior_eval(&e->ior, g.lambda_max) + e->ior_shift;
        text_add(r, "%selement %d %s n %.4f at %g nm to %.4f at %g nm", k++ ? "; " : "", i + 1,
                 e->glass_name[0] ? e->glass_name : "(default glass)", lo, g.lambda_min, hi,
                 g.lambda_max);
    }
    text_add(r, ". Each camera ray is traced through the lens at its own wavelength (hero: the "
                "secondaries end at the film; fan-out: one lane goes on), so the lens's axial and "
                "lateral colour -- fringes at the image's edges, a focus that moves with "
                "wavelength -- come out of its glasses.");
    return 1;
}

static int decide_splitting(plan_t *p, const scene_t *s)
{
    text_t c = {0}, r = {0};
    spectral_grid_t g = s->settings.grid;
    int ndisp = 0, nconst = 0;
    for (size_t i = 0; i < p->nmaterials; i++)
        if (material_has_ior(p->materials[i].kind)) {
            if (p->materials[i].dispersive)
                ndisp++;
            else
                nconst++;
        }
    if (ndisp > 0) {
        text_add(&c, "at dispersive refraction");
        text_add(&r, "%d material%s disperse%s over %g-%g nm: ", ndisp, ndisp > 1 ? "s" : "",
                 ndisp > 1 ? "" : "s", g.lambda_min, g.lambda_max);
        int k = 0;
        for (size_t i = 0; i < p->nmaterials; i++)
            if (p->materials[i].dispersive) {
                text_add(&r, "%s", k++ ? "; " : "");
                describe_dielectric(&r, &p->materials[i], g);
            }
        text_add(&r,
                 ". A refraction there sends each wavelength its own way, so a path's "
                 "wavelengths split (hero: the secondaries end; fan-out: %d monochrome rays).",
                 g.n);
        int nrough = 0;
        for (size_t i = 0; i < s->nmaterials; i++)
            nrough +=
                s->materials[i].dispersive &&
                (s->materials[i].rough || s->materials[i].uroughness || s->materials[i].vroughness);
        if (nrough > 0)
            text_add(
                &r,
                " %d of them %s rough: there each wavelength has its own refraction lobe, "
                "and %s.",
                nrough, nrough > 1 ? "are" : "is",
                s->settings.spectral_mis
                    ? "spectral MIS keeps the 4 hero wavelengths, each weighted by its own lobe "
                      "(\"bool spectralmis\" true, docs/physics.md §11)"
                    : "the secondaries end as at smooth glass (\"bool spectralmis\" false)");
        if (nconst > 0) {
            text_add(&r, " Constant-index glass does not split: ");
            k = 0;
            for (size_t i = 0; i < p->nmaterials; i++)
                if (material_has_ior(p->materials[i].kind) && !p->materials[i].dispersive) {
                    text_add(&r, "%s", k++ ? ", " : "");
                    describe_dielectric(&r, &p->materials[i], g);
                }
            text_add(&r, ".");
        }
        describe_lens(&r, s, g, 0);
    } else if (s->camera.kind == CAMERA_REALISTIC && s->camera.lens_dispersive) {
        text_add(&c, "in the camera's lens");
        describe_lens(&r, s, g, 1);
        text_add(&r, " No material in the scene disperses.");
        ndisp = 1; /* the effect is on: the lens splits every camera path */
    } else {
        text_add(&c, "off");
        text_add(&r, "no material's index varies by more than %g over %g-%g nm",
                 IOR_DISPERSIVE_EPSILON, g.lambda_min, g.lambda_max);
        if (nconst > 0) {
            text_add(&r, " (constant: ");
            int k = 0;
            for (size_t i = 0; i < p->nmaterials; i++)
                if (material_has_ior(p->materials[i].kind)) {
                    text_add(&r, "%s", k++ ? ", " : "");
                    describe_dielectric(&r, &p->materials[i], g);
                }
            text_add(&r, ")");
        } else {
            text_add(&r, " (no glass)");
        }
        text_add(&r,
                 ": every refraction sends all wavelengths the same way, so no path ever "
                 "splits its wavelengths. The %d buckets are still rendered.",
                 g.n);
    }
    return set_decision(p, PLAN_SPLITTING, ndisp > 0, &c, &r);
}

/* Polarised transport (docs/physics.md §14) is carried only where the scene tells polarisations
 * apart: a polariser or retarder sheet, the camera's analyser, or a Stokes output (scene_finish
 * turns render_settings_t.polarised on for them, scene_load for the output; this says which and
 * why), lights that emit polarised light and coherent crystals (their o and e waves interfere,
 * render/crystal_coherent.h). A uniaxial crystal does not turn it on by itself otherwise:
 * its o and e images are polarised across each other, which an intensity camera does not see
 * (only where light meets a later polarising interface, by a few per cent); with polarisation
 * on for another reason, it applies its Mueller matrices (docs/physics.md §15). Without any of them
 * the smooth glass and mirrors still polarise what they reflect and transmit, but a camera that
 * records intensity only sees it where light meets a second polarising surface (a glass seen in
 * a window, light inside a gem): the intensity ignoring it is off by up to a few per cent there
 * (a slab at 60 degrees transmits 0.836 unpolarised against 0.848 polarised: test_polar_render's
 * oracle), which the plan names. Where nothing asks for it, the plan's pilot decides
 * (render/polar_pilot.h polar_pilot_decide, run before the plan: by `prismfarm plan`, by the
 * master before a job starts, by `prismfarm render`): on when its bound on the change exceeds
 * the job's target error (1 % without one). This states its figure against the target. */
static int decide_polarisation(plan_t *p, const scene_t *s)
{
    text_t c = {0}, r = {0};
    int sheets = 0, glass = 0, crystals = 0, coherent = 0;
    for (size_t i = 0; i < s->nmaterials; i++) {
        const material_t *m = &s->materials[i];
        sheets += material_is_sheet(m->kind);
        const material_uniaxial_t *u = material_uniaxial_of(m);
        crystals += u != NULL;
        coherent += u && u->coherent;
        glass += (m->kind == MATERIAL_DIELECTRIC || m->kind == MATERIAL_CONDUCTOR) && !m->rough &&
                 !u;
    }
    const render_settings_t *rs = &s->settings;
    const int on = rs->polarised;
    if (on) {
        text_add(&c, "Stokes carriers%s", rs->stokes ? " + S0-S3 output" : "");
        int k = 0;
        text_add(&r, "carried because ");
        if (sheets) {
            text_add(&r, "of polarising sheets: ");
            for (size_t i = 0; i < s->nmaterials; i++)
                if (material_is_sheet(s->materials[i].kind))
                    text_add(&r, "%s%s (%s)", k++ ? ", " : "", p->materials[i].name,
                             material_kind_name(s->materials[i].kind));
            text_add(&r, "; ");
        }
        if (coherent) {
            text_add(&r, "of coherent crystals (their o and e waves interfere and optical "
                         "activity turns the light: both live in the Stokes carrier): ");
            for (size_t i = 0, k2 = 0; i < s->nmaterials; i++) {
                const material_uniaxial_t *u = material_uniaxial_of(&s->materials[i]);
                if (!u || !u->coherent)
                    continue;
                /* Once per material written: each turned shape has its own copy. */
                size_t j = 0;
                while (j < i && strcmp(p->materials[j].name, p->materials[i].name) != 0)
                    j++;
                if (j == i)
                    text_add(&r, "%s%s", k2++ ? ", " : "", p->materials[i].name);
            }
            text_add(&r, "; ");
        }
        if (s->camera.analyser)
            text_add(&r, "the camera has an analyser at %g degrees; ",
                     s->camera.analyser_angle * 180.0 / PF_PI);
        if (s->polarised_lights) {
            int area = 0;
            for (size_t i = 0; i < s->nlights; i++)
                area += s->lights[i].polarisation > 0.0 && s->lights[i].kind == LIGHT_AREA;
            text_add(&r, "%d light%s emit%s polarised light", s->polarised_lights,
                     s->polarised_lights > 1 ? "s" : "", s->polarised_lights > 1 ? "" : "s");
            if (area)
                text_add(&r, " (%d area light%s: seen directly and through smooth surfaces)", area,
                         area > 1 ? "s" : "");
            if (area < s->polarised_lights)
                text_add(&r,
                         " (%d point, spot, distant or collimated: reached by next-event "
                         "estimation, whose light sample carries the light's Stokes vector "
                         "through the surface's Mueller matrix, and by photons)",
                         s->polarised_lights - area);
            text_add(&r, "; ");
        }
        if (rs->stokes)
            text_add(&r, "the film writes the Stokes layers S1-S3; ");
        if (rs->polarised_asked)
            text_add(&r, "the file asks for it (Integrator \"bool polarized\" true); ");
        if (rs->polar_pilot.run && rs->polar_pilot.on)
            text_add(&r,
                     "the plan's pilot (render/polar_pilot.h: the same samples with and without "
                     "it) measured that ignoring it changes the image by %.2f %% (RMS per pixel "
                     "over the mean luminance), up to %.2f %% at two standard errors, above the "
                     "job's target error of %g %%; its renders took %.2f s against %.2f s "
                     "(decided once, before the job starts, and given to every worker); ",
                     100.0 * rs->polar_pilot.change, 100.0 * rs->polar_pilot.change_hi,
                     100.0 * rs->polar_pilot.target, rs->polar_pilot.seconds_polarised,
                     rs->polar_pilot.seconds_plain);
        if (rs->polar_pilot.forced)
            text_add(&r, "forced by the user (--polarized on: no pilot); ");
        else if (!sheets && !coherent && !s->camera.analyser && !rs->stokes &&
                 !rs->polarised_asked && !s->polarised_lights &&
                 !(rs->polar_pilot.run && rs->polar_pilot.on))
            text_add(&r, "the caller asked for it; ");
        text_add(&r, "a 4x4 Mueller matrix per lane at every glass and metal interface (smooth or "
                     "rough) and sheet; diffuse, thin and layered surfaces depolarise. ");
        if (rs->photon.enabled)
            text_add(&r, "Photons carry a Stokes vector per lane through sheets, smooth glass, "
                         "metal and crystals, choose reflection or refraction by their own "
                         "polarisation, and deposit S0 (the receivers depolarise). ");
        if (crystals)
            text_add(&r,
                     "The %d uniaxial crystal material%s split%s light into o and e waves "
                     "by the boundary's exact amplitudes (phases included; reflections inside "
                     "convert between the waves); crystals alone do not turn polarisation on, "
                     "unless coherent (\"bool coherent\": a thin crystal's two waves as one ray). ",
                     crystals, crystals > 1 ? "s" : "", crystals > 1 ? "" : "s");
        text_add(&r, "Images without any of these are left unpolarised, bit for bit as before.");
    } else {
        text_add(&c, "off");
        if (rs->polar_pilot.forced)
            text_add(&r, "forced by the user (--polarized off: no pilot; sheets pass their "
                         "unpolarised share, an analyser and polarised lights are seen as "
                         "intensities)");
        else
            text_add(&r, "nothing tells polarisations apart (no polariser or retarder sheet, "
                         "no analyser, no Stokes output, no polarised light)");
        if (glass)
            text_add(&r,
                     "; the %d smooth glass and mirror material%s polarise what they reflect, "
                     "which changes intensities only where light meets a second polarising "
                     "surface (a few per cent: a slab at 60 degrees transmits 0.836 "
                     "unpolarised, 0.848 polarised)",
                     glass, glass > 1 ? "s" : "");
        if (rs->polar_pilot.run)
            text_add(&r,
                     "; the plan's pilot (render/polar_pilot.h: the same samples with and "
                     "without polarisation) measured that ignoring it changes the image by "
                     "%.2f %% (RMS per pixel over the mean luminance; at most %.2f %% at two "
                     "standard errors), within the job's target error of %g %%, so it is left "
                     "off (decided once, before the job starts)",
                     100.0 * rs->polar_pilot.change, 100.0 * rs->polar_pilot.change_hi,
                     100.0 * rs->polar_pilot.target);
        if (crystals)
            text_add(&r,
                     "; uniaxial crystals (%d material%s) do not turn it on by themselves: "
                     "their o and e images are polarised across each other, which a camera "
                     "without an analyser does not tell apart",
                     crystals, crystals > 1 ? "s" : "");
        text_add(&r, ".");
    }
    return set_decision(p, PLAN_POLARISATION, on, &c, &r);
}

static int decide_colour(plan_t *p, const scene_t *s)
{
    text_t c = {0}, r = {0};
    spectral_grid_t g = s->settings.grid;
    int nl = 0, nm = 0;
    for (size_t i = 0; i < p->nlights; i++)
        nl += p->lights[i].spectral;
    for (size_t i = 0; i < p->nmaterials; i++)
        nm += p->materials[i].spectral;
    char buf[96];
    if (nl + nm > 0) {
        text_add(&c, "%d buckets", g.n);
        if (nl) {
            text_add(&r, "emission varies over %g-%g nm: ", g.lambda_min, g.lambda_max);
            int k = 0;
            for (size_t i = 0; i < p->nlights; i++)
                if (p->lights[i].spectral) {
                    light_label(s, (int)i, buf, sizeof buf);
                    text_add(&r, "%s%s", k++ ? ", " : "", buf);
                }
            text_add(&r, "%s", nm ? "; " : ". ");
        }
        if (nm) {
            text_add(&r, "reflectance varies: ");
            int k = 0;
            for (size_t i = 0; i < p->nmaterials; i++)
                if (p->materials[i].spectral)
                    text_add(&r, "%s%s", k++ ? ", " : "", p->materials[i].name);
            text_add(&r, ". ");
        }
        text_add(&r,
                 "Colour rides on every path's wavelengths (4 hero or %d fan-out lanes) at no "
                 "extra rays; the %d buckets are always rendered, so nothing is switched off "
                 "here.",
                 g.n, g.n);
    } else {
        text_add(&c, "flat");
        text_add(&r,
                 "every emission and reflectance is flat over %g-%g nm: all %d buckets hold "
                 "the same image up to noise. They are still rendered (nothing to split).",
                 g.lambda_min, g.lambda_max, g.n);
    }
    return set_decision(p, PLAN_COLOUR, nl + nm > 0, &c, &r);
}

static int decide_strategy(plan_t *p, const scene_t *s)
{
    text_t c = {0}, r = {0};
    int n = s->settings.grid.n;
    int asked = p->req.dispersion[0] != 0;
    dispersion_kind_t d = DISPERSION_HERO;
    if (asked && !integrators_dispersion_find(p->req.dispersion, &d))
        d = DISPERSION_HERO; /* the loader refused any other name already */
    p->choice.dispersion = d;
    text_add(&c, "%s", integrators_dispersion_name(d));
    if (asked)
        text_add(&r, "\"%s\" is asked for by the %s. ", p->req.dispersion,
                 p->req.dispersion_overridden ? "command line" : "scene");
    if (s->has_dispersion) {
        if (d == DISPERSION_HERO)
            text_add(&r,
                     "hero wavelengths (Wilkie et al. 2014): 4 continuous wavelengths per "
                     "path, no dispersive aliasing; at a dispersive refraction the 3 "
                     "secondaries end and the hero goes on alone (fan-out would follow %d "
                     "monochrome rays at the path's first one). Measured (docs/accuracy.md): "
                     "where light crosses glass once or twice (a prism, a lens) fan-out "
                     "lowers colour noise 3-4 times faster per CPU second at the same "
                     "luminance cost, so --dispersion fanout suits colour-critical renders; "
                     "in a gem's long internal chains it buys no colour and needs twice the "
                     "time for the same luminance error, which is why hero stays the default.",
                     n);
        else
            text_add(&r,
                     "fan-out (thesis 5.3-5.4): %d lanes per path at the bucket centres; the "
                     "first dispersive refraction follows %d monochrome rays, later ones one "
                     "chosen at random.",
                     n, n);
    } else if (s->camera.kind == CAMERA_REALISTIC && s->camera.lens_dispersive) {
        text_add(&r,
                 "only the camera's lens disperses: hero traces each camera ray at its hero "
                 "wavelength and ends the 3 secondaries there (one wavelength per path), "
                 "fan-out follows one of its %d lanes, picked at random and weighted by %d.",
                 n, n);
    } else {
        text_add(&r,
                 "no material disperses, so neither strategy ever splits: hero's 4 "
                 "wavelengths stay together on every path (never terminated) and fan-out's "
                 "%d lanes are never fanned out. The strategy changes time and colour noise "
                 "(and a bucket's average, hero, against its centre value, fan-out), "
                 "nothing else; hero carries 4 lanes per path instead of %d.",
                 n, n);
    }
    return set_decision(p, PLAN_STRATEGY,
                        s->has_dispersion ||
                            (s->camera.kind == CAMERA_REALISTIC && s->camera.lens_dispersive),
                        &c, &r);
}

static void light_reason(text_t *r, const scene_t *s, const plan_light_t *pl, size_t npl)
{
    char lab[96], glass[80], recv[80];
    light_label(s, pl->index, lab, sizeof lab);
    material_label(s, pl->glass_material, glass, sizeof glass);
    material_label(s, pl->receiver_material, recv, sizeof recv);
    text_add(r, "%s", lab);
    if (pl->undecided) {
        text_add(r, " was not decided within the plan's ray budget: assumed to need photons");
        return;
    }
    switch (pl->kind) {
    case LIGHT_INFINITE:
        text_add(r, " emits no photons (its light through glass is path traced)");
        return;
    case LIGHT_COLLIMATED:
        if (pl->direct)
            text_add(r,
                     " lights %s directly, and no camera path or light sample can find a "
                     "collimated light",
                     recv);
        if (pl->caustic)
            text_add(r, "%s reaches %s, which %s sees (L S+ D or G)", pl->direct ? ";" : "", glass,
                     recv);
        if (!pl->direct && !pl->caustic)
            text_add(r,
                     " lights no diffuse or glossy surface, directly or through mirrors and glass");
        return;
    case LIGHT_POINT:
    case LIGHT_SPOT:
    case LIGHT_GONIOMETRIC:
    case LIGHT_PROJECTION:
    case LIGHT_DISTANT:
        if (npl == 0)
            text_add(r, ": the scene has no mirror or glass");
        else if (pl->caustic)
            text_add(r,
                     " reaches %s, which %s sees: an L S+ D or L S+ G path from a delta light, "
                     "which path tracing finds with probability zero",
                     glass, recv);
        else if (pl->reaches_specular)
            text_add(r, " reaches mirrors or glass, but no diffuse or glossy surface sees where it "
                        "arrives");
        else
            text_add(r, " reaches no mirror or glass");
        return;
    case LIGHT_AREA:
        if (npl == 0) {
            text_add(r, ": the scene has no mirror or glass");
            return;
        }
        if (pl->solid_angle < 0.0) {
            text_add(r, " faces no mirror or glass");
            return;
        }
        if (!pl->small) {
            text_add(r,
                     " subtends at least %.3g sr (>= %.3g) from every mirror and glass: "
                     "path tracing finds its caustics",
                     pl->solid_angle, PLAN_SMALL_SOLID_ANGLE);
            return;
        }
        if (!pl->bright) {
            text_add(r,
                     " is small (%.3g sr) but carries %.1f%% (< %.0f%%) of the light: its "
                     "caustic is faint",
                     pl->solid_angle, 100.0 * pl->power_share, 100.0 * PLAN_BRIGHT_SHARE);
            return;
        }
        if (pl->caustic)
            text_add(r,
                     " is small (%.3g sr < %.3g from the glass) and bright (%.1f%% of the "
                     "light) and reaches %s, which %s sees: path tracing would find this "
                     "caustic in fewer than 1 of 64 bounces (fireflies)",
                     pl->solid_angle, PLAN_SMALL_SOLID_ANGLE, 100.0 * pl->power_share, glass, recv);
        else
            text_add(r, " is small and bright, but no diffuse or glossy surface sees where it "
                        "reaches mirrors or glass");
        return;
    }
}

static int decide_photon(plan_t *p, const scene_t *s)
{
    text_t c = {0}, r = {0};
    int needed = 0, advised = 0;
    for (size_t i = 0; i < p->nlights; i++) {
        needed += p->lights[i].verdict == PLAN_LIGHT_NEEDED;
        advised += p->lights[i].verdict == PLAN_LIGHT_ADVISED;
    }
    int on = needed + advised > 0;
    /* Where the scene's media are simulated both passes carry them (render/photon_volume.h):
     * photons fly through the media, and the store keeps volume photons for the volumetric
     * caustic. */
    p->choice.photon = on;
    text_add(&c, "%s", on ? (needed ? "on (needed)" : "on (advised)") : "off");
    if (p->nlights == 0)
        text_add(&r, "the scene has no lights.");
    int k = 0;
    for (int pass = 0; pass < 2; pass++)
        for (size_t i = 0; i < p->nlights; i++) {
            int counts = p->lights[i].verdict != PLAN_LIGHT_NOT_NEEDED;
            if (counts != (pass == 0))
                continue;
            if (pass == 1 && on && k == needed + advised)
                text_add(&r, ". Other lights: ");
            else if (k > 0)
                text_add(&r, "; ");
            light_reason(&r, s, &p->lights[i], p->nplacements);
            k++;
        }
    if (p->nlights > 0)
        text_add(&r, ".");
    if (on && p->current_media)
        text_add(&r,
                 " The photon pass stores these paths (docs/rendering.md), and the scene's "
                 "participating media are carried by both passes: photons fly through the media "
                 "(delta tracking, as the camera pass's volpath), and those that scatter in a "
                 "medium after a specular chain are stored as volume photons, which the camera "
                 "path gathers at its scattering points (the volumetric caustic, "
                 "docs/physics.md §12).");
    else if (on)
        text_add(&r, " The photon pass stores these paths (docs/rendering.md).");
    else
        text_add(&r,
                 " No light needs photons, so the pass is off: where no L S+ D or G path exists "
                 "it would store nothing and change no pixel; a large or faint light's "
                 "caustic is left to the path tracer.");
    return set_decision(p, PLAN_PHOTON, on, &c, &r);
}

static int decide_photon_params(plan_t *p, const scene_t *s, vec3_t lo, vec3_t hi, size_t npl)
{
    text_t c = {0}, r = {0};
    const render_settings_t *rs = &s->settings;
    if (!p->choice.photon || npl == 0) {
        if (p->choice.photon) {
            /* Only a collimated light's direct beam: no specular surfaces to size against. */
            p->choice.photons = (uint64_t)PLAN_PHOTONS_MIN;
            p->choice.radius = 0.01 * s->scene_radius;
            text_add(&c, "%llu photons, radius %.4g", (unsigned long long)p->choice.photons,
                     p->choice.radius);
            text_add(&r,
                     "no mirror or glass: the fewest photons (%.0f) and a hundredth of the "
                     "scene's bounding radius %.4g.",
                     PLAN_PHOTONS_MIN, s->scene_radius);
            return set_decision(p, PLAN_PHOTON_PARAMS, 1, &c, &r);
        }
        text_add(&c, "-");
        text_add(&r, "no photon pass.");
        return set_decision(p, PLAN_PHOTON_PARAMS, 0, &c, &r);
    }
    vec3_t centre = vec3_scale(vec3_add(lo, hi), 0.5);
    double aim = 0.5 * vec3_length(vec3_sub(hi, lo));
    vec3_t eye = transform_point(&s->camera.camera_to_world, vec3_make(0, 0, 0));
    double d = fmax(vec3_length(vec3_sub(centre, eye)), aim);
    /* A crop renders part of the full film with the full film's pixels (scene.h), so the
     * footprint, and with it the photon pass, is the full film's: the same photons for a crop
     * as for the whole image, whose pixels the crop's must equal. */
    const int fx = rs->full_xres ? rs->full_xres : rs->xres;
    const int fy = rs->full_yres ? rs->full_yres : rs->yres;
    int short_side = fx < fy ? fx : fy;
    double footprint = 2.0 * d * tan(0.5 * s->camera.fov_deg * PF_PI / 180.0) / short_side;
    double radius = PLAN_GATHER_PIXELS * footprint;
    double rmin = PLAN_RADIUS_MIN * s->scene_radius, rmax = PLAN_RADIUS_MAX * s->scene_radius;
    radius = fmin(rmax, fmax(rmin, radius));
    double ratio = aim > 0.0 ? aim / radius : 1.0;
    double n = PLAN_PHOTONS_PER_BUCKET * rs->grid.n * ratio * ratio / PLAN_STORED_FRACTION;
    n = fmin(PLAN_PHOTONS_MAX, fmax(PLAN_PHOTONS_MIN, n));
    n = ceil(n / PLAN_PHOTONS_ROUND) * PLAN_PHOTONS_ROUND;
    p->choice.photons = (uint64_t)n;
    p->choice.radius = radius;
    text_add(&c, "%llu photons, radius %.4g", (unsigned long long)p->choice.photons, radius);
    text_add(&r,
             "gather radius = %.0f pixel footprint(s) at the mirrors' and glasses' distance "
             "from the camera (%.3g, fov %g deg over %d pixels: footprint %.3g), kept within "
             "%g-%g of the scene's radius %.3g; photons = %.0f per bucket x %d buckets per "
             "gather disk over the specular surfaces' cross-section (bounding radius %.3g), "
             "%.0f%% of them stored: %.0f x %d x (%.3g / %.3g)^2 / %.1f, rounded up to %.0f "
             "and kept within %.0f-%.0f.",
             PLAN_GATHER_PIXELS, d, s->camera.fov_deg, short_side, footprint, PLAN_RADIUS_MIN,
             PLAN_RADIUS_MAX, s->scene_radius, PLAN_PHOTONS_PER_BUCKET, rs->grid.n, aim,
             100.0 * PLAN_STORED_FRACTION, PLAN_PHOTONS_PER_BUCKET, rs->grid.n, aim, radius,
             PLAN_STORED_FRACTION, PLAN_PHOTONS_ROUND, PLAN_PHOTONS_MIN, PLAN_PHOTONS_MAX);
    if (p->current_photon.enabled)
        text_add(&r, " The scene asks for %llu photons and radius %s%.4g.",
                 (unsigned long long)p->current_photon.photons,
                 p->current_photon.radius > 0.0 ? "" : "automatic, ",
                 p->current_photon.radius > 0.0 ? p->current_photon.radius
                                                : 0.01 * s->scene_radius);
    return set_decision(p, PLAN_PHOTON_PARAMS, 1, &c, &r);
}

static int decide_integrator(plan_t *p)
{
    text_t c = {0}, r = {0};
    const plan_request_t *q = &p->req;
    p->choice.integrator = INTEGRATOR_PATH;
    const char *chosen = p->choice.photon ? "photon (path gather)" : "path";
    int is_auto = !strcmp(q->integrator, "auto");
    text_add(&c, "%s", chosen);
    if (is_auto) {
        text_add(&r, "%s: integrator \"auto\" follows the plan. ",
                 q->overridden         ? "the command line asks for \"auto\""
                 : q->integrator_named ? "the scene names Integrator \"auto\""
                                       : "the scene names no Integrator");
    } else if (plan_follows_photons(q)) {
        text_add(&r,
                 "the %s asks for pbrt-v4's \"%s\", which traces paths from the lights: "
                 "prismfarm renders it with the path tracer and takes the plan's photon pass "
                 "for the caustics only light paths find. ",
                 q->overridden ? "command line" : "scene", q->integrator);
    } else {
        int asked_photon = !strcmp(q->integrator, "photon");
        int asked_path = !strcmp(q->integrator, "path");
        p->choice.differs = asked_photon ? !p->choice.photon : asked_path ? p->choice.photon : 1;
        text_add(&r,
                 "the %s asks for \"%s\", which is kept (explicit integrators are never "
                 "changed); ",
                 q->overridden ? "command line" : "scene", q->integrator);
        if (p->choice.differs) {
            text_add(&c, " (the %s keeps \"%s\")", q->overridden ? "command line" : "scene",
                     q->integrator);
            text_add(&r, "the plan would choose %s instead (mismatch). ", chosen);
        } else
            text_add(&r, "the plan agrees. ");
    }
    if (p->choice.photon)
        text_add(&r, "A photon pass is called for, gathered by the path tracer (next-event "
                     "estimation with MIS for everything else).");
    else
        text_add(&r, "No photon pass is called for: the path tracer (next-event estimation with "
                     "MIS) finds every light path this scene has.");
    return set_decision(p, PLAN_INTEGRATOR, 1, &c, &r);
}

/* Subsurface materials (material_subsurface.h): named, and how the integrator that renders
 * treats them; pbrt-v4's path-sampled BSSRDF under "path" and "simplepath", their dielectric
 * boundary alone under "whitted" (render.c). */
static int decide_subsurface(plan_t *p, const scene_t *s)
{
    text_t c = {0}, r = {0};
    int n = 0;
    for (size_t i = 0; i < s->nmaterials; i++) {
        const material_t *m = &s->materials[i];
        const material_subsurface_t *sss = material_subsurface_of(m);
        if (!sss || !sss->table)
            continue;
        if (!n)
            text_add(&r, "subsurface scattering: ");
        text_add(&r, "%smaterial %s%s%s (eta %.4g, g %.3g, %s)", n ? "; " : "",
                 m->named ? "\"" : "", m->name, m->named ? "\"" : "",
                 bssrdf_table_eta(sss->table), bssrdf_table_g(sss->table),
                 sss->sigma_a ? "sigma_a and sigma_s" : "reflectance and mfp");
        n++;
    }
    const int whitted = p->current_integrator == INTEGRATOR_WHITTED;
    if (!n) {
        text_add(&c, "-");
        text_add(&r, "no material is \"subsurface\".");
    } else if (whitted) {
        text_add(&c, "boundary only");
        text_add(&r, ". The \"whitted\" integrator renders %s as "
                     "%s dielectric boundary only (no light leaves from beneath); \"path\" "
                     "renders the BSSRDF.",
                 n > 1 ? "them" : "it", n > 1 ? "their" : "its");
    } else {
        text_add(&c, "BSSRDF");
        text_add(&r, ". Light refracted into %s leaves at a point a probe "
                     "ray finds, weighted by pbrt-v4's tabulated photon beam diffusion profile "
                     "(docs/physics.md §18); photons stop at %s, the camera pass path traces "
                     "the light beneath.",
                 n > 1 ? "them" : "it", n > 1 ? "them" : "it");
    }
    return set_decision(p, PLAN_SUBSURFACE, n > 0, &c, &r);
}

plan_t *plan_new(const scene_t *scene, const plan_request_t *req, err_t *err)
{
    plan_t *p = calloc(1, sizeof *p);
    if (!p) {
        err_set(err, "out of memory");
        return NULL;
    }
    p->req = *req;
    p->grid = scene->settings.grid;
    p->current_integrator = scene->settings.integrator;
    p->current_media = scene->settings.media;
    p->current_dispersion = scene->settings.dispersion;
    p->current_photon = scene->settings.photon;
    p->nmaterials = scene->nmaterials;
    p->nlights = scene->nlights;
    p->materials = calloc(p->nmaterials ? p->nmaterials : 1, sizeof *p->materials);
    p->lights = calloc(p->nlights ? p->nlights : 1, sizeof *p->lights);
    placement_t *pls = NULL;
    vec3_t lo, hi;
    long npl = -1;
    tracer_t t = {.s = scene, .budget = PLAN_RAY_BUDGET};
    t.max_hops =
        scene->settings.maxdepth < PLAN_MAX_HOPS ? scene->settings.maxdepth : PLAN_MAX_HOPS;
    t.stamp = calloc(scene->nshapes ? scene->nshapes : 1, sizeof *t.stamp);
    t.visits = calloc(scene->nshapes ? scene->nshapes : 1, sizeof *t.visits);
    t.queue = malloc(PLAN_QUEUE_MAX * sizeof *t.queue);
    double **cdfs = calloc(scene->nshapes ? scene->nshapes : 1, sizeof *cdfs);
    if (p->materials && p->lights && t.stamp && t.visits && t.queue && cdfs)
        npl = plan_detect_placements(scene, &pls, cdfs, &lo, &hi);
    int rc = npl < 0 ? -1 : 0;
    if (!rc) {
        plan_materials(p, scene);
        double total = 0.0;
        for (size_t i = 0; i < scene->nlights; i++)
            total += scene_light_power(scene, &scene->lights[i]);
        for (size_t i = 0; i < scene->nlights; i++) {
            p->lights[i].index = (int)i;
            /* max_hops 0: no scattering, so no caustic; a beam's direct light still counts. */
            plan_detect_light(&t, &p->lights[i], pls, t.max_hops > 0 ? (size_t)npl : 0, total,
                              scene->settings.grid);
        }
        p->rays = t.rays;
        p->nplacements = t.max_hops > 0 ? (size_t)npl : 0;
        rc = decide_splitting(p, scene) || decide_colour(p, scene) || decide_strategy(p, scene) ||
             decide_photon(p, scene) || decide_photon_params(p, scene, lo, hi, (size_t)npl) ||
             decide_integrator(p) || decide_polarisation(p, scene) ||
             decide_subsurface(p, scene);
    }
    free(pls);
    for (size_t i = 0; cdfs && i < scene->nshapes; i++)
        free(cdfs[i]);
    free(cdfs);
    free(t.stamp);
    free(t.visits);
    free(t.queue);
    if (rc) {
        plan_destroy(&p);
        err_set(err, "out of memory");
        return NULL;
    }
    return p;
}

void plan_destroy(plan_t **self_p)
{
    if (!self_p || !*self_p)
        return;
    plan_t *p = *self_p;
    for (size_t i = 0; i < 2 * PLAN_EFFECT_COUNT; i++)
        free(p->strings[i]);
    free(p->materials);
    free(p->lights);
    free(p);
    *self_p = NULL;
}

size_t plan_decision_count(const plan_t *self)
{
    (void)self;
    return PLAN_EFFECT_COUNT;
}

const plan_decision_t *plan_decision_at(const plan_t *self, size_t i)
{
    return i < PLAN_EFFECT_COUNT ? &self->decisions[i] : NULL;
}

const plan_decision_t *plan_decision_of(const plan_t *self, plan_effect_t effect)
{
    return plan_decision_at(self, (size_t)effect);
}

size_t plan_material_count(const plan_t *self)
{
    return self->nmaterials;
}

const plan_material_t *plan_material_at(const plan_t *self, size_t i)
{
    return i < self->nmaterials ? &self->materials[i] : NULL;
}

size_t plan_light_count(const plan_t *self)
{
    return self->nlights;
}

const plan_light_t *plan_light_at(const plan_t *self, size_t i)
{
    return i < self->nlights ? &self->lights[i] : NULL;
}

plan_choice_t plan_choice(const plan_t *self)
{
    return self->choice;
}

const plan_request_t *plan_request(const plan_t *self)
{
    return &self->req;
}

uint64_t plan_rays(const plan_t *self)
{
    return self->rays;
}

void plan_apply(const plan_t *self, render_settings_t *rs)
{
    rs->integrator = self->choice.integrator;
    if (!self->req.dispersion[0])
        rs->dispersion = self->choice.dispersion;
    /* The photon integrator's defaults (render_settings_default) with the plan's count and
     * radius; both passes share maxdepth, as with Integrator "photon". */
    photon_settings_t ph = render_settings_default().photon;
    if (self->choice.photon) {
        ph.enabled = 1;
        ph.store = PHOTON_STORE_PHOTONMAP;
        ph.photons = self->choice.photons;
        ph.radius = self->choice.radius;
        ph.maxdepth = rs->maxdepth;
    }
    rs->photon = ph;
}

int plan_follows_photons(const plan_request_t *req)
{
    const integrator_name_t *in = integrators_find(req->integrator);
    return in && in->plan_photons;
}

int plan_apply_auto(scene_t *scene, const scene_desc_t *desc, const scene_overrides_t *ov,
                    err_t *err)
{
    plan_request_t req = plan_request_make(desc, ov);
    const int is_auto = !strcmp(req.integrator, "auto");
    if (!is_auto && !plan_follows_photons(&req))
        return 0;
    plan_t *p = plan_new(scene, &req, err);
    if (!p)
        return -1;
    int rc = 0;
    if (is_auto) {
        plan_apply(p, &scene->settings);
    } else {
        /* bdpt, mlt, lightpath: only the photon pass is the plan's; the integrator, its depth
         * and the dispersion strategy stay as the file's mapping set them. */
        render_settings_t rs = scene->settings;
        plan_apply(p, &rs);
        scene->settings.photon = rs.photon;
    }
    plan_destroy(&p);
    return rc;
}
