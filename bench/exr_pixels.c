/* bench_exr_pixels: the pixel data of OpenEXR files, without their headers' strings.
 *
 *   bench_exr_pixels FILE.exr            one line per channel of every part and level:
 *                                        part, level, name, type, size, FNV-1a-64 of its samples
 *   bench_exr_pixels compare A.exr B.exr exit 0 if both files hold the same parts, levels and
 *                                        channels (name, type, sampling, data window) with the
 *                                        same sample bytes; else 1, naming the first differing
 *                                        channel, its first differing pixel and both values
 *
 * Exit status 2: a file could not be read (not an EXR, truncated, deep data, ...). Rip-mapped
 * parts stop at their first level with a y reduction: Debian 12's OpenEXRCore 3.1.5 locates
 * those tiles wrongly (the tile's own header disagrees; checked on files from exrmaketiled -r).
 * prismfarm writes single-part scanline files.
 *
 * It reads scanline and tiled parts (every mip/rip level), any compression the library decodes
 * and subsampled channels, with OpenEXRCore alone (it links no prismfarm library, so it builds
 * whatever the project's libraries are called). Each channel is decoded in its own type (UINT,
 * HALF or FLOAT), so the bytes compared and hashed are the file's samples, in scanline order,
 * little-endian as the file stores them on this (x86/ARM) machine. Attributes are ignored: the
 * renderer's EXRs carry timings and job strings that differ between runs with equal pixels.
 * bench/same_pixels.sh uses the compare mode. */
#define _POSIX_C_SOURCE 200809L

#include <openexr.h>

#include <inttypes.h>
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct channel {
    char *name;
    exr_pixel_type_t type;
    int xs, ys;       /* sampling */
    int bpe;          /* bytes per sample */
    int64_t w, h;     /* samples per row, rows (after subsampling) */
    uint8_t *data;    /* w * h * bpe bytes, scanline order */
} channel_t;

typedef struct level {
    int lx, ly;
    int64_t w, h; /* pixels of this level */
    int nch;
    channel_t *ch;
} level_t;

typedef struct part {
    char *name; /* "" when the part has none (single-part files) */
    exr_storage_t storage;
    exr_attr_box2i_t dw;
    int nlev;
    level_t *lev;
} part_t;

typedef struct file {
    const char *path;
    int nparts;
    part_t *parts;
} file_t;

static char errbuf[512];

static int fail(const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(errbuf, sizeof errbuf, fmt, ap);
    va_end(ap);
    return -1;
}

static const char *type_name(exr_pixel_type_t t)
{
    return t == EXR_PIXEL_UINT ? "UINT" : t == EXR_PIXEL_HALF ? "HALF" : t == EXR_PIXEL_FLOAT ? "FLOAT" : "?";
}

/* floor(a / b) for b > 0 */
static int64_t floor_div(int64_t a, int64_t b)
{
    return a >= 0 ? a / b : -((-a + b - 1) / b);
}

/* How many multiples of s lie in [a, b). */
static int64_t multiples(int64_t a, int64_t b, int64_t s)
{
    return b <= a ? 0 : floor_div(b - 1, s) - floor_div(a - 1, s);
}

static double half_to_double(uint16_t h)
{
    int e = (h >> 10) & 0x1f, m = h & 0x3ff;
    double v = e == 0 ? ldexp(m, -24) : e == 31 ? (m ? NAN : INFINITY) : ldexp(m | 0x400, e - 25);
    return (h & 0x8000) ? -v : v;
}

static void format_sample(const channel_t *c, int64_t i, char *buf, size_t size)
{
    const uint8_t *p = c->data + (size_t)i * (size_t)c->bpe;
    if (c->type == EXR_PIXEL_HALF) {
        uint16_t h;
        memcpy(&h, p, 2);
        snprintf(buf, size, "%.9g (0x%04x)", half_to_double(h), h);
    } else if (c->type == EXR_PIXEL_FLOAT) {
        float f;
        uint32_t u;
        memcpy(&f, p, 4);
        memcpy(&u, p, 4);
        snprintf(buf, size, "%.9g (0x%08" PRIx32 ")", (double)f, u);
    } else {
        uint32_t u;
        memcpy(&u, p, 4);
        snprintf(buf, size, "%" PRIu32, u);
    }
}

/* Decodes one chunk into the level's channel buffers; (col, row) is its top-left pixel in the
 * level (tiles) or (0, first row of every channel) given per channel (scanlines). */
