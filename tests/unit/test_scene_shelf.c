/* scene_shelf: a key is loaded once however many threads ask for it at once, a put scene is
 * shared and never loaded, a failed load is not kept, keys never mix, and a scene lives while
 * any holder keeps it and no longer (issue 15: a farm render loaded its scene three times). */
#define _POSIX_C_SOURCE 200809L /* nanosleep */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include "scene_shelf.h"
#include "settings.h"

#include <pthread.h>
#include <string.h>
#include <time.h>

/* A loader that counts its calls, makes an empty scene with a marker, and can be told to
 * fail or to wait on a gate (so that other threads ask while it loads). */
typedef struct counting {
    pthread_mutex_t lock;
    pthread_cond_t gate;
    int calls, open, fail;
    int xres; /* the marker put in the scene */
} counting_t;

static scene_t *count_load(void *arg, err_t *err)
{
    counting_t *c = arg;
    pthread_mutex_lock(&c->lock);
    c->calls++;
    pthread_cond_broadcast(&c->gate);
    while (!c->open)
        pthread_cond_wait(&c->gate, &c->lock);
    int fail = c->fail, xres = c->xres;
    pthread_mutex_unlock(&c->lock);
    if (fail) {
        err_set(err, "test: the load failed");
        return NULL;
    }
    scene_t *sc = scene_new(err);
    if (sc)
        sc->settings.xres = xres;
    return sc;
}

static counting_t *counting_new(int open, int xres)
{
    counting_t *c = calloc(1, sizeof *c);
    assert_non_null(c);
    pthread_mutex_init(&c->lock, NULL);
    pthread_cond_init(&c->gate, NULL);
    c->open = open;
    c->xres = xres;
    return c;
}

static void counting_destroy(counting_t *c)
{
    pthread_cond_destroy(&c->gate);
    pthread_mutex_destroy(&c->lock);
    free(c);
}

typedef struct asker {
    pthread_t thread;
    scene_shelf_t *shelf;
    counting_t *load;
    scene_t *got;
} asker_t;

static void *ask(void *arg)
{
    asker_t *a = arg;
    err_t err;
    a->got = scene_shelf_get(a->shelf, "k", count_load, a->load, &err);
    return NULL;
}

static void test_concurrent_gets_load_once(void **state)
{
    (void)state;
    err_t err;
    scene_shelf_t *shelf = scene_shelf_new(&err);
    assert_non_null(shelf);
    counting_t *c = counting_new(0, 7);
    enum { N = 6 };
    asker_t a[N];
    for (int i = 0; i < N; i++) {
        a[i] = (asker_t){.shelf = shelf, .load = c};
        assert_int_equal(pthread_create(&a[i].thread, NULL, ask, &a[i]), 0);
    }
    /* One of them is loading; the gate holds it while the others ask too. */
    pthread_mutex_lock(&c->lock);
    while (c->calls == 0)
        pthread_cond_wait(&c->gate, &c->lock);
    pthread_mutex_unlock(&c->lock);
    /* A moment for the others to ask while it loads; not a timing assertion: had they come
     * after the load, the counts below would be the same. */
    nanosleep(&(struct timespec){.tv_nsec = 20000000}, NULL);
    pthread_mutex_lock(&c->lock);
    c->open = 1;
    pthread_cond_broadcast(&c->gate);
    pthread_mutex_unlock(&c->lock);
    for (int i = 0; i < N; i++)
        assert_int_equal(pthread_join(a[i].thread, NULL), 0);
    assert_int_equal(c->calls, 1);
    for (int i = 0; i < N; i++) {
        assert_non_null(a[i].got);
        assert_ptr_equal(a[i].got, a[0].got);
        assert_int_equal(a[i].got->settings.xres, 7);
    }
    scene_shelf_stats_t st = scene_shelf_stats(shelf);
    assert_int_equal(st.loads, 1);
    assert_int_equal(st.shares, N - 1);
    /* Every holder frees its reference; the shelf's goes with the shelf. */
    for (int i = 0; i < N; i++)
        scene_destroy(&a[i].got);
    scene_shelf_destroy(&shelf);
    assert_null(shelf);
    counting_destroy(c);
}

static void test_put_is_shared_and_keys_do_not_mix(void **state)
{
    (void)state;
    err_t err;
    scene_shelf_t *shelf = scene_shelf_new(&err);
    scene_t *mine = scene_new(&err);
    assert_non_null(mine);
    mine->settings.xres = 11;
    assert_int_equal(scene_shelf_put(shelf, "a", mine, &err), 0);
    counting_t *c = counting_new(1, 22);
    scene_t *a = scene_shelf_get(shelf, "a", count_load, c, &err);
    assert_ptr_equal(a, mine);
    assert_int_equal(c->calls, 0);
    scene_t *b = scene_shelf_get(shelf, "b", count_load, c, &err);
    assert_non_null(b);
    assert_int_equal(b->settings.xres, 22);
    assert_int_equal(c->calls, 1);
    /* A second put under a key that is there keeps the first. */
    scene_t *other = scene_new(&err);
    assert_int_equal(scene_shelf_put(shelf, "a", other, &err), 0);
    scene_t *a2 = scene_shelf_get(shelf, "a", count_load, c, &err);
    assert_ptr_equal(a2, mine);
    scene_destroy(&other);
    scene_shelf_stats_t st = scene_shelf_stats(shelf);
    assert_int_equal(st.loads, 2);
    assert_int_equal(st.shares, 2);
    scene_destroy(&a);
    scene_destroy(&a2);
    scene_destroy(&b);
    /* mine is still the caller's: the shelf took a reference of its own. */
    assert_int_equal(mine->settings.xres, 11);
    scene_shelf_destroy(&shelf);
    scene_destroy(&mine);
    counting_destroy(c);
}

