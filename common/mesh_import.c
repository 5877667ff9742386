#include "mesh_import.h"

#include <assimp/cimport.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <errno.h>
#include <math.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

void mesh_data_free(mesh_data_t *mesh)
{
    if (!mesh)
        return;
    free(mesh->P);
    free(mesh->N);
    free(mesh->uv);
    free(mesh->indices);
    memset(mesh, 0, sizeof *mesh);
}

/* Assimp picks an importer from the file contents, so a file that is not PLY could load as
 * something else: insist on the PLY magic line first. */
static int check_ply_magic(const char *path, err_t *err)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return err_set(err, "cannot open PLY file \"%s\": %s", path, strerror(errno));
    char head[4] = {0};
    size_t n = fread(head, 1, sizeof head, f);
    fclose(f);
    if (n < 4 || memcmp(head, "ply", 3) != 0 || (head[3] != '\n' && head[3] != '\r'))
        return err_set(err, "\"%s\" is not a PLY file (it does not start with \"ply\")", path);
    return 0;
}

static int fill(const struct aiScene *scene, const char *path, mesh_data_t *out, err_t *err)
{
    size_t nverts = 0, ntris = 0;
    bool normals = scene->mNumMeshes > 0, uvs = scene->mNumMeshes > 0;
    for (unsigned i = 0; i < scene->mNumMeshes; i++) {
        const struct aiMesh *m = scene->mMeshes[i];
        nverts += m->mNumVertices;
        for (unsigned f = 0; f < m->mNumFaces; f++) {
            if (m->mFaces[f].mNumIndices != 3)
                return err_set(err,
                               "\"%s\": face %u has %u vertices (points and lines are not "
                               "surfaces)",
                               path, f, m->mFaces[f].mNumIndices);
            ntris++;
        }
        normals = normals && m->mNormals;
        uvs = uvs && m->mTextureCoords[0];
    }
    if (ntris == 0)
        return err_set(err, "\"%s\" has no faces", path);
    if (nverts >= UINT32_MAX)
        return err_set(err, "\"%s\" has too many vertices (%zu)", path, nverts);

    out->nvertices = nverts;
    out->ntriangles = ntris;
    out->P = malloc(nverts * 3 * sizeof *out->P);
    out->N = normals ? malloc(nverts * 3 * sizeof *out->N) : NULL;
    out->uv = uvs ? malloc(nverts * 2 * sizeof *out->uv) : NULL;
    out->indices = malloc(ntris * 3 * sizeof *out->indices);
    if (!out->P || (normals && !out->N) || (uvs && !out->uv) || !out->indices)
        return err_set(err, "\"%s\": out of memory for %zu vertices", path, nverts);

    size_t v0 = 0, t = 0;
    for (unsigned i = 0; i < scene->mNumMeshes; i++) {
        const struct aiMesh *m = scene->mMeshes[i];
        for (unsigned v = 0; v < m->mNumVertices; v++) {
            const struct aiVector3D *p = &m->mVertices[v];
            if (!isfinite(p->x) || !isfinite(p->y) || !isfinite(p->z))
                return err_set(err, "\"%s\": vertex %zu is not finite", path, v0 + v);
            double *P = &out->P[3 * (v0 + v)];
            P[0] = p->x, P[1] = p->y, P[2] = p->z;
            if (normals) {
                const struct aiVector3D *n = &m->mNormals[v];
                double *N = &out->N[3 * (v0 + v)];
                N[0] = n->x, N[1] = n->y, N[2] = n->z;
            }
            if (uvs) {
                const struct aiVector3D *uv = &m->mTextureCoords[0][v];
                out->uv[2 * (v0 + v)] = uv->x;
                out->uv[2 * (v0 + v) + 1] = uv->y;
            }
        }
        /* Assimp's PLY reader does not check indices against the vertex count. */
        for (unsigned f = 0; f < m->mNumFaces; f++, t++)
            for (int k = 0; k < 3; k++) {
                unsigned idx = m->mFaces[f].mIndices[k];
                if (idx >= m->mNumVertices)
                    return err_set(err, "\"%s\": face %u uses vertex %u but there are only %u",
                                   path, f, idx, m->mNumVertices);
                out->indices[3 * t + (size_t)k] = (uint32_t)(v0 + idx);
            }
        v0 += m->mNumVertices;
    }
    return 0;
}

int mesh_import_ply(const char *path, mesh_data_t *out, err_t *err)
{
    memset(out, 0, sizeof *out);
    if (check_ply_magic(path, err) != 0)
        return -1;
    const struct aiScene *scene = aiImportFile(path, aiProcess_Triangulate);
    if (!scene) {
        const char *why = aiGetErrorString();
        return err_set(err, "cannot read PLY file \"%s\": %s", path,
                       why && *why ? why : "assimp gave no reason");
    }
    int rc = fill(scene, path, out, err);
    aiReleaseImport(scene);
    if (rc != 0)
        mesh_data_free(out);
    return rc;
}
