/* bench_mesh_sphere: writes a tessellated sphere as a binary PLY (positions and vertex
 * normals), for bench/throughput.sh's scene of real geometric complexity: the shipped scenes
 * have tens to hundreds of triangles, where Embree answers a ray in under 100 ns, and the
 * renderer's share of the time says little about a production scene.
 *
 * usage: bench_mesh_sphere OUT.ply RADIUS NU NV
 *   NU segments around, NV from pole to pole: NV * NU vertices on the rings plus the poles'
 *   rings, 2 * NU * (NV - 1) triangles. */
#include <errno.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int put_le32(FILE *f, uint32_t v)
{
    unsigned char b[4] = {(unsigned char)v, (unsigned char)(v >> 8), (unsigned char)(v >> 16),
                          (unsigned char)(v >> 24)};
    return fwrite(b, 1, 4, f) == 4 ? 0 : -1;
}

static int put_float(FILE *f, double x)
{
    float v = (float)x;
    uint32_t u;
    memcpy(&u, &v, sizeof u);
    return put_le32(f, u);
}

int main(int argc, char **argv)
{
    if (argc != 5) {
        fprintf(stderr, "usage: bench_mesh_sphere OUT.ply RADIUS NU NV\n");
        return 2;
    }
    char *end;
    double r = strtod(argv[2], &end);
    long nu = strtol(argv[3], &end, 10), nv = strtol(argv[4], &end, 10);
    if (!(r > 0) || nu < 3 || nv < 2 || nu > 100000 || nv > 100000) {
        fprintf(stderr, "bench_mesh_sphere: RADIUS > 0, NU >= 3, NV >= 2 (at most 100000)\n");
        return 2;
    }
    FILE *f = fopen(argv[1], "wb");
    if (!f) {
        fprintf(stderr, "bench_mesh_sphere: cannot create %s: %s\n", argv[1], strerror(errno));
        return 1;
    }
    long nvert = (nv + 1) * nu, nface = 2 * nu * (nv - 1);
    fprintf(f,
            "ply\nformat binary_little_endian 1.0\nelement vertex %ld\nproperty float x\n"
            "property float y\nproperty float z\nproperty float nx\nproperty float ny\n"
            "property float nz\nelement face %ld\nproperty list uchar int vertex_indices\n"
            "end_header\n",
            nvert, nface);
    int bad = 0;
    const double pi = acos(-1.0);
    /* Ring j at polar angle pi j / nv; the pole rings are degenerate (every vertex at the pole)
     * but only their non-degenerate triangles are listed. */
    for (long j = 0; j <= nv && !bad; j++) {
        double th = pi * (double)j / (double)nv;
        for (long i = 0; i < nu && !bad; i++) {
            double ph = 2 * pi * (double)i / (double)nu;
            double n[3] = {sin(th) * cos(ph), cos(th), sin(th) * sin(ph)};
            for (int k = 0; k < 3; k++)
                bad |= put_float(f, r * n[k]);
            for (int k = 0; k < 3; k++)
                bad |= put_float(f, n[k]);
        }
    }
    for (long j = 0; j < nv && !bad; j++) {
        for (long i = 0; i < nu && !bad; i++) {
            uint32_t a = (uint32_t)(j * nu + i), b = (uint32_t)(j * nu + (i + 1) % nu);
            uint32_t c = (uint32_t)((j + 1) * nu + i), d = (uint32_t)((j + 1) * nu + (i + 1) % nu);
            if (j > 0) /* the triangle touching the north pole ring is degenerate there */
                bad |= fputc(3, f) == EOF || put_le32(f, a) || put_le32(f, c) || put_le32(f, b);
            if (j < nv - 1)
                bad |= fputc(3, f) == EOF || put_le32(f, b) || put_le32(f, c) || put_le32(f, d);
        }
    }
    if (fclose(f) != 0)
        bad = 1;
    if (bad) {
        fprintf(stderr, "bench_mesh_sphere: cannot write %s\n", argv[1]);
        return 1;
    }
    printf("%ld vertices, %ld triangles\n", nvert, nface);
    return 0;
}
