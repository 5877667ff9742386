/* journal_blobs: the bytes the journal keeps -- a tile result, a photon batch, a checkpoint
 * file -- packed and unpacked, each refused by name when it is not of this version. */
#include "journal_db.h"


#include "clock.h"
#include "files.h"
#include "sha256.h"
#include "tilebuf.h"

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <sqlite3.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zlib.h>
#define TILE_MAGIC 0x58544650u  /* "PFTX" in this host's order: a blob of another is refused */
#define PHOT_MAGIC 0x48504650u  /* "PFPH" */
#define CKPT_MAGIC 0x53434650u  /* "PFCS": a checkpoint with its round and SHA-256 */
/* Version 5's first checkpoints, without a checksum: recognised only to say so (the job then
 * falls back to an older checkpoint or renders those passes again). */
#define CKPT_MAGIC_NOSUM 0x58434650u /* "PFCX" */
/* Version 4's, without XYZ sums: recognised only to say so. */
#define TILE_MAGIC_V4 0x4b544650u /* "PFTK" */
#define CKPT_MAGIC_V4 0x4b434650u /* "PFCK" */
#define MAX_IMAGE_SIDE 65536
#define MAX_BUCKETS 4096 /* a Stokes output's four planes of SPECTRAL_GRID_MAX_BUCKETS */

typedef struct reader {
    const uint8_t *p;
    size_t left;
    bool bad;
} reader_t;

static void rd(reader_t *r, void *out, size_t n)
{
    if (r->bad || r->left < n) {
        r->bad = true;
        memset(out, 0, n);
        return;
    }
    memcpy(out, r->p, n);
    r->p += n;
    r->left -= n;
}

static uint32_t rd_u32(reader_t *r)
{
    uint32_t v;
    rd(r, &v, sizeof v);
    return v;
}

static uint64_t rd_u64(reader_t *r)
{
    uint64_t v;
    rd(r, &v, sizeof v);
    return v;
}

static uint8_t *wr(uint8_t *p, const void *src, size_t n)
{
    memcpy(p, src, n);
    return p + n;
}

static uint8_t *wr_u32(uint8_t *p, uint32_t v)
{
    return wr(p, &v, sizeof v);
}

static uint8_t *wr_u64(uint8_t *p, uint64_t v)
{
    return wr(p, &v, sizeof v);
}

/* Sum values per pixel: nb bucket sums, then the X, Y, Z sums. */
static size_t sum_channels(int nb)
{
    return (size_t)nb + TILEBUF_XYZ;
}

/* Bytes of a tile's arrays: bucket sums [h][w][nb], XYZ sums [h][w][3] and counts, lum, lum_sq
 * [h][w], 8 bytes each. */
static size_t tile_array_bytes(int w, int h, int nb)
{
    return (size_t)w * (size_t)h * (sum_channels(nb) + 3) * 8;
}

static bool tile_dims_ok(int x0, int y0, int w, int h, int nb)
{
    return x0 >= 0 && y0 >= 0 && w > 0 && h > 0 && w <= MAX_IMAGE_SIDE && h <= MAX_IMAGE_SIDE &&
           x0 <= MAX_IMAGE_SIDE - w && y0 <= MAX_IMAGE_SIDE - h && nb > 0 && nb <= MAX_BUCKETS;
}

static uint8_t *pack_arrays(uint8_t *p, size_t px, int nb, const double *sums, const double *xyz,
                            const uint64_t *counts, const double *lum, const double *lum_sq)
{
    p = wr(p, sums, px * (size_t)nb * sizeof *sums);
    p = wr(p, xyz, px * TILEBUF_XYZ * sizeof *xyz);
    p = wr(p, counts, px * sizeof *counts);
    p = wr(p, lum, px * sizeof *lum);
    return wr(p, lum_sq, px * sizeof *lum_sq);
}

/* The arrays at r's position for a w x h tile of nb buckets, checked and copied into a
 * tilebuf (tilebuf_new_from refuses non-finite sums). */
