/* photon_phase: the master's merge of a farm job's photon batches. Batches traced apart and
 * merged out of order give the bytes of one pass over all photons; duplicates are ignored;
 * results that do not match their batch or do not decode are refused; refinement adds
 * batches after the old ones; and following several monochrome rays per photon deposits the
 * same caustic energy as one (the post-pass rescale by the photons actually emitted). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include "files_testutil.h"
#include "photon.h"
#include "photon_phase.h"
#include "scene_builders.h"
#include "scene_load.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static scene_t *beam_scene(uint64_t photons, int lanes)
{
    scene_t *s = sb_load_file(testutil_source_path("scenes/prism_beam.pbrt"));
    s->settings.photon.photons = photons;
    s->settings.photon.monochromerays = lanes;
    return s;
}

/* A worker's batch: traced, encoded, and wrapped as a RESULT carries it. */
typedef struct batch_result {
    proto_photon_result_t r;
    uint8_t *bytes;
} batch_result_t;

static batch_result_t trace_batch(const scene_t *s, proto_photon_batch_t b)
{
    err_t err;
    photon_store_t *st = photon_store_new(s, &err);
    assert_non_null(st);
    photon_job_t job = photon_job_from_settings(&s->settings);
    photon_stats_t ps = {0};
    if (photon_trace(s, &job, b.first, b.end, st, &ps, &err))
        fail_msg("%s", err.msg);
    batch_result_t out = {.r = {.range = b, .emitted = ps.emitted, .nonfinite = ps.nonfinite}};
    size_t len;
    assert_int_equal(photon_store_encode(st, &out.bytes, &len, &err), 0);
    out.r.data = out.bytes;
    out.r.size = len;
    photon_store_destroy(&st);
    return out;
}

/* One pass over photons [0, n) in one call, encoded. */
static uint8_t *whole_pass(const scene_t *s, uint64_t n, size_t *len)
{
    batch_result_t b = trace_batch(s, (proto_photon_batch_t){0, n});
    *len = b.r.size;
    return b.bytes;
}

