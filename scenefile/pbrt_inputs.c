#define _XOPEN_SOURCE 700 /* strdup */

#include "pbrt_inputs.h"

#include "paths.h"
#include "pbrt_confine.h"
#include "spectrum_param.h"

#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>
#include <unistd.h>

/* Records a file the scene read (once per relative path): its path as opened and its path
 * relative to the main file's folder. */
int pbrt_inputs_note_file(parser_t *P, scene_file_kind_t kind, const char *path, const char *name,
                          pbrt_loc_t loc)
{
    bool named_absolute = name[0] == '/';
    char *dir = paths_folder(P->main_name), *rel = NULL;
    if (dir && named_absolute) {
        rel = paths_normalise(path);
    } else if (dir && (path[0] == '/') != (dir[0] == '/')) {
        /* A relative name under an absolutely named folder, or the reverse: compare both as
         * absolute paths. */
        char *a = paths_absolute(path), *b = paths_absolute(dir);
        rel = a && b ? paths_relative_to(b, a) : NULL;
        free(a);
        free(b);
    } else if (dir) {
        rel = paths_relative_to(dir, path);
    }
    free(dir);
    if (!rel)
        return pbrt_error(P->err, loc, "out of memory");
    int rc = 0;
    if (scene_desc_find_file(P->scene, rel) < 0) {
        int idx = scene_desc_add_file(P->scene, P->err);
        const char *sp = idx >= 0 ? scene_desc_strdup(P->scene, path, P->err) : NULL;
        const char *sr = sp ? scene_desc_strdup(P->scene, rel, P->err) : NULL;
        if (!sr) {
            rc = -1;
        } else {
            scene_file_t *f = &P->scene->files[idx];
            f->kind = kind;
            f->path = sp;
            f->relative = sr;
            f->outside = named_absolute || !strcmp(rel, "..") || !strncmp(rel, "../", 3);
            f->loc = loc;
        }
    }
    free(rel);
    return rc;
}

scene_spectrum_t pbrt_inputs_constant(double v, pbrt_loc_t loc)
{
    return (scene_spectrum_t){.kind = SCENE_SPECTRUM_CONSTANT, .constant = v, .loc = loc};
}

scene_spectrum_t pbrt_inputs_named(const char *name, pbrt_loc_t loc)
{
    return (scene_spectrum_t){.kind = SCENE_SPECTRUM_NAMED, .name = name, .loc = loc};
}

/* A number of a spectrum file and the line it is on. */
typedef struct spd_number {
    double v;
    int line;
} spd_number_t;

/* pbrt-v4's spectrum file (util/file.cpp ReadFloatFile, spectrum.cpp
 * PiecewiseLinearSpectrum::Read): numbers -- a run of [0-9.eE+-] that starts with a digit,
 * '.', '+' or '-' -- separated by white space, '#' to the end of the line a comment; the
 * numbers are (wavelength nm, value) pairs, wavelengths strictly increasing. pbrt-v4 also
 * skips other text with a warning (so a comma separates numbers too); prismfarm accepts commas
 * and refuses any other text, naming the line. Fills out (SAMPLED, arrays in the scene). */