static tilebuf_t *unpack_arrays(reader_t *r, int x0, int y0, int w, int h, int nb,
                                uint64_t nonfinite, err_t *err)
{
    size_t px = (size_t)w * (size_t)h, need = tile_array_bytes(w, h, nb);
    if (r->bad || r->left < need) {
        err_set(err, "a journal blob of %dx%d pixels and %d buckets is cut short", w, h, nb);
        return NULL;
    }
    /* The blob's bytes need not be aligned for doubles: copy them out first. */
    uint8_t *copy = malloc(need);
    if (!copy) {
        err_set(err, "out of memory for a %dx%d journal tile", w, h);
        return NULL;
    }
    rd(r, copy, need);
    const size_t nc = sum_channels(nb);
    const double *sums = (const double *)copy;
    const double *xyz = (const double *)(copy + px * (size_t)nb * 8);
    const uint64_t *counts = (const uint64_t *)(copy + px * nc * 8);
    const double *lum = (const double *)(copy + px * (nc + 1) * 8);
    const double *lum_sq = (const double *)(copy + px * (nc + 2) * 8);
    tilebuf_t *tb =
        tilebuf_new_from(x0, y0, w, h, nb, sums, xyz, counts, lum, lum_sq, nonfinite, err);
    free(copy);
    return tb;
}

bool journal_blob_is_v8(const void *data, size_t size)
{
    uint32_t magic;
    if (size < sizeof magic)
        return false;
    memcpy(&magic, data, sizeof magic);
    return magic == TILE_MAGIC || magic == PHOT_MAGIC || magic == TILE_MAGIC_V4;
}

/* A tile blob: magic, x0, y0, w, h, nb, sb, se, the sums' width in bits (32 or 64), nonfinite,
 * then bucket sums [h][w][nb] and XYZ sums [h][w][3] at that width and counts, lum, lum_sq
 * [h][w] at 8 bytes. Float32 sums are kept whenever every sum is a float value (tilebuf.h), as
 * on the wire: half the writes, and the same doubles back. */
int journal_pack_tile(const proto_tile_result_t *t, uint8_t **data, size_t *size, err_t *err)
{
    const proto_tile_t *q = &t->rect;
    if (!tile_dims_ok(q->x0, q->y0, q->w, q->h, t->nbuckets))
        return err_set(err, "journal: tile %dx%d at (%d,%d) with %d buckets is out of range", q->w,
                       q->h, q->x0, q->y0, t->nbuckets);
    size_t px = (size_t)q->w * (size_t)q->h, nbs = px * (size_t)t->nbuckets,
           ns = px * sum_channels(t->nbuckets);
    /* A decoded float32 result was checked by the decoder; anything else is checked here. */
    bool narrow = t->sums_bits == 32;
    if (!narrow) {
        size_t i = 0;
        while (i < ns && tilebuf_is_float_value(i < nbs ? t->sums[i] : t->xyz[i - nbs]))
            i++;
        narrow = i == ns;
    }
    size_t n = 4 + 8 * 4 + 8 + tile_array_bytes(q->w, q->h, t->nbuckets) - (narrow ? ns * 4 : 0);
    uint8_t *buf = malloc(n), *p = buf;
    if (!buf)
        return err_set(err, "journal: out of memory for a %zu-byte tile", n);
    p = wr_u32(p, TILE_MAGIC);
    p = wr_u32(p, (uint32_t)q->x0);
    p = wr_u32(p, (uint32_t)q->y0);
    p = wr_u32(p, (uint32_t)q->w);
    p = wr_u32(p, (uint32_t)q->h);
    p = wr_u32(p, (uint32_t)t->nbuckets);
    p = wr_u32(p, q->sample_begin);
    p = wr_u32(p, q->sample_end);
    p = wr_u32(p, narrow ? 32 : 64);
    p = wr_u64(p, t->nonfinite);
    if (narrow) {
        for (size_t i = 0; i < ns; i++) {
            float f = (float)(i < nbs ? t->sums[i] : t->xyz[i - nbs]); /* exact: a float value */
            p = wr(p, &f, sizeof f);
        }
        p = wr(p, t->counts, px * sizeof *t->counts);
        p = wr(p, t->lum, px * sizeof *t->lum);
        p = wr(p, t->lum_sq, px * sizeof *t->lum_sq);
    } else {
        p = pack_arrays(p, px, t->nbuckets, t->sums, t->xyz, t->counts, t->lum, t->lum_sq);
    }
    *data = buf;
    *size = (size_t)(p - buf);
    return 0;
}

/* A blob's float32 sums widened into a float64 copy of its arrays, read as unpack_arrays reads
 * a float64 blob. */
static tilebuf_t *unpack_narrow(reader_t *r, int x0, int y0, int w, int h, int nb,
                                uint64_t nonfinite, err_t *err)
{
    size_t ns = (size_t)w * (size_t)h * sum_channels(nb), wide = tile_array_bytes(w, h, nb);
    if (r->bad || r->left < wide - ns * 4) {
        err_set(err, "a journal blob of %dx%d pixels and %d buckets is cut short", w, h, nb);
        return NULL;
    }
    uint8_t *copy = malloc(wide);
    if (!copy) {
        err_set(err, "out of memory for a %dx%d journal tile", w, h);
        return NULL;
    }
    for (size_t i = 0; i < ns; i++) {
        float f;
        rd(r, &f, sizeof f);
        double d = f;
        memcpy(copy + 8 * i, &d, sizeof d);
    }
    rd(r, copy + 8 * ns, wide - 8 * ns);
    reader_t whole = {.p = copy, .left = wide};
    tilebuf_t *tb = unpack_arrays(&whole, x0, y0, w, h, nb, nonfinite, err);
    free(copy);
    return tb;
}

