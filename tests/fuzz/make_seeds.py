#!/usr/bin/env python3
"""Writes the committed seed corpus tests/fuzz/corpus/<target>/ (docs/fuzzing.md).

Usage: tests/fuzz/make_seeds.py [--root DIR]

Seeds are small valid files of every format (copied from tests/data/, platforms/ and
scenes/, or written here: the binary formats), and reproducers of crash classes fixed
before (repro_*). Reproducers found by fuzzing are added by hand as files named
repro_<what>.<ext> (or, for large ones, generated here); this script only (re)writes the
files it owns and leaves any other file in the corpus alone. Deep-nesting JSON is not a
seed: tests/fuzz/CMakeLists.txt generates it at configure time.
"""
import argparse
import base64
import json
import os
import shutil
import struct
import zlib

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
# fuzz_assimp.cpp: byte 0 of an input picks the extension from this list.
ASSIMP_EXTENSIONS = [".raw", ".nff", ".ac", ".x", ".smd", ".ase", ".dae",
                     ".3ds", ".fbx", ".ms3d", ".lwo", ".b3d", ".md2", ".irrmesh"]


def write(corpus, target, name, data):
    d = os.path.join(corpus, target)
    os.makedirs(d, exist_ok=True)
    with open(os.path.join(d, name), "wb") as f:
        f.write(data.encode() if isinstance(data, str) else data)


def copy(corpus, target, src, name=None):
    d = os.path.join(corpus, target)
    os.makedirs(d, exist_ok=True)
    shutil.copyfile(os.path.join(ROOT, src), os.path.join(d, name or os.path.basename(src)))


# ---- JSON formats --------------------------------------------------------------------

def json_seeds(c):
    for p in ["paper-A.json", "paper-2A.json", "workstation-4gpu.json"]:
        copy(c, "platform", "platforms/" + p)
    for p in sorted(os.listdir(os.path.join(ROOT, "tests/data/platforms/bad"))):
        copy(c, "platform", "tests/data/platforms/bad/" + p, "bad_" + p if not p.startswith("bad_") else p)
    write(c, "platform", "repro_number_overflow.json", '{"nodes": 1e400}')
    write(c, "platform", "repro_duplicate_key.json", '{"name": "x", "name": "y", "nodes": []}')

    copy(c, "job_set", "tests/data/jobs/fig4.json")
    fig4 = open(os.path.join(ROOT, "tests/data/jobs/fig4.json")).read()
    write(c, "job_set", "repro_number_overflow.json", '{"blocks": [{"name": "b", "size": 1e400}], "jobs": []}')
    # Found by mutation fuzzing before (tests/workload/test_job_set.cpp): refused by the loader.
    write(c, "job_set", "repro_at_twice.json", fig4.replace('["A0.disk"]', '["A0.disk", "A0.disk"]', 1))
    write(c, "job_set", "repro_input_twice.json",
          fig4.replace('"inputs": ["scene1", "w"]', '"inputs": ["scene1", "w", "w"]'))
    write(c, "job_set", "repro_queue_read_twice.json",
          fig4.replace('"inputs": ["scene1", "w"]', '"inputs": ["scene1", "rays0"]'))

    copy(c, "scene_profile", "tests/data/profiles/small.profile.json")
    for p in ["bad-block-count", "bad-probabilities", "bad-unknown-neighbour"]:
        copy(c, "scene_profile", "tests/data/profiles/%s.profile.json" % p)
    write(c, "scene_profile", "repro_number_overflow.json", '{"name": "p", "block_count": 1e400}')

    for s in ["cornell.json", "furnace.json", "block-crossing.json", "museum-1m.json"]:
        copy(c, "scene", "scenes/" + s)
    write(c, "scene", "mesh_file.json", json.dumps({
        "version": 1, "materials": {"grey": {"albedo": [0.5, 0.5, 0.5]}},
        "meshes": [{"name": "m", "file": "missing.obj", "material": "grey"}]}))
    write(c, "scene", "repro_number_overflow.json", '{"version": 1, "materials": 1e400}')


