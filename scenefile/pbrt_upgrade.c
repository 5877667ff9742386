#define _XOPEN_SOURCE 700 /* strdup */

#include "pbrt_upgrade.h"

#include "pbrt_lexer.h"

#include <math.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---- output text ---- */

typedef struct buf {
    char *s;
    size_t len, cap;
    bool oom;
} buf_t;

static void buf_add(buf_t *b, const char *s, size_t n)
{
    if (b->oom)
        return;
    if (b->len + n + 1 > b->cap) {
        size_t cap = b->cap ? b->cap : 4096;
        while (cap < b->len + n + 1)
            cap *= 2;
        char *p = realloc(b->s, cap);
        if (!p) {
            b->oom = true;
            return;
        }
        b->s = p;
        b->cap = cap;
    }
    memcpy(b->s + b->len, s, n);
    b->len += n;
    b->s[b->len] = '\0';
}

static void buf_printf(buf_t *b, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static void buf_printf(buf_t *b, const char *fmt, ...)
{
    char tmp[1024];
    va_list ap;
    va_start(ap, fmt);
    int n = vsnprintf(tmp, sizeof tmp, fmt, ap);
    va_end(ap);
    if (n < 0)
        return;
    if ((size_t)n < sizeof tmp) {
        buf_add(b, tmp, (size_t)n);
        return;
    }
    char *big = malloc((size_t)n + 1);
    if (!big) {
        b->oom = true;
        return;
    }
    va_start(ap, fmt);
    vsnprintf(big, (size_t)n + 1, fmt, ap);
    va_end(ap);
    buf_add(b, big, (size_t)n);
    free(big);
}

static void buf_quoted(buf_t *b, const char *s)
{
    buf_add(b, "\"", 1);
    for (const char *p = s; *p; p++) {
        if (*p == '"' || *p == '\\')
            buf_add(b, "\\", 1);
        buf_add(b, p, 1);
    }
    buf_add(b, "\"", 1);
}

/* ---- tokens and statements ---- */

typedef struct tok {
    pbrt_token_kind_t kind;
    char *text;
    pbrt_loc_t loc;
    size_t off; /* byte offset of the token's first character in the text */
} tok_t;

/* One parameter: "type name" and its values (each a token's text; strings unquoted). */
typedef struct uparam {
    char type[48], name[128];
    int n;
    char **v;
    bool str; /* the values are strings */
    bool gone;
    pbrt_loc_t loc;
} uparam_t;

#define MAX_PARAMS 128

typedef struct stmt {
    const char *dir;
    pbrt_loc_t loc;
    char *args[3];
    int nargs;
    uparam_t p[MAX_PARAMS];
    int np;
    char *extra_type; /* MakeNamedMaterial's "string type" rewritten */
} stmt_t;

typedef struct up {
    warnings_t *w;
    err_t *err;
    bool failed;
    char **owned; /* strings made while rewriting, freed at the end */
    size_t nowned, capowned;
} up_t;

static char *own(up_t *u, char *s)
{
    if (!s) {
        u->failed = true;
        err_set(u->err, "out of memory");
        return NULL;
    }
    if (u->nowned == u->capowned) {
        size_t cap = u->capowned ? 2 * u->capowned : 64;
        char **p = realloc(u->owned, cap * sizeof *p);
        if (!p) {
            free(s);
            u->failed = true;
            err_set(u->err, "out of memory");
            return NULL;
        }
        u->owned = p;
        u->capowned = cap;
    }
    return u->owned[u->nowned++] = s;
}

static void note(up_t *u, pbrt_loc_t loc, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));
static void note(up_t *u, pbrt_loc_t loc, const char *fmt, ...)
{
    if (!u->w)
        return;
    char msg[512];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    if (warnings_add(u->w, loc, "upgraded: %s", msg))
        u->failed = true;
}

static void fail(up_t *u, pbrt_loc_t loc, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));
static void fail(up_t *u, pbrt_loc_t loc, const char *fmt, ...)
{
    if (u->failed)
        return;
    char msg[512];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    pbrt_error(u->err, loc, "%s", msg);
    u->failed = true;
}

static bool is_value_word(const char *s)
{
    double d;
    return !strcmp(s, "true") || !strcmp(s, "false") || pbrt_parse_number(s, &d) == 0;
}

/* ---- parameter helpers ---- */

static uparam_t *find(stmt_t *s, const char *name)
{
    for (int i = 0; i < s->np; i++)
        if (!s->p[i].gone && !strcmp(s->p[i].name, name))
            return &s->p[i];
    return NULL;
}

