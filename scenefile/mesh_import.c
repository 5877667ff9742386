#include "mesh_import.h"

#include "files.h"
#include "gzip_data.h"
#include "le_bytes.h"

#include <errno.h>
#include <fcntl.h>
#include <float.h>
#include <math.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>


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
 * PLY (Turk's format as pbrt-v4 reads it through rply, src/pbrt/util/mesh.cpp): a header of
 * elements, each a count and a list of scalar or list properties, then the instances in
 * ascii, binary_little_endian or binary_big_endian. From "vertex" the reader takes x y z, nx
 * ny nz (when all three are there) and texture coordinates u v (or s t, texture_u texture_v,
 * texture_s texture_t), of any scalar type and in any order; from "face" the list
 * vertex_indices (or vertex_index) of any count and index type: triangles as they are, quads
 * and larger polygons as a fan (0, k, k+1), which keeps the winding. Every other element and
 * property (colours, face_indices, texcoord lists, comments, obj_info) is read past. The file
 * is never trusted: an element's count must be backed by the bytes left before anything is
 * allocated for it (a binary instance takes at least the sizes of its scalars and list
 * lengths, an ascii one a character and a separator per property), a list by its own bytes,
 * every index must name a vertex, and kept values must be finite.
 * ------------------------------------------------------------------------------------------ */

enum { PLY_UNSIGNED, PLY_SIGNED, PLY_REAL };
enum { ROLE_OTHER, ROLE_VERTEX, ROLE_FACE }; /* elements */
/* properties: vertex slots 0..7 (x y z nx ny nz u v), or one of these */
enum { SLOT_NONE = -1, ROLE_INDICES = 100 };
enum { NSLOTS = 8 };

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
    bool slot[NSLOTS]; /* which vertex slots the header declares */
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

/* The next token of a line (separated by spaces and tabs); false at
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

/* Whether the whole token is a number of the type: digits, an optional sign and digits, or
 * a decimal with an optional point and exponent ("nan", "inf" and a decimal comma are
 * refused, so a value never reads as something else). */
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
 * most UINT32_MAX (the mesh keeps indices in 32 bits), with
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

/* The vertex slot a property name fills (pbrt-v4 mesh.cpp's names), or SLOT_NONE. */
static int ply_vertex_slot(const char *s, size_t n)
{
    static const struct {
        const char *name;
        int slot;
    } NAMES[] = {{"x", 0},         {"y", 1},         {"z", 2},         {"nx", 3},
                 {"ny", 4},        {"nz", 5},        {"u", 6},         {"s", 6},
                 {"texture_u", 6}, {"texture_s", 6}, {"v", 7},         {"t", 7},
                 {"texture_v", 7}, {"texture_t", 7}};
    for (size_t i = 0; i < sizeof NAMES / sizeof NAMES[0]; i++)
        if (tok_is(s, n, NAMES[i].name))
            return NAMES[i].slot;
    return SLOT_NONE;
}

static int ply_parse_header(const char *d, size_t len, const char *name, ply_header_t *h,
                            err_t *err)
{
    size_t limit = len < MESH_PLY_HEADER_BYTES_MAX ? len : MESH_PLY_HEADER_BYTES_MAX;
    size_t pos = 0;
    const char *line, *tok, *end;
    size_t n, tn;
    bool cr;
    int lineno = 0;
    while (ply_line(d, limit, &pos, &line, &n, &cr)) {
        lineno++;
        const char *p = line;
        end = line + n;
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
        if (tok_is(tok, tn, "comment") || tok_is(tok, tn, "obj_info"))
            continue;
        if (lineno == 2 || tok_is(tok, tn, "format")) {
            const char *fmt, *version;
            size_t fn, vn;
            if (lineno != 2 || !tok_is(tok, tn, "format") || !ply_token(&p, end, &fmt, &fn) ||
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
        if (tok_is(tok, tn, "end_header")) {
            if (ply_token(&p, end, &tok, &tn))
                return err_set(err, "\"%s\": line %d: text after end_header", name, lineno);
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
            int role = h->elements[h->nelements - 1].role;
            pr.role = SLOT_NONE;
            if (role == ROLE_VERTEX) {
                pr.role = ply_vertex_slot(pn, pnn);
                if (pr.role != SLOT_NONE && pr.list)
                    return err_set(err,
                                   "\"%s\": line %d: vertex property \"%.*s\" must be a single "
                                   "value, not a list",
                                   name, lineno, (int)(pnn < 40 ? pnn : 40), pn);
            } else if (role == ROLE_FACE &&
                       (tok_is(pn, pnn, "vertex_indices") || tok_is(pn, pnn, "vertex_index"))) {
                pr.role = ROLE_INDICES;
            }
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

/* The elements pbrt-v4 needs: one vertex element with x y z, one face element after it with
 * one integer index list. */
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
            for (size_t j = 0; j < e->nprops; j++) {
                int s = props[j].role;
                if (s != SLOT_NONE) {
                    if (h->slot[s])
                        return err_set(err, "\"%s\": vertex property %d of the header repeats a "
                                            "coordinate", name, (int)j + 1);
                    h->slot[s] = true;
                }
            }
            if (!h->slot[0] || !h->slot[1] || !h->slot[2])
                return err_set(err, "\"%s\": element vertex needs properties x, y and z", name);
        } else if (e->role == ROLE_FACE) {
            if (face)
                return err_set(err, "\"%s\": element face is declared twice", name);
            if (!vertex)
                return err_set(err, "\"%s\": element face comes before element vertex", name);
            face = e;
            int nindices = 0;
            for (size_t j = 0; j < e->nprops; j++) {
                nindices += props[j].role == ROLE_INDICES;
                if (props[j].role == ROLE_INDICES &&
                    (!props[j].list || props[j].item.kind == PLY_REAL))
                    return err_set(err, "\"%s\": vertex_indices must be a list of integers", name);
            }
            if (nindices != 1)
                return err_set(err, "\"%s\": element face needs one vertex_indices list", name);
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
                       "of the file are left for them (the file is truncated)",
                       name, e->name, (unsigned long long)e->count, left);
    return 0;
}

/* What the reader builds: the vertex slots and the triangles, grown as faces arrive. */
typedef struct ply_sink {
    const ply_header_t *h;
    const char *name;
    double *slots; /* NSLOTS per vertex */
    uint32_t *tris;
    size_t ntris, cap_tris;
    uint32_t face[4096]; /* the indices of the face being read (a longer one is refused) */
    size_t nface;
} ply_sink_t;

static int ply_face_index(ply_sink_t *s, uint64_t i, int sign, uint64_t v, err_t *err)
{
    if (sign < 0)
        return err_set(err, "\"%s\": face %llu uses a negative vertex index", s->name,
                       (unsigned long long)i);
    if (v >= s->h->nvertices)
        return err_set(err, "\"%s\": face %llu uses vertex %llu but there are only %llu", s->name,
                       (unsigned long long)i, (unsigned long long)v,
                       (unsigned long long)s->h->nvertices);
    if (s->nface == sizeof s->face / sizeof s->face[0])
        return err_set(err, "\"%s\": face %llu has more than %zu vertices", s->name,
                       (unsigned long long)i, sizeof s->face / sizeof s->face[0]);
    s->face[s->nface++] = (uint32_t)v;
    return 0;
}

/* Ends face i: a triangle as it is, a quad or polygon as the fan (0, k, k+1). */
static int ply_face_end(ply_sink_t *s, uint64_t i, err_t *err)
{
    size_t n = s->nface;
    s->nface = 0;
    if (n < 3)
        return err_set(err, "\"%s\": face %llu has %zu vertices (points and lines are not surfaces)",
                       s->name, (unsigned long long)i, n);
    if (s->ntris + (n - 2) > s->cap_tris) {
        size_t cap = s->cap_tris ? 2 * s->cap_tris : 1024;
        while (cap < s->ntris + (n - 2))
            cap *= 2;
        uint32_t *t = realloc(s->tris, cap * 3 * sizeof *t);
        if (!t)
            return err_set(err, "\"%s\": out of memory for %zu triangles", s->name, cap);
        s->tris = t;
        s->cap_tris = cap;
    }
    for (size_t k = 1; k + 1 < n; k++, s->ntris++) {
        s->tris[3 * s->ntris] = s->face[0];
        s->tris[3 * s->ntris + 1] = s->face[k];
        s->tris[3 * s->ntris + 2] = s->face[k + 1];
    }
    return 0;
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

/* A binary scalar as a double (integers by value, with their sign). */
static double ply_read_value(const unsigned char *b, ply_type_t t, bool big)
{
    if (t.kind == PLY_REAL)
        return ply_read_real(b, t, big);
    bool negative;
    uint64_t v = ply_read_int(b, t, big, &negative);
    if (negative)
        return -(double)((~v + 1) & (t.size == 8 ? ~0ull : ((1ull << (8 * t.size)) - 1)));
    return (double)v;
}

static int ply_read_binary(const ply_header_t *h, const char *d, size_t len, ply_sink_t *s,
                           err_t *err)
{
    const char *name = s->name;
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
        bool face = e->role == ROLE_FACE, vertex = e->role == ROLE_VERTEX;
        for (uint64_t i = 0; i < e->count; i++) {
            for (size_t j = 0; j < e->nprops; j++) {
                const ply_prop_t *pr = &props[j];
                size_t size = pr->list ? pr->count.size : pr->item.size;
                if (size > len - pos)
                    return err_set(err, "\"%s\": the file ends inside %s %llu (truncated)", name,
                                   e->name, (unsigned long long)i);
                if (!pr->list) {
                    if (vertex && pr->role != SLOT_NONE)
                        s->slots[NSLOTS * i + (size_t)pr->role] =
                            ply_read_value(u + pos, pr->item, big);
                    pos += size;
                    continue;
                }
                bool negative;
                uint64_t n = ply_read_int(u + pos, pr->count, big, &negative);
                pos += size;
                if (negative)
                    return err_set(err, "\"%s\": %s %llu has a list of negative length", name,
                                   e->name, (unsigned long long)i);
                if (n > (len - pos) / pr->item.size)
                    return err_set(err,
                                   "\"%s\": %s %llu has a list of %llu values, more than the "
                                   "%zu bytes left (truncated)",
                                   name, e->name, (unsigned long long)i, (unsigned long long)n,
                                   len - pos);
                if (face && pr->role == ROLE_INDICES)
                    for (uint64_t v = 0; v < n; v++) {
                        uint64_t idx =
                            ply_read_int(u + pos + v * pr->item.size, pr->item, big, &negative);
                        if (ply_face_index(s, i, negative ? -1 : 1, idx, err) != 0)
                            return -1;
                    }
                pos += (size_t)n * pr->item.size;
            }
            if (face && ply_face_end(s, i, err) != 0)
                return -1;
        }
    }
    return 0;
}

static int ply_read_ascii(const ply_header_t *h, const char *d, size_t len, ply_sink_t *s,
                          err_t *err)
{
    const char *name = s->name;
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
        bool face = e->role == ROLE_FACE, vertex = e->role == ROLE_VERTEX;
        for (uint64_t i = 0; i < e->count; i++) {
            if (!ply_line(d, len, &pos, &line, &n, &cr))
                return err_set(err, "\"%s\": the file ends before %s %llu (truncated)", name,
                               e->name, (unsigned long long)i);
            lineno++;
            const char *p = line, *end = line + n;
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
                    if (vertex && !pr->list && pr->role != SLOT_NONE) {
                        char num[64];
                        snprintf(num, sizeof num, "%.*s", (int)(tn < 63 ? tn : 63), tok);
                        s->slots[NSLOTS * i + (size_t)pr->role] = tn < 63 ? strtod(num, NULL) : NAN;
                    }
                    if (indices) {
                        uint64_t idx = 0;
                        int sign = ply_count(tok, tn, true, &idx);
                        if (sign == 0)
                            return err_set(err,
                                           "\"%s\": line %d: vertex index \"%.*s\" is out of "
                                           "range",
                                           name, lineno, (int)(tn < 40 ? tn : 40), tok);
                        if (ply_face_index(s, i, sign, idx, err) != 0)
                            return -1;
                    }
                }
            }
            if (ply_token(&p, end, &tok, &tn))
                return err_set(err, "\"%s\": line %d has more values than %s declares", name,
                               lineno, e->name);
            if (face && ply_face_end(s, i, err) != 0)
                return -1;
        }
    }
    for (; pos < len; pos++)
        if (d[pos] != ' ' && d[pos] != '\t' && d[pos] != '\r' && d[pos] != '\n')
            return err_set(err, "\"%s\": text after the last element (line %d)", name, lineno + 1);
    return 0;
}

/* Embree and the mesh's consumers keep coordinates as floats: a value beyond float's range
 * would become an infinity there. */
static bool ply_value_ok(double v)
{
    return isfinite(v) && fabs(v) <= FLT_MAX;
}

/* The vertex slots into the mesh's arrays, checking that kept values are finite floats. */
static int ply_fill(const ply_header_t *h, ply_sink_t *s, mesh_data_t *out, err_t *err)
{
    size_t nv = (size_t)h->nvertices;
    bool normals = h->slot[3] && h->slot[4] && h->slot[5], uvs = h->slot[6] && h->slot[7];
    out->nvertices = nv;
    out->P = malloc((nv ? nv : 1) * 3 * sizeof *out->P);
    out->N = normals ? malloc((nv ? nv : 1) * 3 * sizeof *out->N) : NULL;
    out->uv = uvs ? malloc((nv ? nv : 1) * 2 * sizeof *out->uv) : NULL;
    if (!out->P || (normals && !out->N) || (uvs && !out->uv))
        return err_set(err, "\"%s\": out of memory for %zu vertices", s->name, nv);
    for (size_t v = 0; v < nv; v++) {
        const double *sl = &s->slots[NSLOTS * v];
        for (int c = 0; c < 3; c++) {
            if (!ply_value_ok(sl[c]))
                return err_set(err,
                               "\"%s\": vertex %zu has a number that is not finite or beyond a "
                               "float's range (3.4e38)",
                               s->name, v);
            out->P[3 * v + (size_t)c] = sl[c];
            if (normals) {
                if (!ply_value_ok(sl[3 + c]))
                    return err_set(err, "\"%s\": the normal of vertex %zu is not finite", s->name, v);
                out->N[3 * v + (size_t)c] = sl[3 + c];
            }
        }
        if (uvs) {
            if (!ply_value_ok(sl[6]) || !ply_value_ok(sl[7]))
                return err_set(err, "\"%s\": the texture coordinates of vertex %zu are not finite",
                               s->name, v);
            out->uv[2 * v] = sl[6];
            out->uv[2 * v + 1] = sl[7];
        }
    }
    out->ntriangles = s->ntris;
    out->indices = s->tris;
    s->tris = NULL;
    return 0;
}

int mesh_import_ply_memory(const void *data, size_t len, const char *name, mesh_data_t *out,
                           err_t *err)
{
    memset(out, 0, sizeof *out);
    if (len > MESH_PLY_BYTES_MAX)
        return err_set(err, "\"%s\" is larger than %zu bytes", name, MESH_PLY_BYTES_MAX);
    const char *d = data;
    if (len < 4 || memcmp(d, "ply", 3) != 0 || (d[3] != '\n' && d[3] != '\r'))
        return err_set(err, "\"%s\" is not a PLY file (it does not start with \"ply\")", name);
    ply_header_t h = {0};
    ply_sink_t s = {.h = &h, .name = name};
    int rc = ply_parse_header(d, len, name, &h, err);
    if (rc == 0)
        rc = ply_check_elements(&h, name, err);
    if (rc == 0) {
        /* Backed by bytes: the vertex element's count was checked against the file first. */
        const ply_element_t *ve = NULL;
        size_t left = len - h.body;
        for (size_t k = 0; k < h.nelements; k++)
            if (h.elements[k].role == ROLE_VERTEX)
                ve = &h.elements[k];
        size_t min = h.format == PLY_ASCII ? 2 * ve->nprops : 0;
        for (size_t j = 0; h.format != PLY_ASCII && j < ve->nprops; j++)
            min += h.props[ve->first_prop + j].list ? h.props[ve->first_prop + j].count.size
                                                    : h.props[ve->first_prop + j].item.size;
        rc = ply_check_count(ve, min ? min : 1, left, h.format == PLY_ASCII, name, err);
        if (rc == 0 && h.nvertices >= UINT32_MAX)
            rc = err_set(err, "\"%s\" has too many vertices (%llu)", name,
                         (unsigned long long)h.nvertices);
        if (rc == 0) {
            s.slots = calloc(h.nvertices ? (size_t)h.nvertices : 1, NSLOTS * sizeof *s.slots);
            if (!s.slots)
                rc = err_set(err, "\"%s\": out of memory for %llu vertices", name,
                             (unsigned long long)h.nvertices);
        }
    }
    if (rc == 0)
        rc = h.format == PLY_ASCII ? ply_read_ascii(&h, d, len, &s, err)
                                   : ply_read_binary(&h, d, len, &s, err);
    if (rc == 0)
        rc = ply_fill(&h, &s, out, err);
    free(s.slots);
    free(s.tris);
    free(h.elements);
    free(h.props);
    if (rc != 0)
        mesh_data_free(out);
    return rc;
}

int mesh_import_ply_any(const void *data, size_t len, const char *name, mesh_data_t *out,
                        err_t *err)
{
    memset(out, 0, sizeof *out);
    if (!gzip_data_is_gzip(data, len))
        return mesh_import_ply_memory(data, len, name, out, err);
    char *plain;
    size_t n;
    if (gzip_data_inflate(data, len, MESH_PLY_BYTES_MAX, name, &plain, &n, err) != 0)
        return -1;
    int rc = mesh_import_ply_memory(plain, n, name, out, err);
    free(plain);
    return rc;
}

int mesh_import_ply_counts(const void *data, size_t len, const char *name, mesh_ply_counts_t *out,
                           err_t *err)
{
    memset(out, 0, sizeof *out);
    char *head = NULL;
    const char *d = data;
    if (gzip_data_is_gzip(data, len)) {
        size_t n;
        if (!(head = malloc(MESH_PLY_HEADER_BYTES_MAX)))
            return err_set(err, "out of memory reading \"%s\"", name);
        if (gzip_data_inflate_prefix(data, len, MESH_PLY_HEADER_BYTES_MAX, name, head, &n, err) !=
            0) {
            free(head);
            return -1;
        }
        d = head;
        len = n;
    }
    int rc = 0;
    ply_header_t h = {0};
    if (len < 4 || memcmp(d, "ply", 3) != 0 || (d[3] != '\n' && d[3] != '\r'))
        rc = err_set(err, "\"%s\" is not a PLY file (it does not start with \"ply\")", name);
    if (rc == 0)
        rc = ply_parse_header(d, len, name, &h, err);
    if (rc == 0)
        rc = ply_check_elements(&h, name, err);
    for (size_t k = 0; rc == 0 && k < h.nelements; k++) {
        const ply_element_t *e = &h.elements[k];
        uint64_t min = 0;
        for (size_t j = 0; j < e->nprops; j++) {
            const ply_prop_t *p = &h.props[e->first_prop + j];
            min += h.format == PLY_ASCII ? 2 : p->list ? p->count.size : p->item.size;
        }
        uint64_t bytes = min && e->count > UINT64_MAX / min ? UINT64_MAX : e->count * min;
        out->body_bytes = bytes > UINT64_MAX - out->body_bytes ? UINT64_MAX : out->body_bytes + bytes;
        if (e->role == ROLE_VERTEX)
            out->vertices = e->count;
        else if (e->role == ROLE_FACE)
            out->faces = e->count;
    }
    free(h.elements);
    free(h.props);
    free(head);
    return rc;
}

/* Reads a whole file (at most MESH_PLY_BYTES_MAX bytes) after checking its magic (PLY's, or
 * gzip's), so that a file that is not PLY (a scene file, a device) is not read any further. */
static char *read_ply(FILE *f, const char *path, size_t *len, err_t *err)
{
    size_t cap = 1 << 16, n;
    char *buf = malloc(cap);
    if (!buf) {
        err_set(err, "out of memory reading \"%s\"", path);
        return NULL;
    }
    n = fread(buf, 1, 4, f);
    if ((n < 4 || memcmp(buf, "ply", 3) != 0 || (buf[3] != '\n' && buf[3] != '\r')) &&
        !gzip_data_is_gzip(buf, n)) {
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
    int rc = mesh_import_ply_any(buf, len, path, out, err);
    free(buf);
    return rc;
}
