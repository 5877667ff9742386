#include "mesh_import.h"

#include "files.h"
#include "le_bytes.h"

#include <assimp/cimport.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <errno.h>
#include <float.h>
#include <math.h>
#include <stdbool.h>
#include <stdio.h>
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>
#include <stdlib.h>
#include <string.h>

void mesh_data_free(mesh_data_t *mesh)
{
    if (!mesh)
        return;
    free(mesh->P);
    free(mesh->N);
    free(mesh->uv);
    free(mesh->indices);
    memset(mesh, 0, sizeof *mesh);
}

/* ------------------------------------------------------------------------------------------
 * PLY structure check. assimp 5.2 (code/AssetLib/Ply) trusts the file:
 *  - it sizes arrays from the header's element counts (new aiVector3D[count] at the first
 *    vertex) and each list from its length field (avList.resize(n)) before reading a value:
 *    a 200-byte file declaring 2^31 vertices asks for 24 GiB, one declaring 2^27 holds
 *    1.5 GiB and loops 20 s over lines that are not there (measured);
 *  - a face with no vertex index (an empty list) trips an ai_assert in its triangulation that
 *    aborts the process (Debian builds assimp with assertions; found by test_pbrt_parser's PLY
 *    mutations), and a face element with texture coordinates but no index list crashes it;
 *  - triangulating a quad or polygon reads the positions of its indices before anything
 *    checks them (a quad with index 900000000 crashes it), and per-face texture coordinates
 *    are stored through the face's indices;
 *  - a comment or "obj_info" line among an element's properties, or a control character in a
 *    header line, makes it read another header than the one written, and so another layout;
 *  - reals beyond a float's range become infinite positions (it keeps floats);
 *  - its triangulation step asserts (abort) on faces it miscounts, which fuzzed headers with
 *    odd elements beside vertex and face still reached: so it is not used, and fill() splits
 *    polygons itself.
 * So the whole file is walked first, the way assimp reads it, and only this profile passes:
 * every count backed by bytes (a binary instance takes at least the sizes of its scalars and
 * list lengths, an ascii instance is one line with at least one character and one separator
 * per property, a list of n values needs n values); every real finite and within a float's
 * range; one "vertex" element of scalars; one "face" element, after it, with one integer list "vertex_indices" (or "vertex_index") of at
 * least 3 indices below the vertex count and, if any, one list "texcoord" of two values per
 * index; no "tristrips". The grammar is stricter than assimp's (exact tokens, numbers spelt as
 * its readers strtoul10, strtol10 and fast_atoreal consume them whole), so that both read the
 * same counts.
 * ------------------------------------------------------------------------------------------ */

enum { PLY_UNSIGNED, PLY_SIGNED, PLY_REAL };
enum { ROLE_OTHER, ROLE_VERTEX, ROLE_FACE };       /* elements */
enum { ROLE_VALUES, ROLE_INDICES, ROLE_TEXCOORD }; /* face properties */

typedef struct ply_type {
    unsigned char size, kind;
} ply_type_t;

typedef struct ply_prop {
    bool list;
    ply_type_t count, item; /* count only for lists */
    int role;
} ply_prop_t;

typedef struct ply_element {
    char name[64];
    uint64_t count;
    size_t first_prop, nprops; /* into the header's props */
    int role;
} ply_element_t;

typedef struct ply_header {
    enum { PLY_ASCII, PLY_LITTLE, PLY_BIG } format;
    ply_element_t *elements;
    size_t nelements, cap_elements;
    ply_prop_t *props;
    size_t nprops, cap_props;
    size_t body;   /* offset of the first byte after end_header's line */
    int body_line; /* line number of the first body line (ascii) */
    uint64_t nvertices;
} ply_header_t;

/* One line of the buffer from *pos (without its '\n' and a '\r' before it); false at the
 * end. *cr tells whether a '\r' was dropped. */
static bool ply_line(const char *d, size_t len, size_t *pos, const char **line, size_t *n, bool *cr)
{
    if (*pos >= len)
        return false;
    const char *start = d + *pos;
    const char *nl = memchr(start, '\n', len - *pos);
    size_t l = nl ? (size_t)(nl - start) : len - *pos;
    *pos += l + (nl ? 1 : 0);
    *cr = l > 0 && start[l - 1] == '\r';
    *line = start;
    *n = l - (*cr ? 1 : 0);
    return true;
}

/* The next token of a line (separated by spaces and tabs, as assimp's SkipSpaces); false at
 * the end of the line. */