static uparam_t *find_typed(stmt_t *s, const char *type, const char *name)
{
    uparam_t *p = find(s, name);
    return p && !strcmp(p->type, type) ? p : NULL;
}

static void rename_param(stmt_t *s, const char *from, const char *to)
{
    uparam_t *p = find(s, from);
    if (p)
        snprintf(p->name, sizeof p->name, "%s", to);
}

static bool is_colour_type(const char *t)
{
    return !strcmp(t, "rgb") || !strcmp(t, "color");
}

static bool is_spectrum_like(const char *t)
{
    return is_colour_type(t) || !strcmp(t, "spectrum") || !strcmp(t, "blackbody");
}

/* An rgb (or color) of three equal values v: *v set. */
static bool constant_rgb(const uparam_t *p, double *v)
{
    if (!is_colour_type(p->type) || p->n != 3 || p->str)
        return false;
    double a, b, c;
    if (pbrt_parse_number(p->v[0], &a) || pbrt_parse_number(p->v[1], &b) ||
        pbrt_parse_number(p->v[2], &c) || a != b || b != c)
        return false;
    *v = a;
    return true;
}

static uparam_t *add_param(up_t *u, stmt_t *s, const char *type, const char *name, bool str,
                           const char *value)
{
    if (s->np == MAX_PARAMS) {
        fail(u, s->loc, "too many parameters to upgrade");
        return NULL;
    }
    uparam_t *p = &s->p[s->np++];
    memset(p, 0, sizeof *p);
    snprintf(p->type, sizeof p->type, "%s", type);
    snprintf(p->name, sizeof p->name, "%s", name);
    p->loc = s->loc;
    p->str = str;
    p->v = (char **)own(u, calloc(2, sizeof(char *)));
    if (!p->v)
        return NULL;
    p->n = 1;
    p->v[0] = own(u, strdup(value));
    return p;
}

static void add_float(up_t *u, stmt_t *s, const char *name, double v)
{
    char num[64];
    snprintf(num, sizeof num, "%.9g", v);
    add_param(u, s, "float", name, false, num);
}

/* pbrt-v4's removeParamSilentIfConstant: drops a spectrum or texture parameter, silently when
 * it is the constant rgb value, else with a note; true when it was that constant. */
static bool remove_if_constant(up_t *u, stmt_t *s, const char *mat, const char *name, double value)
{
    uparam_t *p = find(s, name);
    if (!p || !(is_spectrum_like(p->type) || !strcmp(p->type, "texture")))
        return false;
    double v;
    bool matches = constant_rgb(p, &v) && v == value;
    if (!matches)
        note(u, p->loc, "\"%s %s\" has no counterpart in the \"%s\" material and is dropped",
             p->type, p->name, mat);
    p->gone = true;
    return matches;
}

static void drop(stmt_t *s, const char *type, const char *name)
{
    uparam_t *p = type ? find_typed(s, type, name) : find(s, name);
    if (p)
        p->gone = true;
}

/* ---- the rewrites (pbrt-v4 parser.cpp, FormattingParserTarget, with upgrade) ---- */

/* upgradeMaterialIndex and upgradeMaterial: *name is the v3 material type; returns whether
 * anything changed. */