static void test_merge_in_batch_order(void **state)
{
    (void)state;
    err_t err;
    scene_t *s = beam_scene(50000, 1);
    size_t ref_len;
    uint8_t *ref = whole_pass(s, 50000, &ref_len);
    photon_phase_t *ph = photon_phase_new(&s, &err);
    assert_non_null(ph);
    assert_null(s);
    const scene_t *js = photon_phase_scene(ph);
    /* 50000 photons: batches of the 20000 minimum, the last cut short. */
    assert_int_equal(photon_phase_nbatches(ph), 3);
    proto_photon_batch_t last = photon_phase_batch(ph, 2);
    assert_int_equal(last.first, 40000);
    assert_int_equal(last.end, 50000);
    batch_result_t b[3];
    for (uint32_t i = 0; i < 3; i++)
        b[i] = trace_batch(js, photon_phase_batch(ph, i));
    const uint8_t *data;
    size_t size;
    const char *hash;
    /* Out of order: 2 waits for 0 and 1. */
    assert_int_equal(photon_phase_add(ph, 2, &b[2].r, &err), 1);
    assert_false(photon_phase_complete(ph));
    assert_int_equal(photon_phase_store(ph, &data, &size, &hash, &err), -1);
    assert_int_equal(photon_phase_add(ph, 0, &b[0].r, &err), 1);
    assert_int_equal(photon_phase_stats(ph).batches_merged, 1);
    /* A duplicate (a task issued twice) is ignored, before and after its merge. */
    assert_int_equal(photon_phase_add(ph, 2, &b[2].r, &err), 0);
    assert_int_equal(photon_phase_add(ph, 0, &b[0].r, &err), 0);
    /* A result for the wrong batch, a wrong emitted count, or bytes that do not decode. */
    assert_int_equal(photon_phase_add(ph, 1, &b[0].r, &err), -1);
    assert_non_null(strstr(err.msg, "the batch is [20000, 40000)"));
    proto_photon_result_t bad = b[1].r;
    bad.emitted++;
    assert_int_equal(photon_phase_add(ph, 1, &bad, &err), -1);
    assert_non_null(strstr(err.msg, "expected 20000"));
    bad = b[1].r;
    bad.size -= 3;
    assert_int_equal(photon_phase_add(ph, 1, &bad, &err), -1);
    assert_non_null(strstr(err.msg, "photon batch 1: photon map data"));
    assert_int_equal(photon_phase_add(ph, 7, &b[1].r, &err), -1);
    assert_false(photon_phase_complete(ph));
    assert_int_equal(photon_phase_add(ph, 1, &b[1].r, &err), 1);
    assert_true(photon_phase_complete(ph));
    assert_int_equal(photon_phase_store(ph, &data, &size, &hash, &err), 0);
    assert_int_equal(size, ref_len);
    assert_memory_equal(data, ref, size);
    assert_int_equal(strlen(hash), 64);
    photon_phase_stats_t st = photon_phase_stats(ph);
    assert_int_equal(st.photons, 50000);
    assert_int_equal(st.emitted, 50000);
    print_message("3 batches merged out of order: %zu bytes, the same as one pass\n", size);

    /* Refinement: 30000 more photons in batches after the old ones; the store is then that of
     * one pass over [0, 80000). */
    char old_hash[65];
    memcpy(old_hash, hash, sizeof old_hash);
    assert_int_equal(photon_phase_refine(ph, 30000, &err), 0);
    assert_false(photon_phase_complete(ph));
    assert_int_equal(photon_phase_nbatches(ph), 5);
    assert_int_equal(photon_phase_batch(ph, 3).first, 50000);
    assert_int_equal(photon_phase_batch(ph, 4).end, 80000);
    batch_result_t r3 = trace_batch(js, photon_phase_batch(ph, 3));
    batch_result_t r4 = trace_batch(js, photon_phase_batch(ph, 4));
    assert_int_equal(photon_phase_add(ph, 4, &r4.r, &err), 1);
    assert_int_equal(photon_phase_add(ph, 3, &r3.r, &err), 1);
    assert_int_equal(photon_phase_store(ph, &data, &size, &hash, &err), 0);
    size_t ref2_len;
    uint8_t *ref2 = whole_pass(js, 80000, &ref2_len);
    assert_int_equal(size, ref2_len);
    assert_memory_equal(data, ref2, size);
    assert_string_not_equal(hash, old_hash);
    /* Saved and restored (as the master does between a job's end and a refinement): the same
     * store, and a further refinement cuts the batches it would have cut. */
    scene_t *again = beam_scene(50000, 1);
    photon_phase_t *back = photon_phase_restore(&again, data, size, 80000, &err);
    if (!back)
        fail_msg("%s", err.msg);
    assert_true(photon_phase_complete(back));
    const uint8_t *d2;
    size_t s2;
    const char *h2;
    assert_int_equal(photon_phase_store(back, &d2, &s2, &h2, &err), 0);
    assert_int_equal(s2, size);
    assert_memory_equal(d2, data, size);
    assert_string_equal(h2, hash);
    /* A saved store that does not match the photons claimed is refused. */
    scene_t *third = beam_scene(50000, 1);
    assert_null(photon_phase_restore(&third, data, size, 70000, &err));
    assert_non_null(strstr(err.msg, "expected 70000"));
    /* (data belongs to ph until its next refinement.) */
    assert_int_equal(photon_phase_refine(back, 25000, &err), 0);
    assert_int_equal(photon_phase_refine(ph, 25000, &err), 0);
    assert_int_equal(photon_phase_nbatches(back), 3);
    for (uint32_t i = 0; i < 2; i++) {
        proto_photon_batch_t x = photon_phase_batch(back, 1 + i), y = photon_phase_batch(ph, 5 + i);
        assert_int_equal(x.first, y.first);
        assert_int_equal(x.end, y.end);
    }
    photon_phase_destroy(&back);
    free(ref2);
    free(r3.bytes);
    free(r4.bytes);
    for (int i = 0; i < 3; i++)
        free(b[i].bytes);
    free(ref);
    photon_phase_destroy(&ph);
}