static bool ply_token(const char **p, const char *end, const char **tok, size_t *n)
{
    while (*p < end && (**p == ' ' || **p == '\t'))
        (*p)++;
    if (*p >= end)
        return false;
    *tok = *p;
    while (*p < end && **p != ' ' && **p != '\t')
        (*p)++;
    *n = (size_t)(*p - *tok);
    return true;
}

static bool tok_is(const char *tok, size_t n, const char *word)
{
    return strlen(word) == n && !memcmp(tok, word, n);
}

static bool ply_type_named(const char *tok, size_t n, ply_type_t *t)
{
    static const struct {
        const char *name;
        ply_type_t type;
    } TYPES[] = {
        {"char", {1, PLY_SIGNED}},     {"int8", {1, PLY_SIGNED}},     {"uchar", {1, PLY_UNSIGNED}},
        {"uint8", {1, PLY_UNSIGNED}},  {"short", {2, PLY_SIGNED}},    {"int16", {2, PLY_SIGNED}},
        {"ushort", {2, PLY_UNSIGNED}}, {"uint16", {2, PLY_UNSIGNED}}, {"int", {4, PLY_SIGNED}},
        {"int32", {4, PLY_SIGNED}},    {"uint", {4, PLY_UNSIGNED}},   {"uint32", {4, PLY_UNSIGNED}},
        {"float", {4, PLY_REAL}},      {"float32", {4, PLY_REAL}},    {"double", {8, PLY_REAL}},
        {"float64", {8, PLY_REAL}},
    };
    for (size_t i = 0; i < sizeof TYPES / sizeof TYPES[0]; i++)
        if (tok_is(tok, n, TYPES[i].name)) {
            *t = TYPES[i].type;
            return true;
        }
    return false;
}

static bool is_digit(char c)
{
    return c >= '0' && c <= '9';
}

/* Whether the whole token is a number as assimp reads it for the type: strtoul10 (digits),
 * strtol10 (an optional sign, digits) or fast_atoreal (sign, digits with a point, exponent;
 * its "nan", "inf" and decimal comma are refused here). */
static bool ply_number_ok(const char *s, size_t n, int kind)
{
    size_t i = 0;
    if (kind != PLY_UNSIGNED && i < n && (s[i] == '+' || s[i] == '-'))
        i++;
    if (kind != PLY_REAL) {
        if (i == n)
            return false;
        for (; i < n; i++)
            if (!is_digit(s[i]))
                return false;
        return true;
    }
    size_t digits = 0;
    while (i < n && is_digit(s[i]))
        i++, digits++;
    if (i < n && s[i] == '.') {
        if (digits == 0 && !(i + 1 < n && is_digit(s[i + 1])))
            return false;
        for (i++; i < n && is_digit(s[i]); i++)
            digits++;
    }
    if (digits == 0)
        return false;
    if (i < n && (s[i] == 'e' || s[i] == 'E')) {
        i++;
        if (i < n && (s[i] == '+' || s[i] == '-'))
            i++;
        if (i == n || !is_digit(s[i]))
            return false;
        while (i < n && is_digit(s[i]))
            i++;
    }
    return i == n;
}

/* A decimal count ("element vertex 8", an ascii list length or vertex index): digits, at
 * most UINT32_MAX (assimp keeps counts in unsigned int; a larger one would wrap there), with
 * a sign when sign_ok. Returns 1, or -1 for a negative value, 0 for anything else. */
static int ply_count(const char *s, size_t n, bool sign_ok, uint64_t *out)
{
    size_t i = 0;
    bool negative = false;
    if (sign_ok && n > 0 && (s[0] == '+' || s[0] == '-'))
        negative = s[i++] == '-';
    if (i == n)
        return 0;
    uint64_t v = 0;
    for (; i < n; i++) {
        if (!is_digit(s[i]))
            return 0;
        v = v * 10 + (uint64_t)(s[i] - '0');
        if (v > UINT32_MAX)
            return 0;
    }
    if (negative && v != 0)
        return -1;
    *out = v;
    return 1;
}

static int ply_add_element(ply_header_t *h, const char *name, size_t n, uint64_t count)
{
    if (h->nelements == h->cap_elements) {
        size_t cap = h->cap_elements ? 2 * h->cap_elements : 4;
        ply_element_t *e = realloc(h->elements, cap * sizeof *e);
        if (!e)
            return -1;
        h->elements = e;
        h->cap_elements = cap;
    }
    ply_element_t *e = &h->elements[h->nelements++];
    snprintf(e->name, sizeof e->name, "%.*s", (int)(n < 60 ? n : 60), name);
    e->count = count;
    e->first_prop = h->nprops;
    e->nprops = 0;
    e->role = tok_is(name, n, "vertex") ? ROLE_VERTEX
              : tok_is(name, n, "face") ? ROLE_FACE
                                        : ROLE_OTHER;
    return 0;
}