# ---- meshes ----------------------------------------------------------------------------

PLY_VERTS = "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
PLY_VDATA = "0 0 0\n1 0 0\n0 1 0\n"


def ply(header, body):
    return "ply\nformat ascii 1.0\n" + header + "end_header\n" + body


def binary_ply(endian):
    fmt = "<" if endian == "little" else ">"
    head = ("ply\nformat binary_%s_endian 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
            "property float z\nelement face 2\nproperty list uchar int vertex_indices\n"
            "property int material_index\nend_header\n" % endian).encode()
    body = b"".join(struct.pack(fmt + "fff", *v) for v in [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 1)])
    body += struct.pack(fmt + "Biiii", 3, 0, 1, 2, 0) + struct.pack(fmt + "Biiii", 3, 0, 2, 3, 1)
    return head + body


def binary_stl(tris):
    out = b"binary stl seed".ljust(80, b"\0") + struct.pack("<I", len(tris))
    for t in tris:
        out += struct.pack("<3f", 0, 0, 1) + b"".join(struct.pack("<3f", *v) for v in t) + b"\0\0"
    return out


def mesh_seeds(c):
    copy(c, "ply", "tests/data/meshes/ascii.ply")
    copy(c, "ply", "tests/data/meshes/parity.ply")
    write(c, "ply", "binary_le.ply", binary_ply("little"))
    write(c, "ply", "binary_be.ply", binary_ply("big"))
    face = "element face 1\n"
    # Headers that reached assimp and crashed it (tests/scene/test_mesh_adversarial.cpp).
    repros = {
        "repro_float_count.ply": ply(PLY_VERTS + face + "property list float int vertex_indices\n", PLY_VDATA + "0\n"),
        "repro_double_count.ply": ply(PLY_VERTS + face + "property list double int vertex_indices\n",
                                      PLY_VDATA + "3 0 1 2\n"),
        "repro_float_index.ply": ply(PLY_VERTS + face + "property list uchar float vertex_indices\n",
                                     PLY_VDATA + "3 0 1 2\n"),
        "repro_dup_property.ply": ply("element vertex 3\nproperty float x\nproperty float x\nproperty float y\n"
                                      "property float z\n" + face + "property list uchar int vertex_indices\n",
                                      "0 0 0 0\n1 1 0 0\n0 0 1 0\n3 0 1 2\n"),
        "repro_dup_list.ply": ply(PLY_VERTS + face + "property list uchar int vertex_indices\n"
                                  "property list uchar int vertex_indices\n", PLY_VDATA + "3 0 1 2 3 0 1 2\n"),
        "repro_dup_element.ply": ply(PLY_VERTS + PLY_VERTS + face + "property list uchar int vertex_indices\n",
                                     PLY_VDATA + PLY_VDATA + "3 0 1 2\n"),
        "repro_strip_out_of_range.ply": ply(PLY_VERTS + "element tristrips 1\nproperty list int int vertex_indices\n",
                                            PLY_VDATA + "3 0 1 9\n"),
        "strips.ply": ply(PLY_VERTS + "element tristrips 1\nproperty list int int vertex_indices\n",
                          PLY_VDATA + "3 0 1 2\n"),
    }
    for name, text in repros.items():
        write(c, "ply", name, text)

    for m in ["mixed.obj", "forward.obj", "parity.obj"]:
        copy(c, "obj", "tests/data/meshes/" + m)
    # Degenerate extents (tests/cli/test_cli_partition.cpp): an extent of 1e-40 made the
    # occupancy scale infinite and a NaN voxel index crashed the partitioner.
    write(c, "obj", "repro_thin_1e-40.obj", "v 0 0 0\nv 1 0 0\nv 0 1e-40 1\nf 1 2 3\n")
    write(c, "obj", "repro_point.obj", "v 0 0 0\nv 1e-40 0 0\nv 0 1e-40 1e-41\nf 1 2 3\n")
    write(c, "obj", "repro_flat.obj", "v 0 0 0\nv 1 0 0\nv 0 0 1\nv 1 0 1\nf 1 2 3\nf 2 4 3\n")
    write(c, "obj", "repro_huge_extent.obj", "v -3e38 0 0\nv 3e38 0 0\nv 0 3e38 1\nf 1 2 3\n")

    copy(c, "stl", "tests/data/meshes/parity.stl")
    copy(c, "stl", "tests/data/meshes/two_solids.stl")
    write(c, "stl", "binary.stl", binary_stl([[(0, 0, 0), (1, 0, 0), (0, 1, 0)], [(0, 0, 1), (1, 0, 1), (0, 1, 2)]]))
    write(c, "stl", "repro_thin_1e-40.stl", binary_stl([[(0, 0, 0), (1, 0, 0), (0, 1e-40, 1)]]))

    copy(c, "off", "tests/data/meshes/colored.off")
    copy(c, "off", "tests/data/meshes/parity.off")
    write(c, "off", "repro_thin_1e-40.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1e-40 1\n3 0 1 2\n")


