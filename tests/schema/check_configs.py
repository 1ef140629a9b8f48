#!/usr/bin/env python3
"""Validates config/schema/penumbra-config.schema.json itself, every shipped config
against it, that configs the engine accepts are accepted, and that known-bad configs
are rejected with the error that jsonschema ranks first (best_match, what an editor
shows) naming the failing field. Usage: check_configs.py SOURCE_DIR"""
import json
import pathlib
import sys

import jsonschema
from jsonschema.exceptions import best_match

root = pathlib.Path(sys.argv[1])
schema = json.loads((root / "config/schema/penumbra-config.schema.json").read_text())
jsonschema.Draft202012Validator.check_schema(schema)
validator = jsonschema.Draft202012Validator(schema)


def field(error):
    """The JSON pointer of the field an error is about, as the engine names it: for an
    unknown or a missing key, the key itself rather than the object holding it."""
    path = list(error.absolute_path)
    if error.validator == "additionalProperties" and isinstance(error.instance, dict):
        path.append(sorted(set(error.instance) - set(error.schema.get("properties", {})))[0])
    elif error.validator == "required" and isinstance(error.instance, dict):
        path.append(next(key for key in error.validator_value if error.message.startswith(repr(key))))
    return "/" + "/".join(map(str, path))


failures = 0
shipped = (sorted((root / "config").glob("*.json")) + sorted((root / "config/bench").glob("*.json"))
           + sorted((root / "tests/data/configs/include").glob("*.json")))
for path in shipped:
    errors = list(validator.iter_errors(json.loads(path.read_text())))
    expect_invalid = path.name.startswith("bad_")
    if bool(errors) != expect_invalid:
        failures += 1
        print(f"FAIL {path.relative_to(root)}: expected {'invalid' if expect_invalid else 'valid'}")
        for e in errors:
            print(f"  {field(e)}: {e.message}")

# Configs (or, beside an include, parts of one) that the engine accepts: the schema must
# not be stricter than the engine.
point = {"type": "point", "position": [0, 1, 0]}
good = {
    "$schema": {"$schema": "schema/penumbra-config.schema.json"},
    "a light without a type is a spot": {"lights": [{"position": [0, 1, 0], "direction": [0, -1, 0]}]},
    "one camera field over an include": {"include": "default.json", "camera": {"fov_y_deg": 30}},
    "fps alone over an include": {"include": "animated.json", "animation": {"fps": 60}},
    "params of an included generator": {"include": "city.json", "scene": {"params": {"blocks": 2}}},
    "a generator parameter as a string": {"scene": {"generator": "fence", "params": {"holes_x": "8", "cell": "0.05"}}},
    "a glTF scene removing an included generator": {"include": "default.json",
                                                    "scene": {"gltf": "a.glb", "generator": None, "params": None}},
    "tracks of the config's lights": {"lights": [{"type": "spot", "position": [0, 4, 0], "direction": [0, -1, 0]}, point],
                                      "animation": {"tracks": [
        {"target": "/lights/0/direction", "keys": [{"t": 0, "value": [0, -1, 0]}, {"t": 1, "value": [0.1, -1, 0]}]},
        {"target": "/lights/1/intensity", "keys": [{"t": 0, "value": 1}]}]}},
    "a track of an included light": {"include": "two-spots.json", "animation": {"tracks": [
        {"target": "/lights/1/color", "keys": [{"t": 0, "value": [1, 1, 1]}]}]}},
    "an unshadowed light": {"lights": [dict(point, shadow={"technique": "none"})]},
    "a glTF part over a generated ground": {"scene": {"parts": [
        {"generator": "box-grid", "params": {"columns": 1}},
        {"gltf": "a.glb", "name": "model", "translation": [0, 1, 0], "rotation_deg": [0, 90, 0], "scale": [1, 2, 1],
         "animation": "walk", "allowed_roots": ["textures"]},
        {"gltf": "a.glb", "rotation": [0, 0.7071, 0, 0.7071], "scale": 0.5}]}},
    "animation without tracks where a part plays one": {"scene": {"parts": [{"gltf": "a.glb", "animation": 0}]},
                                                        "animation": {"fps": 30}},
    "one part placed": {"scene": {"gltf": "a.glb", "translation": [1, 2, 3], "rotation": [0, 0, 0, 1]}},
    "parts over an included scene": {"include": "default.json",
                                     "scene": {"generator": None, "params": None, "parts": [{"generator": "fence"}]}},
    "sweep pointers": {"sweep": [{"paths": ["/lights/0/shadow", "/culling"], "values": [[{}, "none"]]},
                                 {"path": "/lights", "values": [[point]]}]},
}
for name, doc in good.items():
    for e in validator.iter_errors(doc):
        failures += 1
        print(f"FAIL schema refuses a config the engine accepts ({name}): {field(e)}: {e.message}")