static int ply_add_prop(ply_header_t *h, ply_prop_t p)
{
    if (h->nprops == h->cap_props) {
        size_t cap = h->cap_props ? 2 * h->cap_props : 16;
        ply_prop_t *q = realloc(h->props, cap * sizeof *q);
        if (!q)
            return -1;
        h->props = q;
        h->cap_props = cap;
    }
    h->props[h->nprops++] = p;
    h->elements[h->nelements - 1].nprops++;
    return 0;
}

static int ply_parse_header(const char *d, size_t len, const char *name, ply_header_t *h,
                            err_t *err)
{
    size_t limit = len < MESH_PLY_HEADER_BYTES_MAX ? len : MESH_PLY_HEADER_BYTES_MAX;
    size_t pos = 0;
    const char *line, *tok, *end;
    size_t n, tn;
    bool cr, any_cr = false;
    int lineno = 0, aside = 0; /* aside: the first of the comment lines just read */
    while (ply_line(d, limit, &pos, &line, &n, &cr)) {
        lineno++;
        any_cr = any_cr || cr;
        const char *p = line;
        end = line + n;
        /* assimp ends a header line at a NUL, '\f' or '\r' too: such bytes would make it read
         * another header than this one. */
        for (size_t i = 0; i < n; i++)
            if ((unsigned char)line[i] < 0x20 && line[i] != '\t')
                return err_set(err, "\"%s\": line %d of the PLY header holds a control character",
                               name, lineno);
        if (lineno == 1) {
            if (!tok_is(line, n, "ply"))
                return err_set(err, "\"%s\" is not a PLY file (it does not start with \"ply\")",
                               name);
            continue;
        }
        if (!ply_token(&p, end, &tok, &tn))
            return err_set(err, "\"%s\": line %d of the PLY header is empty", name, lineno);
        if (lineno == 2) {
            const char *fmt, *version;
            size_t fn, vn;
            if (!tok_is(tok, tn, "format") || !ply_token(&p, end, &fmt, &fn) ||
                !ply_token(&p, end, &version, &vn) || !tok_is(version, vn, "1.0") ||
                ply_token(&p, end, &tok, &tn))
                return err_set(err,
                               "\"%s\": line 2 must be \"format <ascii|binary_little_endian"
                               "|binary_big_endian> 1.0\"",
                               name);
            if (tok_is(fmt, fn, "ascii"))
                h->format = PLY_ASCII;
            else if (tok_is(fmt, fn, "binary_little_endian"))
                h->format = PLY_LITTLE;
            else if (tok_is(fmt, fn, "binary_big_endian"))
                h->format = PLY_BIG;
            else
                return err_set(err, "\"%s\": unknown PLY format \"%.*s\"", name,
                               (int)(fn < 40 ? fn : 40), fmt);
            continue;
        }
        /* assimp 5.2.5 ends an element's property list at a comment or obj_info line and
         * drops the properties after it (so another layout): such lines may stand before the
         * elements and after an element's last property only. */
        if (tok_is(tok, tn, "comment") || tok_is(tok, tn, "obj_info")) {
            if (!aside)
                aside = lineno;
            continue;
        }
        if (aside && tok_is(tok, tn, "property"))
            return err_set(err,
                           "\"%s\": line %d: a comment or obj_info line may not stand among an "
                           "element's properties",
                           name, aside);
        aside = 0;
        if (tok_is(tok, tn, "end_header")) {
            if (ply_token(&p, end, &tok, &tn))
                return err_set(err, "\"%s\": line %d: text after end_header", name, lineno);
            /* A binary body starts right after "end_header\n"; assimp reads a '\r' there as
             * the end of the line and would start one byte early. */
            if (h->format != PLY_ASCII && any_cr)
                return err_set(err,
                               "\"%s\": a binary PLY header must end its lines with \\n "
                               "alone",
                               name);
            h->body = pos;
            h->body_line = lineno + 1;
            return 0;
        }
        if (tok_is(tok, tn, "element")) {
            const char *en, *cnt;
            size_t enn, cn;
            uint64_t count;
            if (!ply_token(&p, end, &en, &enn) || !ply_token(&p, end, &cnt, &cn) ||
                ply_token(&p, end, &tok, &tn))
                return err_set(err, "\"%s\": line %d must be \"element <name> <count>\"", name,
                               lineno);
            if (ply_count(cnt, cn, false, &count) != 1)
                return err_set(err,
                               "\"%s\": line %d: element count \"%.*s\" is not a number in "
                               "0..%u",
                               name, lineno, (int)(cn < 40 ? cn : 40), cnt, UINT32_MAX);
            if (ply_add_element(h, en, enn, count) != 0)
                return err_set(err, "\"%s\": out of memory", name);
            continue;
        }
        if (tok_is(tok, tn, "property")) {
            if (h->nelements == 0)
                return err_set(err, "\"%s\": line %d: property before any element", name, lineno);
            ply_prop_t pr = {0};
            const char *t1, *pn;
            size_t t1n, pnn;
            bool ok = ply_token(&p, end, &t1, &t1n);
            if (ok && tok_is(t1, t1n, "list")) {
                const char *ct, *it;
                size_t ctn, itn;
                pr.list = true;
                ok = ply_token(&p, end, &ct, &ctn) && ply_type_named(ct, ctn, &pr.count) &&
                     pr.count.kind != PLY_REAL && ply_token(&p, end, &it, &itn) &&
                     ply_type_named(it, itn, &pr.item);
            } else {
                ok = ok && ply_type_named(t1, t1n, &pr.item);
            }
            if (!ok || !ply_token(&p, end, &pn, &pnn) || ply_token(&p, end, &tok, &tn))
                return err_set(err,
                               "\"%s\": line %d must be \"property <type> <name>\" or "
                               "\"property list <integer type> <type> <name>\"",
                               name, lineno);
            pr.role = tok_is(pn, pnn, "vertex_indices") || tok_is(pn, pnn, "vertex_index")
                          ? ROLE_INDICES
                      : tok_is(pn, pnn, "texcoord") ? ROLE_TEXCOORD
                                                    : ROLE_VALUES;
            if (ply_add_prop(h, pr) != 0)
                return err_set(err, "\"%s\": out of memory", name);
            continue;
        }
        return err_set(err, "\"%s\": unknown PLY header line %d \"%.*s\"", name, lineno,
                       (int)(n < 40 ? n : 40), line);
    }
    if (lineno < 2)
        return err_set(err, "\"%s\" is not a PLY file (it does not start with \"ply\")", name);
    return err_set(err, "\"%s\": no end_header in the first %zu bytes", name, limit);
}

