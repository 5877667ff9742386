/* fuzz_ply: libFuzzer harness for the PLY path (scenefile/mesh_import.h): the structure check that
 * runs before assimp, then assimp's PLY reader, then the conversion to a triangle mesh, from
 * memory as a confined scene parse calls it. A mesh that loads must hold what the header
 * promises of it: triangles whose indices lie below the vertex count and finite positions. */
#include "mesh_import.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static void fail(const char *why)
{
    fprintf(stderr, "fuzz_ply: %s\n", why);
    abort();
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    mesh_data_t mesh;
    err_t err = {{0}};
    if (mesh_import_ply_memory(data, size, "fuzz.ply", &mesh, &err) != 0) {
        if (!err.msg[0])
            fail("mesh_import_ply_memory failed without a message");
        if (mesh.P || mesh.N || mesh.uv || mesh.indices)
            fail("a failed import left arrays behind");
        return 0;
    }
    if (mesh.nvertices == 0 || mesh.ntriangles == 0 || !mesh.P || !mesh.indices)
        fail("an accepted mesh has no vertices or no triangles");
    for (size_t i = 0; i < 3 * mesh.ntriangles; i++)
        if (mesh.indices[i] >= mesh.nvertices)
            fail("an accepted mesh has an index out of range");
    for (size_t i = 0; i < 3 * mesh.nvertices; i++)
        if (!isfinite(mesh.P[i]))
            fail("an accepted mesh has a non-finite position");
    mesh_data_free(&mesh);
    return 0;
}