static bool upgrade_material(up_t *u, stmt_t *s, char **name, pbrt_loc_t loc)
{
    const char *v3 = *name;
    bool changed = false;
    if (!strcmp(v3, "glass") || !strcmp(v3, "uber")) {
        uparam_t *ix = find(s, "index");
        if (ix) {
            if (find(s, "eta"))
                return fail(u, loc, "Material \"%s\" has both \"index\" and \"eta\" parameters",
                            v3),
                       false;
            snprintf(ix->name, sizeof ix->name, "eta");
            changed = true;
        }
    }
    if (find(s, "bumpmap")) {
        rename_param(s, "bumpmap", "displacement");
        changed = true;
    }
    const char *to = NULL;
    if (!strcmp(v3, "uber")) {
        to = "coateddiffuse";
        if (remove_if_constant(u, s, "coateddiffuse", "Ks", 0)) {
            to = "diffuse";
            drop(s, "float", "eta");
            drop(s, "float", "roughness");
        }
        remove_if_constant(u, s, to, "Kr", 0);
        remove_if_constant(u, s, to, "Kt", 0);
        rename_param(s, "Kd", "reflectance");
        uparam_t *op = find(s, "opacity");
        if (op) {
            double v;
            if (!constant_rgb(op, &v) || v != 1.0)
                return fail(u, op->loc,
                            "a non-opaque \"opacity\" in the \"uber\" material has no pbrt-v4 "
                            "counterpart; edit the file by hand"),
                       false;
            op->gone = true;
        }
    } else if (!strcmp(v3, "mix")) {
        uparam_t *am = find(s, "amount");
        double v;
        if (am && is_colour_type(am->type) && am->n == 3 && !am->str) {
            double r, g, b;
            if (constant_rgb(am, &v)) {
                add_float(u, s, "amount", v);
            } else if (!pbrt_parse_number(am->v[0], &r) && !pbrt_parse_number(am->v[1], &g) &&
                       !pbrt_parse_number(am->v[2], &b)) {
                note(u, am->loc, "rgb \"amount\" (%g, %g, %g) becomes its average %g", r, g, b,
                     (r + g + b) / 3);
                add_float(u, s, "amount", (r + g + b) / 3);
            }
            am->gone = true;
            changed = true;
        }
        uparam_t *m1 = find_typed(s, "string", "namedmaterial1");
        uparam_t *m2 = find_typed(s, "string", "namedmaterial2");
        if (m1 || m2) {
            if (!m1 || !m2 || m1->n != 1 || m2->n != 1)
                return fail(u, loc,
                            "\"mix\" needs \"string namedmaterial1\" and "
                            "\"string namedmaterial2\""),
                       false;
            /* pbrt-v4's materials list is in the opposite order of v3's pair. */
            uparam_t *ms = add_param(u, s, "string", "materials", true, m2->v[0]);
            if (!ms)
                return false;
            char **two = (char **)own(u, calloc(2, sizeof(char *)));
            if (!two)
                return false;
            two[0] = m2->v[0];
            two[1] = m1->v[0];
            ms->v = two;
            ms->n = 2;
            m1->gone = m2->gone = true;
            changed = true;
        }
    } else if (!strcmp(v3, "substrate")) {
        to = "coateddiffuse";
        remove_if_constant(u, s, to, "Ks", 1);
        rename_param(s, "Kd", "reflectance");
    } else if (!strcmp(v3, "glass")) {
        to = "dielectric";
        remove_if_constant(u, s, to, "Kr", 1);
        remove_if_constant(u, s, to, "Kt", 1);
    } else if (!strcmp(v3, "plastic")) {
        to = "coateddiffuse";
        if (remove_if_constant(u, s, to, "Ks", 0)) {
            to = "diffuse";
            drop(s, "float", "roughness");
            drop(s, "float", "eta");
        }
        rename_param(s, "Kd", "reflectance");
    } else if (!strcmp(v3, "kdsubsurface")) {
        to = "subsurface";
        rename_param(s, "Kd", "reflectance");
    } else if (!strcmp(v3, "matte")) {
        to = "diffuse";
        rename_param(s, "Kd", "reflectance");
        drop(s, NULL, "sigma");
    } else if (!strcmp(v3, "metal")) {
        to = "conductor";
        remove_if_constant(u, s, to, "Kr", 1);
    } else if (!strcmp(v3, "translucent")) {
        to = "diffusetransmission";
        rename_param(s, "Kd", "transmittance");
        remove_if_constant(u, s, to, "reflect", 0);
        remove_if_constant(u, s, to, "transmit", 1);
        remove_if_constant(u, s, to, "Ks", 0);
        drop(s, "float", "roughness");
    } else if (!strcmp(v3, "mirror")) {
        to = "conductor";
        add_float(u, s, "roughness", 0.0);
        add_param(u, s, "spectrum", "eta", true, "metal-Ag-eta");
        add_param(u, s, "spectrum", "k", true, "metal-Ag-k");
        remove_if_constant(u, s, to, "Kr", 0);
    } else if (!strcmp(v3, "disney")) {
        to = "diffuse";
        rename_param(s, "color", "reflectance");
    } else if (!strcmp(v3, "hair")) {
        rename_param(s, "color", "reflectance");
    } else if (!strcmp(v3, "fourier")) {
        note(u, loc, "the \"fourier\" material is not pbrt-v4's (its \"measured\" is)");
    } else if (!v3[0] || !strcmp(v3, "none")) {
        to = "interface";
    }
    if (to) {
        note(u, loc, "pbrt-v3's material \"%s\" is pbrt-v4's \"%s\"", v3, to);
        *name = own(u, strdup(to));
        changed = true;
    } else if (changed) {
        note(u, loc, "pbrt-v3's parameters of material \"%s\" renamed", v3);
    }
    return changed;
}