/* The profile of the elements (see the top of this section). */
static int ply_check_elements(ply_header_t *h, const char *name, err_t *err)
{
    const ply_element_t *vertex = NULL, *face = NULL;
    for (size_t k = 0; k < h->nelements; k++) {
        ply_element_t *e = &h->elements[k];
        /* props is NULL while no element has a property: no offset from it (C17 6.5.6). */
        const ply_prop_t *props = e->nprops ? &h->props[e->first_prop] : NULL;
        if (!strcmp(e->name, "tristrips"))
            return err_set(err, "\"%s\": triangle strips (element tristrips) are not supported",
                           name);
        if (e->role == ROLE_VERTEX) {
            if (vertex)
                return err_set(err, "\"%s\": element vertex is declared twice", name);
            vertex = e;
            h->nvertices = e->count;
            for (size_t j = 0; j < e->nprops; j++)
                if (props[j].list)
                    return err_set(err,
                                   "\"%s\": vertex properties must be single values, not "
                                   "lists",
                                   name);
        } else if (e->role == ROLE_FACE) {
            if (face)
                return err_set(err, "\"%s\": element face is declared twice", name);
            if (!vertex)
                return err_set(err, "\"%s\": element face comes before element vertex", name);
            face = e;
            int nindices = 0, ntexcoords = 0;
            for (size_t j = 0; j < e->nprops; j++) {
                nindices += props[j].role == ROLE_INDICES;
                ntexcoords += props[j].role == ROLE_TEXCOORD && props[j].list;
                if (props[j].role == ROLE_INDICES &&
                    (!props[j].list || props[j].item.kind == PLY_REAL))
                    return err_set(err, "\"%s\": vertex_indices must be a list of integers", name);
            }
            if (nindices != 1 || ntexcoords > 1)
                return err_set(err,
                               "\"%s\": element face needs one vertex_indices list (and at "
                               "most one texcoord list)",
                               name);
        }
        if (e->count > 0 && e->nprops == 0)
            return err_set(err, "\"%s\": PLY element \"%s\" has instances but no properties", name,
                           e->name);
    }
    if (!face || face->count == 0)
        return err_set(err, "\"%s\" has no faces", name);
    return 0;
}

/* An element's instances must fit in the bytes left, each taking at least min bytes (slack:
 * bytes the last instance may do without). */
static int ply_check_count(const ply_element_t *e, size_t min, size_t left, size_t slack,
                           const char *name, err_t *err)
{
    if (e->count > 0 && e->count > (left + slack) / min)
        return err_set(err,
                       "\"%s\": PLY element \"%s\" declares %llu instances but only %zu bytes "
                       "of the file are left for them",
                       name, e->name, (unsigned long long)e->count, left);
    return 0;
}