tilebuf_t *journal_unpack_tile(const void *data, size_t size, uint32_t *sample_begin,
                               uint32_t *sample_end, err_t *err)
{
    reader_t r = {.p = data, .left = size};
    uint32_t magic = rd_u32(&r);
    int x0 = (int)rd_u32(&r), y0 = (int)rd_u32(&r), w = (int)rd_u32(&r), h = (int)rd_u32(&r),
        nb = (int)rd_u32(&r);
    *sample_begin = rd_u32(&r);
    *sample_end = rd_u32(&r);
    uint32_t bits = rd_u32(&r);
    uint64_t nonfinite = rd_u64(&r);
    if (!r.bad && magic == TILE_MAGIC_V4) {
        err_set(err, "a journal tile blob of version 4 (no XYZ sums): this master reads version %d",
                JOURNAL_VERSION);
        return NULL;
    }
    if (r.bad || magic != TILE_MAGIC || !tile_dims_ok(x0, y0, w, h, nb) ||
        (bits != 32 && bits != 64)) {
        err_set(err, "a journal tile blob of %zu bytes has no valid header", size);
        return NULL;
    }
    tilebuf_t *tb = bits == 32 ? unpack_narrow(&r, x0, y0, w, h, nb, nonfinite, err)
                               : unpack_arrays(&r, x0, y0, w, h, nb, nonfinite, err);
    if (tb && r.left != 0) {
        tilebuf_destroy(&tb);
        err_set(err, "a journal tile blob has %zu bytes past its arrays", r.left);
    }
    return tb;
}

int journal_pack_photons(const proto_photon_result_t *r, uint8_t **data, size_t *size, err_t *err)
{
    size_t n = 4 + 4 * 8 + r->size;
    uint8_t *buf = malloc(n), *p = buf;
    if (!buf)
        return err_set(err, "journal: out of memory for a %zu-byte photon batch", n);
    p = wr_u32(p, PHOT_MAGIC);
    p = wr_u64(p, r->range.first);
    p = wr_u64(p, r->range.end);
    p = wr_u64(p, r->emitted);
    p = wr_u64(p, r->nonfinite);
    if (r->size)
        p = wr(p, r->data, r->size);
    *data = buf;
    *size = (size_t)(p - buf);
    return 0;
}

int journal_unpack_photons(const void *data, size_t size, proto_photon_result_t *out, err_t *err)
{
    reader_t r = {.p = data, .left = size};
    uint32_t magic = rd_u32(&r);
    memset(out, 0, sizeof *out);
    out->range.first = rd_u64(&r);
    out->range.end = rd_u64(&r);
    out->emitted = rd_u64(&r);
    out->nonfinite = rd_u64(&r);
    if (r.bad || magic != PHOT_MAGIC || out->range.end < out->range.first)
        return err_set(err, "a journal photon blob of %zu bytes has no valid header", size);
    out->data = r.p;
    out->size = r.left;
    return 0;
}

/* A checkpoint: magic, x0, y0, w, h, nb, ntiles, round, nonfinite, the image's arrays, the pass
 * table, then the SHA-256 of every byte before it (issue 16: a flipped bit in a checkpoint whose
 * size was right went into a finished image). */