static bool upgrade_texture(up_t *u, stmt_t *s)
{
    bool changed = false;
    const char *cls = s->args[2];
    if (!strcmp(s->args[1], "color")) {
        s->args[1] = own(u, strdup("spectrum"));
        changed = true;
    }
    if (!strcmp(cls, "scale") && (find(s, "tex1") || find(s, "tex2"))) {
        if (!strcmp(s->args[1], "float")) {
            rename_param(s, "tex1", "tex");
            rename_param(s, "tex2", "scale");
        } else {
            /* One of the two must be a grey rgb: it becomes the float scale. */
            uparam_t *t[2] = {find(s, "tex1"), find(s, "tex2")};
            bool rgb_done = false, tex_done = false;
            for (int i = 0; i < 2; i++) {
                if (!t[i])
                    continue;
                double v;
                if (is_colour_type(t[i]->type) && !rgb_done) {
                    if (!constant_rgb(t[i], &v))
                        return fail(u, t[i]->loc,
                                    "a non-grey \"%s %s\" of a \"scale\" texture has no pbrt-v4 "
                                    "counterpart; edit the file by hand",
                                    t[i]->type, t[i]->name),
                               false;
                    snprintf(t[i]->type, sizeof t[i]->type, "float");
                    snprintf(t[i]->name, sizeof t[i]->name, "scale");
                    t[i]->n = 1;
                    rgb_done = true;
                } else if (!tex_done) {
                    snprintf(t[i]->name, sizeof t[i]->name, "tex");
                    tex_done = true;
                } else {
                    return fail(u, t[i]->loc,
                                "two textures or two rgb values for a \"scale\" texture: edit "
                                "the file by hand"),
                           false;
                }
            }
        }
        changed = true;
    }
    if (!strcmp(cls, "imagemap") || !strcmp(cls, "ptex")) {
        uparam_t *tri = find_typed(s, "bool", "trilinear");
        if (tri) {
            tri->gone = true;
            add_param(u, s, "string", "filter", true,
                      tri->n == 1 && !strcmp(tri->v[0], "true") ? "trilinear" : "bilinear");
            changed = true;
        }
        uparam_t *g = find(s, "gamma");
        if (g && g->n == 1) {
            char enc[64];
            if (!strcmp(g->type, "bool"))
                snprintf(enc, sizeof enc, "%s", !strcmp(g->v[0], "true") ? "sRGB" : "linear");
            else
                snprintf(enc, sizeof enc, "gamma %s", g->v[0]);
            g->gone = true;
            add_param(u, s, "string", "encoding", true, enc);
            changed = true;
        }
    }
    if (changed)
        note(u, s->loc, "pbrt-v3's Texture \"%s\" (\"%s\") rewritten", s->args[0], cls);
    return changed;
}

/* pbrt-v4's upgradeRGBToScale: a grey rgb "name" folds into *scale. false: not grey. */
static bool rgb_to_scale(stmt_t *s, const char *name, double *scale)
{
    uparam_t *p = find(s, name);
    if (!p || !is_spectrum_like(p->type))
        return true;
    double v;
    if (!constant_rgb(p, &v))
        return false;
    *scale *= v;
    p->gone = true;
    return true;
}

/* v3's "blackbody" [T s] is v4's [T] times the scale s (UpgradeBlackbody). */
static double upgrade_blackbody(stmt_t *s, const char *name)
{
    uparam_t *p = find_typed(s, "blackbody", name);
    double k = 1.0;
    if (p && p->n == 2 && !pbrt_parse_number(p->v[1], &k))
        p->n = 1;
    return k;
}