/* One face, once its lists are read: at least 3 indices, two texture coordinates per index. */
static int ply_check_face(uint64_t i, uint64_t nindices, bool has_tc, uint64_t ntc,
                          const char *name, err_t *err)
{
    if (nindices < 3)
        return err_set(err,
                       "\"%s\": face %llu has %llu vertices (points and lines are not "
                       "surfaces)",
                       name, (unsigned long long)i, (unsigned long long)nindices);
    if (has_tc && ntc != 2 * nindices)
        return err_set(err,
                       "\"%s\": face %llu has %llu texture coordinates for %llu vertices (two "
                       "per vertex)",
                       name, (unsigned long long)i, (unsigned long long)ntc,
                       (unsigned long long)nindices);
    return 0;
}

static int ply_check_index(const ply_header_t *h, uint64_t i, int sign, uint64_t v,
                           const char *name, err_t *err)
{
    if (sign < 0)
        return err_set(err, "\"%s\": face %llu uses a negative vertex index", name,
                       (unsigned long long)i);
    if (v >= h->nvertices)
        return err_set(err, "\"%s\": face %llu uses vertex %llu but there are only %llu", name,
                       (unsigned long long)i, (unsigned long long)v,
                       (unsigned long long)h->nvertices);
    return 0;
}

/* assimp keeps every PLY number as a float: a real beyond float's range becomes an infinity
 * there, and infinite vertices make its triangulation abort (a fuzzer found it). */
static bool ply_real_ok(double v)
{
    return isfinite(v) && fabs(v) <= FLT_MAX;
}

static int ply_real_error(const char *name, const char *element, uint64_t i, err_t *err)
{
    return err_set(err, "\"%s\": %s %llu has a number that is not finite or beyond a float's "
                        "range (3.4e38)",
                   name, element, (unsigned long long)i);
}

/* A binary float or double at b. */
static double ply_read_real(const unsigned char *b, ply_type_t t, bool big)
{
    uint8_t c[8];
    for (int i = 0; i < t.size; i++)
        c[i] = b[big ? t.size - 1 - i : i]; /* into little-endian order */
    return t.size == 4 ? (double)le_get_f32(c) : le_get_f64(c);
}

/* An unsigned or two's-complement integer of size bytes; *negative tells its sign. */
static uint64_t ply_read_int(const unsigned char *b, ply_type_t t, bool big, bool *negative)
{
    uint64_t v = 0;
    for (int i = 0; i < t.size; i++)
        v |= (uint64_t)b[big ? t.size - 1 - i : i] << (8 * i);
    *negative = t.kind == PLY_SIGNED && (v >> (8 * t.size - 1)) & 1;
    return v;
}

static int ply_check_binary(const ply_header_t *h, const char *d, size_t len, const char *name,
                            err_t *err)
{
    size_t pos = h->body;
    bool big = h->format == PLY_BIG;
    const unsigned char *u = (const unsigned char *)d;
    for (size_t k = 0; k < h->nelements; k++) {
        const ply_element_t *e = &h->elements[k];
        const ply_prop_t *props = e->nprops ? &h->props[e->first_prop] : NULL;
        size_t min = 0;
        for (size_t j = 0; j < e->nprops; j++)
            min += props[j].list ? props[j].count.size : props[j].item.size;
        if (ply_check_count(e, min ? min : 1, len - pos, 0, name, err) != 0)
            return -1;
        bool face = e->role == ROLE_FACE;
        for (uint64_t i = 0; i < e->count; i++) {
            uint64_t nindices = 0, ntc = 0;
            bool has_tc = false;
            for (size_t j = 0; j < e->nprops; j++) {
                const ply_prop_t *pr = &props[j];
                size_t size = pr->list ? pr->count.size : pr->item.size;
                if (size > len - pos)
                    return err_set(err, "\"%s\": the file ends inside %s %llu", name, e->name,
                                   (unsigned long long)i);
                if (!pr->list) {
                    if (pr->item.kind == PLY_REAL && !ply_real_ok(ply_read_real(u + pos, pr->item, big)))
                        return ply_real_error(name, e->name, i, err);
                    pos += size;
                    continue;
                }
                bool negative;
                uint64_t n = ply_read_int(u + pos, pr->count, big, &negative);
                pos += size;
                /* assimp converts a signed length to unsigned: -1 would be 2^32 - 1. */
                if (negative)
                    return err_set(err, "\"%s\": %s %llu has a list of negative length", name,
                                   e->name, (unsigned long long)i);
                if (n > (len - pos) / pr->item.size)
                    return err_set(err,
                                   "\"%s\": %s %llu has a list of %llu values, more than the "
                                   "%zu bytes left",
                                   name, e->name, (unsigned long long)i, (unsigned long long)n,
                                   len - pos);
                if (face && pr->role == ROLE_INDICES) {
                    nindices = n;
                    for (uint64_t v = 0; v < n; v++) {
                        uint64_t idx =
                            ply_read_int(u + pos + v * pr->item.size, pr->item, big, &negative);
                        if (ply_check_index(h, i, negative ? -1 : 1, idx, name, err) != 0)
                            return -1;
                    }
                } else if (face && pr->role == ROLE_TEXCOORD) {
                    has_tc = true;
                    ntc = n;
                }
                if (pr->item.kind == PLY_REAL)
                    for (uint64_t v = 0; v < n; v++)
                        if (!ply_real_ok(ply_read_real(u + pos + v * pr->item.size, pr->item, big)))
                            return ply_real_error(name, e->name, i, err);
                pos += (size_t)n * pr->item.size;
            }
            if (face && ply_check_face(i, nindices, has_tc, ntc, name, err) != 0)
                return -1;
        }
    }
    return 0;
}

