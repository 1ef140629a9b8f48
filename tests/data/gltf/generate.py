#!/usr/bin/env python3
# Writes the tiny hand-made glTF files of this folder: python3 generate.py . (outputs are committed).
import base64, json, math, struct, zlib, sys, os

OUT = sys.argv[1]

def f32(*v): return struct.pack('<%df' % len(v), *v)
def u8(*v): return struct.pack('<%dB' % len(v), *v)
def u16(*v): return struct.pack('<%dH' % len(v), *v)
def u32(*v): return struct.pack('<%dI' % len(v), *v)
def pad4(b): return b + b'\0' * ((4 - len(b) % 4) % 4)
def uri(b): return 'data:application/octet-stream;base64,' + base64.b64encode(b).decode()

def write(name, doc):
    with open(os.path.join(OUT, name), 'w') as f:
        json.dump(doc, f, indent=1)
        f.write('\n')

ASSET = {"version": "2.0", "generator": "penumbra tests (hand-made)"}

# Quad in the XZ plane, normal +Y, counter-clockwise seen from above.
QUAD_POS = f32(-1, 0, -1, 1, 0, -1, 1, 0, 1, -1, 0, 1)
QUAD_NRM = f32(*([0, 1, 0] * 4))
QUAD_UV = f32(0, 0, 1, 0, 1, 1, 0, 1)
QUAD_IDX = pad4(u16(0, 2, 1, 0, 3, 2))
QUAD_BIN = QUAD_POS + QUAD_NRM + QUAD_UV + QUAD_IDX  # 48 + 48 + 32 + 12 = 140 bytes