static bool upgrade_light(up_t *u, stmt_t *s, bool area)
{
    bool changed = false;
    double total = 1.0;
    uparam_t *sc = find(s, "scale");
    if (sc && is_spectrum_like(sc->type)) {
        if (!rgb_to_scale(s, "scale", &total))
            return fail(u, sc->loc,
                        "pbrt-v4's \"scale\" of a light is a float: a coloured "
                        "scale cannot be upgraded; edit the file by hand"),
                   false;
        changed = true;
    }
    if (!area) {
        if (find(s, "samples")) {
            drop(s, NULL, "samples");
            changed = true;
        }
        uparam_t *map = find_typed(s, "string", "mapname");
        if (map) {
            if (!strcmp(s->args[0], "infinite") && !rgb_to_scale(s, "L", &total))
                return fail(u, map->loc,
                            "a coloured \"L\" with \"mapname\" cannot be upgraded; edit the file "
                            "by hand"),
                       false;
            snprintf(map->name, sizeof map->name, "filename");
            changed = true;
        }
        double k = upgrade_blackbody(s, "I");
        total *= k;
        changed |= k != 1.0;
    } else {
        if (!strcmp(s->args[0], "area")) {
            s->args[0] = own(u, strdup("diffuse"));
            changed = true;
        }
        if (find(s, "nsamples")) {
            drop(s, NULL, "nsamples");
            changed = true;
        }
    }
    uparam_t *bb = find_typed(s, "blackbody", "L");
    if (bb && bb->n == 2) {
        total *= upgrade_blackbody(s, "L");
        changed = true;
    }
    if (total != 1.0) {
        uparam_t *f = find_typed(s, "float", "scale");
        double v = 1.0;
        if (f && f->n == 1 && !pbrt_parse_number(f->v[0], &v))
            f->gone = true;
        add_float(u, s, "scale", total * v);
    }
    if (changed)
        note(u, s->loc, "pbrt-v3's %s \"%s\" rewritten", area ? "AreaLightSource" : "LightSource",
             s->args[0]);
    return changed;
}

static bool upgrade_shape(up_t *u, stmt_t *s)
{
    bool changed = false;
    const char *name = s->args[0];
    if (!strcmp(name, "loopsubdiv") && find(s, "nlevels")) {
        rename_param(s, "nlevels", "levels");
        changed = true;
    }
    if (!strcmp(name, "trianglemesh") || !strcmp(name, "plymesh")) {
        if (find(s, "discarddegenerateUVs") || find_typed(s, "texture", "shadowalpha")) {
            drop(s, NULL, "discarddegenerateUVs");
            drop(s, "texture", "shadowalpha");
            changed = true;
        }
    }
    if (!strcmp(name, "trianglemesh")) {
        uparam_t *st = find_typed(s, "point2", "st");
        uparam_t *uv = find_typed(s, "float", "uv");
        uparam_t *fst = find_typed(s, "float", "st");
        if (st) {
            snprintf(st->name, sizeof st->name, "uv");
            changed = true;
        } else if (uv || fst) {
            uparam_t *p = uv ? uv : fst;
            snprintf(p->type, sizeof p->type, "point2");
            snprintf(p->name, sizeof p->name, "uv");
            changed = true;
        }
    }
    if (find(s, "Kd")) {
        rename_param(s, "Kd", "reflectance");
        changed = true;
    }
    if (changed)
        note(u, s->loc, "pbrt-v3's parameters of Shape \"%s\" rewritten", name);
    return changed;
}