static int ply_check_ascii(const ply_header_t *h, const char *d, size_t len, const char *name,
                           err_t *err)
{
    size_t pos = h->body;
    int lineno = h->body_line - 1;
    const char *line, *tok;
    size_t n, tn;
    bool cr;
    for (size_t k = 0; k < h->nelements; k++) {
        const ply_element_t *e = &h->elements[k];
        const ply_prop_t *props = e->nprops ? &h->props[e->first_prop] : NULL;
        /* One character and one separator (space or line end) per property, except that the
         * file's last line may lack its '\n'. */
        if (ply_check_count(e, 2 * e->nprops, len - pos, 1, name, err) != 0)
            return -1;
        bool face = e->role == ROLE_FACE;
        for (uint64_t i = 0; i < e->count; i++) {
            if (!ply_line(d, len, &pos, &line, &n, &cr))
                return err_set(err, "\"%s\": the file ends before %s %llu", name, e->name,
                               (unsigned long long)i);
            lineno++;
            const char *p = line, *end = line + n;
            uint64_t nindices = 0, ntc = 0;
            bool has_tc = false;
            for (size_t j = 0; j < e->nprops; j++) {
                const ply_prop_t *pr = &props[j];
                uint64_t count = 1;
                if (pr->list) {
                    int c = 0;
                    if (ply_token(&p, end, &tok, &tn))
                        c = ply_count(tok, tn, pr->count.kind == PLY_SIGNED, &count);
                    if (c != 1)
                        return err_set(err,
                                       "\"%s\": line %d: a list length must be a "
                                       "non-negative integer",
                                       name, lineno);
                }
                bool indices = face && pr->list && pr->role == ROLE_INDICES;
                if (indices)
                    nindices = count;
                if (face && pr->list && pr->role == ROLE_TEXCOORD) {
                    has_tc = true;
                    ntc = count;
                }
                /* Reading the values one by one stops at the end of the line, so a list is
                 * never longer than its line. */
                for (uint64_t v = 0; v < count; v++) {
                    if (!ply_token(&p, end, &tok, &tn))
                        return err_set(err, "\"%s\": line %d has too few values for %s", name,
                                       lineno, e->name);
                    if (!ply_number_ok(tok, tn, pr->item.kind))
                        return err_set(err, "\"%s\": line %d: \"%.*s\" is not a%s number", name,
                                       lineno, (int)(tn < 40 ? tn : 40), tok,
                                       pr->item.kind == PLY_REAL       ? " decimal"
                                       : pr->item.kind == PLY_UNSIGNED ? " non-negative integer"
                                                                       : "n integer");
                    if (pr->item.kind == PLY_REAL) {
                        char num[64];
                        snprintf(num, sizeof num, "%.*s", (int)(tn < 63 ? tn : 63), tok);
                        if (tn >= 63 || !ply_real_ok(strtod(num, NULL)))
                            return ply_real_error(name, e->name, i, err);
                    }
                    uint64_t idx = 0;
                    int sign = indices ? ply_count(tok, tn, true, &idx) : 1;
                    if (indices && sign == 0)
                        return err_set(err,
                                       "\"%s\": line %d: vertex index \"%.*s\" is out of "
                                       "range",
                                       name, lineno, (int)(tn < 40 ? tn : 40), tok);
                    if (indices && ply_check_index(h, i, sign, idx, name, err) != 0)
                        return -1;
                }
            }
            if (ply_token(&p, end, &tok, &tn))
                return err_set(err, "\"%s\": line %d has more values than %s declares", name,
                               lineno, e->name);
            if (face && ply_check_face(i, nindices, has_tc, ntc, name, err) != 0)
                return -1;
        }
    }
    for (; pos < len; pos++)
        if (d[pos] != ' ' && d[pos] != '\t' && d[pos] != '\r' && d[pos] != '\n')
            return err_set(err, "\"%s\": text after the last element (line %d)", name, lineno + 1);
    return 0;
}

