/* Tests for texture: the checkerboard's cells (pbrt-v4 Checkerboard: cell (floor(u s_u),
 * floor(v s_v)) shows tex1 when the sum of the two is even, tex2 when odd), including negative
 * cells and coordinates so large that every double is an even integer, and a constant texture
 * inside it returning its spectrum's value exactly. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include "texture.h"

#include <math.h>

static void test_checkerboard_cells(void **state)
{
    (void)state;
    err_t err;
    texture_t *a = texture_new_constant_value(0.25, &err);
    texture_t *b = texture_new_constant_value(0.75, &err);
    assert_non_null(a);
    assert_non_null(b);
    texture_t *c = texture_new_checkerboard(a, b, 4.0, 2.0, &err);
    assert_non_null(c);
    /* Cell centres (i + 0.5) / 4, (j + 0.5) / 2 over negative and positive cells. */
    for (int i = -9; i <= 9; i++)
        for (int j = -9; j <= 9; j++) {
            double u = (i + 0.5) / 4.0, v = (j + 0.5) / 2.0;
            double want = ((i + j) % 2 == 0) ? 0.25 : 0.75;
            assert_true(texture_eval(c, u, v, 550.0) == want);
        }
    /* Cell boundaries belong to the cell above (floor): u = -0.25 is cell -1, u = 0 cell 0. */
    assert_true(texture_eval(c, -0.25, 0.25, 550.0) == 0.75);
    assert_true(texture_eval(c, 0.0, 0.25, 550.0) == 0.25);
    /* From 2^53 on every double is even: u s_u = 2^54 and 2^54 + 4 are even cells, and with
     * v's cell 1 (odd) they show tex2; 2^52 + 1 (exact) is odd, with cell 1 even: tex1. */
    assert_true(texture_eval(c, 0x1p54 / 4.0, 0.75, 550.0) == 0.75);
    assert_true(texture_eval(c, (0x1p54 + 4.0) / 4.0, 0.75, 550.0) == 0.75);
    assert_true(texture_eval(c, (0x1p52 + 1.0) / 4.0, 0.75, 550.0) == 0.25);
    assert_true(texture_eval(c, -(0x1p52 + 1.0) / 4.0, 0.75, 550.0) == 0.25);
    /* A non-finite cell falls back to tex1. */
    assert_true(texture_eval(c, INFINITY, 0.75, 550.0) == 0.25);
    texture_destroy(&c);
    texture_destroy(&a);
    texture_destroy(&b);
    assert_null(c);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_checkerboard_cells),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
