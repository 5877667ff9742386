#!/usr/bin/env python3
"""Writes the malformed messages of the bad-input gallery (tests/bad/MANIFEST, README.md).
Each NAME.hex holds one message as hex bytes after '#' comment lines saying what is wrong.
Run from this folder; the outputs are checked in, so tests never run this script.

The valid bases follow docs/protocol.md (one msgpack map, keys in the encoder's order); each
case breaks one thing. A tiny msgpack packer is included so nothing needs installing.
"""
import struct

V = 3  # PROTO_VERSION (proto/proto.h)


class Raw(bytes):
    """Bytes copied into the message as they are (a hand-made or broken header)."""


def pack(o):
    if isinstance(o, Raw):
        return bytes(o)
    if o is None:
        return b"\xc0"
    if o is True:
        return b"\xc3"
    if o is False:
        return b"\xc2"
    if isinstance(o, int):
        if 0 <= o < 128:
            return bytes([o])
        if -32 <= o < 0:
            return struct.pack("b", o)
        if o >= 0:
            return b"\xcf" + struct.pack(">Q", o)
        return b"\xd3" + struct.pack(">q", o)
    if isinstance(o, float):
        return b"\xcb" + struct.pack(">d", o)
    if isinstance(o, str):
        b = o.encode("utf-8")
        return (bytes([0xa0 | len(b)]) if len(b) < 32 else b"\xd9" + bytes([len(b)])) + b
    if isinstance(o, bytes):
        return b"\xc4" + bytes([len(o)]) + o if len(o) < 256 else b"\xc5" + struct.pack(">H", len(o)) + o
    if isinstance(o, Pairs):
        return bytes([0x80 | len(o)]) + b"".join(pack(k) + pack(v) for k, v in o)
    if isinstance(o, list):
        return bytes([0x90 | len(o)]) + b"".join(pack(x) for x in o)
    if isinstance(o, dict):
        return pack(Pairs(o.items()))
    raise TypeError(o)


class Pairs(list):
    """A map given as (key, value) pairs: keys may repeat or be other than strings."""


def words(*xs, fmt="<d"):
    return b"".join(struct.pack(fmt, x) for x in xs)


def hello(**over):
    m = {"v": V, "t": "HELLO", "name": "node01", "threads": 8, "sw": "prismfarm 0.1.0"}
    m.update(over)
    return m


def submit(files, main="scene.pbrt"):
    return {"v": V, "t": "SUBMIT", "name": "prism",
            "set": {"spp": 0, "xres": 0, "yres": 0, "seed": -1},
            "bundle": {"main": main, "files": [{"path": p, "data": d} for p, d in files]}}


SCENE = b"WorldBegin\nShape \"sphere\"\n"


def result(tile_over=None, stats_over=None):
    tile = {"x0": 0, "y0": 0, "w": 2, "h": 1, "sb": 0, "se": 4, "nb": 1,
            "sums_bits": 64, "sums": words(0.5, 0.25),
            "xyz": words(0.5, 0.5, 0.5, 0.25, 0.25, 0.25), "counts": words(4, 4, fmt="<Q"),
            "lum": words(0.5, 0.25), "lum2": words(0.25, 0.0625), "nonfinite": 0}
    tile.update(tile_over or {})
    stats = {"samples": 8, "rays": 16, "disp": 0, "secs": 0.01}
    stats.update(stats_over or {})
    return {"v": V, "t": "RESULT", "job": 1, "task": 2, "att": 1, "kind": "camera_tile",
            "tile": tile, "stats": stats}


def task(tile_over=None):
    tile = {"x0": 0, "y0": 0, "w": 8, "h": 8, "sb": 0, "se": 16}
    tile.update(tile_over or {})
    return {"v": V, "t": "TASK", "job": 1, "task": 2, "att": 1, "scene": "0" * 64,
            "set": {"spp": 0, "xres": 0, "yres": 0, "seed": -1}, "kind": "camera_tile",
            "tile": tile}


HELLO = pack(hello())
NAN = float("nan")