/* The caustic's energy per emitted monochrome photon, from a merged store: the power the
 * store holds divided by its emitted count. */
static double energy_per_photon(uint64_t photons, int lanes, int visible, double *rel_se)
{
    err_t err;
    scene_t *s = beam_scene(photons, lanes);
    s->settings.visible_sampling = visible;
    photon_phase_t *ph = photon_phase_new(&s, &err);
    assert_non_null(ph);
    const scene_t *js = photon_phase_scene(ph);
    for (uint32_t i = 0; i < photon_phase_nbatches(ph); i++) {
        batch_result_t b = trace_batch(js, photon_phase_batch(ph, i));
        assert_int_equal(photon_phase_add(ph, i, &b.r, &err), 1);
        free(b.bytes);
    }
    const uint8_t *data;
    size_t size;
    const char *hash;
    assert_int_equal(photon_phase_store(ph, &data, &size, &hash, &err), 0);
    photon_store_t *st = photon_store_decode(js, data, size, &err);
    assert_non_null(st);
    const photon_map_t *m = photon_store_map(st);
    double sum = 0.0, sq = 0.0;
    for (size_t i = 0; i < photon_map_count(m); i++) {
        double p = photon_map_photon(m, i).power;
        sum += p;
        sq += p * p;
    }
    uint64_t n = photon_store_emitted(st);
    assert_int_equal(n, photons * (uint64_t)lanes);
    /* The deposits of one monochrome photon are (nearly) one each: the standard error of the
     * mean power per emitted photon is sqrt(sum p^2 - sum^2 / n) / n. Lanes of one photon are
     * correlated before their split, which this treats as independent: the tolerance below
     * allows for it. */
    double mean = sum / (double)n;
    *rel_se = sqrt(fmax(0.0, sq - sum * sum / (double)n)) / (double)n / mean;
    photon_store_destroy(&st);
    photon_phase_destroy(&ph);
    return mean;
}

static void test_monochrome_rays_keep_energy(void **state)
{
    (void)state;
    double se1, se16;
    double e1 = energy_per_photon(64000, 1, 0, &se1);
    double e16 = energy_per_photon(4000, 16, 0, &se16);
    double diff = fabs(e16 / e1 - 1.0);
    print_message("caustic energy per monochrome photon: 1 lane %.6g (se %.2g), 16 lanes %.6g "
                  "(se %.2g): ratio %.4f\n",
                  e1, se1, e16, se16, e16 / e1);
    /* Lanes of a photon share its light, position and direction: 16 lanes of 4000 photons are
     * worth fewer than 64000 independent photons, so allow 4 standard errors of 4000
     * independent photons' worth (4 x sqrt(16) x se16) on top of the 1-lane error. */
    assert_true(diff < 4.0 * sqrt(se1 * se1 + 16.0 * se16 * se16));
}

/* Wavelengths sampled by the eye's response (pdf divided out) deposit the same energy as
 * uniform ones: the estimator is unbiased whatever the pdf. */
static void test_visible_wavelengths_keep_energy(void **state)
{
    (void)state;
    double seu, sev;
    double eu = energy_per_photon(64000, 1, 0, &seu);
    double ev = energy_per_photon(64000, 1, 1, &sev);
    print_message("caustic energy per photon: uniform wavelengths %.6g (se %.2g), visible %.6g "
                  "(se %.2g): ratio %.4f\n",
                  eu, seu, ev, sev, ev / eu);
    assert_true(fabs(ev / eu - 1.0) < 4.0 * sqrt(seu * seu + sev * sev));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_merge_in_batch_order),
        cmocka_unit_test(test_monochrome_rays_keep_energy),
        cmocka_unit_test(test_visible_wavelengths_keep_energy),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
