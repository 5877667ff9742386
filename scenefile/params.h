/* params: a directive's typed parameter list ("float radius" 2, "rgb L" [1 1 1], ...) as
 * pbrt-v4 declares it, with each parameter's location and whether it was looked up, so a
 * consumer can reject the parameters it did not use (pbrt-v4 treats those as errors).
 * Lookups check the declared type and the value count and say precisely what is wrong. */
#ifndef PRISMFARM_PARAMS_H
#define PRISMFARM_PARAMS_H

#include "err.h"
#include "pbrt_lexer.h"
#include "vec3.h"

#include <stdbool.h>
#include <stddef.h>

typedef enum param_type {
    PARAM_INTEGER,
    PARAM_FLOAT,
    PARAM_POINT2,
    PARAM_VECTOR2,
    PARAM_POINT3,  /* also spelled "point" */
    PARAM_VECTOR3, /* also spelled "vector" */
    PARAM_NORMAL3, /* "normal3" or "normal" */
    PARAM_RGB,     /* "rgb" or "color" */
    PARAM_SPECTRUM,
    PARAM_BLACKBODY,
    PARAM_BOOL,
    PARAM_STRING,
    PARAM_TEXTURE,
} param_type_t;

/* What a parameter's values are: numbers, strings or booleans. */
typedef enum param_values {
    PARAM_VALUES_NONE, /* "[ ]" */
    PARAM_VALUES_NUMBERS,
    PARAM_VALUES_STRINGS,
    PARAM_VALUES_BOOLS,
} param_values_t;

typedef struct param {
    param_type_t type;
    const char *type_name; /* as written: "point" stays "point" in messages */
    const char *name;
    pbrt_loc_t loc; /* of the "type name" declaration string */
    param_values_t values;
    size_t count; /* number of values (numbers, strings or bools) */
    double *numbers;
    char **strings;
    bool *bools;
    bool used;
} param_t;

typedef struct params params_t;

/* context names the owner in messages, e.g. "Shape \"sphere\"". */
params_t *params_new(const char *context, err_t *err);
void params_destroy(params_t **self_p);

/* Parses the declaration "type name" (a pbrt type keyword, white space, a name). Appends an
 * empty parameter and returns it, or NULL with a located error (unknown type, missing name,
 * extra words, or the same name declared twice). */
param_t *params_declare(params_t *self, const char *decl, pbrt_loc_t loc, err_t *err);
/* Append one value to a declared parameter. The caller (the parser) checks each value
 * against the type; these only refuse to mix numbers, strings and booleans in one list. */
int params_push_number(params_t *self, param_t *p, double v, err_t *err);
int params_push_string(params_t *self, param_t *p, const char *s, err_t *err);
int params_push_bool(params_t *self, param_t *p, bool b, err_t *err);

size_t params_count(const params_t *self);
param_t *params_at(const params_t *self, size_t i);
const char *params_context(const params_t *self);

/* Appends a copy of each parameter of defaults whose name self does not declare (pbrt-v4's
 * `Attribute` defaults: the entity's own value wins), at the default's own location, marked
 * used so that a default an entity ignores is no error. Fails only when out of memory. */
int params_add_defaults(params_t *self, const params_t *defaults, err_t *err);

/* The parameter called name, marked used, or NULL when absent. An absent name is copied
 * (the first 48 of them) as one the entity reads, for params_check_unused's "did you mean". */
param_t *params_find(params_t *self, const char *name);

/* Typed single-value lookups: absent gives def; present with the wrong type or the wrong
 * number of values fails with e.g. `expected 3 numbers after "point3 from", got 2`. */
int params_get_int(params_t *self, const char *name, int def, int *out, err_t *err);
int params_get_float(params_t *self, const char *name, double def, double *out, err_t *err);
int params_get_bool(params_t *self, const char *name, bool def, bool *out, err_t *err);
int params_get_string(params_t *self, const char *name, const char *def, const char **out,
                      err_t *err);
int params_get_point3(params_t *self, const char *name, vec3_t def, vec3_t *out, err_t *err);

/* Array lookup for a parameter of exactly this type: *out is NULL when absent; the value
 * count must be a non-zero multiple of the type's arity (3 for point3, ...). */
int params_get_array(params_t *self, const char *name, param_type_t type, param_t **out,
                     err_t *err);

/* Marks every parameter used: a directive that accepts its parameters without reading them
 * (what is not simulated, or has no effect on the image). */
void params_accept_all(params_t *self);

/* Fails on the first parameter (in file order) that no lookup marked used:
 * `file:line:col: unsupported parameter "float zmin" for Shape "sphere"`, followed by
 * ` (did you mean "roughness"?)` when a name the entity looked up and did not find is a slip
 * of the hand away (base/suggest.h). */
int params_check_unused(const params_t *self, err_t *err);

/* Fails with `"integer radius" has the wrong type for CONTEXT: expected ...`. */
int params_wrong_type(const params_t *self, const param_t *p, const char *expected, err_t *err);

const char *param_type_name(param_type_t type);
/* Numbers per item: 1, 2 (point2, vector2) or 3 (point3, vector3, normal3, rgb). */
int param_type_arity(param_type_t type);

#endif