static int ply_check(const char *d, size_t len, const char *name, err_t *err)
{
    ply_header_t h = {0};
    int rc = ply_parse_header(d, len, name, &h, err);
    if (rc == 0)
        rc = ply_check_elements(&h, name, err);
    if (rc == 0)
        rc = h.format == PLY_ASCII ? ply_check_ascii(&h, d, len, name, err)
                                   : ply_check_binary(&h, d, len, name, err);
    free(h.elements);
    free(h.props);
    return rc;
}

static int fill(const struct aiScene *scene, const char *path, mesh_data_t *out, err_t *err)
{
    size_t nverts = 0, ntris = 0;
    bool normals = scene->mNumMeshes > 0, uvs = scene->mNumMeshes > 0;
    for (unsigned i = 0; i < scene->mNumMeshes; i++) {
        const struct aiMesh *m = scene->mMeshes[i];
        nverts += m->mNumVertices;
        for (unsigned f = 0; f < m->mNumFaces; f++) {
            if (m->mFaces[f].mNumIndices < 3)
                return err_set(err,
                               "\"%s\": face %u has %u vertices (points and lines are not "
                               "surfaces)",
                               path, f, m->mFaces[f].mNumIndices);
            ntris += m->mFaces[f].mNumIndices - 2;
        }
        normals = normals && m->mNormals;
        uvs = uvs && m->mTextureCoords[0];
    }
    if (ntris == 0)
        return err_set(err, "\"%s\" has no faces", path);
    if (nverts >= UINT32_MAX)
        return err_set(err, "\"%s\" has too many vertices (%zu)", path, nverts);

    out->nvertices = nverts;
    out->ntriangles = ntris;
    out->P = malloc(nverts * 3 * sizeof *out->P);
    out->N = normals ? malloc(nverts * 3 * sizeof *out->N) : NULL;
    out->uv = uvs ? malloc(nverts * 2 * sizeof *out->uv) : NULL;
    out->indices = malloc(ntris * 3 * sizeof *out->indices);
    if (!out->P || (normals && !out->N) || (uvs && !out->uv) || !out->indices)
        return err_set(err, "\"%s\": out of memory for %zu vertices", path, nverts);

    size_t v0 = 0, t = 0;
    for (unsigned i = 0; i < scene->mNumMeshes; i++) {
        const struct aiMesh *m = scene->mMeshes[i];
        for (unsigned v = 0; v < m->mNumVertices; v++) {
            const struct aiVector3D *p = &m->mVertices[v];
            if (!isfinite(p->x) || !isfinite(p->y) || !isfinite(p->z))
                return err_set(err, "\"%s\": vertex %zu is not finite", path, v0 + v);
            double *P = &out->P[3 * (v0 + v)];
            P[0] = p->x, P[1] = p->y, P[2] = p->z;
            if (normals) {
                const struct aiVector3D *n = &m->mNormals[v];
                if (!isfinite(n->x) || !isfinite(n->y) || !isfinite(n->z))
                    return err_set(err, "\"%s\": the normal of vertex %zu is not finite", path,
                                   v0 + v);
                double *N = &out->N[3 * (v0 + v)];
                N[0] = n->x, N[1] = n->y, N[2] = n->z;
            }
            if (uvs) {
                const struct aiVector3D *uv = &m->mTextureCoords[0][v];
                if (!isfinite(uv->x) || !isfinite(uv->y))
                    return err_set(err,
                                   "\"%s\": the texture coordinates of vertex %zu are not "
                                   "finite",
                                   path, v0 + v);
                out->uv[2 * (v0 + v)] = uv->x;
                out->uv[2 * (v0 + v) + 1] = uv->y;
            }
        }
        /* Assimp's PLY reader does not check indices against the vertex count. A polygon of n
         * vertices becomes the fan (0, k, k+1), k = 1..n-2: right for the convex polygons
         * exporters write (assimp's own ear-clipping step aborts on fuzzed files). */
        for (unsigned f = 0; f < m->mNumFaces; f++) {
            const struct aiFace *face = &m->mFaces[f];
            for (unsigned k = 0; k < face->mNumIndices; k++)
                if (face->mIndices[k] >= m->mNumVertices)
                    return err_set(err, "\"%s\": face %u uses vertex %u but there are only %u",
                                   path, f, face->mIndices[k], m->mNumVertices);
            for (unsigned k = 1; k + 1 < face->mNumIndices; k++, t++) {
                out->indices[3 * t] = (uint32_t)(v0 + face->mIndices[0]);
                out->indices[3 * t + 1] = (uint32_t)(v0 + face->mIndices[k]);
                out->indices[3 * t + 2] = (uint32_t)(v0 + face->mIndices[k + 1]);
            }
        }
        v0 += m->mNumVertices;
    }
    return 0;
}