#define CKPT_HEADER (8 * 4 + 8)
int journal_write_checkpoint(const char *path, uint32_t round, const tilebuf_t *image,
                             const int *next_pass, int ntiles, err_t *err)
{
    int x0 = tilebuf_x0(image), y0 = tilebuf_y0(image), w = tilebuf_width(image),
        h = tilebuf_height(image), nb = tilebuf_nbuckets(image);
    size_t n = CKPT_HEADER + tile_array_bytes(w, h, nb) + (size_t)ntiles * 4 + SHA256_DIGEST_BYTES;
    uint8_t *buf = malloc(n), *p = buf;
    if (!buf)
        return err_set(err, "journal: out of memory for a %zu-byte checkpoint", n);
    p = wr_u32(p, CKPT_MAGIC);
    p = wr_u32(p, (uint32_t)x0);
    p = wr_u32(p, (uint32_t)y0);
    p = wr_u32(p, (uint32_t)w);
    p = wr_u32(p, (uint32_t)h);
    p = wr_u32(p, (uint32_t)nb);
    p = wr_u32(p, (uint32_t)ntiles);
    p = wr_u32(p, round);
    p = wr_u64(p, tilebuf_nonfinite(image));
    p = pack_arrays(p, (size_t)w * (size_t)h, nb, tilebuf_sums(image), tilebuf_xyz_sums(image),
                    tilebuf_counts(image), tilebuf_luminance_sums(image),
                    tilebuf_luminance_sq_sums(image));
    for (int t = 0; t < ntiles; t++)
        p = wr_u32(p, (uint32_t)next_pass[t]);
    sha256_t h256;
    sha256_init(&h256);
    sha256_update(&h256, buf, (size_t)(p - buf));
    sha256_final(&h256, p);
    p += SHA256_DIGEST_BYTES;
    int rc = files_write_atomic(path, buf, (size_t)(p - buf), true, err);
    free(buf);
    return rc;
}

int journal_read_checkpoint(const char *path, uint32_t round, int xres, int yres, int nbuckets,
                            int ntiles, tilebuf_t **image, int *next_pass, err_t *err)
{
    *image = NULL;
    uint8_t *data;
    size_t size;
    size_t want = CKPT_HEADER + tile_array_bytes(xres, yres, nbuckets) + (size_t)ntiles * 4 +
                  SHA256_DIGEST_BYTES;
    /* One byte more than it should hold, so that bytes past its end are told from a right
     * size. */
    if (files_read(path, want + 1, &data, &size, err) < 0)
        return err_prefix(err, "checkpoint: ");
    reader_t r = {.p = data, .left = size};
    uint32_t magic = rd_u32(&r);
    int x0 = (int)rd_u32(&r), y0 = (int)rd_u32(&r), w = (int)rd_u32(&r), h = (int)rd_u32(&r),
        nb = (int)rd_u32(&r), nt = (int)rd_u32(&r);
    uint32_t rnd = rd_u32(&r);
    uint64_t nonfinite = rd_u64(&r);
    uint8_t digest[SHA256_DIGEST_BYTES];
    int rc = 0;
    if (!r.bad && magic == CKPT_MAGIC_V4) {
        rc = err_set(err, "checkpoint %s is of journal version 4, without the XYZ sums the RGB "
                          "layers now come from: it cannot be resumed by this master (version %d)",
                     path, JOURNAL_VERSION);
    } else if (!r.bad && magic == CKPT_MAGIC_NOSUM) {
        rc = err_set(err, "checkpoint %s carries no checksum (written by an older master): not "
                          "trusted",
                     path);
    } else if (r.bad || magic != CKPT_MAGIC) {
        rc = err_set(err, "checkpoint %s has no valid header", path);
    } else if (size != want) {
        rc = err_set(err, "checkpoint %s has %s bytes than a %dx%d image of %d buckets and %d "
                          "tiles needs (%zu)",
                     path, size > want ? "more" : "fewer", xres, yres, nbuckets, ntiles, want);
    }
    if (rc == 0) {
        sha256_t h256;
        sha256_init(&h256);
        sha256_update(&h256, data, size - SHA256_DIGEST_BYTES);
        sha256_final(&h256, digest);
        if (memcmp(digest, data + size - SHA256_DIGEST_BYTES, SHA256_DIGEST_BYTES) != 0)
            rc = err_set(err, "checkpoint %s fails its SHA-256 checksum (damaged on disk)", path);
        else if (x0 != 0 || y0 != 0 || w != xres || h != yres || nb != nbuckets || nt != ntiles)
            rc = err_set(err, "checkpoint %s is not a %dx%d image of %d buckets and %d tiles",
                         path, xres, yres, nbuckets, ntiles);
        else if (rnd != round)
            rc = err_set(err, "checkpoint %s is of round %u, the job is at round %u", path, rnd,
                         round);
    }
    if (rc == 0) {
        r.left -= SHA256_DIGEST_BYTES;
        if (!(*image = unpack_arrays(&r, 0, 0, w, h, nb, nonfinite, err))) {
            rc = err_prefix(err, "checkpoint %s: ", path);
        } else {
            for (int t = 0; t < ntiles; t++)
                next_pass[t] = (int)rd_u32(&r);
            if (r.bad || r.left != 0) {
                tilebuf_destroy(image);
                rc = err_set(err, "checkpoint %s: its pass table is %s", path,
                             r.bad ? "cut short" : "followed by extra bytes");
            }
        }
    }
    free(data);
    return rc;
}