# name: (config, the field its best-ranked error must name)
bad = {
    "unknown key": ({"lights": [dict(point, intensty=3)]}, "/lights/0/intensty"),
    "spot without target or direction": ({"lights": [{"type": "spot", "position": [0, 1, 0]}]}, "/lights/0/target"),
    "spot with target and direction": ({"lights": [{"type": "spot", "position": [0, 1, 0], "target": [0, 0, 0],
                                                    "direction": [0, -1, 0]}]}, "/lights/0/target"),
    "cone on a point light": ({"lights": [dict(point, outer_cone_deg=3)]}, "/lights/0/outer_cone_deg"),
    "negative size": ({"lights": [{"type": "rect", "position": [0, 1, 0], "direction": [0, -1, 0], "size": [1, -2]}]},
                      "/lights/0/size/1"),
    "pcss light_size between -1 and 0": ({"lights": [dict(point, shadow={"technique": "pcss", "light_size": -0.5})]},
                                         "/lights/0/shadow/light_size"),
    "zero direction": ({"lights": [{"type": "directional", "direction": [0, 0, 0]}]}, "/lights/0/direction"),
    "unknown light type": ({"lights": [{"type": "area", "position": [0, 1, 0]}]}, "/lights/0/type"),
    "nine lights": ({"lights": [dict(point, name=str(i)) for i in range(9)]}, "/lights"),
    "lights neither an array nor \"scene\"": ({"lights": "gltf"}, "/lights"),
    "bad culling": ({"culling": "sometimes"}, "/culling"),
    "bad track target": ({"animation": {"tracks": [{"target": "/camera/roll", "keys": [{"t": 0, "value": 1}]}]}},
                         "/animation/tracks/0/target"),
    "track of light 8": ({"animation": {"tracks": [{"target": "/lights/8/position", "keys": [{"t": 0, "value": [1, 2, 3]}]}]}},
                         "/animation/tracks/0/target"),
    "track of a light the config lacks": ({"lights": [point], "animation": {"tracks": [
        {"target": "/lights/1/intensity", "keys": [{"t": 0, "value": 1}]}]}}, "/animation/tracks/0/target"),
    "track of a light with the glTF file's lights": ({"scene": {"gltf": "a.glb"}, "lights": "scene", "animation": {"tracks": [
        {"target": "/lights/0/intensity", "keys": [{"t": 0, "value": 1}]}]}}, "/animation/tracks/0/target"),
    "number for a direction track": ({"animation": {"tracks": [{"target": "/lights/0/direction", "keys": [{"t": 0, "value": 1}]}]}},
                                     "/animation/tracks/0/keys/0/value"),
    "vector for a fov track": ({"animation": {"tracks": [{"target": "/camera/fov_y_deg", "keys": [{"t": 0, "value": [1, 2, 3]}]}]}},
                               "/animation/tracks/0/keys/0/value"),
    "negative key time": ({"animation": {"tracks": [{"target": "/camera/fov_y_deg", "keys": [{"t": -1, "value": 3}]}]}},
                          "/animation/tracks/0/keys/0/t"),
    "gltf and generator": ({"scene": {"gltf": "a.gltf", "generator": "box-grid"}}, "/scene/generator"),
    "gltf and generator parameters": ({"scene": {"gltf": "a.gltf", "params": {"rows": 3}}}, "/scene/params"),
    "parameter of another generator": ({"scene": {"generator": "city", "params": {"columns": 3}}}, "/scene/params/columns"),
    "parameter of another generator than the default box-grid": ({"scene": {"params": {"blocks": 3}}}, "/scene/params/blocks"),
    "generator parameter out of range": ({"scene": {"generator": "hair", "params": {"alpha": 2}}}, "/scene/params/alpha"),
    "generator parameter not a number": ({"scene": {"generator": "fence", "params": {"holes_x": True}}}, "/scene/params/holes_x"),
    "fraction for a whole-number generator parameter": ({"scene": {"generator": "fence", "params": {"holes_x": "1.5"}}},
                                                        "/scene/params/holes_x"),
    "parts beside a generator": ({"scene": {"parts": [{"gltf": "a.glb"}], "generator": "city"}}, "/scene/generator"),
    "no parts": ({"scene": {"parts": []}}, "/scene/parts"),
    "65 parts": ({"scene": {"parts": [{"generator": "fence"}] * 65}}, "/scene/parts"),
    "unknown key in a part": ({"scene": {"parts": [{"gltf": "a.glb", "translate": [1, 2, 3]}]}}, "/scene/parts/0/translate"),
    "zero scale in a part": ({"scene": {"parts": [{"gltf": "a.glb", "scale": 0}]}}, "/scene/parts/0/scale"),
    "zero scale component": ({"scene": {"parts": [{"gltf": "a.glb", "scale": [1, 0, 1]}]}}, "/scene/parts/0/scale/1"),
    "translation of two numbers": ({"scene": {"parts": [{"gltf": "a.glb", "translation": [1, 2]}]}},
                                   "/scene/parts/0/translation"),
    "rotation_deg beyond a turn": ({"scene": {"gltf": "a.glb", "rotation_deg": [0, 400, 0]}}, "/scene/rotation_deg/1"),
    "both rotations": ({"scene": {"parts": [{"gltf": "a.glb", "rotation_deg": [0, 90, 0], "rotation": [0, 0, 0, 1]}]}},
                       "/scene/parts/0/rotation"),
    "quaternion of three numbers": ({"scene": {"parts": [{"gltf": "a.glb", "rotation": [0, 0, 1]}]}},
                                    "/scene/parts/0/rotation"),
    "gltf and generator in a part": ({"scene": {"parts": [{"gltf": "a.glb", "generator": "fence"}]}},
                                     "/scene/parts/0/generator"),
    "animation of a generated part": ({"scene": {"parts": [{"generator": "fence", "animation": "walk"}]}},
                                      "/scene/parts/0/animation"),
    "parameter of another generator in a part": ({"scene": {"parts": [{"generator": "city", "params": {"columns": 3}}]}},
                                                 "/scene/parts/0/params/columns"),
    "camera without target": ({"camera": {"position": [0, 1, 0]}}, "/camera/target"),
    "zero width": ({"output": {"width": 0}}, "/output/width"),
    "sweep with path and paths": ({"sweep": [{"path": "/scene", "paths": ["/camera"], "values": [1]}]}, "/sweep/0/paths"),
    "sweep without a path": ({"sweep": [{"values": [1]}]}, "/sweep/0/paths"),
    "sweep label not a string": ({"sweep": [{"path": "/scene", "values": [1], "labels": [2]}]}, "/sweep/0/labels/0"),
    "sweep of an unknown key": ({"sweep": [{"path": "/light/0/intensity", "values": [1]}]}, "/sweep/0/path"),
    "sweep path not a pointer": ({"sweep": [{"path": "lights/0/intensity", "values": [1]}]}, "/sweep/0/path"),
    "sweep path with a bad escape": ({"sweep": [{"path": "/scene/a~2", "values": [1]}]}, "/sweep/0/path"),
    "sweep of the sweep": ({"sweep": [{"path": "/sweep/0", "values": [1]}]}, "/sweep/0/path"),
    "sweep inside a number": ({"sweep": [{"path": "/frames/0", "values": [1]}]}, "/sweep/0/path"),
    "sweep of light 8": ({"sweep": [{"paths": ["/camera", "/lights/8/intensity"], "values": [[{}, 2]]}]}, "/sweep/0/paths/1"),
    "sweep of two paths with a single value": ({"sweep": [{"paths": ["/camera", "/scene"], "values": [1]}]},
                                               "/sweep/0/values/0"),
    "pcss radius out of range": ({"lights": [dict(point, shadow={"technique": "pcss", "max_filter_radius": 1000})]},
                                 "/lights/0/shadow/max_filter_radius"),
    "vsm unknown variant": ({"lights": [dict(point, shadow={"technique": "vsm", "variant": "msm"})]}, "/lights/0/shadow/variant"),
    "parameter on an unshadowed light": ({"lights": [dict(point, shadow={"technique": "none", "resolution": 512})]},
                                         "/lights/0/shadow/resolution"),
    "hard parameter on vsm": ({"lights": [dict(point, shadow={"technique": "vsm", "pcf_kernel": 3})]},
                              "/lights/0/shadow/pcf_kernel"),
}
for name, (doc, expected) in bad.items():
    best = best_match(validator.iter_errors(doc))
    if best is None:
        failures += 1
        print(f"FAIL schema accepts a bad config: {name}")
    elif field(best) != expected:
        failures += 1
        print(f"FAIL {name}: the first error names {field(best)} instead of {expected}: {best.message}")

print(f"{len(shipped) + len(good) + len(bad) - failures} passed, {failures} failed")
sys.exit(1 if failures else 0)