static int decode_chunk(exr_const_context_t ctx, int p, const exr_chunk_info_t *chunk, level_t *L,
                        int64_t px0, int64_t py0, int scanline, int64_t miny, exr_decode_pipeline_t *dec,
                        int *initialised)
{
    exr_result_t rv = *initialised ? exr_decoding_update(ctx, p, chunk, dec) : exr_decoding_initialize(ctx, p, chunk, dec);
    if (rv != EXR_ERR_SUCCESS)
        return fail("cannot prepare chunk %d of part %d: %s", chunk->idx, p, exr_get_default_error_message(rv));
    *initialised = 1;
    for (int c = 0; c < dec->channel_count; c++) {
        exr_coding_channel_info_t *ci = &dec->channels[c];
        channel_t *ch = NULL;
        for (int k = 0; k < L->nch; k++)
            if (!strcmp(L->ch[k].name, ci->channel_name))
                ch = &L->ch[k];
        if (!ch)
            return fail("part %d: the decoder lists channel '%s' that the header does not", p, ci->channel_name);
        if (ci->height <= 0 || ci->width <= 0) {
            ci->decode_to_ptr = NULL;
            continue;
        }
        int64_t row = scanline ? multiples(miny, chunk->start_y, ch->ys) : py0;
        int64_t col = scanline ? 0 : px0;
        if (row + ci->height > ch->h || col + ci->width > ch->w)
            return fail("part %d: chunk %d of channel '%s' (%dx%d at %" PRId64 ",%" PRId64
                        ") lies outside its %" PRId64 "x%" PRId64 " samples",
                        p, chunk->idx, ch->name, ci->width, ci->height, col, row, ch->w, ch->h);
        ci->user_data_type = ch->type;
        ci->user_bytes_per_element = (int16_t)ch->bpe;
        ci->user_pixel_stride = ch->bpe;
        ci->user_line_stride = (int32_t)(ch->w * ch->bpe);
        ci->decode_to_ptr = ch->data + ((size_t)row * (size_t)ch->w + (size_t)col) * (size_t)ch->bpe;
    }
    rv = exr_decoding_choose_default_routines(ctx, p, dec);
    if (rv == EXR_ERR_SUCCESS)
        rv = exr_decoding_run(ctx, p, dec);
    if (rv != EXR_ERR_SUCCESS)
        return fail("cannot decode chunk %d of part %d: %s", chunk->idx, p, exr_get_default_error_message(rv));
    return 0;
}

static int make_level(level_t *L, int lx, int ly, int64_t w, int64_t h, const exr_attr_chlist_t *cl,
                      exr_attr_box2i_t dw, int tiled)
{
    L->lx = lx;
    L->ly = ly;
    L->w = w;
    L->h = h;
    L->nch = cl->num_channels;
    L->ch = calloc((size_t)(cl->num_channels > 0 ? cl->num_channels : 1), sizeof *L->ch);
    if (!L->ch)
        return fail("out of memory");
    for (int i = 0; i < cl->num_channels; i++) {
        const exr_attr_chlist_entry_t *e = &cl->entries[i];
        channel_t *c = &L->ch[i];
        c->name = strdup(e->name.str);
        c->type = e->pixel_type;
        c->xs = e->x_sampling > 0 ? e->x_sampling : 1;
        c->ys = e->y_sampling > 0 ? e->y_sampling : 1;
        c->bpe = e->pixel_type == EXR_PIXEL_HALF ? 2 : 4;
        if (tiled) {
            c->w = w;
            c->h = h;
        } else {
            c->w = multiples(dw.min.x, (int64_t)dw.max.x + 1, c->xs);
            c->h = multiples(dw.min.y, (int64_t)dw.max.y + 1, c->ys);
        }
        size_t bytes = (size_t)c->w * (size_t)c->h * (size_t)c->bpe;
        c->data = calloc(bytes ? bytes : 1, 1);
        if (!c->name || !c->data)
            return fail("out of memory for channel '%s' (%" PRId64 "x%" PRId64 ")", e->name.str, c->w, c->h);
    }
    return 0;
}