CASES = [
    ("empty", "no bytes at all", b""),
    ("not_a_map", "an array where the message map belongs", pack([1, "HELLO"])),
    ("wrong_version", "a HELLO from protocol version 2 (tile results without XYZ sums)",
     pack(hello(v=2))),
    ("version_string", "\"v\" is the string \"1\"", pack(hello(v="1"))),
    ("unknown_type", "type \"HELO\"", pack(hello(t="HELO"))),
    ("missing_type", "no \"t\"", pack({"v": V, "name": "node01"})),
    ("truncated", "a valid HELLO cut after half its bytes", HELLO[: len(HELLO) // 2]),
    ("trailing_bytes", "a valid HELLO followed by one nil", HELLO + b"\xc0"),
    ("depth_bomb", "40 nested one-element arrays", b"\x91" * 40 + b"\xc0"),
    ("oversize_array", "JOBS_REPLY whose jobs array claims 2^31-1 entries in 0 bytes",
     pack({"v": V, "t": "JOBS_REPLY", "jobs": Raw(b"\xdd\x7f\xff\xff\xff")})),
    ("oversize_bin", "FILE whose data claims 4 GiB - 1 bytes",
     pack({"v": V, "t": "FILE", "name": "x.png", "data": Raw(b"\xc6\xff\xff\xff\xff")})),
    ("oversize_map", "a map header claiming 65536 entries", b"\xdf\x00\x01\x00\x00"),
    ("ext_type", "an ext object (never used by the protocol) as a value",
     pack(hello(name=Raw(b"\xd4\x01\x00")))),
    ("threads_string", "HELLO threads given as a string", pack(hello(threads="8"))),
    ("threads_zero", "HELLO threads 0 (range 1..4096)", pack(hello(threads=0))),
    ("threads_negative", "HELLO threads -1", pack(hello(threads=-1))),
    ("name_nil", "HELLO name nil", pack(hello(name=None))),
    ("key_twice", "HELLO with the key \"name\" twice",
     pack(Pairs([("v", V), ("t", "HELLO"), ("name", "a"), ("name", "b"), ("threads", 8),
                 ("sw", "x")]))),
    ("key_not_string", "HELLO with an integer key",
     pack(Pairs([("v", V), ("t", "HELLO"), (7, 1), ("name", "a"), ("threads", 8), ("sw", "x")]))),
    ("nul_in_name", "HELLO name with a NUL byte", pack(hello(name="no\0de"))),
    ("result_sums_short", "RESULT sums of 1 double for a 2x1 tile of 1 bucket",
     pack(result({"sums": words(0.5)}))),
    ("result_lum_nan", "RESULT lum holding a NaN", pack(result({"lum": words(NAN, 0.25)}))),
    ("result_sums_f32_nan", "RESULT float32 sums holding a NaN",
     pack(result({"sums_bits": 32, "sums": words(0.5, NAN, fmt="<f")}))),
    ("result_sums_f32_long", "RESULT float64 bytes under sums_bits 32",
     pack(result({"sums_bits": 32}))),
    ("result_sums_bits", "RESULT sums_bits 16", pack(result({"sums_bits": 16}))),
    ("result_xyz_short", "RESULT XYZ sums of 3 doubles for a 2x1 tile",
     pack(result({"xyz": words(0.5, 0.5, 0.5)}))),
    ("result_xyz_f32_inf", "RESULT float32 XYZ sums holding an Inf (sums float32 too)",
     pack(result({"sums_bits": 32, "sums": words(0.5, 0.25, fmt="<f"),
                  "xyz": words(0.5, 0.5, 0.5, 0.25, float("inf"), 0.25, fmt="<f")}))),
    ("result_secs_nan", "RESULT stats secs NaN", pack(result(stats_over={"secs": NAN}))),
    ("result_no_samples", "RESULT tile with sb == se", pack(result({"sb": 4, "se": 4}))),
    ("task_tile_outside", "TASK tile x0 70000 (at most 65535)", pack(task({"x0": 70000}))),
    ("task_hash_upper", "TASK scene hash in upper-case hex", pack(task() | {"scene": "A" * 64})),
    ("fetch_what", "FETCH what \"tiff\"", pack({"v": V, "t": "FETCH", "job": 1, "what": "tiff"})),
    ("bundle_dotdot", "SUBMIT bundle path \"../escape.pbrt\"",
     pack(submit([("scene.pbrt", SCENE), ("../escape.pbrt", b"x")]))),
    ("bundle_absolute", "SUBMIT bundle path \"/etc/passwd\"",
     pack(submit([("scene.pbrt", SCENE), ("/etc/passwd", b"x")]))),
    ("bundle_backslash", "SUBMIT bundle path with a backslash",
     pack(submit([("scene.pbrt", SCENE), ("meshes\\a.ply", b"x")]))),
    ("bundle_duplicate", "SUBMIT bundle naming scene.pbrt twice",
     pack(submit([("scene.pbrt", SCENE), ("scene.pbrt", SCENE)]))),
    ("bundle_file_and_folder", "SUBMIT bundle with a file \"a\" and a file \"a/b\"",
     pack(submit([("scene.pbrt", SCENE), ("a", b"x"), ("a/b", b"y")]))),
    ("bundle_main_missing", "SUBMIT bundle whose main file is not among its files",
     pack(submit([("scene.pbrt", SCENE)], main="other.pbrt"))),
    ("frames_not_in_bundle", "SUBMIT frame sequence naming a frame that is not in its bundle",
     pack(submit([("scene.pbrt", SCENE)]) | {"frames": [{"main": "scene.pbrt", "n": 1},
                                                       {"main": "walk2.pbrt", "n": 2}]})),
    ("frames_number_twice", "SUBMIT frame sequence with the frame number 7 twice",
     pack(submit([("scene.pbrt", SCENE), ("b.pbrt", SCENE)])
          | {"frames": [{"main": "scene.pbrt", "n": 7}, {"main": "b.pbrt", "n": 7}]})),
    ("frames_empty", "SUBMIT with an empty frames list (absent is a single scene)",
     pack(submit([("scene.pbrt", SCENE)]) | {"frames": []})),
    ("task_main_dotdot", "TASK whose frame main is \"../escape.pbrt\"",
     pack(task() | {"main": "../escape.pbrt"})),
    ("scene_hash_mismatch", "SCENE whose hash is not its bundle's",
     pack({"v": V, "t": "SCENE", "scene": "0" * 64,
           "bundle": {"main": "scene.pbrt", "files": [{"path": "scene.pbrt", "data": SCENE}]}})),
]


def main():
    names = set()
    for name, why, data in CASES:
        assert name not in names, name
        names.add(name)
        with open(name + ".hex", "w") as f:
            f.write("# %s (%d bytes)\n" % (why, len(data)))
            for i in range(0, len(data), 16):
                f.write(" ".join("%02x" % b for b in data[i:i + 16]) + "\n")


if __name__ == "__main__":
    main()