static int parse_spd(parser_t *P, const param_t *p, const char *path, const char *text, size_t len,
                     int use, scene_spectrum_t *out)
{
    size_t cap = 64, n = 0;
    spd_number_t *num = malloc(cap * sizeof *num);
    if (!num)
        return pbrt_error(P->err, p->loc, "out of memory reading spectrum file \"%s\"", path);
    int line = 1, rc = 0;
    for (size_t i = 0; i < len && rc == 0;) {
        char c = text[i];
        if (c == '\n') {
            line++;
            i++;
        } else if (c == '#') {
            while (i < len && text[i] != '\n')
                i++;
        } else if (c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v' || c == ',') {
            i++;
        } else if ((c >= '0' && c <= '9') || c == '.' || c == '+' || c == '-') {
            size_t j = i;
            while (j < len &&
                   ((text[j] >= '0' && text[j] <= '9') || text[j] == '.' || text[j] == 'e' ||
                    text[j] == 'E' || text[j] == '+' || text[j] == '-'))
                j++;
            char tok[64];
            size_t tl = j - i < sizeof tok - 1 ? j - i : sizeof tok - 1;
            memcpy(tok, text + i, tl);
            tok[tl] = 0;
            char *end = NULL;
            double v = j - i < sizeof tok - 1 ? strtod(tok, &end) : NAN;
            if (!end || *end || !isfinite(v)) {
                rc = pbrt_error(P->err, p->loc,
                                "spectrum file \"%s\", line %d: \"%s\" is not a finite number",
                                path, line, tok);
                break;
            }
            if (n == cap) {
                spd_number_t *grown = realloc(num, 2 * cap * sizeof *num);
                if (!grown) {
                    rc = pbrt_error(P->err, p->loc, "out of memory reading spectrum file \"%s\"",
                                    path);
                    break;
                }
                num = grown;
                cap *= 2;
            }
            num[n++] = (spd_number_t){v, line};
            i = j;
        } else {
            char shown[24];
            size_t k = 0;
            while (i + k < len && k < 16 && text[i + k] != '\n' && text[i + k] != '\r')
                k++;
            memcpy(shown, text + i, k);
            shown[k] = 0;
            rc = pbrt_error(P->err, p->loc,
                            "spectrum file \"%s\", line %d: unexpected text \"%s\" (expected "
                            "numbers, '#' comments, spaces or commas)",
                            path, line, shown);
        }
    }
    if (rc == 0 && n == 0)
        rc = pbrt_error(P->err, p->loc, "spectrum file \"%s\" holds no numbers", path);
    if (rc == 0 && n % 2 != 0)
        rc = pbrt_error(P->err, p->loc,
                        "spectrum file \"%s\" holds %zu numbers, an odd count: it needs "
                        "(wavelength, value) pairs (the last number is on line %d)",
                        path, n, num[n - 1].line);
    for (size_t i = 0; rc == 0 && i < n / 2; i++) {
        const spd_number_t *l = &num[2 * i], *v = &num[2 * i + 1];
        if (!(l->v > 0.0))
            rc = pbrt_error(P->err, p->loc,
                            "spectrum file \"%s\", line %d: wavelength %g nm is not positive", path,
                            l->line, l->v);
        else if (i > 0 && !(l->v > num[2 * i - 2].v))
            rc = pbrt_error(P->err, p->loc,
                            "spectrum file \"%s\", line %d: wavelength %g nm does not follow %g "
                            "nm (line %d): wavelengths must increase",
                            path, l->line, l->v, num[2 * i - 2].v, num[2 * i - 2].line);
        else if (use == SPECTRUM_ALBEDO && (v->v < 0.0 || v->v > 1.0))
            rc = pbrt_error(P->err, p->loc,
                            "spectrum file \"%s\", line %d: value %g is outside [0, 1] (a "
                            "reflectance)",
                            path, v->line, v->v);
    }
    double *lv = rc == 0 ? scene_desc_alloc(P->scene, n * sizeof *lv, P->err) : NULL;
    if (rc == 0 && !lv)
        rc = -1;
    if (rc == 0) {
        size_t pairs = n / 2;
        for (size_t i = 0; i < pairs; i++) {
            lv[i] = num[2 * i].v;
            lv[pairs + i] = num[2 * i + 1].v;
        }
        out->kind = SCENE_SPECTRUM_SAMPLED;
        out->count = pairs;
        out->lambda = lv;
        out->value = lv + pairs;
    }
    free(num);
    return rc;
}

/* Reads a whole spectrum file of the user's own (unconfined) scene. */
char *pbrt_inputs_read_file(parser_t *P, const param_t *p, const char *path, const char *what,
                            size_t *len)
{
    FILE *f = fopen(path, "rb");
    if (!f) {
        pbrt_error(P->err, p->loc, "cannot open %s \"%s\": %s", what, path, strerror(errno));
        return NULL;
    }
    size_t cap = 4096, n = 0;
    char *buf = malloc(cap);
    while (buf) {
        n += fread(buf + n, 1, cap - n, f);
        if (n < cap)
            break;
        if (cap > PBRT_FILE_BYTES_MAX) {
            free(buf);
            fclose(f);
            pbrt_error(P->err, p->loc, "\"%s\" is larger than %zu bytes", path,
                       PBRT_FILE_BYTES_MAX);
            return NULL;
        }
        char *nb = realloc(buf, cap * 2);
        if (!nb)
            free(buf);
        buf = nb;
        cap *= 2;
    }
    int bad = ferror(f);
    fclose(f);
    if (!buf || bad) {
        free(buf);
        pbrt_error(P->err, p->loc, "cannot read %s \"%s\"", what, path);
        return NULL;
    }
    *len = n;
    return buf;
}

static char *read_spd_unconfined(parser_t *P, const param_t *p, const char *path, size_t *len)
{
    return pbrt_inputs_read_file(P, p, path, "spectrum file", len);
}

/* A string given for a spectrum (pbrt-v4 paramdict.cpp: a named spectrum, else a spectrum file
 * resolved like every file name). The parser cannot know the names (they live in spectral/,
 * which scenefile does not use), so: a name that is a file -- in the current file's folder,
 * else the main file's (pbrt-v4's rule), inside the root of a confined parse -- or that holds a
 * '/' is read as a spectrum file now, listed among the files read (so bundles carry it) and
 * confined like a PLY; any other string is kept as NAMED with the files looked for, and the
 * loader resolves it or names both. A file named like a named spectrum ("glass-BK7" with no
 * extension) is read, but the loader gives the named spectrum precedence, as pbrt-v4 does. */