static int read_part(exr_const_context_t ctx, int p, part_t *P)
{
    const char *name = NULL;
    const exr_attr_chlist_t *cl = NULL;
    if (exr_get_name(ctx, p, &name) != EXR_ERR_SUCCESS)
        name = NULL;
    P->name = strdup(name ? name : "");
    exr_result_t rv = exr_get_storage(ctx, p, &P->storage);
    if (rv == EXR_ERR_SUCCESS)
        rv = exr_get_data_window(ctx, p, &P->dw);
    if (rv == EXR_ERR_SUCCESS)
        rv = exr_get_channels(ctx, p, &cl);
    if (rv != EXR_ERR_SUCCESS || !cl)
        return fail("cannot read the header of part %d: %s", p, exr_get_default_error_message(rv));
    if (P->storage != EXR_STORAGE_SCANLINE && P->storage != EXR_STORAGE_TILED)
        return fail("part %d holds deep data, which this tool does not read", p);
    int64_t w = (int64_t)P->dw.max.x - P->dw.min.x + 1, h = (int64_t)P->dw.max.y - P->dw.min.y + 1;
    if (w < 1 || h < 1)
        return fail("part %d: empty data window", p);
    exr_decode_pipeline_t dec = EXR_DECODE_PIPELINE_INITIALIZER;
    int initialised = 0, status = 0;
    if (P->storage == EXR_STORAGE_SCANLINE) {
        P->nlev = 1;
        P->lev = calloc(1, sizeof *P->lev);
        if (!P->lev)
            return fail("out of memory");
        if (make_level(&P->lev[0], 0, 0, w, h, cl, P->dw, 0))
            return -1;
        int32_t lines = 0;
        rv = exr_get_scanlines_per_chunk(ctx, p, &lines);
        if (rv != EXR_ERR_SUCCESS || lines < 1)
            return fail("part %d: cannot query scanlines per chunk", p);
        for (int64_t y = P->dw.min.y; y <= P->dw.max.y && status == 0; y += lines) {
            exr_chunk_info_t chunk;
            rv = exr_read_scanline_chunk_info(ctx, p, (int)y, &chunk);
            if (rv != EXR_ERR_SUCCESS)
                status = fail("part %d: cannot locate the chunk of scanline %" PRId64 ": %s", p, y,
                              exr_get_default_error_message(rv));
            else
                status = decode_chunk(ctx, p, &chunk, &P->lev[0], 0, 0, 1, P->dw.min.y, &dec, &initialised);
        }
    } else {
        uint32_t tw = 0, th = 0;
        exr_tile_level_mode_t mode;
        exr_tile_round_mode_t round;
        int32_t nlx = 0, nly = 0;
        rv = exr_get_tile_descriptor(ctx, p, &tw, &th, &mode, &round);
        if (rv == EXR_ERR_SUCCESS)
            rv = exr_get_tile_levels(ctx, p, &nlx, &nly);
        if (rv != EXR_ERR_SUCCESS || tw < 1 || th < 1 || nlx < 1 || nly < 1)
            return fail("part %d: cannot read the tile description", p);
        for (int i = 0; i < cl->num_channels; i++)
            if (cl->entries[i].x_sampling != 1 || cl->entries[i].y_sampling != 1)
                return fail("part %d: tiled channel '%s' is subsampled (not allowed by the format)", p,
                            cl->entries[i].name.str);
        P->nlev = mode == EXR_TILE_RIPMAP_LEVELS ? nlx * nly : nlx;
        P->lev = calloc((size_t)P->nlev, sizeof *P->lev);
        if (!P->lev)
            return fail("out of memory");
        for (int l = 0; l < P->nlev && status == 0; l++) {
            int lx = mode == EXR_TILE_RIPMAP_LEVELS ? l % nlx : l;
            int ly = mode == EXR_TILE_RIPMAP_LEVELS ? l / nlx : l;
            int32_t lw = 0, lh = 0;
            rv = exr_get_level_sizes(ctx, p, lx, ly, &lw, &lh);
            if (rv != EXR_ERR_SUCCESS || lw < 1 || lh < 1)
                return fail("part %d: cannot read the size of level (%d, %d)", p, lx, ly);
            if (make_level(&P->lev[l], lx, ly, lw, lh, cl, P->dw, 1))
                return -1;
            int64_t ntx = (lw + (int64_t)tw - 1) / tw, nty = (lh + (int64_t)th - 1) / th;
            for (int64_t ty = 0; ty < nty && status == 0; ty++)
                for (int64_t tx = 0; tx < ntx && status == 0; tx++) {
                    exr_chunk_info_t chunk;
                    rv = exr_read_tile_chunk_info(ctx, p, (int)tx, (int)ty, lx, ly, &chunk);
                    if (rv != EXR_ERR_SUCCESS)
                        status = fail("part %d: cannot locate tile (%" PRId64 ", %" PRId64 ") of level (%d, %d): %s", p,
                                      tx, ty, lx, ly, exr_get_default_error_message(rv));
                    else
                        status = decode_chunk(ctx, p, &chunk, &P->lev[l], tx * tw, ty * th, 0, 0, &dec, &initialised);
                }
        }
    }
    if (initialised)
        exr_decoding_destroy(ctx, &dec);
    return status;
}