static void test_failed_load_is_not_kept(void **state)
{
    (void)state;
    err_t err = {{0}};
    scene_shelf_t *shelf = scene_shelf_new(&err);
    counting_t *c = counting_new(1, 5);
    c->fail = 1;
    assert_null(scene_shelf_get(shelf, "k", count_load, c, &err));
    assert_non_null(strstr(err.msg, "the load failed"));
    c->fail = 0;
    scene_t *sc = scene_shelf_get(shelf, "k", count_load, c, &err);
    assert_non_null(sc);
    assert_int_equal(c->calls, 2);
    scene_shelf_stats_t st = scene_shelf_stats(shelf);
    assert_int_equal(st.loads, 1);
    assert_int_equal(st.shares, 0);
    scene_destroy(&sc);
    scene_shelf_destroy(&shelf);
    counting_destroy(c);
}

/* Trimmed once nobody else holds it: the next get loads again; held, it stays. */
static void test_trim_drops_only_unheld(void **state)
{
    (void)state;
    err_t err;
    scene_shelf_t *shelf = scene_shelf_new(&err);
    counting_t *c = counting_new(1, 3);
    scene_t *held = scene_shelf_get(shelf, "held", count_load, c, &err);
    scene_t *dropped = scene_shelf_get(shelf, "dropped", count_load, c, &err);
    assert_int_equal(atomic_load(&dropped->holders), 2);
    scene_destroy(&dropped);
    scene_shelf_trim(shelf);
    scene_t *again = scene_shelf_get(shelf, "held", count_load, c, &err);
    assert_ptr_equal(again, held);
    assert_int_equal(c->calls, 2);
    scene_t *reloaded = scene_shelf_get(shelf, "dropped", count_load, c, &err);
    assert_non_null(reloaded);
    assert_int_equal(c->calls, 3);
    scene_destroy(&again);
    scene_destroy(&reloaded);
    scene_shelf_destroy(&shelf);
    /* The shelf is gone; the holder's scene is whole. */
    assert_int_equal(held->settings.xres, 3);
    assert_int_equal(atomic_load(&held->holders), 1);
    scene_destroy(&held);
    counting_destroy(c);
}

/* The key: one setting apart, two keys; NULL (the file's) and a name, two keys. */
static void test_settings_key(void **state)
{
    (void)state;
    const char *h = "0123456789abcdef0123456789abcdef0123456789abcdef0123456789abcdef";
    proto_settings_t a = {.seed = -1}, b = a;
    char ka[SETTINGS_KEY_SIZE], kb[SETTINGS_KEY_SIZE];
    settings_scene_key(h, "scene.pbrt", &a, ka);
    settings_scene_key(h, "scene.pbrt", &b, kb);
    assert_string_equal(ka, kb);
    /* The stopping rules are the master's: the scene is the same. */
    b.target_error = 0.01;
    b.time_limit = 5;
    settings_scene_key(h, "scene.pbrt", &b, kb);
    assert_string_equal(ka, kb);
    proto_settings_t vary[] = {{.seed = 2},
                               {.seed = -1, .spp = 4},
                               {.seed = -1, .xres = 8},
                               {.seed = -1, .yres = 8},
                               {.seed = -1, .integrator = "path"},
                               {.seed = -1, .integrator = ""},
                               {.seed = -1, .dispersion = "hero"}};
    for (size_t i = 0; i < sizeof vary / sizeof *vary; i++) {
        settings_scene_key(h, "scene.pbrt", &vary[i], kb);
        assert_string_not_equal(ka, kb);
    }
    settings_scene_key("f123456789abcdef0123456789abcdef0123456789abcdef0123456789abcdef",
                       "scene.pbrt", &a, kb);
    assert_string_not_equal(ka, kb);
    /* The frames of a sequence share a bundle, each with its own main file. */
    settings_scene_key(h, "frame0002.pbrt", &a, kb);
    assert_string_not_equal(ka, kb);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_concurrent_gets_load_once),
        cmocka_unit_test(test_put_is_shared_and_keys_do_not_mix),
        cmocka_unit_test(test_failed_load_is_not_kept),
        cmocka_unit_test(test_trim_drops_only_unheld),
        cmocka_unit_test(test_settings_key),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
