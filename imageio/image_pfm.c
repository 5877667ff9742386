#include "image_pfm.h"

#include "files.h"

#include <ctype.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Skips white space, then reads one token of at most cap - 1 bytes. */
static int token(const uint8_t *d, size_t n, size_t *pos, char *out, size_t cap)
{
    while (*pos < n && isspace(d[*pos]))
        (*pos)++;
    size_t k = 0;
    while (*pos < n && !isspace(d[*pos])) {
        if (k + 1 >= cap)
            return -1;
        out[k++] = (char)d[(*pos)++];
    }
    out[k] = 0;
    return k > 0 ? 0 : -1;
}

int image_pfm_decode(const uint8_t *d, size_t n, const char *name, int *width, int *height,
                     float **rgb, err_t *err)
{
    size_t pos = 0;
    char magic[4], ws[16], hs[16], ss[64];
    if (token(d, n, &pos, magic, sizeof magic) || (strcmp(magic, "PF") && strcmp(magic, "Pf")))
        return err_set(err, "%s: not a PFM file (it must begin with \"PF\" or \"Pf\")", name);
    int channels = magic[1] == 'F' ? 3 : 1;
    char *end;
    if (token(d, n, &pos, ws, sizeof ws) || token(d, n, &pos, hs, sizeof hs) ||
        token(d, n, &pos, ss, sizeof ss))
        return err_set(err, "%s: truncated PFM header", name);
    long w = strtol(ws, &end, 10);
    if (*end || w <= 0)
        return err_set(err, "%s: PFM width \"%s\" is not a positive integer", name, ws);
    long h = strtol(hs, &end, 10);
    if (*end || h <= 0)
        return err_set(err, "%s: PFM height \"%s\" is not a positive integer", name, hs);
    double scale = strtod(ss, &end);
    if (*end || !isfinite(scale) || scale == 0.0)
        return err_set(err, "%s: PFM scale \"%s\" is not a non-zero number", name, ss);
    if ((size_t)w > IMAGE_PFM_MAX_PIXELS / (size_t)h)
        return err_set(err, "%s: PFM of %ldx%ld pixels is larger than %zu pixels", name, w, h,
                       IMAGE_PFM_MAX_PIXELS);
    if (pos >= n || !isspace(d[pos]))
        return err_set(err, "%s: truncated PFM header", name);
    pos++; /* the single white-space byte before the data */
    size_t npix = (size_t)w * (size_t)h, need = npix * (size_t)channels * 4;
    if (n - pos < need)
        return err_set(err, "%s: PFM data is truncated (%zu bytes for %ldx%ld, %zu present)", name,
                       need, w, h, n - pos);
    float *out = malloc(npix * 3 * sizeof *out);
    if (!out)
        return err_set(err, "%s: out of memory for %ldx%ld pixels", name, w, h);
    const int little = scale < 0.0;
    const uint8_t *p = d + pos;
    for (long y = 0; y < h; y++) {
        /* File row y counts from the bottom. */
        float *row = out + (size_t)(h - 1 - y) * (size_t)w * 3;
        for (long x = 0; x < w; x++)
            for (int c = 0; c < channels; c++) {
                uint32_t bits = little ? (uint32_t)p[0] | (uint32_t)p[1] << 8 |
                                             (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24
                                       : (uint32_t)p[3] | (uint32_t)p[2] << 8 |
                                             (uint32_t)p[1] << 16 | (uint32_t)p[0] << 24;
                p += 4;
                float f;
                memcpy(&f, &bits, sizeof f);
                if (channels == 3)
                    row[3 * x + c] = f;
                else
                    row[3 * x] = row[3 * x + 1] = row[3 * x + 2] = f;
            }
    }
    *width = (int)w;
    *height = (int)h;
    *rgb = out;
    return 0;
}

int image_pfm_read(const char *path, int *width, int *height, float **rgb, err_t *err)
{
    uint8_t *data;
    size_t size;
    if (files_read(path, 64 + IMAGE_PFM_MAX_PIXELS * 12, &data, &size, err))
        return -1;
    int rc = image_pfm_decode(data, size, path, width, height, rgb, err);
    free(data);
    return rc;
}