static void on_error(exr_const_context_t ctx, exr_result_t code, const char *msg)
{
    (void)ctx;
    if (!errbuf[0])
        snprintf(errbuf, sizeof errbuf, "%s (%s)", msg ? msg : "", exr_get_error_code_as_string(code));
}

static int read_file(const char *path, file_t *f)
{
    f->path = path;
    errbuf[0] = 0;
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.error_handler_fn = on_error;
    init.flags = EXR_CONTEXT_FLAG_DISABLE_CHUNK_RECONSTRUCTION; /* a damaged file is an error */
    exr_context_t ctx = NULL;
    exr_result_t rv = exr_start_read(&ctx, path, &init);
    if (rv != EXR_ERR_SUCCESS) {
        if (!errbuf[0])
            fail("%s", exr_get_default_error_message(rv));
        return -1;
    }
    errbuf[0] = 0;
    int status = 0;
    if (exr_get_count(ctx, &f->nparts) != EXR_ERR_SUCCESS || f->nparts < 1)
        status = fail("cannot count the parts");
    if (status == 0 && !(f->parts = calloc((size_t)f->nparts, sizeof *f->parts)))
        status = fail("out of memory");
    for (int p = 0; status == 0 && p < f->nparts; p++)
        status = read_part(ctx, p, &f->parts[p]);
    exr_finish(&ctx);
    return status;
}

static uint64_t fnv1a64(const uint8_t *p, size_t n)
{
    uint64_t h = 0xcbf29ce484222325ULL;
    for (size_t i = 0; i < n; i++) {
        h ^= p[i];
        h *= 0x100000001b3ULL;
    }
    return h;
}

static int cmd_hash(const file_t *f)
{
    for (int p = 0; p < f->nparts; p++) {
        const part_t *P = &f->parts[p];
        for (int l = 0; l < P->nlev; l++) {
            const level_t *L = &P->lev[l];
            for (int c = 0; c < L->nch; c++) {
                const channel_t *ch = &L->ch[c];
                printf("part %d%s%s%s level %d,%d %s %s %" PRId64 "x%" PRId64 " fnv1a64 %016" PRIx64 "\n", p,
                       P->name[0] ? " '" : "", P->name, P->name[0] ? "'" : "", L->lx, L->ly, ch->name,
                       type_name(ch->type), ch->w, ch->h,
                       fnv1a64(ch->data, (size_t)ch->w * (size_t)ch->h * (size_t)ch->bpe));
            }
        }
    }
    return 0;
}