int mesh_import_ply_memory(const void *data, size_t len, const char *name, mesh_data_t *out,
                           err_t *err)
{
    memset(out, 0, sizeof *out);
    if (len > MESH_PLY_BYTES_MAX)
        return err_set(err, "\"%s\" is larger than %zu bytes", name, MESH_PLY_BYTES_MAX);
    /* Assimp picks an importer from the file contents, so a file that is not PLY could load as
     * something else: insist on the PLY magic line first. */
    const char *d = data;
    if (len < 4 || memcmp(d, "ply", 3) != 0 || (d[3] != '\n' && d[3] != '\r'))
        return err_set(err, "\"%s\" is not a PLY file (it does not start with \"ply\")", name);
    if (ply_check(d, len, name, err) != 0)
        return -1;
    const struct aiScene *scene =
        aiImportFileFromMemory(d, (unsigned)len, 0, "ply");
    if (!scene) {
        const char *why = aiGetErrorString();
        return err_set(err, "cannot read PLY file \"%s\": %s", name,
                       why && *why ? why : "assimp gave no reason");
    }
    int rc = fill(scene, name, out, err);
    aiReleaseImport(scene);
    if (rc != 0)
        mesh_data_free(out);
    return rc;
}

/* Reads a whole file (at most MESH_PLY_BYTES_MAX bytes) after checking its magic, so that a
 * file that is not PLY (a scene file, a device) is not read any further. */
static char *read_ply(FILE *f, const char *path, size_t *len, err_t *err)
{
    size_t cap = 1 << 16, n;
    char *buf = malloc(cap);
    if (!buf) {
        err_set(err, "out of memory reading \"%s\"", path);
        return NULL;
    }
    n = fread(buf, 1, 4, f);
    if (n < 4 || memcmp(buf, "ply", 3) != 0 || (buf[3] != '\n' && buf[3] != '\r')) {
        free(buf);
        err_set(err, "\"%s\" is not a PLY file (it does not start with \"ply\")", path);
        return NULL;
    }
    for (;;) {
        if (n == cap) {
            size_t grown = cap * 2 <= MESH_PLY_BYTES_MAX + 1 ? cap * 2 : MESH_PLY_BYTES_MAX + 1;
            char *nb = grown > cap ? realloc(buf, grown) : NULL;
            if (!nb) {
                free(buf);
                if (grown > cap)
                    err_set(err, "out of memory reading \"%s\"", path);
                else
                    err_set(err, "\"%s\" is larger than %zu bytes", path, MESH_PLY_BYTES_MAX);
                return NULL;
            }
            buf = nb;
            cap = grown;
        }
        size_t got = fread(buf + n, 1, cap - n, f);
        n += got;
        if (got == 0)
            break;
    }
    if (ferror(f)) {
        free(buf);
        err_set(err, "cannot read PLY file \"%s\": %s", path, strerror(errno));
        return NULL;
    }
    *len = n;
    return buf;
}

int mesh_import_ply(const char *path, mesh_data_t *out, err_t *err)
{
    memset(out, 0, sizeof *out);
    /* A FIFO would block the open, a device never end: regular files only. */
    int fd = open(path, O_RDONLY | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0)
        return err_set(err, "cannot open PLY file \"%s\": %s", path, strerror(errno));
    struct stat st = {0};
    int flags;
    if (fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
        const char *kind = files_kind(st.st_mode);
        (void)close(fd);
        return err_set(err, "cannot open PLY file \"%s\": it is %s, not a regular file", path,
                       kind);
    }
    FILE *f = NULL;
    if ((flags = fcntl(fd, F_GETFL)) < 0 || fcntl(fd, F_SETFL, flags & ~O_NONBLOCK) < 0 ||
        !(f = fdopen(fd, "rb"))) {
        int e = errno;
        (void)close(fd);
        return err_set(err, "cannot open PLY file \"%s\": %s", path, strerror(e));
    }
    size_t len = 0;
    char *buf = read_ply(f, path, &len, err);
    fclose(f);
    if (!buf)
        return -1;
    int rc = mesh_import_ply_memory(buf, len, path, out, err);
    free(buf);
    return rc;
}
