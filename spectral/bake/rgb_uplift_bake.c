/* rgb_uplift_bake: writes the RGB uplift table (spectral/rgb_uplift.h) as C source, every
 * node fitted by the same code and floating-point mode (pool.h) as a load would fit it, so the
 * built table equals the fits bit for bit.
 *   rgb_uplift_bake OUT.c */
#include "rgb_uplift.h"

#include <stdio.h>

int main(int argc, char **argv)
{
    if (argc != 2) {
        fprintf(stderr, "usage: rgb_uplift_bake OUT.c\n");
        return 2;
    }
    char tmp[4096];
    if (snprintf(tmp, sizeof tmp, "%s.tmp", argv[1]) >= (int)sizeof tmp) {
        fprintf(stderr, "rgb_uplift_bake: path too long\n");
        return 2;
    }
    FILE *f = fopen(tmp, "w");
    if (!f) {
        perror(tmp);
        return 1;
    }
    err_t err = {{0}};
    int rc = rgb_uplift_bake_write(f, 0, &err);
    if (fclose(f) != 0 && rc == 0)
        rc = err_set(&err, "cannot write %s", tmp);
    if (rc == 0 && rename(tmp, argv[1]) != 0)
        rc = err_set(&err, "cannot rename %s", tmp);
    if (rc != 0) {
        fprintf(stderr, "rgb_uplift_bake: %s\n", err.msg);
        remove(tmp);
        return 1;
    }
    return 0;
}