static bool upgrade_stmt(up_t *u, stmt_t *s)
{
    const char *d = s->dir;
    if (!strcmp(d, "Material")) {
        return upgrade_material(u, s, &s->args[0], s->loc);
    } else if (!strcmp(d, "MakeNamedMaterial")) {
        uparam_t *t = find_typed(s, "string", "type");
        char *type = t && t->n == 1 ? t->v[0] : (char *)"";
        bool changed = upgrade_material(u, s, &type, s->loc);
        if (t)
            t->v[0] = type;
        else if (changed)
            add_param(u, s, "string", "type", true, type);
        return changed;
    } else if (!strcmp(d, "Texture")) {
        return upgrade_texture(u, s);
    } else if (!strcmp(d, "LightSource")) {
        return upgrade_light(u, s, false);
    } else if (!strcmp(d, "AreaLightSource")) {
        return upgrade_light(u, s, true);
    } else if (!strcmp(d, "Shape")) {
        return upgrade_shape(u, s);
    } else if (!strcmp(d, "Film")) {
        bool changed = false;
        uparam_t *m = find(s, "maxsampleluminance");
        if (m) {
            snprintf(m->name, sizeof m->name, "maxcomponentvalue");
            changed = true;
        }
        uparam_t *sc = find_typed(s, "float", "scale");
        double v;
        if (sc && sc->n == 1 && !pbrt_parse_number(sc->v[0], &v)) {
            sc->gone = true;
            add_float(u, s, "iso", 100.0 * v);
            changed = true;
        }
        if (!strcmp(s->args[0], "image")) {
            s->args[0] = own(u, strdup("rgb"));
            changed = true;
        }
        if (changed)
            note(u, s->loc,
                 "pbrt-v3's Film rewritten (\"image\" is \"rgb\", scale s is iso 100 s)");
        return changed;
    } else if (!strcmp(d, "Sampler")) {
        static const char *MAP[][2] = {{"lowdiscrepancy", "paddedsobol"},
                                       {"02sequence", "paddedsobol"},
                                       {"maxmindist", "pmj02bn"},
                                       {"random", "independent"}};
        for (size_t i = 0; i < sizeof MAP / sizeof MAP[0]; i++)
            if (!strcmp(s->args[0], MAP[i][0])) {
                note(u, s->loc, "pbrt-v3's Sampler \"%s\" is pbrt-v4's \"%s\"", MAP[i][0],
                     MAP[i][1]);
                s->args[0] = own(u, strdup(MAP[i][1]));
                return true;
            }
        return false;
    } else if (!strcmp(d, "PixelFilter")) {
        bool changed = false;
        uparam_t *xw = find_typed(s, "float", "xwidth"), *yw = find_typed(s, "float", "ywidth");
        if (xw)
            snprintf(xw->name, sizeof xw->name, "xradius");
        if (yw)
            snprintf(yw->name, sizeof yw->name, "yradius");
        changed = xw || yw;
        uparam_t *al = find_typed(s, "float", "alpha");
        double a;
        if (!strcmp(s->args[0], "gaussian") && al && al->n == 1 &&
            !pbrt_parse_number(al->v[0], &a) && a > 0.0) {
            al->gone = true;
            add_float(u, s, "sigma", 1.0 / sqrt(2.0 * a));
            changed = true;
        }
        if (changed)
            note(u, s->loc,
                 "pbrt-v3's PixelFilter widths are pbrt-v4's radii (gaussian alpha: sigma)");
        return changed;
    } else if (!strcmp(d, "Integrator")) {
        bool changed = false;
        if (find(s, "rrthreshold")) {
            drop(s, NULL, "rrthreshold");
            changed = true;
        }
        uparam_t *lss = find_typed(s, "string", "lightsamplestrategy");
        if (lss && lss->n == 1 && !strcmp(lss->v[0], "spatial")) {
            lss->v[0] = own(u, strdup("bvh"));
            changed = true;
        }
        if (lss)
            snprintf(lss->name, sizeof lss->name, "lightsampler");
        changed |= lss != NULL;
        if (!strcmp(s->args[0], "directlighting")) {
            s->args[0] = own(u, strdup("path"));
            drop(s, NULL, "maxdepth");
            drop(s, NULL, "strategy");
            add_param(u, s, "integer", "maxdepth", false, "1");
            changed = true;
        }
        if (changed)
            note(u, s->loc,
                 "pbrt-v3's Integrator rewritten (directlighting is path of maxdepth 1)");
        return changed;
    } else if (!strcmp(d, "Camera")) {
        if (!strcmp(s->args[0], "environment")) {
            s->args[0] = own(u, strdup("spherical"));
            add_param(u, s, "string", "mapping", true, "equirectangular");
            note(u, s->loc,
                 "pbrt-v3's Camera \"environment\" is pbrt-v4's \"spherical\" "
                 "\"equirectangular\"");
            return true;
        }
        if (!strcmp(s->args[0], "realistic") && find(s, "simpleweighting")) {
            drop(s, NULL, "simpleweighting");
            return true;
        }
        return false;
    } else if (!strcmp(d, "MakeNamedMedium")) {
        uparam_t *t = find_typed(s, "string", "type");
        if (t && t->n == 1 && !strcmp(t->v[0], "heterogeneous")) {
            t->v[0] = own(u, strdup("uniformgrid"));
            note(u, s->loc, "pbrt-v3's medium \"heterogeneous\" is pbrt-v4's \"uniformgrid\"");
            return true;
        }
        return false;
    }
    return false;
}

/* ---- reading statements and writing them back ---- */

static int nstring_args(const char *dir)
{
    if (!strcmp(dir, "Texture"))
        return 3;
    static const char *ONE[] = {
        "Material", "MakeNamedMaterial", "LightSource", "AreaLightSource", "Shape",          "Film",
        "Sampler",  "PixelFilter",       "Integrator",  "Camera",          "MakeNamedMedium"};
    for (size_t i = 0; i < sizeof ONE / sizeof ONE[0]; i++)
        if (!strcmp(dir, ONE[i]))
            return 1;
    return 0;
}

