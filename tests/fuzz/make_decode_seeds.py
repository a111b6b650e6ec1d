#!/usr/bin/env python3
"""Writes the limit_* seeds of fuzz_glb, fuzz_gltf and fuzz_obj (tests/fuzz/corpus/<target>/): one
tiny file (< 4 KB) per class of hostile avatar file that rig/decode_limits.hpp bounds, so that the
fuzzers start next to each check. The same attacks, full size, are built by
tests/rig/hostile_glb.cpp. Run from anywhere: python3 tests/fuzz/make_decode_seeds.py
(scripts/fuzz.sh runs the fuzzers from the corpus)."""
import base64
import json
import os
import struct

HERE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "corpus")
DIRS = {"glb": "fuzz_glb", "gltf": "fuzz_gltf", "obj": "fuzz_obj"}


def glb(text, binary):
    text += " " * (-len(text) % 4)
    binary += b"\0" * (-len(binary) % 4)
    body = b"JSON" + text.encode()
    total = 12 + 8 + len(text) + 8 + len(binary)
    return (b"glTF" + struct.pack("<II", 2, total) + struct.pack("<I", len(text)) + body +
            struct.pack("<I", len(binary)) + b"BIN\0" + binary)


def triangle():
    binary = struct.pack("<9f", 0, 0, 0, 1, 0, 0, 0, 1, 0) + struct.pack("<9f", 0, 0, 0, 0, 0, .5, 0, 0, 0)
    binary += struct.pack("<3I", 0, 1, 2)
    doc = {
        "asset": {"version": "2.0"},
        "buffers": [{"byteLength": len(binary)}],
        "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 36},
                        {"buffer": 0, "byteOffset": 36, "byteLength": 36},
                        {"buffer": 0, "byteOffset": 72, "byteLength": 12}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                       "min": [0, 0, 0], "max": [1, 1, 0]},
                      {"bufferView": 1, "componentType": 5126, "count": 3, "type": "VEC3"},
                      {"bufferView": 2, "componentType": 5125, "count": 3, "type": "SCALAR"}],
        "meshes": [{"name": "face", "primitives": [{"attributes": {"POSITION": 0}, "indices": 2,
                                                    "targets": [{"POSITION": 1}]}],
                    "extras": {"targetNames": ["jawOpen"]}}],
        "nodes": [{"mesh": 0}], "scenes": [{"nodes": [0]}], "scene": 0}
    return doc, binary


def varint(v):
    out = bytearray()
    while True:
        b = v & 0x7F
        v >>= 7
        out.append(b | 0x80 if v else b)
        if not v:
            return bytes(out)


def seeds():
    out = {}
    doc, binary = triangle()
    out["plain"] = (doc, binary)
    text = json.dumps(doc, separators=(",", ":"))
    out["deep_json"] = text[:-1] + ',"extras":' + "[" * 1200 + "]" * 1200 + "}"
    out["string_brackets"] = text[:-1] + ',"extras":{"s":"' + "[" * 1200 + '"}}'
    d, b = triangle()
    d["buffers"].append({"byteLength": 1 << 31, "extensions": {"EXT_meshopt_compression": {"fallback": True}}})
    d["bufferViews"].append({"buffer": 1, "byteLength": 1 << 31, "byteStride": 16, "extensions": {
        "EXT_meshopt_compression": {"buffer": 0, "byteOffset": 0, "byteLength": 84, "byteStride": 16,
                                    "count": (1 << 31) // 16, "mode": "ATTRIBUTES"}}})
    d["extensionsUsed"] = ["EXT_meshopt_compression"]
    out["meshopt_2gib"] = (d, b)
    d, b = triangle()
    draco = b"DRACO\x02\x02\x01\x01\0\0\0" + varint(10**9) + varint(10**9) + b"\0" + varint(10**9) + varint(0)
    d["bufferViews"].append({"buffer": 0, "byteOffset": len(b), "byteLength": len(draco)})
    b += draco
    d["buffers"][0]["byteLength"] = len(b)
    d["meshes"][0]["primitives"][0]["extensions"] = {
        "KHR_draco_mesh_compression": {"bufferView": 3, "attributes": {"POSITION": 0}}}
    d["accessors"][2]["count"] = 3 * 10**9
    d["accessors"][0]["count"] = 10**9
    out["draco_counts"] = (d, b)
    d, b = triangle()
    d["accessors"][1] = {"componentType": 5126, "count": 80000000, "type": "VEC3", "sparse": {
        "count": 1, "indices": {"bufferView": 2, "componentType": 5125}, "values": {"bufferView": 1}}}
    out["sparse_rows"] = (d, b)
    d, b = triangle()
    png = b"\x89PNG\r\n\x1a\n" + struct.pack(">I", 13) + b"IHDR" + struct.pack(">II", 100000, 100000)
    png += b"\x08\x06\0\0\0" + b"\0\0\0\0"
    d["bufferViews"].append({"buffer": 0, "byteOffset": len(b), "byteLength": len(png)})
    d["images"] = [{"bufferView": 3, "mimeType": "image/png"}]
    b += png
    d["buffers"][0]["byteLength"] = len(b)
    out["png_side"] = (d, b)
    return out


def main():
    for target in DIRS.values():
        os.makedirs(os.path.join(HERE, target), exist_ok=True)
    for name, seed in seeds().items():
        if isinstance(seed, str):
            doc_text, binary = seed, triangle()[1]
        else:
            doc_text, binary = json.dumps(seed[0], separators=(",", ":")), seed[1]
        data = glb(doc_text, binary)
        gltf = json.loads(doc_text) if name != "deep_json" else None
        with open(os.path.join(HERE, DIRS["glb"], "limit_" + name + ".glb"), "wb") as f:
            f.write(data)
        if gltf is not None:
            gltf["buffers"][0]["uri"] = ("data:application/octet-stream;base64," +
                                         base64.b64encode(binary).decode())
            text = json.dumps(gltf, separators=(",", ":"))
        else:
            uri = "data:application/octet-stream;base64," + base64.b64encode(binary).decode()
            text = doc_text.replace('"buffers":[{', '"buffers":[{"uri":"%s",' % uri, 1)
        with open(os.path.join(HERE, DIRS["gltf"], "limit_" + name + ".gltf"), "w") as f:
            f.write(text)
    obj = {
        "plain": "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
        "long_line": "v 0 0 0\n# " + "x" * 3000 + "\n",
        "wide_face": "v 0 0 0\nv 1 0 0\nv 0 1 0\nf" + " 1 2 3" * 300 + "\n",
    }
    for name, text in obj.items():
        with open(os.path.join(HERE, DIRS["obj"], "limit_" + name + ".obj"), "w") as f:
            f.write(text)
    for root, _, files in os.walk(HERE):
        for name in files:
            if name.startswith("limit_"):
                assert os.path.getsize(os.path.join(root, name)) < 4096, name


if __name__ == "__main__":
    main()