def gltf_doc(positions, indices, extra=None):
    pos = b"".join(struct.pack("<3f", *p) for p in positions)
    idx = b"".join(struct.pack("<H", i) for i in indices)
    idx += b"\0" * (-len(idx) % 4)
    doc = {
        "asset": {"version": "2.0"},
        "buffers": [{"byteLength": len(pos) + len(idx)}],
        "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": len(pos)},
                        {"buffer": 0, "byteOffset": len(pos), "byteLength": 2 * len(indices)}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": len(positions), "type": "VEC3"},
                      {"bufferView": 1, "componentType": 5123, "count": len(indices), "type": "SCALAR"}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
        "nodes": [{"mesh": 0, "translation": [1, 2, 3]}, {"mesh": 0, "scale": [2, 2, 2], "children": [0]}],
        "scenes": [{"nodes": [1]}],
        "scene": 0,
    }
    if extra:
        doc.update(extra)
    return doc, pos + idx


QUAD = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)]


def gltf_seeds(c):
    doc, data = gltf_doc(QUAD, [0, 1, 2, 0, 2, 3])
    doc["buffers"][0]["uri"] = "data:application/octet-stream;base64," + base64.b64encode(data).decode()
    write(c, "gltf", "embedded.gltf", json.dumps(doc))
    doc, data = gltf_doc(QUAD, [0, 1, 2, 0, 2, 3])
    text = json.dumps(doc).encode()
    text += b" " * (-len(text) % 4)
    data += b"\0" * (-len(data) % 4)
    glb = struct.pack("<III", 0x46546C67, 2, 12 + 8 + len(text) + 8 + len(data))
    glb += struct.pack("<II", len(text), 0x4E4F534A) + text + struct.pack("<II", len(data), 0x004E4942) + data
    write(c, "gltf", "quad.glb", glb)
    write(c, "gltf", "repro_number_overflow.gltf", '{"nodes": 1e400, "asset": {"version": "2.0"}}')
    doc, data = gltf_doc(QUAD, [0, 1, 2, 0, 2, 7])
    doc["buffers"][0]["uri"] = "data:application/octet-stream;base64," + base64.b64encode(data).decode()
    write(c, "gltf", "index_out_of_range.gltf", json.dumps(doc))