/* Prints what differs first and returns 1, or 0 when the pixels are the same. */
static int cmd_compare(const file_t *a, const file_t *b)
{
    if (a->nparts != b->nparts) {
        printf("DIFFERENT: %d parts vs %d parts\n", a->nparts, b->nparts);
        return 1;
    }
    for (int p = 0; p < a->nparts; p++) {
        const part_t *A = &a->parts[p], *B = &b->parts[p];
        if (strcmp(A->name, B->name) || A->storage != B->storage || A->nlev != B->nlev ||
            memcmp(&A->dw, &B->dw, sizeof A->dw)) {
            printf("DIFFERENT: part %d: name '%s' vs '%s', %s vs %s, %d vs %d levels, data window "
                   "(%d,%d)-(%d,%d) vs (%d,%d)-(%d,%d)\n",
                   p, A->name, B->name, A->storage == EXR_STORAGE_TILED ? "tiled" : "scanline",
                   B->storage == EXR_STORAGE_TILED ? "tiled" : "scanline", A->nlev, B->nlev, A->dw.min.x,
                   A->dw.min.y, A->dw.max.x, A->dw.max.y, B->dw.min.x, B->dw.min.y, B->dw.max.x, B->dw.max.y);
            return 1;
        }
        for (int l = 0; l < A->nlev; l++) {
            const level_t *LA = &A->lev[l], *LB = &B->lev[l];
            if (LA->nch != LB->nch) {
                printf("DIFFERENT: part %d: %d channels vs %d channels\n", p, LA->nch, LB->nch);
                return 1;
            }
            for (int c = 0; c < LA->nch; c++) {
                const channel_t *ca = &LA->ch[c], *cb = &LB->ch[c];
                if (strcmp(ca->name, cb->name) || ca->type != cb->type || ca->xs != cb->xs || ca->ys != cb->ys ||
                    ca->w != cb->w || ca->h != cb->h) {
                    printf("DIFFERENT: part %d channel %d: '%s' %s %" PRId64 "x%" PRId64 " vs '%s' %s %" PRId64
                           "x%" PRId64 "\n",
                           p, c, ca->name, type_name(ca->type), ca->w, ca->h, cb->name, type_name(cb->type), cb->w,
                           cb->h);
                    return 1;
                }
            }
            /* Same layout: the first differing channel (in the file's order) and sample. */
            int first = -1, ndiff_ch = 0;
            int64_t first_i = 0, ndiff_first = 0;
            for (int c = 0; c < LA->nch; c++) {
                const channel_t *ca = &LA->ch[c], *cb = &LB->ch[c];
                int64_t n = ca->w * ca->h, nd = 0, fi = -1;
                if (!memcmp(ca->data, cb->data, (size_t)n * (size_t)ca->bpe))
                    continue;
                for (int64_t i = 0; i < n; i++)
                    if (memcmp(ca->data + i * ca->bpe, cb->data + i * cb->bpe, (size_t)ca->bpe)) {
                        if (fi < 0)
                            fi = i;
                        nd++;
                    }
                ndiff_ch++;
                if (first < 0) {
                    first = c;
                    first_i = fi;
                    ndiff_first = nd;
                }
            }
            if (first >= 0) {
                const channel_t *ca = &LA->ch[first], *cb = &LB->ch[first];
                int64_t col = first_i % ca->w, row = first_i / ca->w;
                /* In data-window coordinates; in a tiled part's smaller levels, from the level's corner. */
                int64_t x = col, y = row;
                if (A->storage == EXR_STORAGE_SCANLINE) {
                    x = floor_div((int64_t)A->dw.min.x + ca->xs - 1, ca->xs) * ca->xs + col * ca->xs;
                    y = floor_div((int64_t)A->dw.min.y + ca->ys - 1, ca->ys) * ca->ys + row * ca->ys;
                } else if (LA->lx == 0 && LA->ly == 0) {
                    x += A->dw.min.x;
                    y += A->dw.min.y;
                }
                char va[64], vb[64];
                format_sample(ca, first_i, va, sizeof va);
                format_sample(cb, first_i, vb, sizeof vb);
                printf("DIFFERENT: part %d", p);
                if (A->storage == EXR_STORAGE_TILED)
                    printf(" level %d,%d", LA->lx, LA->ly);
                printf(" channel %s pixel (%" PRId64 ",%" PRId64 "): %s vs %s; %" PRId64 " of %" PRId64
                       " samples of %s differ, %d of %d channels differ\n",
                       ca->name, x, y, va, vb, ndiff_first, ca->w * ca->h, ca->name, ndiff_ch, LA->nch);
                return 1;
            }
        }
    }
    int nch = 0;
    for (int p = 0; p < a->nparts; p++)
        for (int l = 0; l < a->parts[p].nlev; l++)
            nch += a->parts[p].lev[l].nch;
    printf("identical: %d part%s, %d channel%s\n", a->nparts, a->nparts == 1 ? "" : "s", nch, nch == 1 ? "" : "s");
    return 0;
}

static void usage(FILE *out)
{
    fprintf(out, "usage: bench_exr_pixels FILE.exr            per channel: name, type, size, FNV-1a-64 of its samples\n"
                 "       bench_exr_pixels compare A.exr B.exr exit 0 if the pixel data are identical, else 1\n"
                 "(exit 2: a file cannot be read)\n");
}

int main(int argc, char **argv)
{
    if (argc == 2 && (!strcmp(argv[1], "--help") || !strcmp(argv[1], "-h"))) {
        usage(stdout);
        return 0;
    }
    if (argc == 2) {
        file_t f = {0};
        if (read_file(argv[1], &f)) {
            fprintf(stderr, "bench_exr_pixels: %s: %s\n", argv[1], errbuf);
            return 2;
        }
        return cmd_hash(&f);
    }
    if (argc == 4 && !strcmp(argv[1], "compare")) {
        file_t a = {0}, b = {0};
        for (int i = 0; i < 2; i++)
            if (read_file(argv[2 + i], i ? &b : &a)) {
                fprintf(stderr, "bench_exr_pixels: %s: %s\n", argv[2 + i], errbuf);
                printf("UNREADABLE: %s: %s\n", argv[2 + i], errbuf);
                return 2;
            }
        return cmd_compare(&a, &b);
    }
    usage(stderr);
    return 2;
}