/* Reads tokens [a, b) of a statement whose directive takes nargs strings into *s. */
static bool read_stmt(up_t *u, tok_t *t, size_t a, size_t b, int nargs, stmt_t *s)
{
    memset(s, 0, sizeof *s);
    s->dir = t[a].text;
    s->loc = t[a].loc;
    size_t i = a + 1;
    for (int k = 0; k < nargs; k++, i++) {
        if (i >= b || t[i].kind != PBRT_TOKEN_STRING)
            return fail(u, t[a].loc, "%s: expected %d quoted names after it", s->dir, nargs), false;
        s->args[s->nargs++] = t[i].text;
    }
    while (i < b) {
        if (t[i].kind != PBRT_TOKEN_STRING)
            return fail(u, t[i].loc, "expected a parameter (\"type name\"), got \"%s\"", t[i].text),
                   false;
        if (s->np == MAX_PARAMS)
            return fail(u, t[i].loc, "too many parameters to upgrade"), false;
        uparam_t *p = &s->p[s->np++];
        memset(p, 0, sizeof *p);
        p->loc = t[i].loc;
        char extra[8];
        if (sscanf(t[i].text, "%47s %127s %7s", p->type, p->name, extra) != 2)
            return fail(u, t[i].loc, "bad parameter declaration \"%s\"", t[i].text), false;
        i++;
        if (i >= b)
            return fail(u, p->loc, "no value after \"%s\"", t[i - 1].text), false;
        size_t v0 = i, v1 = i + 1;
        if (t[i].kind == PBRT_TOKEN_LBRACKET) {
            v0 = i + 1;
            for (v1 = v0; v1 < b && t[v1].kind != PBRT_TOKEN_RBRACKET; v1++)
                ;
            if (v1 >= b)
                return fail(u, t[i].loc, "unterminated [ after \"%s %s\"", p->type, p->name), false;
            i = v1 + 1;
        } else {
            i++;
        }
        p->n = (int)(v1 - v0);
        p->v = (char **)own(u, calloc(p->n ? (size_t)p->n : 1, sizeof(char *)));
        if (!p->v)
            return false;
        for (size_t k = v0; k < v1; k++) {
            p->v[k - v0] = t[k].text;
            p->str = t[k].kind == PBRT_TOKEN_STRING;
        }
    }
    return true;
}

static void write_stmt(buf_t *o, const stmt_t *s)
{
    buf_add(o, s->dir, strlen(s->dir));
    for (int k = 0; k < s->nargs; k++) {
        buf_add(o, " ", 1);
        buf_quoted(o, s->args[k]);
    }
    buf_add(o, "\n", 1);
    for (int i = 0; i < s->np; i++) {
        const uparam_t *p = &s->p[i];
        if (p->gone)
            continue;
        buf_printf(o, "    \"%s %s\" [", p->type, p->name);
        for (int k = 0; k < p->n; k++) {
            buf_add(o, " ", 1);
            if (p->str)
                buf_quoted(o, p->v[k]);
            else
                buf_add(o, p->v[k], strlen(p->v[k]));
        }
        buf_add(o, " ]\n", 3);
    }
}

