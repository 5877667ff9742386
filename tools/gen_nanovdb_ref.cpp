// gen_nanovdb_ref: writes tests/data/scenes/cloud_ref.nvdb (ref_zip.nvdb below) with OpenVDB's
// own NanoVDB library (Debian 12: apt-get install libnanovdb-dev libblosc-dev), so that
// scene/nanovdb.c is checked against files the reference writer made, not ones it wrote
// itself. Not part of the build (prismfarm is C; this is the one C++ file):
//   g++ -std=c++17 tools/gen_nanovdb_ref.cpp -o gen -lz -lblosc && ./gen
// It prints the grid's bounds and the reference sampler's trilinear values at a few points,
// which tests/unit/test_medium.c (test_nanovdb_reference) expects. The same grids are written
// uncompressed (ref_none), with ZIP (ref_zip) and with BLOSC (ref_blosc).
#define NANOVDB_USE_ZIP 1
#define NANOVDB_USE_BLOSC 1
#include <nanovdb/util/GridBuilder.h>
#include <nanovdb/util/IO.h>
#include <nanovdb/util/SampleFromVoxels.h>
#include <cstdio>
static float dens(int i, int j, int k) {
    // interior 2..9 of a 12^3 padded region starting at index (-3, 5, 9)
    int a = i + 3, b = j - 5, c = k - 9;
    if (a < 2 || b < 2 || c < 2 || a > 9 || b > 9 || c > 9) return 0.f;
    return 0.5f + 0.25f * (a % 3) + 0.125f * (b % 2) + 0.0625f * c;
}
int main() {
    nanovdb::GridBuilder<float> b(0.f, nanovdb::GridClass::FogVolume);
    auto acc = b.getAccessor();
    for (int i = -3; i < 9; i++) for (int j = 5; j < 17; j++) for (int k = 9; k < 21; k++)
        acc.setValue(nanovdb::Coord(i, j, k), dens(i, j, k));
    auto h = b.getHandle<>(0.25, nanovdb::Vec3d(0.5, -1.0, 2.0), "density");
    nanovdb::GridBuilder<float> t(0.f, nanovdb::GridClass::FogVolume);
    auto ta = t.getAccessor();
    for (int i = 0; i < 4; i++) for (int j = 0; j < 4; j++) for (int k = 0; k < 4; k++)
        ta.setValue(nanovdb::Coord(i, j, k), 1000.f + 100.f * i);
    auto th = t.getHandle<>(1.0, nanovdb::Vec3d(0.0), "temperature");
    std::vector<nanovdb::GridHandle<>> hs;
    hs.push_back(std::move(h)); hs.push_back(std::move(th));
    nanovdb::io::writeGrids("ref_none.nvdb", hs, nanovdb::io::Codec::NONE);
    nanovdb::io::writeGrids("ref_zip.nvdb", hs, nanovdb::io::Codec::ZIP);
    nanovdb::io::writeGrids("ref_blosc.nvdb", hs, nanovdb::io::Codec::BLOSC);
    auto g = hs[0].grid<float>();
    auto bb = g->worldBBox();
    printf("wbbox %g %g %g  %g %g %g\n", bb.min()[0], bb.min()[1], bb.min()[2], bb.max()[0], bb.max()[1], bb.max()[2]);
    auto ib = g->indexBBox();
    printf("ibbox %d %d %d  %d %d %d\n", ib.min()[0], ib.min()[1], ib.min()[2], ib.max()[0], ib.max()[1], ib.max()[2]);
    printf("gridsize %llu leaves %u lower %u upper %u\n", (unsigned long long)hs[0].size(), g->tree().nodeCount(0), g->tree().nodeCount(1), g->tree().nodeCount(2));
    using S = nanovdb::SampleFromVoxels<nanovdb::FloatGrid::TreeType, 1, false>;
    auto s = nanovdb::createSampler<1, nanovdb::FloatGrid::TreeType, false>(g->tree());
    float pts[][3] = {{1.0f,0.3f,3.9f},{0.3f,0.6f,5.2f},{0.9f,1.1f,4.4f},{-3, -3, -3},{0.55f,1.8f,5.6f}};
    for (auto &p : pts) {
        auto pi = g->worldToIndexF(nanovdb::Vec3f(p[0], p[1], p[2]));
        printf("sample %g %g %g -> idx %g %g %g = %.9g\n", p[0], p[1], p[2], pi[0], pi[1], pi[2], (double)s(pi));
    }
}