static int spectrum_string(parser_t *P, const param_t *p, const char *name, int use,
                           scene_spectrum_t *out)
{
    char *first = paths_resolve(P->file, name), *second = paths_resolve(P->main_name, name);
    if (!first || !second) {
        free(first);
        free(second);
        return pbrt_error(P->err, p->loc, "out of memory");
    }
    bool two = name[0] != '/' && strcmp(first, second) != 0;
    const char *path = pbrt_confine_present(P, first)           ? first
                       : two && pbrt_confine_present(P, second) ? second
                                                                : NULL;
    char searched[2 * NAME_MAX_LEN + 16];
    if (two)
        snprintf(searched, sizeof searched, "\"%s\" and \"%s\"", first, second);
    else
        snprintf(searched, sizeof searched, "\"%s\"", first);
    int rc = 0;
    if (!path && !strchr(name, '/')) {
        out->kind = SCENE_SPECTRUM_NAMED;
        out->name = scene_desc_strdup(P->scene, name, P->err);
        out->searched = out->name ? scene_desc_strdup(P->scene, searched, P->err) : NULL;
        rc = out->searched ? 0 : -1;
    } else if (!path && !(P->root_lex && pbrt_confine_inside(P, first) == 0)) {
        rc = pbrt_error(P->err, p->loc,
                        "\"%s\" is not a named spectrum, and no spectrum file is there (looked "
                        "for %s)",
                        name, searched);
    } else {
        /* Outside a confined parse's root, confine() refuses it with its usual message. */
        const char *use_path = path ? path : first;
        size_t len = 0;
        char *buf = NULL;
        if (pbrt_confine_bundle_check(P, use_path, name, p->loc) != 0) {
            free(first);
            free(second);
            return -1;
        }
        if (P->root_real) {
            char *real = pbrt_confine_check(P, use_path, name, &p->loc, "spectrum file");
            buf = real ? pbrt_confine_read(P, real, name, use_path, &p->loc, "spectrum file", &len)
                       : NULL;
            free(real);
        } else {
            buf = read_spd_unconfined(P, p, use_path, &len);
        }
        rc = buf ? parse_spd(P, p, use_path, buf, len, use, out) : -1;
        free(buf);
        if (rc == 0) {
            out->name = scene_desc_strdup(P->scene, name, P->err);
            out->file = out->name ? scene_desc_strdup(P->scene, use_path, P->err) : NULL;
            rc = out->file ? pbrt_inputs_note_file(P, SCENE_FILE_SPECTRUM, use_path, name, p->loc)
                           : -1;
        }
    }
    free(first);
    free(second);
    return rc;
}

static void *desc_alloc(void *ctx, size_t size)
{
    parser_t *P = ctx;
    return scene_desc_alloc(P->scene, size, P->err);
}

/* A spectrum-valued parameter in its raw form: float (constant), rgb, blackbody, or spectrum
 * given as (lambda, value) pairs (spectrum_param.h, the reader the material loader shares) or
 * by name (pbrt-v4 paramdict.cpp extractSpectrumArray). */
int pbrt_inputs_spectrum_param(parser_t *P, params_t *ps, const param_t *p, int use,
                               scene_spectrum_t *out)
{
    const int rc =
        spectrum_param_numbers(ps, p, use == SPECTRUM_ALBEDO, desc_alloc, P, out, P->err);
    if (rc != 1)
        return rc;
    if (p->count != 1)
        return pbrt_error(P->err, p->loc, "expected 1 string after \"%s %s\", got %zu",
                          p->type_name, p->name, p->count);
    const char *name = p->strings[0];
    if (!*name)
        return pbrt_error(P->err, p->loc, "empty spectrum name in \"%s %s\"", p->type_name,
                          p->name);
    return spectrum_string(P, p, name, use, out);
}

int pbrt_inputs_spectrum(parser_t *P, params_t *ps, const char *name, scene_spectrum_t def, int use,
                         scene_spectrum_t *out)
{
    param_t *p = params_find(ps, name);
    if (!p) {
        *out = def;
        return 0;
    }
    return pbrt_inputs_spectrum_param(P, ps, p, use, out);
}

