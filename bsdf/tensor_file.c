#include "tensor_file.h"

#include <stdbool.h>
#include <stdlib.h>
#include <string.h>

struct tensor_file {
    const char *name;
    size_t nfields;
    tensor_field_t *fields;
};

static const char MAGIC[12] = "tensor_file"; /* with its terminating zero: 12 bytes */

/* The fewest bytes a field's header takes: name length, dimension count, type, offset. */
enum { FIELD_HEADER_MIN = 2 + 2 + 1 + 8, FILE_HEADER = 12 + 2 + 4 };

static int type_size(int type)
{
    switch (type) {
    case TENSOR_UINT8:
    case TENSOR_INT8:
        return 1;
    case TENSOR_UINT16:
    case TENSOR_INT16:
    case TENSOR_FLOAT16:
        return 2;
    case TENSOR_UINT32:
    case TENSOR_INT32:
    case TENSOR_FLOAT32:
        return 4;
    case TENSOR_UINT64:
    case TENSOR_INT64:
    case TENSOR_FLOAT64:
        return 8;
    }
    return 0;
}

static const char *type_name(tensor_type_t type)
{
    static const char *NAMES[] = {"?",     "uint8",  "int8",  "uint16",  "int16",   "uint32",
                                  "int32", "uint64", "int64", "float16", "float32", "float64"};
    return (int)type >= 1 && (int)type <= TENSOR_FLOAT64 ? NAMES[type] : "?";
}

void tensor_file_destroy(tensor_file_t **self_p)
{
    if (!self_p || !*self_p)
        return;
    free((*self_p)->fields);
    free(*self_p);
    *self_p = NULL;
}

/* A cursor over the header that refuses to read past the end. */
typedef struct cursor {
    const uint8_t *buf;
    size_t len, at;
} cursor_t;

static bool take(cursor_t *c, size_t n, const uint8_t **p)
{
    if (n > c->len - c->at)
        return false;
    *p = c->buf + c->at;
    c->at += n;
    return true;
}

static int truncated(const char *name, size_t at, const char *what, size_t field, err_t *err)
{
    if (field)
        return err_set(err,
                       "%s: not a whole tensor file: it ends at byte %zu, inside field %zu's %s",
                       name, at, field, what);
    return err_set(err, "%s: not a whole tensor file: it ends at byte %zu, inside the %s", name, at,
                   what);
}

static int read_field(cursor_t *c, const char *name, size_t k, tensor_field_t *f, err_t *err)
{
    const uint8_t *p;
    if (!take(c, 2, &p))
        return truncated(name, c->len, "name length", k, err);
    uint16_t nlen = le_get_u16(p);
    if (!take(c, nlen, &p))
        return truncated(name, c->len, "name", k, err);
    if (nlen >= sizeof f->name || memchr(p, 0, nlen))
        return err_set(err,
                       "%s: field %zu's name is %u bytes or holds a zero byte (expected a "
                       "name of at most %zu bytes)",
                       name, k, nlen, sizeof f->name - 1);
    memcpy(f->name, p, nlen);
    f->name[nlen] = 0;
    if (!take(c, 2 + 1 + 8, &p))
        return truncated(name, c->len, "header", k, err);
    uint16_t ndim = le_get_u16(p);
    uint8_t type = p[2];
    uint64_t offset = le_get_u64(p + 3);
    int size = type_size(type);
    if (!size)
        return err_set(err, "%s: field \"%s\" has type %u (expected 1 to 11, uint8 to float64)",
                       name, f->name, type);
    if (ndim > TENSOR_MAX_DIMS)
        return err_set(err, "%s: field \"%s\" has %u dimensions (at most %d expected)", name,
                       f->name, ndim, TENSOR_MAX_DIMS);
    f->type = (tensor_type_t)type;
    f->ndim = ndim;
    /* Every extent and the product stay below the file's length in elements: a field's data
     * must fit in the file, so nothing larger is ever meaningful (and nothing overflows). */
    uint64_t count = 1;
    const uint64_t limit = c->len / (uint64_t)size;
    for (int d = 0; d < ndim; d++) {
        if (!take(c, 8, &p))
            return truncated(name, c->len, "shape", k, err);
        f->shape[d] = le_get_u64(p);
        if (f->shape[d] == 0)
            count = 0;
        else if (count && f->shape[d] > limit / count)
            return err_set(err,
                           "%s: field \"%s\" claims more elements than the file's %zu bytes "
                           "can hold (dimension %d is %llu)",
                           name, f->name, c->len, d + 1, (unsigned long long)f->shape[d]);
        else
            count *= f->shape[d];
    }
    f->count = count;
    const uint64_t bytes = count * (uint64_t)size;
    if (offset > c->len || bytes > c->len - offset)
        return err_set(err,
                       "%s: field \"%s\" needs bytes %llu to %llu, past the file's end at %zu "
                       "(a truncated file?)",
                       name, f->name, (unsigned long long)offset,
                       (unsigned long long)(offset + bytes), c->len);
    f->data = c->buf + offset;
    return 0;
}