def assimp_seeds(c):
    def put(ext, name, text):
        write(c, "assimp", name, bytes([ASSIMP_EXTENSIONS.index(ext)]) + text.encode())
    put(".raw", "ok.raw", "0 0 0 1 0 0 0 1 0\n1 1 1 0 0 0 1 1 1 0 0 1\n")
    # A RAW file revisiting a group: assimp left a null child node (tests/scene/test_mesh_adversarial.cpp).
    put(".raw", "repro_groups.raw", "g1\n0 0 0 1 0 0 0 1 0\ng2\n0 0 0 1 0 0 0 1 0 1 1 1\ng1\n1 1 1 0 0 0 1 0 1 0 1 0\n")
    put(".nff", "tri.nff", "f 0.5 0.5 0.5 0 0 0 0 0\n3\n0 0 0\n1 0 0\n0 1 0\n")
    put(".ac", "tri.ac", "AC3Db\nMATERIAL \"m\" rgb 1 1 1  amb 0.2 0.2 0.2  emis 0 0 0  spec 0.5 0.5 0.5  shi 10  trans 0\n"
        "OBJECT world\nkids 1\nOBJECT poly\nname \"t\"\nnumvert 3\n0 0 0\n1 0 0\n0 1 0\nnumsurf 1\nSURF 0x10\n"
        "mat 0\nrefs 3\n0 0 0\n1 0 0\n2 0 0\nkids 0\n")
    put(".x", "tri.x", "xof 0303txt 0032\nMesh m {\n 3;\n 0.0;0.0;0.0;,\n 1.0;0.0;0.0;,\n 0.0;1.0;0.0;;\n 1;\n 3;0,1,2;;\n}\n")
    put(".smd", "tri.smd", "version 1\nnodes\n0 \"root\" -1\nend\nskeleton\ntime 0\n0 0 0 0 0 0 0\nend\ntriangles\nmat\n"
        "0 0 0 0 0 0 1 0 0\n0 1 0 0 0 0 1 1 0\n0 0 1 0 0 0 1 0 1\nend\n")
    put(".dae", "tri.dae", """<?xml version="1.0"?>
<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1">
<asset><up_axis>Y_UP</up_axis></asset>
<library_geometries><geometry id="g"><mesh>
<source id="p"><float_array id="pa" count="9">0 0 0 1 0 0 0 1 0</float_array>
<technique_common><accessor source="#pa" count="3" stride="3"><param name="X" type="float"/><param name="Y" type="float"/><param name="Z" type="float"/></accessor></technique_common></source>
<vertices id="v"><input semantic="POSITION" source="#p"/></vertices>
<triangles count="1"><input semantic="VERTEX" source="#v" offset="0"/><p>0 1 2</p></triangles>
</mesh></geometry></library_geometries>
<library_visual_scenes><visual_scene id="s"><node id="n"><instance_geometry url="#g"/></node></visual_scene></library_visual_scenes>
<scene><instance_visual_scene url="#s"/></scene>
</COLLADA>
""")


# ---- blocks ----------------------------------------------------------------------------

def fnv1a64(b):
    h = 0xcbf29ce484222325
    for c in b:
        h = ((h ^ c) * 0x100000001b3) & 0xFFFFFFFFFFFFFFFF
    return h


def block_file(tris, block_id=0, block_count=1, cell=((0, 0, 0), (1, 1, 1))):
    payload = b"".join(struct.pack("<9fI", *[x for v in t[:3] for x in v], t[3]) for t in tris)
    lo = [min(v[a] for t in tris for v in t[:3]) for a in range(3)] if tris else [float("inf")] * 3
    hi = [max(v[a] for t in tris for v in t[:3]) for a in range(3)] if tris else [float("-inf")] * 3
    h = bytearray(128)
    h[0:8] = b"RLBLOCK\0"
    struct.pack_into("<IIQIIII", h, 8, 1, 128, len(tris), 1, 40, block_id, block_count)
    struct.pack_into("<6f", h, 40, *cell[0], *cell[1])
    struct.pack_into("<6f", h, 64, *lo, *hi)
    struct.pack_into("<QQ", h, 88, len(payload), zlib.crc32(payload))
    struct.pack_into("<Q", h, 120, fnv1a64(bytes(h[:120])))
    return bytes(h) + payload


