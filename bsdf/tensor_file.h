/* tensor_file: the container format of RGL's measured BSDF files (Dupuy & Jakob 2018; read
 * by pbrt-v4's Tensor class and Mitsuba's TensorFile): the 12 bytes "tensor_file\0", version
 * 1.0 (two bytes), a little-endian u32 field count, then per field a u16 name length, the
 * name, a u16 dimension count, a u8 type, a u64 byte offset of the data and a u64 extent per
 * dimension; the data of each field lies at its offset, little-endian, dimensions in C order.
 *
 * Guarantees: the bytes are untrusted. Every count, name, extent and data range is checked
 * against the buffer's length before anything is allocated or read, so a truncated or
 * hostile file is refused with a message naming the file (and the field) and what was
 * expected, and what is allocated is bounded by the buffer's length. The parsed file refers
 * to the caller's bytes, which must outlive it. */
#ifndef PRISMFARM_TENSOR_FILE_H
#define PRISMFARM_TENSOR_FILE_H

#include "err.h"
#include "le_bytes.h"

#include <stddef.h>
#include <stdint.h>

/* The element types (pbrt-v4's Tensor::Type numbering). */
typedef enum tensor_type {
    TENSOR_UINT8 = 1,
    TENSOR_INT8,
    TENSOR_UINT16,
    TENSOR_INT16,
    TENSOR_UINT32,
    TENSOR_INT32,
    TENSOR_UINT64,
    TENSOR_INT64,
    TENSOR_FLOAT16,
    TENSOR_FLOAT32,
    TENSOR_FLOAT64,
} tensor_type_t;

/* More dimensions than any RGL field has; a field with more is refused. */
#define TENSOR_MAX_DIMS 8

typedef struct tensor_field {
    char name[64]; /* longer names are refused */
    tensor_type_t type;
    int ndim;
    uint64_t shape[TENSOR_MAX_DIMS];
    uint64_t count;      /* product of the extents (1 for no dimensions) */
    const uint8_t *data; /* count elements, in the caller's buffer */
} tensor_field_t;

typedef struct tensor_file tensor_file_t;

/* Parses buf[0..len); name is the file's name for messages. NULL with err on bad input. */
tensor_file_t *tensor_file_parse(const uint8_t *buf, size_t len, const char *name, err_t *err);
void tensor_file_destroy(tensor_file_t **self_p);

/* The field called name, or NULL. */
const tensor_field_t *tensor_file_find(const tensor_file_t *self, const char *name);

/* The field called name of the given type and dimension count, or NULL with a message naming
 * the file, the field and what was expected (ndim < 0: any). */
const tensor_field_t *tensor_file_expect(const tensor_file_t *self, const char *name,
                                         tensor_type_t type, int ndim, err_t *err);

/* Element i of a FLOAT32 field. */
static inline float tensor_field_f32(const tensor_field_t *f, uint64_t i)
{
    return le_get_f32(f->data + 4 * i);
}

#endif