tensor_file_t *tensor_file_parse(const uint8_t *buf, size_t len, const char *name, err_t *err)
{
    if (len < FILE_HEADER || memcmp(buf, MAGIC, sizeof MAGIC) != 0) {
        err_set(err,
                "%s: not a tensor file (expected it to start with \"tensor_file\", as RGL's "
                "measured BSDF files do)",
                name);
        return NULL;
    }
    if (buf[12] != 1 || buf[13] != 0) {
        err_set(err, "%s: tensor file version %u.%u (expected 1.0)", name, buf[12], buf[13]);
        return NULL;
    }
    uint32_t n = le_get_u32(buf + 14);
    if (n > (len - FILE_HEADER) / FIELD_HEADER_MIN) {
        err_set(err, "%s: claims %u fields, more than its %zu bytes can describe (truncated?)",
                name, n, len);
        return NULL;
    }
    tensor_file_t *t = calloc(1, sizeof *t);
    if (t)
        t->fields = calloc(n ? n : 1, sizeof *t->fields);
    if (!t || !t->fields) {
        tensor_file_destroy(&t);
        err_set(err, "%s: out of memory", name);
        return NULL;
    }
    t->name = name;
    cursor_t c = {buf, len, FILE_HEADER};
    for (uint32_t k = 0; k < n; k++) {
        if (read_field(&c, name, k + 1, &t->fields[k], err) != 0) {
            tensor_file_destroy(&t);
            return NULL;
        }
        if (tensor_file_find(t, t->fields[k].name)) {
            err_set(err, "%s: field \"%s\" appears twice", name, t->fields[k].name);
            tensor_file_destroy(&t);
            return NULL;
        }
        t->nfields = k + 1;
    }
    return t;
}

const tensor_field_t *tensor_file_find(const tensor_file_t *t, const char *name)
{
    for (size_t i = 0; i < t->nfields; i++)
        if (!strcmp(t->fields[i].name, name))
            return &t->fields[i];
    return NULL;
}

const tensor_field_t *tensor_file_expect(const tensor_file_t *t, const char *name,
                                         tensor_type_t type, int ndim, err_t *err)
{
    const tensor_field_t *f = tensor_file_find(t, name);
    if (!f) {
        err_set(err,
                "%s: no field \"%s\" (an RGL measured BSDF file has theta_i, phi_i, ndf, "
                "sigma, vndf, luminance, spectra, wavelengths, description and jacobian)",
                t->name, name);
        return NULL;
    }
    if (f->type != type || (ndim >= 0 && f->ndim != ndim)) {
        err_set(err, "%s: field \"%s\" is %s with %d dimensions (expected %s with %d)", t->name,
                name, type_name(f->type), f->ndim, type_name(type), ndim);
        return NULL;
    }
    return f;
}