TRIS = [((0, 0, 0), (1, 0, 0), (0, 1, 0), 0), ((0, 0, 1), (1, 0, 1), (0, 1, 1), 1)]


def block_seeds(c):
    write(c, "block", "two_triangles.rlb", block_file(TRIS))
    write(c, "block", "empty.rlb", block_file([], 1, 2))
    good = block_file(TRIS)
    write(c, "block", "truncated.rlb", good[:-7])
    bad_crc = bytearray(good)
    bad_crc[-1] ^= 1
    write(c, "block", "payload_corrupted.rlb", bytes(bad_crc))

    def bounds(lo, hi):
        return {"lo": list(lo), "hi": list(hi)}

    def block(i, cell, geometry, tris, neighbours):
        return {"id": i, "file": "block_%05d.rlb" % i, "triangles": tris, "bytes": 128 + 40 * tris,
                "payload_crc32": 0, "cell": bounds(*cell), "geometry_bounds": geometry and bounds(*geometry),
                "neighbours": neighbours}
    one = {"format": "rayline-blocks", "version": 1, "scene": "seed.obj", "scene_triangles": 2, "references": 2,
           "bounds": bounds((0, 0, 0), (1, 1, 1)),
           "kdtree": {"root": 0, "nodes": [{"block": 0}]},
           "blocks": [block(0, ((0, 0, 0), (1, 1, 1)), ((0, 0, 0), (1, 1, 1)), 2, [])]}
    one["blocks"][0]["occupancy"] = {"resolution": 32, "bits": "f" * 8192}
    write(c, "block_index", "one_block.json", json.dumps(one, indent=1))
    three = {"format": "rayline-blocks", "version": 1, "scene": "seed.obj", "scene_triangles": 3, "references": 4,
             "bounds": bounds((0, 0, 0), (2, 1, 1)),
             "kdtree": {"root": 0, "nodes": [{"axis": 0, "split": 1, "left": 1, "right": 2}, {"block": 0},
                                             {"axis": 1, "split": 0.5, "left": 3, "right": 4}, {"block": 1},
                                             {"block": 2}]},
             "blocks": [block(0, ((0, 0, 0), (1, 1, 1)), ((0, 0, 0), (1, 1, 1)), 2,
                              [{"block": 1, "axis": 0, "area": 0.5}, {"block": 2, "axis": 0, "area": 0.5}]),
                        block(1, ((1, 0, 0), (2, 0.5, 1)), None, 0, [{"block": 0, "axis": 0, "area": 0.5}]),
                        block(2, ((1, 0.5, 0), (2, 1, 1)), ((1, 0.5, 0), (2, 1, 1)), 2,
                              [{"block": 0, "axis": 0, "area": 0.5}])]}
    write(c, "block_index", "three_blocks.json", json.dumps(three, indent=1))
    # Found by the block_index target: a version no int holds (1e20; the conversion was
    # undefined behaviour).
    write(c, "block_index", "repro_version_1e20.json", json.dumps(dict(one, version=1e20)))


JOBS_HEADER = ("activity,kind,job,type,device_or_channel,block,bytes,planned_start,planned_end,actual_start,"
               "actual_end,state,created\n")


