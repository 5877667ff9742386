#!/usr/bin/env python3
"""Writes the tiny PLY meshes (and the 2x2 PNG texture) that tests/test_pbrt_parser.c reads.
Run from this folder; the outputs are checked in, so tests never run this script.

quad_tri_ascii.ply   ascii: 5 vertices with (u, v), one quad (0 1 2 3) and one triangle (0 1 4)
                     -> 3 triangles after splitting the quad.
tetra_binary.ply     binary little-endian: the unit tetrahedron, 4 vertices with normals (0 0 1),
                     4 triangles, int32 indices.
../../scene_checker2x2.png  2x2 8-bit grey: 255 0 / 0 255.
"""
import struct
import zlib

with open("quad_tri_ascii.ply", "w") as f:
    f.write("ply\nformat ascii 1.0\ncomment prismfarm test mesh: a unit quad and one triangle\n"
            "element vertex 5\nproperty float x\nproperty float y\nproperty float z\n"
            "property float u\nproperty float v\nelement face 2\n"
            "property list uchar int vertex_indices\nend_header\n"
            "0 0 0 0 0\n1 0 0 1 0\n1 1 0 1 1\n0 1 0 0 1\n0.5 0.5 1 0.5 0.5\n"
            "4 0 1 2 3\n3 0 1 4\n")

verts = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1)]
faces = [(0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3)]
header = ("ply\nformat binary_little_endian 1.0\ncomment prismfarm test mesh: unit tetrahedron\n"
          "element vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
          "property float nx\nproperty float ny\nproperty float nz\n"
          "element face 4\nproperty list uchar int vertex_indices\nend_header\n")
body = b"".join(struct.pack("<6f", *v, 0.0, 0.0, 1.0) for v in verts)
body += b"".join(struct.pack("<B3i", 3, *f) for f in faces)
with open("tetra_binary.ply", "wb") as f:
    f.write(header.encode("ascii") + body)


def chunk(kind, data):
    return (struct.pack(">I", len(data)) + kind + data +
            struct.pack(">I", zlib.crc32(kind + data) & 0xffffffff))


raw = b"\x00\xff\x00" + b"\x00\x00\xff"  # filter byte 0 + two grey pixels per row
png = (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", 2, 2, 8, 0, 0, 0, 0)) +
       chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))
with open("../../scene_checker2x2.png", "wb") as f:
    f.write(png)
