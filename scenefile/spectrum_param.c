#include "spectrum_param.h"

#include "pbrt_lexer.h"

#include <stdio.h>
#include <string.h>

int spectrum_param_numbers(const params_t *ps, const param_t *p, bool albedo,
                           spectrum_param_alloc_t alloc, void *ctx, scene_spectrum_t *out,
                           err_t *err)
{
    memset(out, 0, sizeof *out);
    out->loc = p->loc;
    switch (p->type) {
    case PARAM_FLOAT:
        if (p->count != 1)
            return pbrt_error(err, p->loc, "expected 1 number after \"%s %s\", got %zu",
                              p->type_name, p->name, p->count);
        if (albedo && (p->numbers[0] < 0.0 || p->numbers[0] > 1.0))
            return pbrt_error(err, p->loc, "\"%s %s\" must be within [0, 1], got %g", p->type_name,
                              p->name, p->numbers[0]);
        out->kind = SCENE_SPECTRUM_CONSTANT;
        out->constant = p->numbers[0];
        return 0;
    case PARAM_RGB:
        if (p->count != 3)
            return pbrt_error(err, p->loc, "expected 3 numbers after \"%s %s\", got %zu",
                              p->type_name, p->name, p->count);
        for (int i = 0; i < 3; i++) {
            if (p->numbers[i] < 0.0)
                return pbrt_error(err, p->loc, "\"%s %s\" has a negative component", p->type_name,
                                  p->name);
            if (albedo && p->numbers[i] > 1.0)
                return pbrt_error(err, p->loc,
                                  "\"%s %s\" has a component above 1 (a "
                                  "reflectance is at most 1)",
                                  p->type_name, p->name);
            out->rgb[i] = p->numbers[i];
        }
        out->kind = SCENE_SPECTRUM_RGB;
        return 0;
    case PARAM_BLACKBODY:
        if (p->count != 1)
            return pbrt_error(err, p->loc,
                              "expected 1 number after \"%s %s\", got %zu "
                              "(pbrt-v4 takes only the temperature)",
                              p->type_name, p->name, p->count);
        if (!(p->numbers[0] > 0.0))
            return pbrt_error(err, p->loc, "\"%s %s\" needs a temperature above 0 K, got %g",
                              p->type_name, p->name, p->numbers[0]);
        out->kind = SCENE_SPECTRUM_BLACKBODY;
        out->temperature = p->numbers[0];
        return 0;
    case PARAM_SPECTRUM: {
        if (p->values == PARAM_VALUES_STRINGS)
            return 1;
        if (p->count == 0)
            return pbrt_error(err, p->loc, "no values after \"%s %s\"", p->type_name, p->name);
        if (p->count % 2 != 0)
            return pbrt_error(err, p->loc,
                              "\"%s %s\" needs (wavelength, value) pairs, got %zu "
                              "numbers",
                              p->type_name, p->name, p->count);
        size_t n = p->count / 2;
        for (size_t i = 0; i < n; i++) {
            double l = p->numbers[2 * i], v = p->numbers[2 * i + 1];
            if (!(l > 0.0))
                return pbrt_error(err, p->loc,
                                  "\"%s %s\": wavelength %g in pair %zu is not "
                                  "positive",
                                  p->type_name, p->name, l, i + 1);
            if (i > 0 && !(l > p->numbers[2 * i - 2]))
                return pbrt_error(err, p->loc,
                                  "\"%s %s\": wavelengths must increase, but pair "
                                  "%zu has %g nm after %g nm",
                                  p->type_name, p->name, i + 1, l, p->numbers[2 * i - 2]);
            if (albedo && (v < 0.0 || v > 1.0))
                return pbrt_error(err, p->loc,
                                  "\"%s %s\": value %g in pair %zu is outside "
                                  "[0, 1] (a reflectance)",
                                  p->type_name, p->name, v, i + 1);
        }
        double *lv = alloc(ctx, 2 * n * sizeof *lv);
        if (!lv)
            return -1;
        for (size_t i = 0; i < n; i++) {
            lv[i] = p->numbers[2 * i];
            lv[n + i] = p->numbers[2 * i + 1];
        }
        out->kind = SCENE_SPECTRUM_SAMPLED;
        out->count = n;
        out->lambda = lv;
        out->value = lv + n;
        return 0;
    }
    default:
        break;
    }
    char expected[256];
    snprintf(expected, sizeof expected,
             "\"spectrum %s\", \"rgb %s\", \"blackbody %s\" or \"float %s\"", p->name, p->name,
             p->name, p->name);
    return params_wrong_type(ps, p, expected, err);
}