def report_seeds(c):
    """`rayline report`'s inputs: a simulation's and a render's metrics.json, jobs CSVs."""
    sim = {"rayline": {"command": "rayline simulate --out x", "version": "0.1.0"}, "scheduler": "gmb",
           "platform": "tiny", "workload": "ray-stream", "simulated_s": 4.0, "rays_per_second": 2.5e6,
           "rays_per_second_series": [1e6, 3e6, 2e6, 4e6], "lan_utilisation_mean": 0.25,
           "queue_wait_s": {"p50": 0.5, "p95": 2.0}, "activities": {"e_jobs_done": 3}, "stalled": False,
           "makespan_s": {"actual": 4.0, "planned": 3.5}, "path_trace": {"steady_rays_shot_per_second": 9e5},
           "devices": [{"name": "A0.cpu0", "kind": "cpu", "busy_s": 1.0, "setup_s": 0.0, "fetching_s": 2.0,
                        "idle_s": 1.0, "utilisation": 0.25},
                       {"name": "A0.gpu0", "kind": "gpu", "busy_s": 3.0, "setup_s": 0.5, "fetching_s": 0.5,
                        "idle_s": 0.0, "utilisation": 0.75}],
           "resources": [{"resource": "A0.sata", "utilisation": 0.5, "bytes": 3e8, "bandwidth_Bps": 1.5e8,
                          "lan": False},
                         {"resource": "lan:A0->B", "utilisation": 0.125, "bytes": 1e8, "bandwidth_Bps": 1e9,
                          "lan": True}]}
    write(c, "run_metrics", "simulate.json", json.dumps(sim, indent=1))
    render = {"rayline": {"command": "rayline render --out r.exr", "version": "0.1.0"}, "scheduler": "gmb",
              "platform": "auto", "scene": "scenes/cornell.json", "seconds": 0.13, "rays_per_second": 6e5,
              "resolution": [64, 64], "spp": 4, "threads": 2, "io": {"bytes_read": 400128},
              "cache": {"hit_ratio": 0.9},
              "devices": [{"device": "W.cpu0", "busy_s": 0.065, "setup_s": 1.2e-4, "fetching_idle_s": 0.029,
                           "true_idle_s": 0.04, "utilisation": 0.49}]}
    write(c, "run_metrics", "render.json", json.dumps(render, indent=1))
    write(c, "run_metrics", "repro_number_overflow.json", '{"simulated_s": 1e400}')
    write(c, "run_metrics", "huge_values.json",
          '{"rays_per_second_series": [1e308, 1e308], "devices": [{"name": "a", "busy_s": 1e308, '
          '"fetching_s": 1e308, "idle_s": 1e308}], "resources": [{"resource": "r", "utilisation": 1e308}]}')
    write(c, "jobs_csv", "simulate.csv", JOBS_HEADER +
          "0,T,j0,transfer,A.sata:disk->ram,scene0,1000,0,1,0,1.5,done,0\n"
          "1,E,j0,RayIntersect,A.cpu0,,2000,1,2,1.5,2.5,done,0.5\n"
          "2,E,j1,Shade,A.gpu0,,4000,0,1,0,1,done,0\n"
          "3,E,j2,Shade,A.gpu0,,4000,1,3,3,4,done,0\n"
          "4,E,j3,RayIntersect,A.cpu0,,2000,3,4,,,planned,2.5\n")
    write(c, "jobs_csv", "render.csv", JOBS_HEADER +
          "0,T,ri0,transfer,W.disk:disk->ram,scene0,1404096,0.018,0.028,0.019,0.054,done,0.0005\n"
          "1,E,ri0,RayIntersect,W.cpu0,,2452672,0.028,0.044,0.055,0.096,done,0.0005\n")
    write(c, "jobs_csv", "quoted_cells.csv", JOBS_HEADER.replace(",created", "") +
          '0,E,"j,0",Shade,"A.cpu0",,1,0,1,0,1,done\n')
    write(c, "jobs_csv", "extreme_times.csv", JOBS_HEADER +
          "0,E,j,Shade,A.cpu0,,1e308,0,1e308,-1e308,1e308,done,-1e308\n")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--root", default=ROOT)
    corpus = os.path.join(ap.parse_args().root, "tests", "fuzz", "corpus")
    json_seeds(corpus)
    mesh_seeds(corpus)
    gltf_seeds(corpus)
    assimp_seeds(corpus)
    block_seeds(corpus)
    report_seeds(corpus)


if __name__ == "__main__":
    main()