char *pbrt_upgrade_text(const char *file, const char *text, size_t len, warnings_t *w,
                        size_t *out_len, err_t *err)
{
    up_t u = {.w = w, .err = err};
    buf_t o = {0};
    tok_t *t = NULL;
    size_t nt = 0, capt = 0;
    size_t *line_start = NULL, nlines = 0;
    stmt_t *s = malloc(sizeof *s); /* large: one statement at a time */
    pbrt_lexer_t *lx = s ? pbrt_lexer_new(file, text, len, err) : NULL;
    if (!lx) {
        if (!s)
            err_set(err, "out of memory");
        free(s);
        return NULL;
    }
    /* Byte offsets of line starts, to place each token in the text. */
    line_start = malloc((len + 2) * sizeof *line_start);
    if (!line_start) {
        err_set(err, "out of memory");
        goto done;
    }
    line_start[nlines++] = 0;
    for (size_t i = 0; i < len; i++)
        if (text[i] == '\n')
            line_start[nlines++] = i + 1;
    for (;;) {
        pbrt_token_t tk;
        if (pbrt_lexer_next(lx, &tk, err)) {
            u.failed = true;
            goto done;
        }
        if (nt == capt) {
            capt = capt ? 2 * capt : 1024;
            tok_t *p = realloc(t, capt * sizeof *t);
            if (!p) {
                err_set(err, "out of memory");
                u.failed = true;
                goto done;
            }
            t = p;
        }
        t[nt].kind = tk.kind;
        t[nt].loc = tk.loc;
        t[nt].off = tk.loc.line >= 1 && (size_t)tk.loc.line <= nlines
                        ? line_start[tk.loc.line - 1] + (size_t)(tk.loc.col - 1)
                        : len;
        if (t[nt].off > len)
            t[nt].off = len;
        t[nt].text = strdup(tk.text ? tk.text : "");
        if (!t[nt].text) {
            err_set(err, "out of memory");
            u.failed = true;
            goto done;
        }
        nt++;
        if (tk.kind == PBRT_TOKEN_EOF)
            break;
    }
    /* Statements: a word outside brackets that is not a number or a boolean starts one. */
    size_t copied = 0; /* text before this offset is written */
    int depth = 0;
    size_t start = SIZE_MAX;
    for (size_t i = 0; i < nt && !u.failed; i++) {
        bool starts = t[i].kind == PBRT_TOKEN_EOF ||
                      (depth == 0 && t[i].kind == PBRT_TOKEN_WORD && !is_value_word(t[i].text));
        if (t[i].kind == PBRT_TOKEN_LBRACKET)
            depth++;
        else if (t[i].kind == PBRT_TOKEN_RBRACKET && depth > 0)
            depth--;
        if (!starts)
            continue;
        if (start != SIZE_MAX) {
            const char *dir = t[start].text;
            int nargs = nstring_args(dir);
            bool rewrite = false;
            if (!strcmp(dir, "WorldEnd")) {
                note(&u, t[start].loc, "pbrt-v3's WorldEnd dropped");
                buf_add(&o, text + copied, t[start].off - copied);
                buf_add(&o, "# WorldEnd (pbrt-v3)", 20);
                copied = t[start].off + strlen(dir);
                rewrite = false;
            } else if (!strcmp(dir, "TransformBegin") || !strcmp(dir, "TransformEnd")) {
                note(&u, t[start].loc, "%s is written as %s", dir,
                     dir[9] == 'B' ? "AttributeBegin" : "AttributeEnd");
                buf_add(&o, text + copied, t[start].off - copied);
                buf_add(&o, dir[9] == 'B' ? "AttributeBegin" : "AttributeEnd",
                        dir[9] == 'B' ? 14 : 12);
                copied = t[start].off + strlen(dir);
            } else if (nargs > 0) {
                if (!read_stmt(&u, t, start, i, nargs, s))
                    break;
                rewrite = upgrade_stmt(&u, s);
            }
            if (rewrite && !u.failed) {
                buf_add(&o, text + copied, t[start].off - copied);
                write_stmt(&o, s);
                /* The next statement keeps its indentation when it starts its own line. */
                size_t ls = t[i].loc.line >= 1 && (size_t)t[i].loc.line <= nlines
                                ? line_start[t[i].loc.line - 1]
                                : t[i].off;
                bool own_line = ls <= t[i].off;
                for (size_t k = ls; own_line && k < t[i].off; k++)
                    own_line = text[k] == ' ' || text[k] == '\t';
                copied = own_line && ls >= t[start].off ? ls : t[i].off;
            }
        }
        start = i;
    }
    if (!u.failed)
        buf_add(&o, text + copied, len - copied);
    if (o.oom && !u.failed) {
        err_set(err, "out of memory");
        u.failed = true;
    }
done:
    free(s);
    pbrt_lexer_destroy(&lx);
    for (size_t i = 0; i < nt; i++)
        free(t[i].text);
    free(t);
    free(line_start);
    for (size_t i = 0; i < u.nowned; i++)
        free(u.owned[i]);
    free(u.owned);
    if (u.failed) {
        free(o.s);
        return NULL;
    }
    if (!o.s)
        o.s = calloc(1, 1);
    if (!o.s) {
        err_set(err, "out of memory");
        return NULL;
    }
    *out_len = o.len;
    return o.s;
}

const char *pbrt_upgrade_v3_material(const char *name)
{
    static const char *const MAP[][2] = {
        {"uber", "coateddiffuse"},
        {"plastic", "coateddiffuse"},
        {"substrate", "coateddiffuse"},
        {"glass", "dielectric"},
        {"metal", "conductor"},
        {"mirror", "conductor"},
        {"matte", "diffuse"},
        {"disney", "diffuse"},
        {"translucent", "diffusetransmission"},
        {"kdsubsurface", "subsurface"},
    };
    for (size_t i = 0; i < sizeof MAP / sizeof MAP[0]; i++)
        if (!strcmp(name, MAP[i][0]))
            return MAP[i][1];
    return NULL;
}