def quad_doc(buffer_uri, extra=None):
    doc = {
        "asset": ASSET,
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"name": "quad", "mesh": 0}],
        "meshes": [{"name": "quad", "primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2}, "indices": 3, "material": 0}]}],
        "materials": [{"name": "red", "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.1, 0.1, 1.0]}}],
        "buffers": [{"byteLength": len(QUAD_BIN), "uri": buffer_uri}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 128},
            {"buffer": 0, "byteOffset": 128, "byteLength": 12},
        ],
        "accessors": [
            {"bufferView": 0, "byteOffset": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [-1, 0, -1], "max": [1, 0, 1]},
            {"bufferView": 0, "byteOffset": 48, "componentType": 5126, "count": 4, "type": "VEC3"},
            {"bufferView": 0, "byteOffset": 96, "componentType": 5126, "count": 4, "type": "VEC2"},
            {"bufferView": 1, "byteOffset": 0, "componentType": 5123, "count": 6, "type": "SCALAR"},
        ],
    }
    if extra: extra(doc)
    return doc

write('quad.gltf', quad_doc(uri(QUAD_BIN)))
with open(os.path.join(OUT, 'quad.bin'), 'wb') as f: f.write(QUAD_BIN)
write('quad_external.gltf', quad_doc('quad.bin'))

# GLB: the quad with its buffer in the BIN chunk.
def glb(doc, binary, version=2):
    js = json.dumps(doc, separators=(',', ':')).encode()
    js += b' ' * ((4 - len(js) % 4) % 4)
    binary = pad4(binary)
    body = struct.pack('<II', len(js), 0x4E4F534A) + js + struct.pack('<II', len(binary), 0x004E4942) + binary
    return b'glTF' + struct.pack('<II', version, 12 + len(body)) + body

glb_doc = quad_doc(None)
del glb_doc["buffers"][0]["uri"]
with open(os.path.join(OUT, 'quad.glb'), 'wb') as f: f.write(glb(glb_doc, QUAD_BIN))
# A glTF 1.0 binary: version 1 header (content format 0), the rest does not matter.
with open(os.path.join(OUT, 'gltf1.glb'), 'wb') as f:
    js = b'{"asset":{"version":"1.0"}}    '
    f.write(b'glTF' + struct.pack('<IIII', 1, 20 + len(js), len(js), 0) + js)

# 2x2 RGBA PNG: red, green / blue, half-transparent white.
def png(w, h, rgba):
    raw = b''.join(b'\0' + bytes(rgba[y * w * 4:(y + 1) * w * 4]) for y in range(h))
    def chunk(t, d): return struct.pack('>I', len(d)) + t + d + struct.pack('>I', zlib.crc32(t + d) & 0xffffffff)
    return b'\x89PNG\r\n\x1a\n' + chunk(b'IHDR', struct.pack('>IIBBBBB', w, h, 8, 6, 0, 0, 0)) + chunk(b'IDAT', zlib.compress(raw)) + chunk(b'IEND', b'')

PNG = png(2, 2, [255, 0, 0, 255, 0, 255, 0, 255, 0, 0, 255, 255, 255, 255, 255, 128])

def textured(doc):
    doc["materials"] = [{"name": "checker", "alphaMode": "MASK", "alphaCutoff": 0.25, "doubleSided": True,
                         "pbrMetallicRoughness": {"baseColorFactor": [1.0, 0.5, 0.25, 1.0], "baseColorTexture": {"index": 0}}}]
    doc["textures"] = [{"source": 0}]
    doc["images"] = [{"name": "checker", "uri": "data:image/png;base64," + base64.b64encode(PNG).decode()}]
write('textured.gltf', quad_doc(uri(QUAD_BIN), textured))

def missing_texture(doc):
    textured(doc)
    doc["images"] = [{"name": "checker", "uri": "checker_missing.png"}]
write('missing_texture.gltf', quad_doc(uri(QUAD_BIN), missing_texture))

write('missing_bin.gltf', quad_doc('quad_missing.bin'))

with open(os.path.join(OUT, 'malformed.gltf'), 'w') as f:
    f.write('{\n  "asset": {"version": "2.0"},\n  "nodes": [{"mesh": 0,}]\n}\n')

def huge_accessor(doc): doc["accessors"][0]["count"] = 4294967295
write('huge_accessor.gltf', quad_doc(uri(QUAD_BIN), huge_accessor))

def view_out_of_range(doc): doc["bufferViews"][1]["byteLength"] = 400
write('bufferview_out_of_range.gltf', quad_doc(uri(QUAD_BIN), view_out_of_range))

def missing_accessor(doc): doc["meshes"][0]["primitives"][0]["attributes"]["NORMAL"] = 9
write('missing_accessor.gltf', quad_doc(uri(QUAD_BIN), missing_accessor))

BAD_IDX_BIN = QUAD_POS + QUAD_NRM + QUAD_UV + pad4(u16(0, 2, 1, 0, 7, 2))
write('index_out_of_range.gltf', quad_doc(uri(BAD_IDX_BIN)))

def cycle(doc):
    doc["nodes"] = [{"name": "root", "children": [1]}, {"name": "quad", "mesh": 0},
                    {"name": "a", "children": [3]}, {"name": "b", "children": [4]}, {"name": "c", "children": [2]}]
write('node_cycle.gltf', quad_doc(uri(QUAD_BIN), cycle))

def two_parents(doc):
    doc["nodes"] = [{"name": "left", "children": [2]}, {"name": "right", "children": [2]}, {"name": "shared", "mesh": 0}]
    doc["scenes"] = [{"nodes": [0, 1]}]
write('two_parents.gltf', quad_doc(uri(QUAD_BIN), two_parents))

def draco(doc):
    doc["extensionsUsed"] = ["KHR_draco_mesh_compression"]
    doc["extensionsRequired"] = ["KHR_draco_mesh_compression"]
write('draco_required.gltf', quad_doc(uri(QUAD_BIN), draco))

def unknown_used(doc): doc["extensionsUsed"] = ["KHR_texture_transform"]
write('unknown_used_extension.gltf', quad_doc(uri(QUAD_BIN), unknown_used))

# Two quads' worth of triangles where one triangle has a NaN corner and one an infinite
# corner; the two good triangles keep the quad.
nan, inf = float('nan'), float('inf')
NF_POS = QUAD_POS + f32(0, nan, 0, 5, 0, 5, 0, inf, 3)
NF_NRM = QUAD_NRM + f32(*([0, 1, 0] * 3))
NF_IDX = pad4(u16(0, 2, 1, 0, 3, 2, 4, 0, 1, 5, 6, 0))
NF_BIN = NF_POS + NF_NRM + NF_IDX
def non_finite(doc):
    doc["meshes"][0]["primitives"][0]["attributes"] = {"POSITION": 0, "NORMAL": 1}
    doc["buffers"][0]["byteLength"] = len(NF_BIN)
    doc["bufferViews"] = [{"buffer": 0, "byteOffset": 0, "byteLength": 168}, {"buffer": 0, "byteOffset": 168, "byteLength": 24}]
    doc["accessors"] = [
        {"bufferView": 0, "byteOffset": 0, "componentType": 5126, "count": 7, "type": "VEC3"},
        {"bufferView": 0, "byteOffset": 84, "componentType": 5126, "count": 7, "type": "VEC3"},
        {"bufferView": 1, "componentType": 5123, "count": 12, "type": "SCALAR"},
    ]
    doc["meshes"][0]["primitives"][0]["indices"] = 2
write('non_finite.gltf', quad_doc(uri(NF_BIN), non_finite))

write('gltf1.gltf', {"asset": {"version": "1.0"}, "accessors": {"accessor_0": {"bufferView": "bufferView_0", "count": 3}},
                     "meshes": {"mesh_0": {"primitives": []}}, "scene": "defaultScene"})

# Hierarchy: children listed before their parents, TRS and matrix transforms, one mesh
# (two primitives, two materials) instanced under two nodes, lights of each type.
def hierarchy(doc):
    s = math.sqrt(0.5)
    doc["extensionsUsed"] = ["KHR_lights_punctual"]
    doc["extensions"] = {"KHR_lights_punctual": {"lights": [
        {"name": "sun", "type": "directional", "color": [1.0, 0.9, 0.8], "intensity": 3.0},
        {"name": "lamp", "type": "spot", "intensity": 500.0, "spot": {"innerConeAngle": 0.3, "outerConeAngle": 0.6}},
        {"name": "bulb", "type": "point", "intensity": 40.0, "range": 10.0}]}}
    doc["nodes"] = [
        {"name": "left", "mesh": 0, "translation": [-3, 0, 0]},                                  # 0, child of 4
        {"name": "right", "mesh": 0, "matrix": [2, 0, 0, 0, 0, 2, 0, 0, 0, 0, 2, 0, 3, 0, 0, 1]},  # 1, child of 4
        {"name": "sun", "rotation": [-s, 0, 0, s], "extensions": {"KHR_lights_punctual": {"light": 0}}},  # 2: points down (-Y)
        {"name": "lamp", "translation": [0, 5, 0], "rotation": [-s, 0, 0, s], "extensions": {"KHR_lights_punctual": {"light": 1}}},  # 3, child of 4
        {"name": "root", "translation": [0, 1, 0], "children": [3, 1, 0]},                         # 4
        {"name": "bulb", "translation": [1, 2, 3], "extensions": {"KHR_lights_punctual": {"light": 2}}},  # 5
        {"name": "unused", "mesh": 0},                                                            # 6, not in the scene
    ]
    doc["scenes"] = [{"nodes": [4, 2, 5]}]
    doc["materials"].append({"name": "glass", "alphaMode": "BLEND", "pbrMetallicRoughness": {"baseColorFactor": [0.2, 0.4, 0.9, 0.5]}})
    doc["meshes"][0]["primitives"].append({"attributes": {"POSITION": 0, "NORMAL": 1}, "material": 1})  # non-indexed: 4 vertices -> 1 triangle + warning
write('hierarchy.gltf', quad_doc(uri(QUAD_BIN), hierarchy))

def no_scene(doc):
    del doc["scene"]
    del doc["scenes"]
    doc["nodes"] = [{"name": "a", "mesh": 0}, {"name": "b", "children": [2]}, {"name": "c", "mesh": 0}]
write('no_scene.gltf', quad_doc(uri(QUAD_BIN), no_scene))

# Primitive modes and index types over 5 vertices in the XZ plane.
# A zig-zag v0..v4 = (0,0,0) (0,0,1) (1,0,0) (1,0,1) (2,0,0): every strip, fan and list
# triangle below has area 1/2 and faces +Y.
MODE_POS = f32(0, 0, 0, 0, 0, 1, 1, 0, 0, 1, 0, 1, 2, 0, 0)
MODE_BIN = MODE_POS + pad4(u8(0, 1, 2, 3, 4)) + pad4(u16(0, 1, 2, 3, 4)) + u32(0, 1, 2, 2, 3, 4)
def modes(doc):
    doc["buffers"][0]["byteLength"] = len(MODE_BIN)
    doc["bufferViews"] = [{"buffer": 0, "byteOffset": 0, "byteLength": 60},
                          {"buffer": 0, "byteOffset": 60, "byteLength": 5},
                          {"buffer": 0, "byteOffset": 68, "byteLength": 10},
                          {"buffer": 0, "byteOffset": 80, "byteLength": 24}]
    doc["accessors"] = [{"bufferView": 0, "componentType": 5126, "count": 5, "type": "VEC3"},
                        {"bufferView": 1, "componentType": 5121, "count": 5, "type": "SCALAR"},
                        {"bufferView": 2, "componentType": 5123, "count": 5, "type": "SCALAR"},
                        {"bufferView": 3, "componentType": 5125, "count": 6, "type": "SCALAR"}]
    P = {"POSITION": 0}
    doc["meshes"] = [{"name": "modes", "primitives": [
        {"attributes": P, "mode": 0},                 # POINTS: refused
        {"attributes": P, "mode": 1, "indices": 1},   # LINES: refused
        {"attributes": P, "mode": 5, "indices": 1},   # TRIANGLE_STRIP, u8: 3 triangles
        {"attributes": P, "mode": 6, "indices": 2},   # TRIANGLE_FAN, u16: 3 triangles
        {"attributes": P, "mode": 4, "indices": 3},   # TRIANGLES, u32: 2 triangles
        {"attributes": P, "mode": 5},                 # TRIANGLE_STRIP, non-indexed: 3 triangles
    ]}]
    doc["nodes"] = [{"name": "modes", "mesh": 0}]
    del doc["materials"]
write('modes.gltf', quad_doc(uri(MODE_BIN), modes))

# Interleaved vertices (byteStride 16: float position + normalized u16 uv) and a second
# primitive with normalized u8 uvs; positions partly replaced by a sparse accessor.
IL = b''.join(QUAD_POS[i * 12:(i + 1) * 12] + u16(*uv) for i, uv in enumerate([(0, 0), (65535, 0), (65535, 65535), (0, 65535)]))
UV8 = u8(0, 0, 255, 0, 255, 255, 0, 255)
SPARSE_IDX = pad4(u16(2))
SPARSE_VAL = f32(1, 2, 1)
IL_BIN = IL + UV8 + QUAD_IDX + SPARSE_IDX + SPARSE_VAL
def interleaved(doc):
    doc["buffers"][0]["byteLength"] = len(IL_BIN)
    doc["bufferViews"] = [{"buffer": 0, "byteOffset": 0, "byteLength": 64, "byteStride": 16},
                          {"buffer": 0, "byteOffset": 64, "byteLength": 8},
                          {"buffer": 0, "byteOffset": 72, "byteLength": 12},
                          {"buffer": 0, "byteOffset": 84, "byteLength": 2},
                          {"buffer": 0, "byteOffset": 88, "byteLength": 12}]
    doc["accessors"] = [{"bufferView": 0, "byteOffset": 0, "componentType": 5126, "count": 4, "type": "VEC3"},
                        {"bufferView": 0, "byteOffset": 12, "componentType": 5123, "normalized": True, "count": 4, "type": "VEC2"},
                        {"bufferView": 1, "componentType": 5121, "normalized": True, "count": 4, "type": "VEC2"},
                        {"bufferView": 2, "componentType": 5123, "count": 6, "type": "SCALAR"},
                        {"bufferView": 0, "byteOffset": 0, "componentType": 5126, "count": 4, "type": "VEC3",
                         "sparse": {"count": 1, "indices": {"bufferView": 3, "componentType": 5123}, "values": {"bufferView": 4}}}]
    doc["meshes"] = [{"name": "interleaved", "primitives": [
        {"attributes": {"POSITION": 0, "TEXCOORD_0": 1}, "indices": 3},
        {"attributes": {"POSITION": 4, "TEXCOORD_0": 2}, "indices": 3}]}]
    del doc["materials"]
write('interleaved_sparse.gltf', quad_doc(uri(IL_BIN), interleaved))

# The quad moved by two animations: "wave" (translation LINEAR, rotation STEP, scale
# CUBICSPLINE with zero tangents) and "spin" (rotation LINEAR, a quarter turn about +Y).
S45 = math.sin(math.pi / 4)
ANIM = (f32(0, 2) +                                   # 140: times 0, 2
        f32(0, 1) +                                   # 148: times 0, 1
        f32(0, 0, 0, 4, 2, 0) +                       # 156: translations
        f32(0, 0, 0, 1, 0, S45, 0, S45) +             # 180: rotations (x, y, z, w)
        f32(0, 0, 0, 1, 1, 1, 0, 0, 0,                # 212: scale key 0: in-tangent, value, out-tangent
            0, 0, 0, 3, 3, 3, 0, 0, 0))               #      scale key 1
ANIM_BIN = QUAD_BIN + ANIM

def animated(doc):
    doc["nodes"] = [{"name": "quad", "mesh": 0, "translation": [0, 0, 0]}]
    doc["buffers"][0]["byteLength"] = len(ANIM_BIN)
    doc["bufferViews"].append({"buffer": 0, "byteOffset": len(QUAD_BIN), "byteLength": len(ANIM)})
    base = len(doc["accessors"])
    doc["accessors"] += [
        {"bufferView": 2, "byteOffset": 0, "componentType": 5126, "count": 2, "type": "SCALAR", "min": [0], "max": [2]},
        {"bufferView": 2, "byteOffset": 8, "componentType": 5126, "count": 2, "type": "SCALAR", "min": [0], "max": [1]},
        {"bufferView": 2, "byteOffset": 16, "componentType": 5126, "count": 2, "type": "VEC3"},
        {"bufferView": 2, "byteOffset": 40, "componentType": 5126, "count": 2, "type": "VEC4"},
        {"bufferView": 2, "byteOffset": 72, "componentType": 5126, "count": 6, "type": "VEC3"},
    ]
    t2, t1, trans, rot, scale = range(base, base + 5)
    doc["animations"] = [
        {"name": "wave",
         "samplers": [{"input": t2, "output": trans, "interpolation": "LINEAR"},
                      {"input": t1, "output": rot, "interpolation": "STEP"},
                      {"input": t2, "output": scale, "interpolation": "CUBICSPLINE"}],
         "channels": [{"sampler": 0, "target": {"node": 0, "path": "translation"}},
                      {"sampler": 1, "target": {"node": 0, "path": "rotation"}},
                      {"sampler": 2, "target": {"node": 0, "path": "scale"}}]},
        {"name": "spin",
         "samplers": [{"input": t1, "output": rot}],
         "channels": [{"sampler": 0, "target": {"node": 0, "path": "rotation"}}]},
    ]
write('animated.gltf', quad_doc(uri(ANIM_BIN), animated))
