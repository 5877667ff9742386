#include "plan.h"

#include "plan_internal.h"

#include <stdio.h>
#include <string.h>

const char *plan_light_kind_name(light_kind_t kind)
{
    switch (kind) {
    case LIGHT_AREA:
        return "area";
    case LIGHT_COLLIMATED:
        return "collimated";
    case LIGHT_POINT:
        return "point";
    case LIGHT_SPOT:
        return "spot";
    case LIGHT_DISTANT:
        return "distant";
    case LIGHT_INFINITE:
        return "infinite";
    case LIGHT_GONIOMETRIC:
        return "goniometric";
    case LIGHT_PROJECTION:
        return "projection";
    }
    return "?";
}

const char *plan_verdict_name(plan_verdict_t verdict)
{
    switch (verdict) {
    case PLAN_LIGHT_NOT_NEEDED:
        return "not needed";
    case PLAN_LIGHT_NEEDED:
        return "needed";
    case PLAN_LIGHT_ADVISED:
        return "advised";
    }
    return "?";
}

/* ---- the report ---- */

/* Writes text wrapped at width columns, each line indented by indent spaces. */
static void write_wrapped(FILE *out, const char *text, int indent, int width)
{
    const char *s = text;
    while (*s) {
        while (*s == ' ')
            s++;
        if (!*s)
            break;
        int room = width - indent;
        int len = (int)strlen(s);
        int cut = len;
        if (len > room) {
            cut = room;
            while (cut > 0 && s[cut] != ' ')
                cut--;
            if (cut == 0) {
                cut = room;
                while (s[cut] && s[cut] != ' ')
                    cut++;
            }
        }
        fprintf(out, "%*s%.*s\n", indent, "", cut, s);
        s += cut;
    }
}

static void current_settings(const plan_t *p, char *buf, size_t n)
{
    if (p->current_photon.enabled)
        snprintf(buf, n, "photon (%s gather, %llu photons%s), %s",
                 integrators_kind_name(p->current_integrator),
                 (unsigned long long)p->current_photon.photons,
                 p->current_media ? ", media in both passes: volume photons" : "",
                 integrators_dispersion_name(p->current_dispersion));
    else
        snprintf(buf, n, "%s, %s",
                 integrators_used_name(p->current_integrator, false, p->current_media),
                 integrators_dispersion_name(p->current_dispersion));
}

int plan_write_text(const plan_t *p, FILE *out)
{
    char cur[160];
    current_settings(p, cur, sizeof cur);
    fprintf(out, "integrator asked: %s (%s)\nrenders with:     %s\n\n", p->req.integrator,
            p->req.overridden         ? "command line"
            : p->req.integrator_named ? "Integrator directive"
                                      : "no Integrator directive",
            cur);
    fprintf(out, "%-22s %-4s %s\n", "EFFECT", "ON", "CHOICE");
    for (size_t i = 0; i < PLAN_EFFECT_COUNT; i++) {
        const plan_decision_t *d = &p->decisions[i];
        fprintf(out, "%-22s %-4s %s\n", d->effect_name, d->on ? "yes" : "no", d->choice);
        write_wrapped(out, d->reason, 4, 100);
    }
    int any = 0;
    for (size_t i = 0; i < p->nmaterials; i++)
        any |= material_has_ior(p->materials[i].kind) ||
               p->materials[i].kind == MATERIAL_CONDUCTOR ||
               p->materials[i].kind == MATERIAL_COATED_CONDUCTOR;
    if (any) {
        /* The name column fits the longest name (file:line labels run past 16). */
        int w = 16;
        for (size_t i = 0; i < p->nmaterials; i++)
            if ((int)strlen(p->materials[i].name) > w)
                w = (int)strlen(p->materials[i].name);
        fprintf(out, "\nMIRRORS AND GLASS\n%-*s %-11s %-6s %-9s %-9s %-8s %-9s %s\n", w, "material",
                "kind", "disp.", "n_lo", "n_hi", "dn", "n_d", "v_d");
        for (size_t i = 0; i < p->nmaterials; i++) {
            const plan_material_t *m = &p->materials[i];
            if (m->kind == MATERIAL_CONDUCTOR)
                fprintf(out, "%-*s %-11s %-6s\n", w, m->name, "conductor", "-");
            if (!material_has_ior(m->kind))
                continue;
            fprintf(out, "%-*s %-11s %-6s %-9.5f %-9.5f %-8.5f %-9.5f ", w, m->name,
                    material_kind_name(m->kind), m->dispersive ? "yes" : "no", m->n_lo, m->n_hi,
                    m->n_lo - m->n_hi, m->n_d);
            if (m->has_v_d)
                fprintf(out, "%.2f\n", m->v_d);
            else
                fprintf(out, "inf\n");
        }
    }
    if (p->nlights > 0) {
        fprintf(out, "\nLIGHTS\n%-3s %-11s %-6s %-7s %-9s %-7s %-7s %-7s %-12s %s\n", "#", "kind",
                "shape", "power", "omega sr", "small", "bright", "caustic", "receiver", "photons");
        for (size_t i = 0; i < p->nlights; i++) {
            const plan_light_t *l = &p->lights[i];
            char shape[16] = "-", omega[16] = "-", recv[64] = "-";
            if (l->shape >= 0)
                snprintf(shape, sizeof shape, "%d", l->shape);
            if (l->solid_angle >= 0.0)
                snprintf(omega, sizeof omega, "%.4f", l->solid_angle);
            if (l->receiver_material >= 0)
                snprintf(recv, sizeof recv, "%s", p->materials[l->receiver_material].name);
            fprintf(out, "%-3d %-11s %-6s %-7.3f %-9s %-7s %-7s %-7s %-12s %s\n", l->index,
                    plan_light_kind_name(l->kind), shape, l->power_share, omega,
                    l->kind == LIGHT_AREA ? (l->small ? "yes" : "no") : "-",
                    l->bright ? "yes" : "no",
                    l->caustic  ? "yes"
                    : l->direct ? "direct"
                                : "no",
                    recv, plan_verdict_name(l->verdict));
        }
    }
    fprintf(out, "\nSWITCHED OFF\n");
    int off = 0;
    for (size_t i = 0; i < PLAN_EFFECT_COUNT; i++) {
        const plan_decision_t *d = &p->decisions[i];
        if (d->on)
            continue;
        const char *why = "";
        switch (d->effect) {
        case PLAN_SPLITTING:
            why = "no material disperses";
            break;
        case PLAN_COLOUR:
            why = "every spectrum is flat (buckets still rendered)";
            break;
        case PLAN_STRATEGY:
            why = "nothing disperses: the strategy never splits (time and colour noise only)";
            break;
        case PLAN_PHOTON:
            why = "no light needs photons";
            break;
        case PLAN_PHOTON_PARAMS:
            why = "no photon pass";
            break;
        case PLAN_POLARISATION:
            why = "nothing polarising is seen or asked for (intensities only)";
            break;
        case PLAN_SUBSURFACE:
            why = "no subsurface material";
            break;
        default:
            break;
        }
        fprintf(out, "  %-22s %s\n", d->effect_name, why);
        off++;
    }
    if (!off)
        fprintf(out, "  nothing: every effect the renderer has is called for\n");
    fprintf(out, "\n(%llu visibility rays)\n", (unsigned long long)p->rays);
    return ferror(out) ? -1 : 0;
}