static int texture_ref(parser_t *P, params_t *ps, const param_t *p, scene_texture_type_t type,
                       int *out)
{
    (void)ps;
    if (p->count != 1)
        return pbrt_error(P->err, p->loc, "expected 1 string after \"%s %s\", got %zu",
                          p->type_name, p->name, p->count);
    int t = scene_desc_find_texture(P->scene, p->strings[0], type);
    if (t >= 0) {
        *out = t;
        return 0;
    }
    const char *want = type == SCENE_TEXTURE_FLOAT ? "float" : "spectrum";
    const char *other = type == SCENE_TEXTURE_FLOAT ? "spectrum" : "float";
    if (scene_desc_find_texture(P->scene, p->strings[0],
                                type == SCENE_TEXTURE_FLOAT ? SCENE_TEXTURE_SPECTRUM
                                                            : SCENE_TEXTURE_FLOAT) >= 0)
        return pbrt_error(P->err, p->loc,
                          "texture \"%s\" is a %s texture, but \"%s\" needs a %s "
                          "texture",
                          p->strings[0], other, p->name, want);
    return pbrt_error(P->err, p->loc,
                      "%s texture \"%s\" is not defined (a Texture must come "
                      "before its use)",
                      want, p->strings[0]);
}

int pbrt_inputs_float(parser_t *P, params_t *ps, const char *name, double def,
                      scene_float_input_t *out)
{
    out->texture = -1;
    out->value = def;
    param_t *p = params_find(ps, name);
    if (!p)
        return 0;
    if (p->type == PARAM_TEXTURE)
        return texture_ref(P, ps, p, SCENE_TEXTURE_FLOAT, &out->texture);
    if (p->type != PARAM_FLOAT) {
        char expected[160];
        snprintf(expected, sizeof expected, "\"float %s\" or \"texture %s\"", name, name);
        return params_wrong_type(ps, p, expected, P->err);
    }
    if (p->count != 1)
        return pbrt_error(P->err, p->loc, "expected 1 number after \"%s %s\", got %zu",
                          p->type_name, p->name, p->count);
    out->value = p->numbers[0];
    return 0;
}

int pbrt_inputs_spectrum_input(parser_t *P, params_t *ps, const char *name, scene_spectrum_t def,
                               int use, scene_spectrum_input_t *out)
{
    out->texture = -1;
    out->spectrum = def;
    param_t *p = params_find(ps, name);
    if (!p)
        return 0;
    if (p->type == PARAM_TEXTURE)
        return texture_ref(P, ps, p, SCENE_TEXTURE_SPECTRUM, &out->texture);
    return pbrt_inputs_spectrum_param(P, ps, p, use, &out->spectrum);
}

static bool ends_with_png(const char *s)
{
    size_t n = strlen(s);
    return n >= 4 && !strcasecmp(s + n - 4, ".png");
}

/* A file named by fp that the loader reads: the path to open into *out (in a confined parse
 * the checked real path, its bytes charged), listed among the files read as kind. A PNG image
 * in a confined parse is charged for its decoded pixels too (pbrt_confine_charge_png). */
static int loaded_file(parser_t *P, const param_t *fp, const char *filename, const char *what,
                       scene_file_kind_t file_kind, const char **out)
{
    const char *path = pbrt_confine_scene_path(P, filename, fp->loc);
    if (!path)
        return -1;
    if (P->root_real) {
        char *real = pbrt_confine_check(P, path, filename, &fp->loc, what);
        if (!real)
            return -1;
        int rc;
        if (file_kind == SCENE_FILE_IMAGE && ends_with_png(filename)) {
            rc = pbrt_confine_charge_png(P, real, filename, path, &fp->loc);
        } else {
            size_t size;
            int fd = pbrt_confine_open(P, real, filename, path, &fp->loc, what, &size);
            rc = fd < 0 ? -1 : pbrt_confine_charge(P, size, &fp->loc);
            if (fd >= 0)
                close(fd);
        }
        *out = rc == 0 ? scene_desc_strdup(P->scene, real, P->err) : NULL;
        free(real);
        if (!*out)
            return -1;
    } else {
        const char *kind;
        char why[96];
        FILE *f = pbrt_confine_open_regular(path, &kind);
        if (!f)
            return pbrt_error(P->err, fp->loc, "cannot open %s \"%s\": %s", what, path,
                              pbrt_confine_open_failure(kind, why, sizeof why));
        fclose(f);
        *out = path;
    }
    return pbrt_inputs_note_file(P, file_kind, path, filename, fp->loc);
}

/* An image file named by fp (a texture, a normal map, an environment). */
int pbrt_inputs_image_file(parser_t *P, const param_t *fp, const char *filename, const char **out)
{
    return loaded_file(P, fp, filename, "image", SCENE_FILE_IMAGE, out);
}

int pbrt_inputs_data_file(parser_t *P, const param_t *fp, const char *filename, const char *what,
                          scene_file_kind_t kind, const char **out)
{
    return loaded_file(P, fp, filename, what, kind, out);
}
